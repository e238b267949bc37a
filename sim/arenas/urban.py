"""An urban block: streets between buildings and an elevated road (viaduct) reached by two ramps."""

from __future__ import annotations

import itertools
import math

import numpy as np

from .builder import Rect, WorldBuilder
from .storeys import WorldSource

__all__ = ["urban"]

DECK_HEIGHT = 3.0  # m, top of the viaduct deck
DECK = Rect(-20.0, 20.0, -4.0, 4.0)
RAMP_LENGTH = DECK_HEIGHT / math.tan(math.radians(10.0))  # 17.0 m at 10 degrees
HALF_X, HALF_Y = 46.0, 28.0


def _block(builder: WorldBuilder, area: Rect, count: int) -> None:
    """A row of ``count`` buildings of random height filling ``area``, with shop signs at street level."""
    xs = np.linspace(area.x0, area.x1, count + 1)
    for a, b in itertools.pairwise(xs):
        height = float(builder.rng.uniform(6.0, 22.0))
        builder.box([(a + b) / 2, (area.y0 + area.y1) / 2, height / 2], [(b - a) / 2 - 0.2, (area.y1 - area.y0) / 2,
                    height / 2], material=builder.material("facade"), kind="building")
        for y, sign in ((area.y0, -1), (area.y1, 1)):
            builder.box([(a + b) / 2, y + sign * 0.08, 2.2], [min(2.5, (b - a) / 2 - 0.6), 0.06, 0.5],
                        material=builder.material("sign"), collide=False, kind="sign")
            for x in np.linspace(a + 1.5, b - 1.5, 3):
                builder.box([x, y + sign * 0.05, height * 0.6], [0.6, 0.04, 0.8], material=builder.material("sign"),
                            collide=False, kind="window")


def urban(seed: int = 3) -> WorldSource:
    """Streets around four blocks of buildings, a 40 m viaduct at 3 m with 10-degree ramps at both ends.

    The ground streets form a ring (x = ±42 m, y = ±24 m) and a north–south street (x = 0) that passes
    under the viaduct; the viaduct's two carriageways are split by a median, so a robot can loop on it.
    """
    builder = WorldBuilder("urban", seed)
    asphalt = builder.material("floor", scale=2.0)
    builder.slab(Rect(-HALF_X, HALF_X, -HALF_Y, HALF_Y), 0.0, thickness=0.3, material=asphalt)
    for start, end in (((-HALF_X, -HALF_Y), (HALF_X, -HALF_Y)), ((HALF_X, -HALF_Y), (HALF_X, HALF_Y)),
                       ((HALF_X, HALF_Y), (-HALF_X, HALF_Y)), ((-HALF_X, HALF_Y), (-HALF_X, -HALF_Y))):
        builder.wall(start, end, 0.0, 5.0, thickness=0.4, material=builder.material("facade"))
    for area in (Rect(-38, -4, 8, 20), Rect(4, 38, 8, 20), Rect(-38, -4, -20, -8), Rect(4, 38, -20, -8)):
        _block(builder, area, int(builder.rng.integers(3, 6)))
    # the viaduct: deck, railings, median, supports, and one ramp at each end
    builder.box([0, 0, DECK_HEIGHT - 0.2], [DECK.x1, DECK.y1, 0.2], material=builder.material("ramp"), kind="deck")
    railing = builder.material("wall")
    for y in (DECK.y0, DECK.y1):
        builder.wall((DECK.x0, y), (DECK.x1, y), DECK_HEIGHT, DECK_HEIGHT + 1.0, material=railing)
    builder.wall((-14.0, 0.0), (14.0, 0.0), DECK_HEIGHT, DECK_HEIGHT + 0.5, thickness=0.3,
                 material=builder.material("pillar"))
    support = builder.material("pillar")
    for x in (-16.0, -8.0, 8.0, 16.0):
        for y in (-3.5, 3.5):
            builder.box([x, y, (DECK_HEIGHT - 0.4) / 2], [0.35, 0.35, (DECK_HEIGHT - 0.4) / 2], material=support,
                        kind="support")
    builder.ramp(Rect(DECK.x0 - RAMP_LENGTH, DECK.x0, DECK.y0, DECK.y1), "+x", 0.0, DECK_HEIGHT, low_railing=False)
    builder.ramp(Rect(DECK.x1, DECK.x1 + RAMP_LENGTH, DECK.y0, DECK.y1), "-x", 0.0, DECK_HEIGHT, low_railing=False)
    paint = builder.material("marking")
    for x in np.arange(-HALF_X + 6, HALF_X - 5, 3.0):
        for y in (-HALF_Y + 6.5, HALF_Y - 6.5):
            builder.box([x, y, 0.003], [0.75, 0.07, 0.002], material=paint, collide=False, kind="marking")
    for y in np.arange(-HALF_Y + 6, HALF_Y - 5, 3.0):
        if abs(y) > 4.5:
            builder.box([1.6, y, 0.003], [0.07, 0.75, 0.002], material=paint, collide=False, kind="marking")
    for x in (-25.0, 25.0):
        builder.light([x, 0, 30], [0.3, 0.2, -1], diffuse=0.35)
    bottom = RAMP_LENGTH + DECK.x1 + 0.4
    top = DECK.x1 - 0.4
    main = [
        [-42, -24, 0], [0, -24, 0], [0, 24, 0], [-42, 24, 0], [-42, -2, 0],
        [-bottom, -2, 0], [-top, -2, DECK_HEIGHT], [13, -2, DECK_HEIGHT], [16.5, 0, DECK_HEIGHT],
        [13, 2, DECK_HEIGHT], [-top, 2, DECK_HEIGHT], [-bottom, 2, 0], [-42, 2, 0],
    ]
    crossing = [
        [-42, -24, 0], [-42, -2, 0], [-bottom, -2, 0], [-top, -2, DECK_HEIGHT], [top, -2, DECK_HEIGHT],
        [bottom, -2, 0], [42, -2, 0], [42, -24, 0],
    ]
    rounded = [[[round(float(v), 3) for v in p] for p in route] for route in (main, crossing)]
    return WorldSource("urban", builder.to_xml(), {"levels": [0.0, DECK_HEIGHT], "routes": {
        "main": {"waypoints": rounded[0], "loop": True},
        "crossing": {"waypoints": rounded[1], "loop": True},
    }})
