"""The heading against the scene's own straight lines (eqs. M1–M3): a compass from the floor and the ceiling.

Not in the NeuroSLAM paper. Buildings, car parks and streets are built along two perpendicular directions:
the floor's tiles and lane markings, the walls' feet and the ceiling's beams and strips run along them. Seen
from above, the floor's (or the ceiling's) edges point along those directions whatever the robot's position,
so their orientation in the robot's frame, plus the robot's heading, is the same everywhere, modulo 90°. The
visual odometry's heading drifts (a bias of about 0.07° a metre on the testbed's generated worlds, one way
around a ring); this measurement does not.

**The edges' orientation on a plane** (eq. M1). A pixel (u, v) of the floor, a plane h below the camera,
lies at depth X = h f / (v - c_v) ahead and Y = -(u - c_u) X / f to the left (eq. G1). The image edge
through it runs perpendicular to its gradient, e = (-I_v, I_u); on the plane it runs along J e, J the
Jacobian of (X, Y) with respect to (u, v), at the angle theta = atan2((J e)_Y, (J e)_X). The height h scales
J and not the angle, so the ceiling (a plane above the camera) is read the same way without knowing its
height.

**Modulo 90°** (eq. M2). Two perpendicular families of edges give angles phi and phi + 90°; their fourth
multiple is the same. Weighting each pixel by its squared gradient,

    z = sum_q |grad I(q)|^2 exp(4 i theta_q),    phi = arg(z) / 4,    R = |z| / sum_q |grad I(q)|^2   (M2)

phi in (-45°, 45°] is the lines' orientation in the robot's frame, and R in [0, 1] how much of the edges'
energy lies along the two families (1: all of it; a texture whose edges point every way gives about 0).

**The heading** (eq. M3). Where R >= ``strength``, psi_structure = phi + psi is the lines' orientation in the
odometry's frame, psi being the heading the odometry has integrated; such a frame *counts*. The first
``window`` counted frames that agree (the median absolute deviation of their psi_structure within
``spread``) fix the reference psi_0, their median. Afterwards each counted frame adds its innovation
nu = wrap_90(psi_0 - psi_structure) to the last ``window``; while they agree (their median absolute deviation
within ``spread``), the heading turns by

    delta psi = (1 - exp(-rate dt)) median(nu)                                                    (M3)

and the stored innovations by as much. The median over a window of seconds and the agreement test pass
over the runs of frames whose lines are misread (a wall's vertical edges taken for lines on the floor, a
ramp's level landing ahead); the slow rate averages the per-frame scatter of phi (about 2° on the generated
worlds) while the odometry's own drift, a few hundredths of a degree a frame, is removed. A world whose
lines are not perpendicular gives innovations that do not agree; a world without straight lines gives R
below ``strength``: in both nothing happens. A steady drift of b a frame is followed with a lag of
b / (1 - exp(-rate dt)): 0.34° for the 0.0067° a frame measured on gen2:107's straight frames (0.2/s,
10 Hz). An odometry heading more than 45° off the lines is brought to the wrong family of them, 90° away:
the lines say nothing about which family is which.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..geometry import quarter_wrap

__all__ = ["StructureHeading"]


class StructureHeading:
    """Heading corrections from the orientation of the floor's and the ceiling's edges (eqs. M1–M3).

    Args:
        horizontal_fov: the camera's horizontal field of view, rad (square pixels, a level pinhole camera).
        first_row: the planes' pixels start this far from the image centre (below it for the floor, above it
            for the ceiling), as a fraction of half the height: near the horizon the plane is too foreshortened.
        strength: the least R of eq. M2 for a frame to count.
        spread: the largest median absolute deviation of a window's orientations that still agree, rad.
        window: counted frames over which eq. M3's median is taken.
        rate: eq. M3's rate, 1/s.

    Attributes:
        heading: the heading integrated from the yaw changes passed to :meth:`correct`, rad.
        reference: psi_0 of eq. M3 (None until a frame's lines are strong enough).
        orientation: the last frame's (phi, R) of eq. M2, the stronger of the floor's and the ceiling's.
    """

    def __init__(self, *, horizontal_fov: float, first_row: float = 0.3, strength: float = 0.5,
                 spread: float = math.radians(3.0), window: int = 50, rate: float = 0.2):
        self.horizontal_fov = horizontal_fov
        self.first_row = first_row
        self.strength = strength
        self.spread = spread
        self.rate = rate
        self.heading = 0.0
        self.reference: float | None = None
        self.orientation = (0.0, 0.0)
        self._geometry: dict[tuple[int, int, int], tuple] = {}
        self._recent: deque[float] = deque(maxlen=window)  # psi_structure (no reference yet) or nu + _shift, rad
        self._shift = 0.0  # rad, eq. M3's corrections since the reference: each stored nu is less by as much now

    def _plane(self, shape: tuple[int, int], surface: int) -> tuple:
        """Per image size and plane (1 floor, -1 ceiling): the plane's pixels (flat indices) and the entries of
        eq. M1's Jacobian at each (for a plane 1 m from the camera; the height does not change the angles)."""
        key = (*shape, surface)
        cached = self._geometry.get(key)
        if cached is not None:
            return cached
        rows, columns = shape
        focal = (columns / 2) / math.tan(self.horizontal_fov / 2)
        v, u = np.mgrid[0:rows, 0:columns].astype(np.float64)
        x, y = u - (columns / 2 - 0.5), v - (rows / 2 - 0.5)
        inside = (y * surface > self.first_row * rows / 2).ravel()
        x, y = x.ravel()[inside], y.ravel()[inside]
        depth = focal / np.abs(y)  # X of eq. M1 for h = 1
        # d(X, Y) / d(u, v): X = f h / |y| depends on v alone; Y = -x X / f
        dx_dv = -depth / y
        dy_du = -depth / focal
        dy_dv = x * depth / (focal * y)
        cached = (np.flatnonzero(inside), dx_dv.astype(np.float32), dy_du.astype(np.float32),
                  dy_dv.astype(np.float32))
        self._geometry[key] = cached
        return cached

    def edge_orientation(self, stack: np.ndarray, surface: int = 1) -> tuple[float, float]:
        """Eq. M2 on one plane of a (3, rows, columns) stack of a blurred grey image and its horizontal and
        vertical gradients: (phi rad, R); (0, 0) where the plane shows no gradient."""
        indices, dx_dv, dy_du, dy_dv = self._plane(stack.shape[1:], surface)
        gradient_u = stack[1].ravel()[indices]
        gradient_v = stack[2].ravel()[indices]
        # the edge e = (-I_v, I_u) on the plane: (J e)_X = dX/dv I_u, (J e)_Y = -dY/du I_v + dY/dv I_u
        along_x = dx_dv * gradient_u
        along_y = dy_dv * gradient_u - dy_du * gradient_v
        weight = gradient_u * gradient_u + gradient_v * gradient_v
        total = float(weight.sum())
        if total <= 0:
            return 0.0, 0.0
        # exp(4 i theta) from the direction's components without an arctangent
        squared = along_x * along_x + along_y * along_y
        cosine2 = (along_x * along_x - along_y * along_y) / np.maximum(squared, 1e-20)
        sine2 = 2 * along_x * along_y / np.maximum(squared, 1e-20)
        real = float(weight @ (cosine2 * cosine2 - sine2 * sine2))
        imaginary = float(weight @ (2 * sine2 * cosine2))
        return math.atan2(imaginary, real) / 4, math.hypot(real, imaginary) / total

    def correct(self, stack: np.ndarray, yaw_change: float, dt: float) -> float:
        """The frame's yaw change (rad) corrected by eq. M3 from its image ``stack`` (see
        :meth:`edge_orientation`), the odometry's own ``yaw_change`` (rad) over ``dt`` seconds."""
        self.heading += yaw_change
        floor, ceiling = self.edge_orientation(stack, 1), self.edge_orientation(stack, -1)
        phi, strength = floor if floor[1] >= ceiling[1] else ceiling
        self.orientation = (phi, strength)
        if strength < self.strength:
            return yaw_change
        structure = quarter_wrap(phi + self.heading)
        recent = self._recent
        if self.reference is None:  # the first window that agrees fixes the reference
            recent.append(structure)
            middle = self._agreed()
            if middle is not None and len(recent) == recent.maxlen:
                self.reference = middle
                recent.clear()
            return yaw_change
        recent.append(quarter_wrap(self.reference - structure) + self._shift)
        middle = self._agreed()
        if middle is None or len(recent) < recent.maxlen // 2:
            return yaw_change
        correction = (1.0 - math.exp(-self.rate * dt)) * middle
        self._shift += correction  # every stored innovation is smaller by the correction now
        self.heading += correction
        return yaw_change + correction

    def _agreed(self) -> float | None:
        """The median of the recent values if their median absolute deviation is within ``spread``, else None."""
        values = np.fromiter(self._recent, dtype=float, count=len(self._recent)) - self._shift
        middle = float(np.median(values))
        return middle if float(np.median(np.abs(values - middle))) <= self.spread else None

    def state_dict(self) -> dict[str, np.ndarray]:
        """The integrated heading, the reference (empty: none yet) and the recent values, for saving."""
        return {"heading": np.float64(self.heading),
                "reference": np.array([] if self.reference is None else [self.reference], dtype=np.float64),
                "recent": np.array(self._recent, dtype=np.float64) - self._shift}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output."""
        self.heading = float(state["heading"])
        reference = np.asarray(state["reference"], dtype=np.float64).ravel()
        self.reference = float(reference[0]) if reference.size else None
        self._recent = deque((float(value) for value in np.asarray(state["recent"]).ravel()),
                             maxlen=self._recent.maxlen)
        self._shift = 0.0
