"""Synthetic scenes with exact ground truth for the visual odometry's tests: a ray caster in numpy.

A scene is a box of planes (a floor at z = 0, optionally a ceiling, two side walls along x and two end
walls along y), each with a texture given in its own metres: blank, smooth random blobs, or tiles (thin
lines every few metres on a blank ground), and an open sky where no plane is hit. The camera is the
testbed's (160 × 120, 80° horizontal field of view, square pixels), 0.5 m above the floor and 0.1 m ahead
of the robot's turning axis, looking level: the geometry :class:`neuroslam.config.VisualOdometryConfig`
assumes by default. Each pixel is the mean of 3 × 3 rays (antialiasing, as a camera's pixel integrates
light over its area).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

CAMERA_HEIGHT = 0.5  # m
CAMERA_FORWARD = 0.1  # m ahead of the turning axis
FIELD_OF_VIEW = math.radians(80)
WIDTH, HEIGHT = 160, 120
SUPERSAMPLING = 3


@dataclass(frozen=True)
class Texture:
    """Intensity in [0, 1] of a surface point from its surface coordinates (a, b), m.

    kind: ``blank`` (``level`` everywhere), ``blobs`` (smooth random blobs of about ``scale`` m around
    ``level`` with ``contrast``) or ``tiles`` (lines ``line`` m wide every ``scale`` m in both directions,
    ``contrast`` darker than ``level``).
    """

    kind: str = "blobs"
    level: float = 0.5
    blank_beyond: float | None = None  # blank (``level``) where a > this, m
    contrast: float = 0.35
    scale: float = 0.15
    line: float = 0.04
    seed: int = 0

    def __call__(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        if self.blank_beyond is not None:
            inside = Texture(self.kind, self.level, None, self.contrast, self.scale, self.line, self.seed)(a, b)
            return np.where(a > self.blank_beyond, self.level, inside)
        if self.kind == "blank":
            return np.full(a.shape, self.level)
        if self.kind == "tiles":
            def on_line(c: np.ndarray) -> np.ndarray:
                return np.abs((c + self.line / 2) % self.scale) < self.line
            return self.level - self.contrast * (on_line(a) | on_line(b))
        grid = _noise_grid(self.seed)
        size = grid.shape[0]
        # two octaves of value noise, wrapped on a 64 × 64 lattice of ``scale`` m cells
        value = np.zeros(a.shape)
        for octave, weight in ((1.0, 0.65), (0.37, 0.35)):
            u, v = a / (self.scale * octave), b / (self.scale * octave) + 17.0 * octave
            u0, v0 = np.floor(u), np.floor(v)
            fu, fv = u - u0, v - v0
            fu, fv = fu * fu * (3 - 2 * fu), fv * fv * (3 - 2 * fv)  # smoothstep: no creases at the lattice
            i0, j0 = u0.astype(np.int64) % size, v0.astype(np.int64) % size
            i1, j1 = (i0 + 1) % size, (j0 + 1) % size
            top = grid[i0, j0] + fu * (grid[i1, j0] - grid[i0, j0])
            bottom = grid[i0, j1] + fu * (grid[i1, j1] - grid[i0, j1])
            value += weight * (top + fv * (bottom - top))
        return np.clip(self.level + self.contrast * 2 * (value - 0.5), 0.0, 1.0)


def _noise_grid(seed: int) -> np.ndarray:
    return np.random.default_rng([seed, 77]).uniform(0.0, 1.0, (64, 64))


@dataclass(frozen=True)
class Scene:
    """A box of textured planes. ``half_width``: the side walls at y = ±half_width (None: none);
    ``half_length``: the end walls at x = ±half_length (None: none); ``ceiling``: its height (None: sky);
    ``wall_height``: the walls' height (m; above it, sky or ceiling)."""

    floor: Texture = field(default_factory=Texture)
    walls: Texture | None = field(default_factory=lambda: Texture(seed=1))
    ceiling_texture: Texture = field(default_factory=lambda: Texture(seed=2, level=0.7))
    half_width: float | None = 2.0
    half_length: float | None = None
    ceiling: float | None = 3.0
    sky: float = 0.85
    wall_height: float = math.inf  # m: the walls' tops (sky above them where there is no ceiling)

    def render(self, x: float, y: float, yaw: float) -> np.ndarray:
        """The grey image (HEIGHT × WIDTH, float32 in [0, 1]) seen from the robot at (x, y, yaw), m and rad."""
        focal = (WIDTH / 2) / math.tan(FIELD_OF_VIEW / 2)
        offsets = (np.arange(SUPERSAMPLING) + 0.5) / SUPERSAMPLING - 0.5
        columns = (np.arange(WIDTH)[:, None] + offsets[None, :]).ravel() - (WIDTH / 2 - 0.5)
        rows = (np.arange(HEIGHT)[:, None] + offsets[None, :]).ravel() - (HEIGHT / 2 - 0.5)
        v, u = np.meshgrid(rows, columns, indexing="ij")
        # camera frame: forward, left, up
        forward, left, up = np.full(u.shape, focal), -u, -v
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy, dz = c * forward - s * left, s * forward + c * left, up
        ox, oy, oz = x + CAMERA_FORWARD * c, y + CAMERA_FORWARD * s, CAMERA_HEIGHT
        image = np.full(u.shape, self.sky)
        distance = np.full(u.shape, np.inf)

        def hit(t: np.ndarray, texture: Texture, a: np.ndarray, b: np.ndarray) -> None:
            nearer = (t > 1e-6) & (t < distance)
            if nearer.any():
                distance[nearer] = t[nearer]
                image[nearer] = texture(a[nearer], b[nearer])

        with np.errstate(divide="ignore", invalid="ignore"):
            t = -oz / dz
            hit(np.where(dz < 0, t, np.inf), self.floor, ox + t * dx, oy + t * dy)
            if self.ceiling is not None:
                t = (self.ceiling - oz) / dz
                hit(np.where(dz > 0, t, np.inf), self.ceiling_texture, ox + t * dx, oy + t * dy)
            if self.walls is not None and self.half_width is not None:
                for side in (-1, 1):
                    t = (side * self.half_width - oy) / dy
                    t = np.where((dy * side > 0) & (oz + t * dz <= self.wall_height), t, np.inf)
                    hit(t, self.walls, ox + t * dx + 100.0 * side, oz + t * dz)
            if self.walls is not None and self.half_length is not None:
                for side in (-1, 1):
                    t = (side * self.half_length - ox) / dx
                    t = np.where((dx * side > 0) & (oz + t * dz <= self.wall_height), t, np.inf)
                    hit(t, self.walls, oy + t * dy + 50.0 * side, oz + t * dz)
        image = image.reshape(HEIGHT, SUPERSAMPLING, WIDTH, SUPERSAMPLING).mean(axis=(1, 3))
        return image.astype(np.float32)


def arc_path(segments: list[tuple[float, float]], speed: float = 1.0, rate: float = 10.0,
             start: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Robot poses (N, 3: x, y, yaw) at ``rate`` Hz along segments of (distance m, turn rad), each driven at
    ``speed`` m/s as a constant-curvature arc (a turn on the spot when its distance is 0, at 0.5 rad/s)."""
    x, y, yaw = start
    poses = [(x, y, yaw)]
    for distance, turn in segments:
        duration = distance / speed if distance > 0 else abs(turn) / 0.5
        frames = max(1, int(round(duration * rate)))
        step_distance, step_turn = distance / frames, turn / frames
        for _ in range(frames):
            middle = yaw + step_turn / 2
            x, y, yaw = x + step_distance * math.cos(middle), y + step_distance * math.sin(middle), yaw + step_turn
            poses.append((x, y, yaw))
    return np.array(poses)
