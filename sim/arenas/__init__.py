"""World builders: the built-in worlds shipped in ``worlds/`` and the seeded procedural generator.

The MJCF files in ``worlds/`` are written by ``python -m sim.arenas`` from these builders (a test checks
that the shipped files match them), so the worlds stay readable data while their design lives in code.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

from .builder import Rect, WorldBuilder, subtract_rectangles
from .storeys import GENERATOR_VERSION, GENERATOR_VERSIONS, StoreyLayout, WorldSource, building, carpark, generated
from .urban import urban

__all__ = [
    "BUILTIN_BUILDERS", "GENERATOR_VERSION", "GENERATOR_VERSIONS", "Rect", "StoreyLayout", "WorldBuilder",
    "WorldSource", "building", "carpark", "generated", "routes_json", "subtract_rectangles", "urban", "write_world",
]

BUILTIN_BUILDERS: dict[str, Callable[[], WorldSource]] = {"carpark": carpark, "urban": urban, "building": building}


def routes_json(source: WorldSource) -> str:
    """The routes sidecar text of a world (stable formatting: one waypoint per line)."""
    lines = ["{", f'  "levels": {json.dumps(source.routes["levels"])},', '  "routes": {']
    routes = list(source.routes["routes"].items())
    for i, (name, route) in enumerate(routes):
        points = ",\n".join(f"        {json.dumps(p)}" for p in route["waypoints"])
        lines += [f"    {json.dumps(name)}: {{", f'      "loop": {json.dumps(route["loop"])},',
                  f'      "waypoints": [\n{points}\n      ]', "    }" + ("," if i < len(routes) - 1 else "")]
    lines += ["  }", "}"]
    return "\n".join(lines) + "\n"


def write_world(source: WorldSource, directory: Path, stem: str | None = None) -> Path:
    """Write ``STEM.xml`` and ``STEM.routes.json`` into ``directory``; returns the MJCF path."""
    directory.mkdir(parents=True, exist_ok=True)
    stem = stem or source.name.replace(":", "_")
    path = directory / f"{stem}.xml"
    path.write_text(source.xml)
    (directory / f"{stem}.routes.json").write_text(routes_json(source))
    return path
