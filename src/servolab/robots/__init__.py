"""servolab's robots: each wires the pure algorithms to the Dynamixel bus and to topics, as a
set of nodes (the biped's controller manager and joint controllers, ...)."""
