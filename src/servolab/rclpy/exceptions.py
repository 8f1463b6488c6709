"""``rclpy.exceptions``: the parameter exceptions rclpy raises, with its messages
(``rclpy/exceptions.py``)."""

from __future__ import annotations

from typing import Any

from servolab.middleware.errors import ParameterError


class NotInitializedException(Exception):
    def __init__(self, message: str | None = None) -> None:
        super().__init__(f"rclpy.init() has not been called. msg:{message}" if message
                         else "rclpy.init() has not been called.")


class ParameterException(ParameterError):
    """Base exception for parameter-related errors (servolab's ParameterError too)."""

    def __init__(self, error_msg: str, parameters: str | list[str]) -> None:
        Exception.__init__(self, f"{error_msg}: {parameters}")


class ParameterNotDeclaredException(ParameterException):
    def __init__(self, parameters: str | list[str]) -> None:
        super().__init__("Invalid access to undeclared parameter(s)", parameters)


class ParameterAlreadyDeclaredException(ParameterException):
    def __init__(self, parameters: str | list[str]) -> None:
        super().__init__("Parameter(s) already declared", parameters)


class InvalidParameterException(ParameterException):
    def __init__(self, parameter_name: str) -> None:
        super().__init__("Invalid parameter name", parameter_name)


class InvalidParameterTypeException(ParameterException):
    def __init__(self, desired_parameter: Any, expected_type: Any) -> None:
        from .parameter import Parameter
        value = desired_parameter.value
        super().__init__(
            f"Trying to set parameter '{desired_parameter.name}' to '{value}' of type "
            f"'{Parameter.Type.from_parameter_value(value).name}', expecting type "
            f"'{expected_type}'", desired_parameter.name)


class InvalidParameterValueException(ParameterException):
    def __init__(self, parameter: str, value: Any, reason: str) -> None:
        super().__init__(f"Invalid parameter value ({value}) for parameter. Reason: {reason}",
                         parameter)


class ParameterImmutableException(ParameterException):
    def __init__(self, parameter_name: str) -> None:
        super().__init__("Attempted to modify read-only parameter", parameter_name)


class ParameterUninitializedException(ParameterException):
    def __init__(self, parameter_name: str) -> None:
        super().__init__(f"The parameter '{parameter_name}' is not initialized", parameter_name)


class ROSInterruptException(Exception):
    def __init__(self) -> None:
        super().__init__("rclpy.shutdown() has been called")


__all__ = ["InvalidParameterException", "InvalidParameterTypeException",
           "InvalidParameterValueException", "NotInitializedException",
           "ParameterAlreadyDeclaredException", "ParameterException",
           "ParameterImmutableException", "ParameterNotDeclaredException",
           "ParameterUninitializedException", "ROSInterruptException"]
