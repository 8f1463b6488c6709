"""The commands of ``servolab``, one module each (``scan.py`` is ``servolab scan``).

Each command module registers its arguments and its run function as ``COMMAND`` (see
:mod:`.registry`, which finds them) and keeps its work in functions of plain values that tests
and programs call directly. :mod:`.arguments` holds the options several commands share;
modules whose name starts with ``_`` hold work two commands share.
"""
