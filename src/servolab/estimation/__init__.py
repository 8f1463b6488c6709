"""State estimation for servolab's robots: pure functions and small stateful filters over numpy
arrays (no I/O, no threads, no clock; time enters only as the ``dt`` a caller passes)."""
