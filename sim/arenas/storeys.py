"""Stacked multi-level worlds: a car park, an office building, and seeded random ones.

Every world here shares one skeleton (:func:`build_storeys`): a rectangular footprint, floors stacked at
the given heights, ramps alternating between the east side (rising +y) and the west side (rising -y),
and a ring lane on every level. The main route climbs every ramp with a ring on each level, comes back
down, drives the ring of the ground level and returns to its start, so lower-level places are revisited
after the upper ones (on the way down and on the next lap), as in the NeuroSLAM paper's datasets.
Flavours add what makes each place look like itself: pillars, parked cars and lane markings; rooms and
doorways; random obstacles.

The seeded generator is versioned (:data:`GENERATOR_VERSION`; ``gen:SEED`` is the latest, ``genN:SEED``
version N), so a seed's world never changes under a researcher: version 1 (:func:`_generated_1`) is kept
byte for byte, version 2 (:func:`_generated_2`) documents the distribution it draws from, and version 3
draws the same worlds as version 2 without coplanar faces of different materials
(:class:`~.builder.WorldBuilder`'s ``coplanar_free``).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .builder import COPLANAR_INSET, FLOOR_STYLES, Rect, WorldBuilder, subtract_rectangles

__all__ = ["GENERATOR_VERSION", "GENERATOR_VERSIONS", "StoreyLayout", "WorldSource", "build_storeys", "building",
           "carpark", "generated"]

RAMP_WIDTH = 4.0  # m
RAMP_END_MARGIN = 0.4  # m: waypoints just beyond a ramp's ends, on flat floor
SLAB_THICKNESS = 0.25  # m


@dataclass(frozen=True)
class WorldSource:
    """A world as data: its MJCF text, the routes sidecar content, and its name."""

    name: str
    xml: str
    routes: dict


@dataclass(frozen=True)
class StoreyLayout:
    """Geometry of a stacked world.

    Attributes:
        width: footprint along x, m.
        depth: footprint along y, m.
        levels: floor heights, m, starting at 0 and increasing.
        slope: ramp slope, radians (at most 12 degrees).
        roof: True to close the top level with a roof (building), False for an open deck (car park).
    """

    width: float
    depth: float
    levels: tuple[float, ...]
    slope: float = math.radians(10.0)
    roof: bool = False
    lane_inset_x: float = 6.0
    lane_inset_y: float = 2.5
    wall_heights: tuple[float, ...] = field(default=())

    def ramp_length(self, k: int) -> float:
        """Horizontal length of the ramp from level ``k`` to ``k + 1``, m."""
        return (self.levels[k + 1] - self.levels[k]) / math.tan(self.slope)

    def ramp_area(self, k: int) -> Rect:
        """Footprint of the ramp from level ``k`` to ``k + 1``: east side for even k, west for odd."""
        half = self.ramp_length(k) / 2
        if k % 2 == 0:
            return Rect(self.width / 2 - RAMP_WIDTH, self.width / 2, -half, half)
        return Rect(-self.width / 2, -self.width / 2 + RAMP_WIDTH, -half, half)

    def validate(self) -> None:
        if len(self.levels) < 2 or self.levels[0] != 0.0 or any(
                b <= a for a, b in itertools.pairwise(self.levels)):
            raise ValueError(f"levels={self.levels!r}: need two or more increasing heights starting at 0")
        if not 0 < self.slope <= math.radians(12.0) + 1e-9:
            raise ValueError(f"slope={self.slope!r}: must be in (0, 12 degrees]")
        longest = max(self.ramp_length(k) for k in range(len(self.levels) - 1))
        if self.depth < longest + 2 * self.lane_inset_y + 4.0:
            raise ValueError(f"depth={self.depth!r}: too short for a {longest:.1f} m ramp plus turning space")
        if self.width < 2 * self.lane_inset_x + 8.0:
            raise ValueError(f"width={self.width!r}: too narrow for a ring lane")


def _lanes(layout: StoreyLayout) -> dict[str, float]:
    w, d = layout.width / 2, layout.depth / 2
    return {
        "east": w - layout.lane_inset_x, "west": -(w - layout.lane_inset_x),
        "north": d - layout.lane_inset_y, "south": -(d - layout.lane_inset_y),
        "east_up": w - 1.3, "east_down": w - 2.7, "west_up": -(w - 1.3), "west_down": -(w - 2.7),
    }


def main_route(layout: StoreyLayout) -> list[list[float]]:
    """Waypoints of the main route: up through every level with a ring on each, then all the way down
    and a ring on the ground level back to the start.

    The route starts at the south-east corner of the ground ring heading east to the first ramp, and
    arrives there heading south, so laps join without turning back (every turn is at most 90 degrees).
    """
    lane = _lanes(layout)
    e, w, n, s = lane["east"], lane["west"], lane["north"], lane["south"]
    h = layout.levels
    top = len(h) - 1
    points: list[tuple[float, float, float]] = [(e, s, 0)]
    # climb: ramp k starts at the south end (east side, k even) or the north end (west side, k odd)
    for k in range(top):
        half = layout.ramp_length(k) / 2 + RAMP_END_MARGIN
        if k % 2 == 0:
            x = lane["east_up"]
            points += [(x, s, h[k]), (x, -half, h[k]), (x, half, h[k + 1]), (x, n, h[k + 1])]
            ring = [(w, n), (w, s), (e, s), (e, n)]
        else:
            x = lane["west_up"]
            points += [(x, n, h[k]), (x, half, h[k]), (x, -half, h[k + 1]), (x, s, h[k + 1])]
            ring = [(e, s), (e, n), (w, n), (w, s)]
        points += [(px, py, h[k + 1]) for px, py in ring]
    # descend the same ramps in the other lane, top first
    for k in reversed(range(top)):
        half = layout.ramp_length(k) / 2 + RAMP_END_MARGIN
        if k % 2 == 0:
            x = lane["east_down"]
            points += [(x, n, h[k + 1]), (x, half, h[k + 1]), (x, -half, h[k]), (x, s, h[k])]
        else:
            x = lane["west_down"]
            points += [(x, s, h[k + 1]), (x, -half, h[k + 1]), (x, half, h[k]), (x, n, h[k])]
    points += [(w, s, 0), (w, n, 0), (e, n, 0)]  # the ground ring, clockwise, back to the start
    cleaned: list[list[float]] = []
    for p in points:
        q = [round(float(v), 3) for v in p]
        if not cleaned or q != cleaned[-1]:
            cleaned.append(q)
    if cleaned[-1] == cleaned[0]:
        cleaned.pop()
    return cleaned


def build_storeys(builder: WorldBuilder, layout: StoreyLayout, *, floors: Sequence[str] | None = None,
                  ramps: Sequence[str] | None = None, parapet: float = 1.1, light: float = 1.0) -> list[Rect]:
    """Floors, ramps, outer walls and lights of a stacked world; returns the open core area of the rings.

    Level ``k`` is enclosed by outer walls up to the next floor; the top level gets a roof (or a ``parapet``
    metres high when ``layout.roof`` is False: 1.1 m hides the horizon from the robot's camera, 0.2 m, a curb,
    shows it). ``floors`` and ``ramps`` name each level's and each ramp's material (drawn at random when
    omitted); ``light`` scales the directional lights' brightness.
    """
    layout.validate()
    w, d = layout.width / 2, layout.depth / 2
    footprint = Rect(-w, w, -d, d)
    top = len(layout.levels) - 1
    for k, height in enumerate(layout.levels):
        holes = [layout.ramp_area(k - 1)] if k > 0 else []
        floor_material = floors[k] if floors is not None else builder.material("floor")
        builder.slab(footprint, height, thickness=SLAB_THICKNESS, material=floor_material, holes=holes)
        if k > 0:  # the slab's underside seen from the level below, drawn as its own ceiling
            ceiling = builder.material("ceiling")
            for r in subtract_rectangles(footprint, holes):
                builder.box([(r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2, height - SLAB_THICKNESS - 0.005],
                            [(r.x1 - r.x0) / 2, (r.y1 - r.y0) / 2, 0.005], material=ceiling, collide=False,
                            kind="ceiling")
        if k < top:
            builder.ramp(layout.ramp_area(k), "+y" if k % 2 == 0 else "-y", height, layout.levels[k + 1],
                         material=ramps[k] if ramps is not None else None)
        upper = layout.levels[k + 1] if k < top else height + (3.0 if layout.roof else parapet)
        if k < top and builder.coplanar_free:  # the wall's top inside the next slab, not in its floor's plane
            upper -= COPLANAR_INSET
        for start, end in (((-w, -d), (w, -d)), ((w, -d), (w, d)), ((w, d), (-w, d)), ((-w, d), (-w, -d))):
            builder.wall(start, end, height, upper, material=builder.material("wall"))
    if layout.roof:
        roof_height = layout.levels[-1] + 3.0
        builder.slab(footprint, roof_height + SLAB_THICKNESS, thickness=SLAB_THICKNESS,
                     material=builder.material("ceiling"))
    for x in (-w / 2, w / 2):
        builder.light([x, 0, layout.levels[-1] + 20], [0.2, 0.1, -1], diffuse=0.35 * light)
    lane = _lanes(layout)
    margin = 1.8
    return [Rect(lane["west"] + margin, lane["east"] - margin, lane["south"] + margin, lane["north"] - margin)]


def _wall_panels(builder: WorldBuilder, layout: StoreyLayout, spacing: float = 5.0,
                 heights: Sequence[float] | None = None) -> None:
    """Distinct coloured panels on the inside of the outer walls of every level (or of the floors at
    ``heights``): landmarks for place recognition."""
    w, d = layout.width / 2, layout.depth / 2
    for height in layout.levels if heights is None else heights:
        for x in np.arange(-w + 3, w - 2, spacing):
            for y, sign in ((-d, 1), (d, -1)):
                builder.box([x, y + sign * 0.13, height + 1.4], [0.7, 0.03, 0.45], material=builder.material("sign"),
                            collide=False, kind="sign")
        for y in np.arange(-d + 3, d - 2, spacing):
            for x, sign in ((-w, 1), (w, -1)):
                builder.box([x + sign * 0.13, y, height + 1.4], [0.03, 0.7, 0.45], material=builder.material("sign"),
                            collide=False, kind="sign")


def _lane_markings(builder: WorldBuilder, layout: StoreyLayout) -> None:
    """Dashed lines along the ring lanes of every level (flat, not colliding)."""
    lane = _lanes(layout)
    paint = builder.material("marking")
    for height in layout.levels:
        z = height + 0.003
        for y in (lane["south"], lane["north"]):
            for x in np.arange(lane["west"] + 1.0, lane["east"] - 0.5, 2.0):
                builder.box([x, y, z], [0.5, 0.06, 0.002], material=paint, collide=False, kind="marking")
        for x in (lane["west"], lane["east"]):
            for y in np.arange(lane["south"] + 1.0, lane["north"] - 0.5, 2.0):
                builder.box([x, y, z], [0.06, 0.5, 0.002], material=paint, collide=False, kind="marking")


def _parked_car(builder: WorldBuilder, x: float, y: float, floor: float, yaw: float) -> None:
    body = builder.material("car")
    length, width = builder.rng.uniform(3.8, 4.8), builder.rng.uniform(1.7, 1.9)
    builder.box([x, y, floor + 0.45], [length / 2, width / 2, 0.3], material=body, yaw=yaw, kind="car")
    cabin = builder.material("car")
    builder.box([x - 0.2 * math.cos(yaw), y - 0.2 * math.sin(yaw), floor + 1.0],
                [length * 0.28, width / 2 - 0.1, 0.26], material=cabin, yaw=yaw, kind="car")


def carpark(seed: int = 1) -> WorldSource:
    """A two-level car park, 40 × 30 m per level, 3 m between levels, one 10-degree ramp."""
    layout = StoreyLayout(width=40.0, depth=30.0, levels=(0.0, 3.0))
    builder = WorldBuilder("carpark", seed)
    (core,) = build_storeys(builder, layout)
    _wall_panels(builder, layout)
    _lane_markings(builder, layout)
    for k, height in enumerate(layout.levels):
        pillar = builder.material("pillar")
        xs = np.linspace(core.x0 + 1.0, core.x1 - 1.0, 5)
        for x in xs:
            for y in (core.y0 + 0.6, 0.0, core.y1 - 0.6):
                if k == 0:
                    builder.box([x, y, 1.5], [0.3, 0.3, 1.5], material=pillar, kind="pillar")
                else:
                    builder.cylinder([x, y, height + 2.0], 0.08, 2.0, material=pillar)
        for x0, x1 in itertools.pairwise(xs):
            for y in (core.y0 + 2.8, core.y1 - 2.8):
                if builder.rng.uniform() < 0.75:
                    _parked_car(builder, (x0 + x1) / 2, y, height, math.pi / 2 + builder.rng.normal(0, 0.05))
    return WorldSource("carpark", builder.to_xml(), {"levels": list(layout.levels), "routes": {
        "main": {"waypoints": main_route(layout), "loop": True}, **_session_routes(layout, core, xs)}})


def _session_routes(layout: StoreyLayout, core: Rect, pillars: np.ndarray) -> dict[str, dict]:
    """Loops on the car park's ground floor for multisession experiments, all driven the way the main route
    drives its ground ring (west along the south lane, north along the west lane, east along the north
    lane, south along the east lane), so that their views match the main route's where they overlap.

    ``west`` uses the free column between the last two pillar columns as its east side; ``ground`` is the
    whole ring (it starts at the north-east corner, where ``west`` never goes); ``west-then-ground`` drives
    one and then the other; ``south-block`` and ``north-block`` are the halves south and north of the
    middle pillar row (rows midway to the outer pillar rows), which never meet.
    """
    lane = _lanes(layout)
    west, east, south, north = lane["west"], lane["east"], lane["south"], lane["north"]
    column = round(float(pillars[-2] + pillars[-1]) / 2, 1)
    row = round((core.y1 - 0.6) / 2, 1)
    floor = layout.levels[0]

    def loop(*points: tuple[float, float]) -> dict:
        return {"waypoints": [[float(x), float(y), floor] for x, y in points], "loop": True}

    return {
        "west": loop((column, south), (west, south), (west, north), (column, north)),
        "ground": loop((east, north), (east, south), (west, south), (west, north)),
        "west-then-ground": loop((column, south), (west, south), (west, north), (column, north), (column, south),
                                 (west, south), (west, north), (east, north), (east, south)),
        "south-block": loop((column, south), (west, south), (west, -row), (column, -row)),
        "north-block": loop((west, north), (column, north), (column, row), (west, row)),
    }


def _rooms(builder: WorldBuilder, core: Rect, floor: float, height: float, rooms: int) -> None:
    """A block of ``rooms`` rooms filling ``core``, each with a doorway onto the corridor around it."""
    wall = builder.material("wall")
    top = floor + height
    door = 1.2
    builder.wall((core.x0, core.y0), (core.x0, core.y1), floor, top, material=wall)
    builder.wall((core.x1, core.y0), (core.x1, core.y1), floor, top, material=wall)
    xs = np.linspace(core.x0, core.x1, rooms + 1)
    for x in xs[1:-1]:
        builder.wall((x, core.y0), (x, core.y1), floor, top, material=builder.material("wall"))
    for a, b in itertools.pairwise(xs):
        middle = (a + b) / 2
        for y in (core.y0, core.y1):  # a doorway in each room's long sides
            builder.wall((a, y), (middle - door / 2, y), floor, top, material=wall)
            builder.wall((middle + door / 2, y), (b, y), floor, top, material=wall)
        furniture = builder.material("car")
        builder.box([middle + builder.rng.uniform(-1, 1), (core.y0 + core.y1) / 2, floor + 0.4],
                    [0.8, 0.5, 0.4], material=furniture, kind="furniture")


def building(seed: int = 2) -> WorldSource:
    """An office building with three floors 3 m apart, a ring corridor around rooms, ramps between floors."""
    layout = StoreyLayout(width=36.0, depth=28.0, levels=(0.0, 3.0, 6.0), roof=True, slope=math.radians(11.0))
    builder = WorldBuilder("building", seed)
    (core,) = build_storeys(builder, layout)
    _wall_panels(builder, layout, spacing=4.0)
    for height in layout.levels:
        _rooms(builder, core, height, 3.0 - SLAB_THICKNESS, rooms=4)
    return WorldSource("building", builder.to_xml(), {"levels": list(layout.levels), "routes": {
        "main": {"waypoints": main_route(layout), "loop": True}}})


GENERATOR_VERSION = 3  # what ``gen:SEED`` draws from; ``genN:SEED`` names version N
GENERATOR_VERSIONS = (1, 2, 3)


def generated(seed: int, version: int = GENERATOR_VERSION) -> WorldSource:
    """A random stacked world for tests and benchmarks, different for every seed and identical for the same
    seed and generator ``version`` (see :func:`_generated_2` for the distribution it draws from, and the
    changelog for what each version changed).

    Raises:
        ValueError: a negative seed or an unknown version.
    """
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed={seed!r}: must be a non-negative integer")
    if version not in GENERATOR_VERSIONS:
        raise ValueError(f"version={version!r}: the generator's versions are {GENERATOR_VERSIONS}")
    return _generated_1(int(seed)) if version == 1 else _generated_2(int(seed), version)


def _generated_1(seed: int) -> WorldSource:
    """Generator version 1 (``gen1:SEED``; ``gen:SEED`` until version 2): 2–3 levels, 8–11.5 degree ramps, a
    random footprint, random obstacles, and every surface's texture drawn by :meth:`WorldBuilder.material`."""
    rng = np.random.default_rng([seed, 0x5EED])
    n_levels = int(rng.integers(2, 4))
    heights = np.cumsum([0.0, *rng.uniform(2.6, 3.4, n_levels - 1)])
    slope = math.radians(float(rng.uniform(8.0, 11.5)))
    longest = max(np.diff(heights)) / math.tan(slope)
    layout = StoreyLayout(
        width=float(round(rng.uniform(30.0, 46.0), 1)),
        depth=float(round(longest + 9.0 + rng.uniform(0.0, 8.0), 1)),
        levels=tuple(float(round(h, 2)) for h in heights),
        slope=slope, roof=bool(rng.uniform() < 0.5),
    )
    name = f"gen:{seed}"  # the name it had as the only version: its MJCF stays byte for byte the same
    builder = WorldBuilder(name, int(rng.integers(2**31)))
    (core,) = build_storeys(builder, layout)
    _wall_panels(builder, layout, spacing=float(rng.uniform(3.5, 7.0)))
    if rng.uniform() < 0.5:
        _lane_markings(builder, layout)
    for height in layout.levels:
        for _ in range(int(rng.integers(4, 10))):
            sx, sy = rng.uniform(0.3, 1.5, 2)
            reach = math.hypot(sx, sy)  # any yaw keeps the obstacle inside the core
            x = rng.uniform(core.x0 + reach, core.x1 - reach)
            y = rng.uniform(core.y0 + reach, core.y1 - reach)
            tall = rng.uniform(0.4, 2.4)
            builder.box([x, y, height + tall / 2], [sx, sy, tall / 2], material=builder.material("pillar"),
                        yaw=float(rng.uniform(0, math.pi)), kind="obstacle")
    return WorldSource(name, builder.to_xml(), {"levels": list(layout.levels), "routes": {
        "main": {"waypoints": main_route(layout), "loop": True}}})


# generator version 2's distribution: (choices, probabilities) or (low, high) of a uniform draw
LEVEL_COUNTS = ((2, 3, 4), (0.4, 0.35, 0.25))
SLOPES = (5.0, 12.0)  # degrees
TOPS = (("roof", "parapet", "open", "deck"), (0.3, 0.2, 0.25, 0.25))
BRIGHTNESS = (0.45, 1.3)  # times the built-in worlds' lights
CORRIDOR_SHARE = 0.35  # of levels: a block of rooms with a corridor around it instead of an open hall


def _generated_2(seed: int, version: int = 2) -> WorldSource:
    """Generator versions 2 (``gen2:SEED``) and 3 (``gen:SEED``, ``gen3:SEED``): the distribution the
    generalization benchmark draws. Version 3 draws the same world as version 2 and builds it without coplanar
    faces of different materials (:class:`~.builder.WorldBuilder`'s ``coplanar_free``: a ramp's side walls
    stood in the outer walls, the walls' tops lay in the floors above them and a wall's end in the face of the
    wall it met, each pair flickering in the camera's images); its MJCF differs only there and in its model
    name.

    - **Levels**: 2, 3 or 4 (probabilities 0.4, 0.35, 0.25), 2.6–3.4 m apart; ramps of 5–12 degrees
      (uniform), so the footprint's depth (ramp plus turning space, 9–17 m more) runs from about 22 to 56 m,
      its width 30–46 m.
    - **Floors**: every level's floor and every ramp draws one of :data:`~sim.arenas.builder.FLOOR_STYLES`
      with equal chances: blank (one flat colour), low-contrast, large-tiled (thin lines 2.5–4 m apart) and
      well-marked; half the worlds paint dashed lane markings on every level on top.
    - **Top level**: a roof (0.3), a 1.1 m parapet that hides the horizon (0.2), an open deck behind a 0.2 m
      curb with the land and the horizon in view (0.25), or such a deck with a second deck 2.6–3.2 m over a
      third to two thirds of it, on pillars (0.25).
    - **Halls and corridors**: each level is an open hall with 4–9 obstacles (0.65), or a block of 3–5 rooms
      whose walls stand 1 m beside the ring lane, a narrow corridor (0.35).
    - **Light**: the headlight and the sun scaled by 0.45–1.3, from dim to bright.
    - Walls, ceilings and obstacles draw their textures as version 1 does (:meth:`WorldBuilder.material`),
      coloured panels on the outer walls every 3.5–7 m.
    - **Routes**: ``main`` (see :func:`main_route`), and ``upper``, the same loop begun where it first
      reaches level 1, for a second session that starts on another level than the first.
    """
    rng = np.random.default_rng([seed, 0x5EED, 2])
    n_levels = int(rng.choice(LEVEL_COUNTS[0], p=LEVEL_COUNTS[1]))
    heights = np.cumsum([0.0, *rng.uniform(2.6, 3.4, n_levels - 1)])
    slope = math.radians(float(rng.uniform(*SLOPES)))
    longest = max(np.diff(heights)) / math.tan(slope)
    top_kind = str(rng.choice(TOPS[0], p=TOPS[1]))
    layout = StoreyLayout(
        width=float(round(rng.uniform(30.0, 46.0), 1)),
        depth=float(round(longest + 9.0 + rng.uniform(0.0, 8.0), 1)),
        levels=tuple(float(round(h, 2)) for h in heights),
        slope=slope, roof=top_kind == "roof",
    )
    floor_styles = [str(rng.choice(FLOOR_STYLES)) for _ in layout.levels]
    ramp_styles = [str(rng.choice(FLOOR_STYLES)) for _ in layout.levels[1:]]
    corridors = [bool(rng.uniform() < CORRIDOR_SHARE) for _ in layout.levels]
    brightness = float(rng.uniform(*BRIGHTNESS))
    markings = bool(rng.uniform() < 0.5)
    name = f"gen{version}:{seed}"
    builder = WorldBuilder(name, int(rng.integers(2**31)), coplanar_free=version >= 3)
    builder.lighting(brightness)
    floors = [builder.floor_material(style) for style in floor_styles]
    ramps = [builder.floor_material(style, kind="ramp") for style in ramp_styles]
    open_top = top_kind in ("open", "deck")
    (core,) = build_storeys(builder, layout, floors=floors, ramps=ramps, parapet=0.2 if open_top else 1.1,
                            light=brightness)
    if open_top:
        builder.ground(200.0, material=builder.material("land", scale=4.0))
    _wall_panels(builder, layout, spacing=float(builder.rng.uniform(3.5, 7.0)),  # none in the air over a curb
                 heights=layout.levels[:-1] if open_top else layout.levels)
    if markings:
        _lane_markings(builder, layout)
    lane = _lanes(layout)
    for k, height in enumerate(layout.levels):
        if corridors[k]:
            upper = layout.levels[k + 1] if k + 1 < len(layout.levels) else height + 3.0
            block = Rect(lane["west"] + 1.0, lane["east"] - 1.0, lane["south"] + 1.0, lane["north"] - 1.0)
            _rooms(builder, block, height, upper - height - SLAB_THICKNESS, rooms=int(builder.rng.integers(3, 6)))
            continue
        for _ in range(int(builder.rng.integers(4, 10))):
            sx, sy = builder.rng.uniform(0.3, 1.5, 2)
            reach = math.hypot(sx, sy)  # any yaw keeps the obstacle inside the core
            x = builder.rng.uniform(core.x0 + reach, core.x1 - reach)
            y = builder.rng.uniform(core.y0 + reach, core.y1 - reach)
            tall = builder.rng.uniform(0.4, 2.4)
            builder.box([x, y, height + tall / 2], [sx, sy, tall / 2], material=builder.material("pillar"),
                        yaw=float(builder.rng.uniform(0, math.pi)), kind="obstacle")
    if top_kind == "deck":
        _partial_deck(builder, layout, float(builder.rng.uniform(1 / 3, 2 / 3)), float(builder.rng.uniform(2.6, 3.2)))
    main = main_route(layout)
    # the same loop begun on the first level: a second session that starts where the first never began
    first = next(k for k, point in enumerate(main) if point[2] == layout.levels[1])
    return WorldSource(name, builder.to_xml(), {"levels": list(layout.levels), "routes": {
        "main": {"waypoints": main, "loop": True},
        "upper": {"waypoints": main[first:] + main[:first], "loop": True}}})


def _partial_deck(builder: WorldBuilder, layout: StoreyLayout, share: float, clearance: float) -> None:
    """A deck ``clearance`` metres over the west ``share`` of the open top level, on a row of pillars along
    its east edge and the outer walls: part of the top level under a ceiling, the rest under the sky."""
    w, d = layout.width / 2, layout.depth / 2
    top = layout.levels[-1]
    edge = -w + share * layout.width
    underside = top + clearance
    builder.slab(Rect(-w, edge, -d, d), underside + SLAB_THICKNESS, thickness=SLAB_THICKNESS,
                 material=builder.material("floor"), kind="deck")
    builder.box([(edge - w) / 2, 0.0, underside - 0.005], [(edge + w) / 2, d, 0.005],
                material=builder.material("ceiling"), collide=False, kind="ceiling")
    lane = _lanes(layout)
    pillar = builder.material("pillar")
    inner = np.linspace(lane["south"] + 2.0, lane["north"] - 2.0, max(2, int(layout.depth // 8)))
    for y in (-d + 0.4, *inner, d - 0.4):  # beside the lanes, never on them (they keep 2 m from a pillar)
        builder.box([edge - 0.2, float(y), top + clearance / 2], [0.2, 0.2, clearance / 2], material=pillar,
                    kind="pillar")
