"""``rclpy.executors``: the exception rclpy code catches around ``spin``.

servolab's ``spin`` returns when the context is shut down or on Ctrl-C rather than raising,
so this is never raised; it exists so that ``except (KeyboardInterrupt,
ExternalShutdownException)`` in rclpy code needs only its import changed.
"""


class ExternalShutdownException(Exception):
    """The context was shut down (rclpy's; see the module docstring)."""


__all__ = ["ExternalShutdownException"]
