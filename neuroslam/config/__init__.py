"""Parameters of NeuroSLAM as frozen dataclasses, with validation and loading from dicts and files.

Every section validates itself on construction and names the offending field (``grid_cells.size``).
Units: metres, seconds and radians at the boundary; cells only inside the networks. Defaults are the
``sim`` preset (the testbed's 160×120, 80° camera); :mod:`neuroslam.presets` holds the paper's tables.

Why the ``sim`` defaults are what they are, and what each changed on the benchmark: ``docs/configuration.md``.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InvalidParameterError
from .checks import number, require
from .mapping import ExperienceMapConfig
from .networks import GridCellConfig, GridNetworkConfig, HeadDirectionConfig
from .options import (
    HEIGHT_MODELS,
    INTEGRATORS,
    LOOP_CLOSURES,
    PLANAR_MOTIONS,
    RELAXATIONS,
    SHIFTS,
    HeightModel,
    Integrator,
    LoopClosure,
    PlanarMotion,
    Relaxation,
    Shift,
)
from .vision import LocalViewConfig, Region, VisualOdometryConfig

__all__ = [
    "HEIGHT_MODELS", "INTEGRATORS", "LOOP_CLOSURES", "PLANAR_MOTIONS", "RELAXATIONS", "SHIFTS", "Config",
    "ExperienceMapConfig", "GridCellConfig", "GridNetworkConfig", "HeadDirectionConfig", "HeightModel", "Integrator",
    "LocalViewConfig", "LoopClosure", "PlanarMotion", "Region", "Relaxation", "Shift", "VisualOdometryConfig",
    "load_config",
]


@dataclass(frozen=True)
class Config:
    """All NeuroSLAM parameters.

    Attributes:
        horizontal_fov: the camera's horizontal field of view, rad (2 pi for a panorama).
        vertical_fov: the camera's vertical field of view, rad.
        panoramic: True when image columns wrap around (a 360-degree strip).
        integrator: how the odometric displacement that links experiences is integrated: ``odometry``
            (the self-motion directly, as the paper) or ``grid-network`` (through the Burak–Fiete network
            of the grid-network paper, ``grid_network``; :mod:`neuroslam.cells.grid_network`).
    """

    horizontal_fov: float = math.radians(80.0)
    vertical_fov: float = 2 * math.atan(math.tan(math.radians(40.0)) * 0.75)
    panoramic: bool = False
    integrator: Integrator = "odometry"
    odometry: VisualOdometryConfig = field(default_factory=VisualOdometryConfig)
    local_view: LocalViewConfig = field(default_factory=LocalViewConfig)
    grid_cells: GridCellConfig = field(default_factory=GridCellConfig)
    head_direction: HeadDirectionConfig = field(default_factory=HeadDirectionConfig)
    experience_map: ExperienceMapConfig = field(default_factory=ExperienceMapConfig)
    grid_network: GridNetworkConfig = field(default_factory=GridNetworkConfig)

    def __post_init__(self) -> None:
        require("horizontal_fov", self.horizontal_fov, number(self.horizontal_fov)
                 and 0 < self.horizontal_fov <= 2 * math.pi + 1e-9, "must be in (0, 2 pi] radians")
        require("vertical_fov", self.vertical_fov, number(self.vertical_fov) and 0 < self.vertical_fov < math.pi,
                 "must be in (0, pi) radians")
        require("panoramic", self.panoramic, isinstance(self.panoramic, bool), "must be true or false")
        require("integrator", self.integrator, self.integrator in INTEGRATORS,
                 f"must be one of {', '.join(INTEGRATORS)}")
        if self.panoramic and isinstance(self.odometry, VisualOdometryConfig):
            require("odometry.planar_motion", self.odometry.planar_motion, self.odometry.planar_motion == "profile",
                     "must be 'profile' for a panoramic camera (the ground-plane model needs a pinhole camera)")
        for name, kind in _SECTIONS.items():
            section = getattr(self, name)
            require(name, section, isinstance(section, kind), f"must be a {kind.__name__}")
            section.validate(name)

    def replace(self, **changes: Any) -> Config:
        """A copy with some top-level fields or whole sections replaced."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, base: Config | None = None) -> Config:
        """Build a config from nested plain data (as read from TOML or JSON) over ``base`` (defaults).

        Unknown keys are refused with the closest known name suggested.
        """
        base = base or cls()
        if not isinstance(data, dict):
            raise InvalidParameterError("config", type(data).__name__, "must be a table of settings")
        return _merge(base, data, "")

    def to_dict(self) -> dict[str, Any]:
        """Nested plain data (tuples as lists), the inverse of :meth:`from_dict`."""
        return json.loads(json.dumps(dataclasses.asdict(self)))


_SECTIONS = {
    "odometry": VisualOdometryConfig, "local_view": LocalViewConfig, "grid_cells": GridCellConfig,
    "head_direction": HeadDirectionConfig, "experience_map": ExperienceMapConfig, "grid_network": GridNetworkConfig,
}


def _merge(base: Any, data: dict[str, Any], prefix: str) -> Any:
    fields = {f.name: f for f in dataclasses.fields(base)}
    changes: dict[str, Any] = {}
    for key, value in data.items():
        path = f"{prefix}{key}"
        if key not in fields:
            close = difflib.get_close_matches(str(key), list(fields), n=1)
            hint = f" (did you mean {prefix + close[0]!r}?)" if close else f"; known: {', '.join(fields)}"
            raise InvalidParameterError(path, value, f"unknown setting{hint}")
        current = getattr(base, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise InvalidParameterError(path, value, "must be a table of settings")
            changes[key] = _merge(current, value, f"{path}.")
        elif isinstance(current, tuple):
            if not isinstance(value, (list, tuple)):
                raise InvalidParameterError(path, value, f"must be a list of {len(current)} values")
            changes[key] = tuple(value)
        else:
            changes[key] = value
    return dataclasses.replace(base, **changes)  # every section validates itself on construction


def load_config(path: str | Path, *, base: Config | None = None) -> Config:
    """Read a TOML (``.toml``) or JSON (``.json``) file of settings over ``base`` (default: the defaults)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise InvalidParameterError("config", str(path), f"cannot read ({error.strerror})") from None
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as error:
        raise InvalidParameterError("config", str(path), f"not valid {path.suffix or 'TOML'} ({error})") from None
    return Config.from_dict(data, base=base)
