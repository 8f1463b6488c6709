"""``python -m servolab`` is the ``servolab`` command."""

import sys

from .cli import main

sys.exit(main())
