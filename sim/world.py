"""Finding, loading and validating worlds and their routes.

A world is an MJCF file of static geometry (no robot) plus a routes sidecar ``NAME.routes.json`` next to
``NAME.xml``::

    {"levels": [0.0, 3.0],                      # optional: floor heights, m
     "routes": {"main":  {"waypoints": [[x, y, z], ...], "loop": true},
                "other": {...}}}

Each waypoint's z is the floor height there; the robot starts at the first waypoint facing the second;
the first route is the default. Without ``levels`` the floor heights are the distinct waypoint heights.

World names: a built-in name (``carpark``, ``urban``, ``building``), ``gen:SEED`` for a generated world
(the generator's latest version; ``gen1:SEED`` to ``gen3:SEED`` name a version, so a seed's world stays the
same when the generator changes), or a path to an MJCF file.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass
from functools import cached_property
from importlib import resources
from pathlib import Path

import numpy as np

from .errors import RouteError, WorldError

__all__ = ["Route", "World", "builtin_worlds", "load_world", "parse_routes"]


@dataclass(frozen=True)
class Route:
    """A named polyline of 3-D waypoints (m) the robot drives along.

    Attributes:
        name: the route's name in its sidecar.
        waypoints: (N, 3) array of x, y, z in metres, z being the floor height.
        loop: True when the last waypoint connects back to the first.
    """

    name: str
    waypoints: np.ndarray
    loop: bool = True

    @cached_property
    def vertices(self) -> np.ndarray:
        """Polyline vertices, closed (first point repeated at the end) for loops (computed once: the route's
        controller asks for them several times a control period)."""
        return np.vstack([self.waypoints, self.waypoints[:1]]) if self.loop else self.waypoints

    @cached_property
    def cumulative_length(self) -> np.ndarray:
        """Arc length at each vertex of :attr:`vertices`, m (3-D, so ramps count their slope)."""
        steps = np.linalg.norm(np.diff(self.vertices, axis=0), axis=1)
        return np.concatenate([[0.0], np.cumsum(steps)])

    @property
    def length(self) -> float:
        """Length of one lap (or of the open route), m."""
        return float(self.cumulative_length[-1])

    def point_at(self, distance: float | np.ndarray) -> np.ndarray:
        """Point(s) at arc length ``distance`` (m) along the route; loops wrap around."""
        s = np.asarray(distance, dtype=float)
        s = np.mod(s, self.length) if self.loop else np.clip(s, 0.0, self.length)
        cumulative = self.cumulative_length
        return np.stack([np.interp(s, cumulative, self.vertices[:, i]) for i in range(3)], axis=-1)

    @property
    def start_yaw(self) -> float:
        """Heading from the first waypoint to the second, rad."""
        d = self.waypoints[1] - self.waypoints[0]
        return math.atan2(d[1], d[0])


@dataclass(frozen=True)
class World:
    """A loadable world: its MJCF (as a file path or text), routes and floor heights.

    Attributes:
        name: built-in name, ``gen:SEED`` or the file's stem.
        xml: MJCF text when the world was generated in memory, else None.
        path: the MJCF file when the world lives on disk, else None.
        routes: routes by name, in sidecar order (the first is the default).
        levels: floor heights, m, increasing.
    """

    name: str
    routes: dict[str, Route]
    levels: tuple[float, ...]
    path: Path | None = None
    xml: str | None = None

    def route(self, name: str | None = None) -> Route:
        """The route called ``name`` (the default route when None)."""
        if name is None:
            return next(iter(self.routes.values()))
        if name not in self.routes:
            raise RouteError(f"route={name!r}: world {self.name!r} has routes {list(self.routes)}")
        return self.routes[name]

    def level_of(self, height: float | np.ndarray) -> int | np.ndarray:
        """Index of the floor level nearest to ``height`` (m)."""
        levels = np.asarray(self.levels)
        index = np.abs(np.asarray(height, dtype=float)[..., None] - levels).argmin(axis=-1)
        return int(index) if np.ndim(index) == 0 else index


def _worlds_directory() -> Path:
    try:
        return Path(str(resources.files("sim.worlds")))
    except ModuleNotFoundError:  # a source checkout on sys.path ahead of (or without) the installed package
        return Path(__file__).resolve().parent.parent / "worlds"


def builtin_worlds() -> list[str]:
    """Names of the built-in worlds shipped with the package."""
    return sorted(p.stem for p in _worlds_directory().glob("*.xml"))


def parse_routes(data: object, *, source: str = "routes") -> tuple[dict[str, Route], tuple[float, ...]]:
    """Validate the content of a routes sidecar and return (routes by name, floor levels)."""
    if not isinstance(data, dict) or not isinstance(data.get("routes"), dict) or not data["routes"]:
        raise RouteError(f"{source}: expected an object with a non-empty 'routes' object")
    routes: dict[str, Route] = {}
    for name, entry in data["routes"].items():
        where = f"{source}: routes.{name}"
        if not isinstance(entry, dict) or "waypoints" not in entry:
            raise RouteError(f"{where}: expected an object with 'waypoints'")
        try:
            waypoints = np.asarray(entry["waypoints"], dtype=float)
        except (TypeError, ValueError) as error:
            raise RouteError(f"{where}.waypoints: not a list of [x, y, z] numbers ({error})") from None
        if waypoints.ndim != 2 or waypoints.shape[1] != 3:
            raise RouteError(f"{where}.waypoints: expected [[x, y, z], ...], got shape {waypoints.shape}")
        if len(waypoints) < 2:
            raise RouteError(f"{where}.waypoints: needs at least two waypoints, got {len(waypoints)}")
        if not np.all(np.isfinite(waypoints)):
            raise RouteError(f"{where}.waypoints: contains NaN or infinity")
        if np.any(np.linalg.norm(np.diff(waypoints, axis=0), axis=1) == 0):
            raise RouteError(f"{where}.waypoints: two consecutive waypoints are identical")
        loop = entry.get("loop", True)
        if not isinstance(loop, bool):
            raise RouteError(f"{where}.loop={loop!r}: expected true or false")
        routes[name] = Route(name, waypoints, loop)
    if "levels" in data:
        levels = data["levels"]
        if (not isinstance(levels, list) or not levels
                or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in levels)):
            raise RouteError(f"{source}: levels={levels!r}: expected a list of floor heights in metres")
        levels = tuple(sorted(float(v) for v in levels))
    else:
        heights = sorted({round(float(z), 2) for r in routes.values() for z in r.waypoints[:, 2]})
        levels = tuple(heights)
    return routes, levels


def _read_routes(path: Path) -> tuple[dict[str, Route], tuple[float, ...]]:
    try:
        text = path.read_text()
    except OSError as error:
        raise RouteError(f"route file {str(path)!r}: cannot read ({error.strerror})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise RouteError(f"route file {str(path)!r}: invalid JSON ({error})") from None
    return parse_routes(data, source=f"route file {str(path)!r}")


def load_world(name: str | Path, *, routes: str | Path | None = None) -> World:
    """Find a world by name and read its routes.

    Args:
        name: a built-in world name, ``gen:SEED`` (an integer seed; ``genN:SEED`` for generator version N),
            or a path to an MJCF file.
        routes: a routes file to use instead of the sidecar ``NAME.routes.json``.

    Raises:
        WorldError: unknown name, missing file, or a bad ``gen:`` seed.
        RouteError: the routes file is missing or malformed.
    """
    text = str(name)
    generator = re.fullmatch(r"gen(\d*):(.*)", text)
    if generator is not None:
        from .arenas import GENERATOR_VERSION, GENERATOR_VERSIONS, generated

        version_text, seed_text = generator.groups()
        prefix = f"gen{version_text}:"
        version = int(version_text) if version_text else GENERATOR_VERSION
        if version not in GENERATOR_VERSIONS:
            raise WorldError(f"world={text!r}: no generator version {version} "
                             f"(versions {', '.join(map(str, GENERATOR_VERSIONS))}; gen:SEED is the latest)")
        try:
            seed = int(seed_text)
        except ValueError:
            raise WorldError(f"world={text!r}: {prefix!r} must be followed by an integer seed") from None
        if seed < 0:
            raise WorldError(f"world={text!r}: the seed must be a non-negative integer")
        source = generated(seed, version)
        if routes is not None:
            route_table, levels = _read_routes(Path(routes))
        else:
            route_table, levels = parse_routes(source.routes, source=text)
        return World(text, route_table, levels, xml=source.xml)
    path = Path(text)
    if path.suffix.lower() != ".xml":
        if text in builtin_worlds():
            path = _worlds_directory() / f"{text}.xml"
        else:
            raise WorldError(
                f"world={text!r}: not a built-in world ({', '.join(builtin_worlds())}), "
                "not 'gen:SEED' and not a path to an .xml file"
            )
    if not path.is_file():
        raise WorldError(f"world={text!r}: MJCF file {str(path)!r} does not exist")
    sidecar = Path(routes) if routes is not None else path.with_name(path.stem + ".routes.json")
    if routes is None and not sidecar.is_file():
        raise RouteError(f"world={text!r}: no route file {str(sidecar)!r} next to it (pass routes=...)")
    route_table, levels = _read_routes(sidecar)
    return World(path.stem, route_table, levels, path=path)
