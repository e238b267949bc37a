"""Composable MJCF building blocks for multi-level worlds: slabs, walls, ramps, boxes, textures.

A :class:`WorldBuilder` collects static geometry into one MJCF document. Every surface gets its own
procedural texture (MuJoCo's built-in checker, gradient and speckle generators with colours, marks and
scales drawn from the builder's seeded generator), so a camera sees different places differently and
the same seed always gives the same world. All lengths are metres, angles radians, z is up.
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["FLOOR_STYLES", "Rect", "WorldBuilder", "subtract_rectangles"]

FLOOR_STYLES = ("blank", "low-contrast", "large-tiled", "well-marked")

# Hue (0..1), saturation and value ranges per kind of surface: concrete is grey, cars are vivid...
_PALETTES: dict[str, tuple[tuple[float, float], tuple[float, float], tuple[float, float]]] = {
    "floor": ((0.0, 1.0), (0.02, 0.15), (0.35, 0.6)),
    "ceiling": ((0.0, 1.0), (0.0, 0.1), (0.55, 0.8)),
    "wall": ((0.0, 1.0), (0.15, 0.55), (0.45, 0.85)),
    "pillar": ((0.0, 1.0), (0.3, 0.8), (0.5, 0.9)),
    "car": ((0.0, 1.0), (0.5, 0.95), (0.35, 0.95)),
    "sign": ((0.0, 1.0), (0.6, 1.0), (0.6, 1.0)),
    "facade": ((0.0, 1.0), (0.1, 0.5), (0.35, 0.8)),
    "ramp": ((0.0, 1.0), (0.05, 0.3), (0.4, 0.65)),
    "marking": ((0.12, 0.17), (0.0, 0.9), (0.85, 1.0)),
    "land": ((0.2, 0.4), (0.2, 0.5), (0.3, 0.55)),
}


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle in the horizontal plane, metres (x0 < x1, y0 < y1)."""

    x0: float
    x1: float
    y0: float
    y1: float

    def overlaps(self, other: Rect) -> bool:
        return self.x0 < other.x1 and other.x0 < self.x1 and self.y0 < other.y1 and other.y0 < self.y1


def subtract_rectangles(outer: Rect, holes: Sequence[Rect]) -> list[Rect]:
    """Cover ``outer`` minus the ``holes`` with few axis-aligned rectangles.

    The plane is cut along every hole edge; the cells outside all holes are merged along x into
    strips, and vertically adjacent strips with the same x-extent are merged again.
    """
    xs = sorted({outer.x0, outer.x1, *(min(max(v, outer.x0), outer.x1) for h in holes for v in (h.x0, h.x1))})
    ys = sorted({outer.y0, outer.y1, *(min(max(v, outer.y0), outer.y1) for h in holes for v in (h.y0, h.y1))})
    strips: list[Rect] = []
    for y0, y1 in itertools.pairwise(ys):
        start = None
        for x0, x1 in itertools.pairwise(xs):
            cell = Rect(x0, x1, y0, y1)
            free = not any(cell.overlaps(h) for h in holes)
            if free and start is None:
                start = x0
            if not free and start is not None:
                strips.append(Rect(start, x0, y0, y1))
                start = None
        if start is not None:
            strips.append(Rect(start, xs[-1], y0, y1))
    merged: list[Rect] = []
    for strip in strips:
        for i, m in enumerate(merged):
            if m.x0 == strip.x0 and m.x1 == strip.x1 and m.y1 == strip.y0:
                merged[i] = Rect(m.x0, m.x1, m.y0, strip.y1)
                break
        else:
            merged.append(strip)
    return merged


def _fmt(values: Sequence[float]) -> str:
    return " ".join(f"{v:.4g}" if abs(v) >= 1e-9 else "0" for v in values)


def _yaw_pitch_quaternion(yaw: float, pitch: float) -> tuple[float, float, float, float]:
    """Quaternion (w, x, y, z) of a rotation by ``pitch`` about y (positive tilts +x up) then ``yaw`` about z."""
    half_yaw, half_pitch = yaw / 2, -pitch / 2
    qz = (math.cos(half_yaw), 0.0, 0.0, math.sin(half_yaw))
    qy = (math.cos(half_pitch), 0.0, math.sin(half_pitch), 0.0)
    w1, x1, y1, z1 = qz
    w2, x2, y2, z2 = qy
    return (
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    )


# m: how far a surface is kept out of another's plane where generator version 3 keeps them apart
# (WorldBuilder.coplanar_free). Far above the depth buffer's resolution (under 0.1 mm at 20 m for the
# testbed's camera), far below what the camera resolves (a pixel spans 1.7 cm at 2 m).
COPLANAR_INSET = 0.02


class WorldBuilder:
    """Collects static geometry, textures and lights of one world and writes it as MJCF.

    Args:
        name: model name written into the MJCF file.
        seed: seed of the generator that picks every texture's colours and pattern.
        coplanar_free: keep surfaces of different materials out of each other's planes where they overlap
            (generator version 3 on). Two coplanar faces of one place flicker from frame to frame as the
            depth buffer picks either ("z-fighting"), which a camera reads as motion: a ramp's side wall
            standing in a level's outer wall, a wall's top in the floor slab above it, a wall's end in the
            face of the wall it meets at a corner. With it, a ramp's walls are :data:`COPLANAR_INSET`
            thinner on each side than a level's (so where one stands in a level's wall it is hidden inside
            it), every wall reaches :data:`COPLANAR_INSET` less than half its thickness past its end points
            (its end inside the wall it meets, not in that wall's face), and
            :func:`~.storeys.build_storeys` ends a level's outer walls :data:`COPLANAR_INSET` below the next
            floor's top (inside its slab). Off, the geometry is what versions 1 and 2 and the built-in worlds
            were built with.
    """

    def __init__(self, name: str, seed: int, *, coplanar_free: bool = False):
        self.name = name
        self.coplanar_free = bool(coplanar_free)
        self.rng = np.random.default_rng(seed)
        self.root = ET.Element("mujoco", model=name)
        ET.SubElement(self.root, "compiler", angle="radian")
        ET.SubElement(self.root, "option", timestep="0.005", integrator="implicitfast")
        visual = ET.SubElement(self.root, "visual")
        ET.SubElement(visual, "headlight", ambient="0.35 0.35 0.35", diffuse="0.45 0.45 0.45", specular="0 0 0")
        ET.SubElement(visual, "quality", shadowsize="4096", offsamples="4")
        self.asset = ET.SubElement(self.root, "asset")
        ET.SubElement(
            self.asset, "texture", name="sky", type="skybox", builtin="gradient",
            rgb1="0.55 0.7 0.9", rgb2="0.95 0.95 1", width="64", height="64",
        )
        self.worldbody = ET.SubElement(self.root, "worldbody")
        self._counts: dict[str, int] = {}

    def _name(self, kind: str) -> str:
        n = self._counts.get(kind, 0)
        self._counts[kind] = n + 1
        return f"{kind}{n}"

    def _colour(self, kind: str) -> np.ndarray:
        (h0, h1), (s0, s1), (v0, v1) = _PALETTES[kind]
        h, s, v = self.rng.uniform(h0, h1), self.rng.uniform(s0, s1), self.rng.uniform(v0, v1)
        i = int(h * 6) % 6
        f = h * 6 - int(h * 6)
        p, q, t = v * (1 - s), v * (1 - f * s), v * (1 - (1 - f) * s)
        return np.array([(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i])

    def material(self, kind: str, *, scale: float | None = None) -> str:
        """Create a new procedural texture and material for one surface; returns the material name.

        Args:
            kind: palette to draw colours from (floor, ceiling, wall, pillar, car, sign, facade, ramp, marking).
            scale: size of one texture tile in metres (drawn at random when omitted).
        """
        if kind not in _PALETTES:
            raise ValueError(f"kind={kind!r}: unknown surface kind, expected one of {sorted(_PALETTES)}")
        name = self._name(f"{kind}_")
        base = self._colour(kind)
        second = np.clip(base * self.rng.uniform(0.55, 0.85) + self.rng.uniform(-0.08, 0.08, 3), 0, 1)
        mark_colour = np.clip(1.0 - base + self.rng.uniform(-0.2, 0.2, 3), 0, 1)
        builtin = str(self.rng.choice(["checker", "flat", "gradient", "checker", "flat"]))
        mark = str(self.rng.choice(["random", "edge", "cross", "random", "none"]))
        if kind == "marking":
            builtin, mark = "flat", "none"
        size = int(self.rng.choice([32, 48, 64]))
        attributes = {
            "name": name, "type": "2d", "builtin": builtin, "rgb1": _fmt(base), "rgb2": _fmt(second),
            "width": str(size), "height": str(size), "mark": mark, "markrgb": _fmt(mark_colour),
        }
        if mark == "random":
            attributes["random"] = f"{self.rng.uniform(0.02, 0.12):.3f}"
        ET.SubElement(self.asset, "texture", attributes)
        tile = scale if scale is not None else float(self.rng.uniform(0.8, 3.0))
        ET.SubElement(
            self.asset, "material", name=name, texture=name, texuniform="true",
            texrepeat=_fmt([1 / tile, 1 / tile]), specular="0.1", shininess="0.1",
        )
        return name

    def floor_material(self, style: str, *, kind: str = "floor") -> str:
        """A texture and material for a floor or ramp of one of the generator's floor ``style``s; returns its name.

        - ``blank``: one flat colour, no marks (nothing for a floor alignment to hold on to);
        - ``low-contrast``: a checker or gradient whose two colours differ by 3–10 %, faint random marks;
        - ``large-tiled``: one colour with thin lines along the edges of 2.5–4 m tiles (sparse lines);
        - ``well-marked``: a contrasting checker of 0.6–1.5 m tiles (squares 0.3–0.75 m) with dense random dots
          of 2–5 cm.
        """
        if style not in FLOOR_STYLES:
            raise ValueError(f"style={style!r}: unknown floor style, expected one of {FLOOR_STYLES}")
        name = self._name(f"{kind}_{style}_")  # e.g. floor_large-tiled_0: the style is in the MJCF
        base = self._colour(kind)
        attributes = {"name": name, "type": "2d", "rgb1": _fmt(base), "width": "64", "height": "64"}
        if style == "blank":
            attributes.update(builtin="flat", rgb2=_fmt(base), mark="none")
            tile = 1.0
        elif style == "low-contrast":
            second = np.clip(base * self.rng.uniform(0.90, 0.97), 0, 1)
            marks = np.clip(base * self.rng.uniform(1.04, 1.10), 0, 1)
            attributes.update(builtin=str(self.rng.choice(["checker", "gradient"])), rgb2=_fmt(second),
                              mark="random", markrgb=_fmt(marks), random=f"{self.rng.uniform(0.02, 0.08):.3f}")
            tile = float(self.rng.uniform(0.8, 2.0))
        elif style == "large-tiled":
            lines = np.clip(1.0 - base + self.rng.uniform(-0.2, 0.2, 3), 0, 1)
            attributes.update(builtin="flat", rgb2=_fmt(base), mark="edge", markrgb=_fmt(lines))
            tile = float(self.rng.uniform(2.5, 4.0))
        else:  # well-marked: squares of a third to three quarters of a metre, and dots a few centimetres wide
            second = np.clip(base * self.rng.uniform(0.55, 0.8), 0, 1)
            marks = np.clip(1.0 - base + self.rng.uniform(-0.2, 0.2, 3), 0, 1)
            attributes.update(builtin="checker", rgb2=_fmt(second), mark="random", markrgb=_fmt(marks),
                              random=f"{self.rng.uniform(0.06, 0.15):.3f}", width="32", height="32")
            tile = float(self.rng.uniform(0.6, 1.5))
        ET.SubElement(self.asset, "texture", attributes)
        ET.SubElement(self.asset, "material", name=name, texture=name, texuniform="true",
                      texrepeat=_fmt([1 / tile, 1 / tile]), specular="0.1", shininess="0.1")
        return name

    def lighting(self, brightness: float) -> None:
        """Scale the headlight (ambient 0.35, diffuse 0.45 at ``brightness`` 1) for dim or bright worlds."""
        headlight = self.root.find("visual/headlight")
        headlight.set("ambient", _fmt([0.35 * brightness] * 3))
        headlight.set("diffuse", _fmt([0.45 * brightness] * 3))

    def ground(self, half_size: float, *, material: str) -> str:
        """A visual ground plane just below height 0 reaching ``half_size`` metres out (the land an open deck
        overlooks, up to the horizon); it does not collide. Returns its name."""
        name = self._name("ground")
        ET.SubElement(self.worldbody, "geom", name=name, type="plane", pos="0 0 -0.05",
                      size=_fmt([half_size, half_size, 1.0]), material=material, contype="0", conaffinity="0",
                      group="1")
        return name

    # geometry -----------------------------------------------------------------------------------------
    def box(
        self,
        center: Sequence[float],
        half_size: Sequence[float],
        *,
        material: str,
        yaw: float = 0.0,
        pitch: float = 0.0,
        collide: bool = True,
        kind: str = "box",
    ) -> str:
        """Add a static box; ``half_size`` is (x, y, z) half-lengths in its own frame. Returns its name."""
        name = self._name(kind)
        attributes = {
            "name": name, "type": "box", "pos": _fmt(center), "size": _fmt(half_size), "material": material,
        }
        if yaw or pitch:
            attributes["quat"] = _fmt(_yaw_pitch_quaternion(yaw, pitch))
        if not collide:
            attributes.update(contype="0", conaffinity="0", group="1")
        ET.SubElement(self.worldbody, "geom", attributes)
        return name

    def cylinder(self, center: Sequence[float], radius: float, half_height: float, *, material: str) -> str:
        """Add a static vertical cylinder (a pillar or pole). Returns its name."""
        name = self._name("pillar")
        ET.SubElement(
            self.worldbody, "geom", name=name, type="cylinder", pos=_fmt(center),
            size=_fmt([radius, half_height]), material=material,
        )
        return name

    def slab(self, area: Rect, top: float, *, thickness: float = 0.25, material: str,
             holes: Sequence[Rect] = (), kind: str = "floor") -> list[str]:
        """A horizontal floor slab whose upper face is at height ``top``, with rectangular openings."""
        names = []
        for r in subtract_rectangles(area, holes):
            names.append(self.box(
                [(r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2, top - thickness / 2],
                [(r.x1 - r.x0) / 2, (r.y1 - r.y0) / 2, thickness / 2], material=material, kind=kind,
            ))
        return names

    def wall(self, start: Sequence[float], end: Sequence[float], bottom: float, top: float, *,
             thickness: float = 0.2, material: str | None = None) -> str:
        """A vertical wall along the segment ``start``→``end`` (x, y) from height ``bottom`` to ``top``."""
        dx, dy = end[0] - start[0], end[1] - start[1]
        length = math.hypot(dx, dy)
        beyond = thickness / 2 - (COPLANAR_INSET if self.coplanar_free else 0.0)  # past each end point
        return self.box(
            [(start[0] + end[0]) / 2, (start[1] + end[1]) / 2, (bottom + top) / 2],
            [length / 2 + beyond, thickness / 2, (top - bottom) / 2],
            material=material or self.material("wall"), yaw=math.atan2(dy, dx), kind="wall",
        )

    def ramp(self, area: Rect, direction: str, bottom: float, top: float, *, thickness: float = 0.2,
             railing: float = 1.0, low_railing: bool = True, material: str | None = None) -> Rect:
        """A drivable ramp filling ``area`` and rising from ``bottom`` to ``top`` along ``direction``.

        ``direction`` is one of ``+x, -x, +y, -y``. The ramp gets side walls from ``bottom`` to
        ``top + railing`` (they also close the space under it and act as railings on the upper level),
        a wall under its high end (kept 0.3 m below the surface so it never forms a step), and (when
        ``low_railing``) a railing across the opening at the upper level's low end, for ramps that come
        up through a hole in a floor.
        Returns the opening the upper floor slab must leave (``area`` itself).
        """
        if direction not in ("+x", "-x", "+y", "-y"):
            raise ValueError(f"direction={direction!r}: expected one of +x, -x, +y, -y")
        along_x = direction[1] == "x"
        sign = 1.0 if direction[0] == "+" else -1.0
        length = (area.x1 - area.x0) if along_x else (area.y1 - area.y0)
        rise = top - bottom
        slope = math.atan2(rise, length)
        yaw = {"+x": 0.0, "+y": math.pi / 2, "-x": math.pi, "-y": -math.pi / 2}[direction]
        centre = np.array([(area.x0 + area.x1) / 2, (area.y0 + area.y1) / 2, (bottom + top) / 2])
        heading = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        normal = np.array([-math.sin(slope) * heading[0], -math.sin(slope) * heading[1], math.cos(slope)])
        width = (area.y1 - area.y0) if along_x else (area.x1 - area.x0)
        self.box(
            centre - normal * thickness / 2, [math.hypot(length, rise) / 2, width / 2, thickness / 2],
            material=material or self.material("ramp"), yaw=yaw, pitch=slope, kind="ramp",
        )
        side = self.material("wall")
        # coplanar_free: thinner than a level's 0.2 m walls, so that one standing in them is hidden inside them
        wall = {"material": side, "thickness": 0.2 - 2 * COPLANAR_INSET if self.coplanar_free else 0.2}
        if along_x:
            self.wall((area.x0, area.y0), (area.x1, area.y0), bottom, top + railing, **wall)
            self.wall((area.x0, area.y1), (area.x1, area.y1), bottom, top + railing, **wall)
            low, high = (area.x0, area.x1) if sign > 0 else (area.x1, area.x0)
            self.wall((high, area.y0), (high, area.y1), bottom, top - 0.3, **wall)
            if low_railing:
                self.wall((low, area.y0), (low, area.y1), top, top + railing, **wall)
        else:
            self.wall((area.x0, area.y0), (area.x0, area.y1), bottom, top + railing, **wall)
            self.wall((area.x1, area.y0), (area.x1, area.y1), bottom, top + railing, **wall)
            low, high = (area.y0, area.y1) if sign > 0 else (area.y1, area.y0)
            self.wall((area.x0, high), (area.x1, high), bottom, top - 0.3, **wall)
            if low_railing:
                self.wall((area.x0, low), (area.x1, low), top, top + railing, **wall)
        return area

    def light(self, position: Sequence[float], direction: Sequence[float] = (0, 0, -1), *,
              directional: bool = True, diffuse: float = 0.5) -> None:
        """Add a light; shadows are decided by the visual profile at load time."""
        ET.SubElement(
            self.worldbody, "light", name=self._name("light"), pos=_fmt(position), dir=_fmt(direction),
            directional="true" if directional else "false", diffuse=_fmt([diffuse] * 3),
            specular="0.1 0.1 0.1", castshadow="true",
        )

    def to_xml(self) -> str:
        """The MJCF document as a string (indented, deterministic)."""
        tree = ET.ElementTree(self.root)
        ET.indent(tree, space="  ")
        return ET.tostring(self.root, encoding="unicode") + "\n"
