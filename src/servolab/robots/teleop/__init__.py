"""Leader–follower teleoperation of two Dynamixel arms, recorded as episodes for learning.

A person moves the *leader* arm by hand (its torque off); the *follower*, a twin arm on a bus of
its own, copies it joint by joint, and every episode goes into an MCAP bag that a learning
pipeline reads: what both arms did, what the follower was told, and (in simulation) what a
camera saw. ``servolab teleop`` runs it (:mod:`.run`); by default on two emulated
OpenMANIPULATOR-X, the follower on its table in MuJoCo under gravity and the leader moved by a
scripted hand (:mod:`.hand`), a seeded smooth motion of its joints.

**The loop** (:mod:`.loop`), as fast as the wires allow (or at ``rate``): one SYNC_READ of the
leader's present positions on its bus, the joints mapped to the follower's by name and kept
within the follower's URDF limits (:mod:`.mapping`), one SYNC_WRITE of the follower's goal
positions on its bus. Every ``state_rate`` (50 Hz: a learning pipeline's observation rate;
LeRobot records at 30) the follower's state is read too (one SYNC_READ from Goal Position to
Present Position), which also checks that the last goals written arrived
(``commands_lost``).

The follower is written directly on its bus, as LeRobot's and ALOHA's teleoperation loops
write theirs, not through ros2_control's position group: a teleoperation loop is its own
controller, bound by the wire, and the group would add a topic hop and the controller
manager's period to every command, and, on the OpenMANIPULATOR-X's ROBOTIS block, one READ per
motor for its gpio state interfaces to every update: 3.4 ms of wire an update at 1 Mbps,
against 1.33 ms for the loop's whole cycle, the leader's read included. The
block still says everything about the motors: IDs, models, the joint <-> horn transmission
(the gripper's metres), the limits, and the control-table items written at start
(:mod:`.arms`), but one: the follower runs without a profile (Profile Velocity and
Acceleration 0), as a stream of goals is its own trajectory (:data:`.arms.STREAMING` says
why). The leader's block settings are written too (Return Delay Time 0 matters to the rate),
and its torque stays off. Gravity compensation of the leader (current mode, the arm's own
weight held) is not done: a person holds it, as a leader with its torque off is held.

**Stops.** The follower holds where it is, torque on (goal = present position), whatever ends
the run: its end, Ctrl-C, SIGTERM or SIGHUP (:func:`servolab.robots.lifecycle.run_task`), an
error, or the watchdog: a leader that gave no reading for ``watchdog`` seconds (0.1 s) ends the
run with :class:`~.loop.LeaderLost`. At the start the follower is brought to the leader's pose
over a smooth ramp (``engage``), never in one jump.

**The bag: a schema for learning pipelines.** ``teleop_bag/`` in the run folder, rosbag2's
layout (``teleop_bag_0.mcap`` and ``metadata.yaml``): MCAP profile ``ros2``, ``ros2msg``
schemas, CDR messages, readable with ``mcap`` + ``mcap-ros2-support``, rosbags, ``ros2 bag``
and Foxglove. Log time = the header's stamp (the simulation's seconds in virtual time, epoch
seconds in real time). Positions are in the joints' units: rad, and m for a prismatic joint (the
gripper's finger); velocities in rad/s (m/s); efforts in N m (N).

- ``/leader/joint_states`` (``sensor_msgs/msg/JointState``), every cycle: the leader's
  positions as read (its joint names);
- ``/follower/joint_commands`` (``sensor_msgs/msg/JointState``), every cycle: the goal
  positions sent to the follower (the *action*; its joint names), stamped as the leader's
  reading they come from;
- ``/follower/joint_states`` (``sensor_msgs/msg/JointState``), at ``state_rate``: the
  follower's position, velocity and effort (the *observation*);
- ``/follower/camera/image/compressed`` (``sensor_msgs/msg/CompressedImage``, JPEG, 320 x
  240, frame ``follower_camera``), at ``camera_rate`` (10 Hz), when the follower is emulated
  in MuJoCo: a fixed camera from the front left, above the table;
- ``/teleop/episode`` (``std_msgs/msg/Int32``), at each boundary: see below.

**Episodes.** ``/teleop/episode`` says which episode is in progress from its log time on: ``k``
(0, 1, ...) when episode ``k`` starts, ``-1`` when it ends (and at the start, while the follower
engages): a message belongs to episode ``k`` when the last ``/teleop/episode`` at or before its
log time says ``k``. Between two episodes (``reset`` seconds, the time to put the scene back) the
loop goes on and is recorded, under ``-1``. ``summary.json`` lists the episodes too (index,
start and end in log-time seconds, cycles, whether it ran to its end), with the loop's figures:
the achieved rate against the wire limit of one SYNC_READ + one SYNC_WRITE from the packet
sizes, the follower's tracking error (|present - goal| at each state read: p50, p99, max, the
arm's joints in rad and a prismatic gripper in m), the commands sent, checked and lost.

A converter to LeRobot's dataset layout is not here: each episode's ``/follower/joint_states``
(observation.state), ``/follower/joint_commands`` (action) and images are what it would take.
"""

from __future__ import annotations

#: what ``--leader`` / ``--follower`` take for an arm emulated in this process
EMULATED = "emu://"
#: where an emulated follower may be: its robot's own world, its URDF in MuJoCo, its motors
#: alone (:mod:`.run`)
WORLDS = ("robot", "mujoco", "emulated")
