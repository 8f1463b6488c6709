"""Seed 002's treadmill: a fruit fly on a ball held by three omni-wheels, steering a robot.
Listing 1's control law, the thesis's binary logs, the tracking node, the camera PC of the
launch files (the rig), chapter 3's analysis, and ``servolab flyball``'s run (the command
keeps the experiment's name, a fly on a ball; the robot is the treadmill)."""
