"""Armstrong, seed 001's 21-servo biped: its bus and configuration (``armstrong.yaml``, seed
001's Listing 3.3 and Appendix A, shipped here), its poses, the seed's control node, the nodes
of its launch files, and ``servolab walk``'s run."""
