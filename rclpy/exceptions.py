"""rclpy's exception types (the names user code catches)."""

from __future__ import annotations

DOCS = "docs/rclpy.md (the API table)"


class NotInitializedException(Exception):
    def __init__(self, *args: object) -> None:
        super().__init__("rclpy.init() has not been called", *args)


class NoTypeSupportImportedException(Exception):
    pass


class NameValidationException(Exception):
    pass


class InvalidNamespaceException(NameValidationException):
    pass


class InvalidNodeNameException(NameValidationException):
    pass


class InvalidTopicNameException(NameValidationException):
    pass


class InvalidServiceNameException(NameValidationException):
    pass


class ParameterException(Exception):
    def __init__(self, error: str, parameters: object = None, *args: object) -> None:
        Exception.__init__(self, error if parameters is None else f"{error}: {parameters}", *args)


class ParameterNotDeclaredException(ParameterException):
    def __init__(self, parameters: object, *args: object) -> None:
        ParameterException.__init__(self, "Invalid access to undeclared parameter(s)", parameters, *args)


class ParameterAlreadyDeclaredException(ParameterException):
    def __init__(self, parameters: object, *args: object) -> None:
        ParameterException.__init__(self, "Parameter(s) already declared", parameters, *args)


class InvalidParameterException(ParameterException):
    def __init__(self, parameter: object, *args: object) -> None:
        ParameterException.__init__(self, "Invalid parameter name", parameter, *args)


class InvalidParameterTypeException(ParameterException):
    def __init__(self, desired_parameter: object, actual_type: object, *args: object) -> None:
        name = getattr(desired_parameter, "name", desired_parameter)
        ParameterException.__init__(
            self, f"Trying to set parameter '{name}' to a value of type '{actual_type}'", None, *args)


class InvalidParameterValueException(ParameterException):
    def __init__(self, parameter: object, value: object, reason: str, *args: object) -> None:
        ParameterException.__init__(
            self, f"Invalid parameter value ({value}) for parameter '{parameter}'. Reason: {reason}", None, *args)


class ParameterImmutableException(ParameterException):
    def __init__(self, parameter: object, *args: object) -> None:
        ParameterException.__init__(self, "Attempted to modify read-only parameter", parameter, *args)


class ParameterUninitializedException(ParameterException):
    def __init__(self, parameter: object, *args: object) -> None:
        ParameterException.__init__(self, "Parameter is uninitialized (statically typed, no value)", parameter,
                                    *args)


class ROSInterruptException(Exception):
    pass


def not_implemented(api: str) -> NotImplementedError:
    """The error every rclpy API zenroid does not implement raises: never a silent no-op."""
    return NotImplementedError(f"rclpy {api} is not implemented by zenroid's rclpy: see {DOCS}")
