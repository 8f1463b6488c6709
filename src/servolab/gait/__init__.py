"""Gaits: the biped's walking-pattern generator (seed 001, Appendix D and E) and the motion
files it writes and the robot plays. Pure: arrays and files in, arrays and files out."""
