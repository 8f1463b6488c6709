"""Where ``servolab view`` and every ``--view`` serve unless told otherwise: Foxglove's and
foxglove_bridge's port, on this computer only. A light module, so the command line reads it
without loading the server."""

DEFAULT_PORT = 8765
DEFAULT_HOST = "127.0.0.1"
