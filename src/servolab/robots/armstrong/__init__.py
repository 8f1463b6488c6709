"""Armstrong, seed 001's 21-servo biped: its bus and configuration (``armstrong.yaml``, seed
001's Listing 3.3 and Appendix A, shipped here), its poses, the seed's control node, the nodes
of its launch files, and ``servolab walk``'s run."""

#: what stopping this robot does to its motors, on any end of a run (servolab.harness)
ON_STOP = ("the joints go to the stand pose (double support) over 1 s, then hold it with "
           "torque on (a biped that went limp would fall); with the bus gone, the motors "
           "hold the last pose sent")
