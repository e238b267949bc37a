"""Typed errors of the testbed: each names the offending field and value."""

from __future__ import annotations

__all__ = ["InvalidParameterError", "RouteError", "SimError", "WorldError"]


class SimError(Exception):
    """Base class of every error the simulator raises on purpose."""


class InvalidParameterError(SimError, ValueError):
    """A parameter is out of range or of the wrong type.

    Attributes:
        field: name of the parameter (dotted for nested configs).
        value: the rejected value.
    """

    def __init__(self, field: str, value: object, reason: str):
        self.field = field
        self.value = value
        super().__init__(f"{field}={value!r}: {reason}")


class WorldError(SimError, ValueError):
    """A world cannot be found, parsed or compiled."""


class RouteError(SimError, ValueError):
    """A route file or route is malformed or unknown."""
