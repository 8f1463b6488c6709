"""Seed 002's treadmill: a fruit fly on a ball held by three omni-wheels, steering a robot.
Listing 1's control law, the thesis's binary logs, the tracking node, the camera PC of the
launch files (the rig), chapter 3's analysis, and ``servolab flyball``'s run (the command
keeps the experiment's name, a fly on a ball; the robot is the treadmill)."""

#: what stopping this robot does to its motors, on any end of a run (servolab.harness)
ON_STOP = ("the wheels stop (goal velocity 0) and their torque goes off (a ball left turning "
           "would carry the fly away)")
