"""Differential-drive bases: the configuration of a base (``base_*.yaml`` shipped here: seed
000's two-wheel and four-motor robots, a TurtleBot3 Waffle), the base driven by one SYNC_WRITE
with encoder odometry, its node (``/cmd_vel`` in, ``/odom`` out), seed 000's D.4 fusion node,
and ``servolab drive``'s run."""

#: what stopping this robot does to its motors, on any end of a run (servolab.harness)
ON_STOP = "the wheels stop (goal speed 0)"
