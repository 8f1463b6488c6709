"""Kinematics of servolab's robots: pure functions of arrays (no I/O, no threads, no clock),
vectorised over many poses, in SI-like units as each module states."""
