"""Typed errors of the SLAM library; each names what was wrong and the offending value."""

from __future__ import annotations

__all__ = ["InvalidInputError", "InvalidParameterError", "NeuroSLAMError"]


class NeuroSLAMError(Exception):
    """Base class of every error neuroslam raises on purpose."""


class InvalidParameterError(NeuroSLAMError, ValueError):
    """A configuration value is unknown, of the wrong type or out of range.

    Attributes:
        field: dotted name of the parameter (``grid_cells.size``).
        value: the rejected value.
    """

    def __init__(self, field: str, value: object, reason: str):
        self.field = field
        self.value = value
        super().__init__(f"{field}={value!r}: {reason}")


class InvalidInputError(NeuroSLAMError, ValueError):
    """A frame, timestamp or odometry input cannot be processed; nothing was changed.

    Attributes:
        field: which input (``image``, ``timestamp``, ``odometry``).
        value: a short description of the rejected value.
    """

    def __init__(self, field: str, value: object, reason: str):
        self.field = field
        self.value = value
        super().__init__(f"{field}={value}: {reason}")
