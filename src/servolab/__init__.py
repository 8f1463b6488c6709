"""servolab: build, simulate and run robots made of ROBOTIS Dynamixel servos from Python.

The layers, bottom up: :mod:`servolab.dynamixel` speaks the servo bus (protocols 1.0 and 2.0,
control tables, ports, the driver and a byte-level emulator); everything above it speaks SI units.
"""

__version__ = "0.1.0"
