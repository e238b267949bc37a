"""Validation of configuration values: each check names the field and the value it refuses."""

from __future__ import annotations

import math
from typing import Any

from ..errors import InvalidParameterError
from .options import SHIFTS

__all__ = ["cells", "non_negative", "number", "odd_width", "positive", "require", "validate_network"]


def number(value: object) -> bool:
    """A finite int or float (not a bool)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def require(path: str, value: object, ok: bool, reason: str) -> None:
    """Raise :class:`InvalidParameterError` naming ``path`` and ``value`` unless ``ok``."""
    if not ok:
        raise InvalidParameterError(path, value, reason)


def positive(section: str, **values: object) -> None:
    for name, value in values.items():
        require(f"{section}.{name}", value, number(value) and value > 0, "must be a positive number")


def non_negative(section: str, **values: object) -> None:
    for name, value in values.items():
        require(f"{section}.{name}", value, number(value) and value >= 0, "must be a number >= 0")


def odd_width(section: str, name: str, value: object, limit: int) -> None:
    require(f"{section}.{name}", value, isinstance(value, int) and not isinstance(value, bool)
             and value >= 1 and value % 2 == 1 and value <= limit,
             f"must be an odd number of cells from 1 to {limit} (odd, so a resting packet cannot drift)")


def cells(section: str, name: str, value: object, dimensions: int) -> None:
    ok = (isinstance(value, tuple) and len(value) == dimensions
          and all(isinstance(v, int) and not isinstance(v, bool) and 4 <= v <= 512 for v in value))
    require(f"{section}.{name}", value, ok, f"must be {dimensions} integers from 4 to 512 (cells)")


def validate_network(path: str, section: Any) -> None:
    """The attractor-network fields the grid-cell and head-direction sections share."""
    size = min(section.size)
    odd_width(path, "excitation_width", section.excitation_width, size)
    odd_width(path, "inhibition_width", section.inhibition_width, size)
    positive(path, excitation_variance=section.excitation_variance, inhibition_variance=section.inhibition_variance)
    non_negative(path, global_inhibition=section.global_inhibition, view_injection=section.view_injection)
    require(f"{path}.inhibition_scale", section.inhibition_scale, number(section.inhibition_scale)
             and 0 <= section.inhibition_scale < 1, "must be in [0, 1)")
    require(f"{path}.shift", section.shift, section.shift in SHIFTS, "must be 'fourier' or 'linear'")
    require(f"{path}.readout_radius", section.readout_radius, isinstance(section.readout_radius, int)
             and 1 <= section.readout_radius < size // 2, "must be an integer from 1 to size/2 - 1")
