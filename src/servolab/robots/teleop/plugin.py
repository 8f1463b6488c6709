"""The default rig's leader as a robot plug-in: an OpenMANIPULATOR-X held by the scripted hand
(:mod:`.hand`), so that ``servolab sim --robot open_manipulator_x_leader --pty`` serves a leader
arm that moves, in real time, to any client (``servolab teleop --leader DEVICE``, the
benchmark, another program). ROBOTIS sells the same arm as a leader (OMX-L): its motors, its
URDF, and a person's hand instead of torque.

On a port it is the arm itself, its torque off (the joints limp, ready for a hand). Its hand's
motion about a home pose of the arm's reach over its table (:data:`HAND`): a choice, checked in
MuJoCo to keep the fingers at least 5 cm above the table (and its boxes' tops) whichever way
the sines add up, and within each joint's limits.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ..plugin import BusSummary, RobotPlugin, ServedRobot
from ..urdf_robot import ON_STOP
from . import DEFAULT_ARM, DEFAULT_LEADER

if TYPE_CHECKING:
    from ...dynamixel.emulator import Emulator
    from ...sim.simulation import Simulation
    from ..dynamixel_system import DynamixelSystem
    from .hand import HandWorld

SUMMARY = ("an OpenMANIPULATOR-X as a leader arm: torque off, moved by a scripted hand when "
           "emulated (servolab teleop)")
#: the default arm's hand: (home, swing) of each joint (rad; m for the gripper's finger):
#: joint2 leaning back, joint4 pitched down, as ROBOTIS's "home" pose of the arm
#: (joint2 -1.05, joint3 0.35, joint4 0.7) is, nearer the table's boxes
HAND = {"joint1": (0.0, 0.8), "joint2": (-0.6, 0.4), "joint3": (-0.2, 0.4),
        "joint4": (1.0, 0.4), "gripper_left_joint": (0.0045, 0.009)}
#: what the served leader's hand does: episodes of this long, this far apart, with this
#: seed, the first this long after the server starts (a client has time to connect), on
#: and on
SERVED_EPISODE_S, SERVED_RESET_S, SERVED_SEED, SERVED_BEGIN_S = 20.0, 1.0, 0, 1.0
SERVED_EPISODES = 1_000_000


def _arm() -> RobotPlugin:
    from ..registry import entry

    return entry(DEFAULT_ARM)


def _urdf() -> str:
    text = _arm().description
    assert text is not None, f"{DEFAULT_ARM} has a URDF"
    return text()


def _system() -> DynamixelSystem:
    from ..dynamixel_system import dynamixel_system

    return dynamixel_system(_urdf(), f"{DEFAULT_ARM}.urdf", default_model=_arm().default_model)


def _bus() -> BusSummary:
    return _system().bus()


def _open(port: str | None) -> Any:
    from ..urdf_robot import UrdfRobot

    return UrdfRobot.open(DEFAULT_LEADER, _urdf(), port, source=f"{DEFAULT_ARM}.urdf",
                          default_model=_arm().default_model, on_stop="torque_off")


def _served(baudrate: int | None) -> ServedRobot:
    found = _system()
    spec = found.bus().motor_spec().at_baudrate(baudrate or found.baudrate)

    def place(emulator: Emulator) -> tuple[Simulation, Emulator, HandWorld]:
        from ...sim.simulation import Simulation
        from .hand import Episodes, HandScript, hand_on, swings

        simulation = Simulation()
        simulation.add_emulator(emulator)
        script = HandScript(swings(found.joints, HAND),
                            Episodes(SERVED_EPISODE_S, SERVED_EPISODES, SERVED_RESET_S),
                            SERVED_SEED, begin=simulation.now() + SERVED_BEGIN_S)
        return simulation, emulator, hand_on(emulator, simulation, found.joints, script)

    return ServedRobot(spec, place=place, what="moving the leader arm by a scripted hand")


ROBOTS = (RobotPlugin(DEFAULT_LEADER, SUMMARY, bus=_bus, open=_open,
                      on_stop=ON_STOP["torque_off"], description=_urdf, served=_served,
                      commands=("teleop",)),)
