"""Planar self-motion from the floor: direct alignment of consecutive images under a ground-plane model.

This is not in the NeuroSLAM paper (whose speed, NeuroSLAM eq. 30, is a profile difference times a scene-dependent
gain); it replaces NeuroSLAM eqs. 27–30 when ``odometry.planar_motion = "ground"``. A camera ``h`` metres above the
floor, looking level, ``a`` metres ahead of the robot's turning axis, sees the floor point at
robot-frame ground coordinates ``q = (x, y)`` (x ahead of the axis, y to the left) at pixel

    u = c_u - f y / (x - a),    v = c_v + f h / (x - a)                                   (G1)

(f: focal length in pixels, (c_u, c_v): the image centre). A differential-drive robot that drives
``d`` metres along an arc while turning by ``w`` radians moves its axis to ``t = d (cos w/2, sin w/2)``
in its previous frame, so a floor point seen at ``q`` now was at

    p = t + R(w) q                                                                         (G2)

before. The motion (d, w) minimises the robust (Huber) photometric error

    E(d, w) = sum_q rho(I_prev(pi(p)) - I_now(pi(q))) + (d - d0)^2 / s_d^2 + (w - w0)^2 / s_w^2   (G3)

over the floor pixels below the horizon (pi: eq. G1; (d0, w0): the previous frame's motion, a
constant-velocity prior that keeps the estimate where the floor shows too little texture). Its variance on
the distance grows by s_d^2 with each frame whose distance nothing observed (n frames: held or none, see
:class:`~neuroslam.vision.odometry.Observed`), so the distance term weighs

    (d - d0)^2 / ((1 + n) s_d^2)                                                                  (G3a)

(:attr:`GroundMotion.distance_certainty` = 1 / (1 + n)): a floor seen again after a blank stretch reads its
own distance, not the stale (or zero) speed held over the stretch. Where the floor
says almost nothing about the distance (its information on d, the Gauss–Newton normal entry sum w J_d^2,
is below ``min_information`` times the prior's weight: a uniform floor whose only marks run along the
path), the distance is the prior's and only the yaw is solved. There the image does not change from
frame to frame, and the data term's faint slope comes from resampling the line on the pixel grid, which
favours no motion: left to pull, it walked the estimate down frame after frame, to a tenth of the true
speed over 12 frames on the building's tiled floors (measured: distances 7–33 % short over 10 m
stretches). It is solved
by Gauss–Newton, coarse to fine (half, then full resolution), starting from (d0, w0); when the solution
sends more than a fifth of the floor pixels out of the previous image (a wrong minimum, which the prior
would otherwise carry on to the next frames), it is solved again from rest and the one that keeps more
of the floor in view is taken. Metric scale comes from the camera height alone: no gain to calibrate per
scene. Obstacles standing on the floor break the model locally and are down-weighted by the Huber weights.

Walls are not, where they stand within about 2 m of the path: their feet and lowest metre reach into the
far floor rows at the image's sides (at 160 x 120 and 80 degrees the floor region's top row lies 2.7 m
ahead and spans 2.2 m to either side), where eq. G1 takes them for floor lying farther away than they
are. Forward motion then moves them faster than the model expects, outwards, and the yaw of eq. G3
absorbs the difference: measured on the testbed's building, whose ring corridors have walls on both
sides, its first floor's six straight 18–26 m corridors read -11 to +7 degrees of turn. With ``near_row``
set, the yaw is therefore solved once more on the near floor alone (rows from ``near_row`` of half the
height below the centre: floor up to about 1.6 m ahead, where the robot drives), from the full solution
and with its distance held,

    w_near = argmin_w  sum_{q near} rho(I_prev(pi(p(d, w))) - I_now(pi(q))) + (w - w0)^2 / s_w^2     (G4)

and taken where the near floor says enough about the yaw (its information, sum w J_w^2, at least
``near_information`` times the prior's weight) and stays within ``near_tolerance`` of the full solution
(a guard against a wrong minimum that the prior would carry on to the next frames: without it a ramp's
top sent one drive spinning at 14 degrees per frame). The same corridors then read -1.6 to +2.2 degrees.
The distance stays the full floor's: the near floor alone read the building's ground floor 5 % long.

Eq. G4 helps only where the near floor has texture. On a sparsely marked or blank floor the walls' pixels
carry most of eq. G3's information, and a wall on one side of a ring route (the inner wall, turn after turn)
biases the yaw one way: 48 degrees over one lap of a generated world with large tiles, while the distance
stayed within 0.3 %. With ``half_width`` set, the floor region is therefore only the floor within that
lateral distance of the path (ground points with |y| <= half_width in eq. G1),

    Q = { q : x > 0 below the horizon, |y| <= half_width }                                    (G5)

the lane the robot itself drives on, which is floor wherever it can drive; a wall standing farther to
the side no longer enters eq. G3 (nor eq. G4). It removes the far rows' outer columns, not the near floor's:
at 160 x 120 and 80 degrees, 1 m keeps the whole width of the rows up to 1.2 m ahead.

A ramp is a narrow strip between side walls or railings, and a robot on it drives nearer one of them than
on a floor: the testbed's generated ramps are 4 m wide, their lanes 1.3 m from the wall on their right, and
that wall's face enters eq. G4's near floor at its top outer corner (at 160 x 120 and 80 degrees the near
floor's top row spans 1.3 m to either side). On a faintly marked ramp it outweighs the floor and turns eq. G4's
yaw towards the far side: over the generalization benchmark the straight frames read counter-clockwise on 42
of 43 worlds uphill and 40 downhill, a median +8 and +23 degrees per 100 m, against +1 on the floors
(docs/generalization.md, twenty-third step). With ``slope_half_width`` set, eq. G4's near floor is therefore
the lane alone while :attr:`GroundMotion.on_slope` is set (the odometry sets it where the pitch it holds is a
slope),

    Q_near = { q in eq. G4's near floor : |y| <= slope_half_width }     on a slope               (G7)

and the whole near floor elsewhere (the odometry's default since the forty-seventh step, at 1 m). (On the floors
the whole near floor reads straighter: the lane there turned the building's flat straights -10.6 -> -32.8 degrees
over 455 m, docs/generalization.md.)

A ramp's far floor reads its distance short. Eq. G3 alone over a hand-written car park's recorded ramps reads
them 0.882 of their length, 0.995 on eq. G4's near floor alone; over a generated world's (gen3:103) 0.964
and 0.997 (docs/generalization.md, forty-second step). The far rows of a
ramp show its top or foot, where another plane begins, and on a ramp of large tiles a few sharp edges that
the renderer moves in whole pixels. With ``slope_near_floor`` set, eq. G3's floor region is therefore eq.
G4's near floor while :attr:`GroundMotion.on_slope` is set (and eq. G4, which would solve the yaw again on the
same pixels, is skipped),

    Q = { q in eq. G4's near floor }     on a slope                                          (G9)

(within eq. G7's lane where ``slope_half_width`` is set) and the whole floor elsewhere. (The odometry's default
since the forty-fourth step. Where the near floor of a faint ramp sees too little of the distance, the odometry
holds the speed, and it holds it right only with eq. R12 and without the ceiling over the ramp,
``odometry.held_direction`` and ``odometry.ceiling_on_slopes``: eq. G9 alone made two catastrophes on ten unseen
generated worlds, the forty-third step.)

Whether the floor sees the distance at all is decided by its information on it (``min_information``). An
edge that runs along the path (a wall's foot, a ramp's side, a line along the lane) carries none: a forward
step slides it along itself and the image does not change (the aperture problem). Its pixels'
J_d = grad I . d pi / dd is then zero only to within how far their measured gradient and their modelled
image motion are off perpendicular: about 5 degrees for an edge rendered at 160 x 120 and blurred (measured
along a blank ramp's side in the generated world gen2:125), which on a strong edge is enough to count as
seeing and to pull the distance towards rest, as above (that ramp's 32 m read 9 m). The information that
decides therefore counts only the pixels whose gradient lies more than ``aperture`` from perpendicular to
their image motion:

    I_d = sum over q with J_d^2 >= sin^2(aperture) |grad I|^2 |d pi / dd|^2 of  w J_d^2            (G6)

(d pi / dd: a forward step's image motion at the pixel, eqs. G1 and G2 at rest). At 10 degrees, twice that
error, a texture whose gradients point every way loses about 0.2 % of its information (measured on the
testbed's textured floors: 99 % kept; the urban world's thin far lines, which cross the path, count on
2,992 of its 2,993 seeing frames), while the blank ramp's falls from 0.7-1.4 to 0.04-0.2 of the prior's
weight, below ``min_information``. Eq. G6 only decides; the solution uses every pixel. The odometry's
default is 10° (``odometry.floor_aperture``; see that setting for what it does over the benchmark).

Eq. G6 reads the previous image's gradients alone, and sensor noise has gradients: a blank floor under 1 grey
level of independent noise has about 0.5 of the prior's weight (3.5 levels: 6), above ``min_information``, and
the floor then reads motion at rest (summed over 4 s still: up to 22 degrees and 1.2 m). What a texture has
and noise has not is that the next image shows it again. With ``shared_information`` the information that
decides is the part both images share, at the finest level's solution:

    I'_d = sum over the pixels of eq. G6 of  w J_d J'_d,
    z = I'_d / sqrt(A s_g^2 sum over the same pixels of  w^2 |d pi / dd|^2 (J_d^2 + J'_d^2))              (G8)

J'_d = grad I' . d pi / dd, the same derivative from the current image's gradients at the floor pixel (eqs. G1
and G2 at rest). Noise the two images do not share averages out of the sum; its spread under noise is the
denominator: s_g^2 = s_r^2 / (4 s^2), the gradient's noise variance (per axis) of an image blurred by s pixels
whose residual against the other has the variance s_r^2 (two images under noise n differ by 2 n^2 / (4 pi s^2);
one's gradient has n^2 / (8 pi s^4)), and A = 2 pi s^2 / step, the floor pixels (every ``step``-th column) one
pixel's blurred noise reaches. The floor sees the distance where z > 3 (a normal tail of 0.13 %: a noise
frame passes about once in 740) and I'_d / the prior's weight >= ``min_information``. Where it does, the
solution is eq. G3's unchanged (bit for bit); where eq. G3 saw the distance and eq. G8 does not, the level is
solved again with the distance the prior's. A clean render's residual is its interpolation's, small: a
texture there stands 30-70 standard errors out, sparse marks (a 4 cm spot every 0.5 m) 35-70.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from .kernels import ground_align, sample_bilinear

__all__ = ["GroundMotion", "blurred_with_gradients", "sample_bilinear"]

_PRIOR_DISTANCE = 0.02  # m per frame, s_d of eq. G3 (a 1.5 m/s^2 drive changes speed ~0.015 m per frame at 10 Hz)
_PRIOR_TURN = 0.05  # rad per frame, s_w of eq. G3
_LOST_SUPPORT = 0.8  # below this share of floor pixels still in view, the solution is suspect


def blurred_with_gradients(image: np.ndarray, smoothing: float) -> np.ndarray:
    """(3, rows, columns) float32: the image blurred by a Gaussian of ``smoothing`` pixels (truncated at 4
    standard deviations, mirrored at the borders), and its horizontal and vertical central-difference
    gradients (one-sided at the borders)."""
    image = np.ascontiguousarray(image, dtype=np.float32)
    stack = np.empty((3, *image.shape), dtype=np.float32)
    if smoothing > 0:
        radius = int(4 * smoothing + 0.5)
        cv2.GaussianBlur(image, (2 * radius + 1, 2 * radius + 1), smoothing, dst=stack[0], sigmaY=smoothing,
                         borderType=cv2.BORDER_REFLECT)
    else:
        stack[0] = image
    blurred, gradient_u, gradient_v = stack
    if image.shape[1] > 1:
        np.subtract(blurred[:, 2:], blurred[:, :-2], out=gradient_u[:, 1:-1])
        gradient_u[:, 1:-1] *= 0.5
        gradient_u[:, 0] = blurred[:, 1] - blurred[:, 0]
        gradient_u[:, -1] = blurred[:, -1] - blurred[:, -2]
    else:
        gradient_u[:] = 0
    if image.shape[0] > 1:
        np.subtract(blurred[2:], blurred[:-2], out=gradient_v[1:-1])
        gradient_v[1:-1] *= 0.5
        gradient_v[0] = blurred[1] - blurred[0]
        gradient_v[-1] = blurred[-1] - blurred[-2]
    else:
        gradient_v[:] = 0
    return stack


class GroundMotion:
    """Distance and yaw change between consecutive grey images from the floor's motion (eqs. G1–G3).

    Args:
        horizontal_fov: the camera's horizontal field of view, rad (square pixels assumed).
        camera_height: the camera above the floor, m.
        camera_forward: the camera ahead of the turning axis, m.
        first_row: floor pixels start this far below the image centre, as a fraction of half the height.
        smoothing: Gaussian blur before alignment, pixels of each resolution level.
        robust_scale: Huber threshold on the intensity residual (images in [0, 1]).
        iterations: most Gauss–Newton iterations per resolution level (it stops once the update is below
            0.1 mm and 0.01 mrad).
        min_information: the floor's information on the distance (Σ w J_d², intensity² per m²) below which
            the distance is left to the prior, as a multiple of the prior's weight (robust_scale / s_d)²
            (measured on the testbed: 0.3 leaves every textured floor alone and keeps the tiled ones'
            distances within 2 %; 1.0 held the speed through slowdowns, 7 % long).
        near_row: rows of the near floor of eq. G4, as a fraction of half the height below the image centre
            (above ``first_row``); 0 (the default) leaves the yaw to eq. G3 alone.
        near_information: the near floor's information on the yaw (Σ w J_w², intensity² per rad²) below which
            eq. G4 is not used, as a multiple of the prior's weight (robust_scale / s_w)² (measured on the
            testbed: 3 keeps the building's sparsely speckled first floor, 5–17, and leaves its blank
            floors, 0, to the whole floor region).
        near_tolerance: the largest change of the yaw eq. G4 may make, rad per frame.
        half_width: the floor region's half width beside the path, m (eq. G5); 0 (the default) takes every
            floor pixel below ``first_row``. Only for the floor (a ceiling's plane has no lane).
        slope_near_floor: eq. G3's floor region is eq. G4's near floor (below ``near_row``) while :attr:`on_slope`
            is set (eq. G9); needs ``near_row``.
        slope_half_width: eq. G4's near floor's half width beside the path while :attr:`on_slope` is set, m (eq.
            G7), and so eq. G9's region's with ``slope_near_floor``; 0 (the default) keeps the whole near floor on
            slopes too. Only for the floor.
        aperture: rad; a pixel counts towards the information on the distance (eq. G6, what
            ``min_information`` is compared with) only where its image gradient lies more than this from
            perpendicular to the image motion a forward step gives it. 0 (this class's default) counts every
            pixel; the odometry passes ``odometry.floor_aperture`` (10°, see there).
        shared_information: the information on the distance (what ``min_information`` is compared with) is eq.
            G8's, the part both images share, not the previous image's alone (see the module's notes); False
            (this class's default) is eq. G3's.
        levels: resolution levels, each half the previous (2: half, then full resolution), each blurred
            by ``smoothing`` of its own pixels; the coarsest sets how far the motion may be from the
            previous frame's and still be found (0.1 m, or 0.08 m with 0.06 rad, from rest at 160 x 120
            with 2; measured on the testbed, a third level made the paths less accurate).
    """

    def __init__(self, *, horizontal_fov: float, camera_height: float, camera_forward: float,
                 first_row: float = 0.3, smoothing: float = 1.0, robust_scale: float = 0.05, iterations: int = 10,
                 min_information: float = 0.3, near_row: float = 0.0, near_information: float = 3.0,
                 near_tolerance: float = 0.03, levels: int = 2, surface: str = "floor", half_width: float = 0.0,
                 aperture: float = 0.0, slope_half_width: float = 0.0, shared_information: bool = False,
                 slope_near_floor: bool = False):
        if surface not in ("floor", "ceiling"):
            raise ValueError(f"surface={surface!r}: must be 'floor' or 'ceiling'")
        if not half_width >= 0 or (half_width and surface != "floor"):
            raise ValueError(f"half_width={half_width!r}: must be 0 or more, and 0 for a ceiling")
        if not slope_half_width >= 0 or (slope_half_width and surface != "floor"):
            raise ValueError(f"slope_half_width={slope_half_width!r}: must be 0 or more, and 0 for a ceiling")
        self.slope_half_width = float(slope_half_width)
        if slope_near_floor and (surface != "floor" or not near_row > 0):
            raise ValueError(f"slope_near_floor={slope_near_floor!r}: only for a floor with a near floor "
                             "(near_row > 0)")
        self.slope_near_floor = bool(slope_near_floor)
        # whether the robot is on a slope: eq. G4's near floor is then eq. G7's lane (set by the odometry)
        self.on_slope = False
        if not 0 <= aperture < math.pi / 2:
            raise ValueError(f"aperture={aperture!r}: must be in [0, pi/2) radians")
        self.aperture = float(aperture)
        self.shared_information = bool(shared_information)
        self._crosswise = math.sin(self.aperture) ** 2
        self.half_width = float(half_width)
        self.surface = surface
        self.horizontal_fov = horizontal_fov
        self.camera_height = camera_height
        self.camera_forward = camera_forward
        self.first_row = first_row
        self.smoothing = smoothing
        self.robust_scale = robust_scale
        self.iterations = iterations
        self.min_information = min_information
        self.near_row = near_row
        self.near_information = near_information
        self.near_tolerance = near_tolerance
        self.levels = levels
        self.motion = np.zeros(2)  # (d, w) of the last frame: m, rad
        # the prior's weight on the distance in eq. G3, as a share of (robust_scale / s_d)^2: 1 where the last
        # frame's distance was observed; the odometry lowers it while the distance goes unobserved (eq. G3a)
        self.distance_certainty = 1.0
        self.support = 0.0  # share of floor pixels that stayed in view and were used, last frame
        # the floor's information on (d, w) at the last frame's solution (Σ w J², data term only), as
        # multiples of the prior's weights (robust_scale / s_d)², (robust_scale / s_w)²
        self.information = np.zeros(2)
        # eq. G8: how many of its standard errors the information both images share stands above zero
        self.standing = 0.0
        self._previous: list[np.ndarray] | None = None
        # Gauss–Newton iterations run so far, each one pass over the floor pixels of its level (for the cost)
        self.passes = 0
        self._geometry: dict[tuple[int, int], tuple] = {}

    @property
    def _height(self) -> float:
        """The plane's height relative to the camera in eq. G1, m: the floor below (positive), the ceiling
        above (negative)."""
        return self.camera_height if self.surface == "floor" else -self.camera_height

    def align(self, previous: list[np.ndarray], current: list[np.ndarray], prior: np.ndarray) -> tuple[float, float]:
        """Eq. G3 (and G4) between two pyramids of :meth:`pyramid`, from ``prior`` (d0, w0): (d, w), m and rad.
        Sets :attr:`information` and :attr:`support` as :meth:`step` does, and :attr:`motion`."""
        distance, turn = self._solve(previous, current, np.asarray(prior, dtype=float).copy())
        self.motion = np.array([distance, turn])
        return float(distance), float(turn)

    @property
    def pyramid(self) -> list[np.ndarray] | None:
        """The last image's pyramid, coarsest first (each level blurred, with its gradients), or None."""
        return self._previous

    @property
    def distance_weight(self) -> float:
        """The prior's weight on the distance, (robust_scale / s_d)², intensity² per m²: the unit of
        :attr:`information`'s first entry."""
        return (self.robust_scale / _PRIOR_DISTANCE) ** 2

    @property
    def sees_distance(self) -> bool:
        """The last frame's floor observed the distance (its information at least ``min_information``)."""
        return bool(self.information[0] >= self.min_information)

    @property
    def finest(self) -> np.ndarray | None:
        """The last image at full resolution, blurred, with its gradients: (3, rows, columns), or None."""
        return None if self._previous is None else self._previous[-1]

    def state_dict(self) -> dict[str, np.ndarray]:
        """The last frame's motion, support and image pyramid, for saving."""
        state = {"motion": self.motion.copy(), "support": np.float64(self.support)}
        for level, image in enumerate(self._previous or []):
            state[f"previous.{level}"] = image.copy()
        return state

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it does not fit."""
        motion = np.asarray(state["motion"], dtype=float)
        if motion.shape != (2,):
            raise ValueError(f"motion has shape {motion.shape}, expected (2,)")
        previous = [np.asarray(state[f"previous.{level}"]) for level in range(self.levels)
                    if f"previous.{level}" in state]
        if previous and (len(previous) != self.levels or any(image.ndim != 3 or len(image) != 3 for image in previous)):
            raise ValueError(f"the previous image pyramid has {len(previous)} levels, expected {self.levels}")
        self.motion = motion.copy()
        self.support = float(state["support"])
        self._previous = [image.copy() for image in previous] or None

    def _pyramid(self, image: np.ndarray) -> list[np.ndarray]:
        """The image at 1/2^k resolution (means of 2^k x 2^k blocks), coarsest first, each blurred, with its
        central-difference gradients; float32."""
        full = image.astype(np.float32)
        images = []
        for level in range(self.levels - 1, -1, -1):
            factor = 2**level
            rows, columns = full.shape[0] // factor, full.shape[1] // factor
            reduced = full if factor == 1 else cv2.resize(full[: rows * factor, : columns * factor], (columns, rows),
                                                          interpolation=cv2.INTER_AREA)
            images.append(blurred_with_gradients(reduced, self.smoothing))
        return images

    def _floor(self, shape: tuple[int, int], near_only: bool = False, whole: bool = False) -> tuple:
        """Per image size: focal length, centre, the floor pixels' flat indices and their ground points q
        (with ``near_only``, those of eq. G4's near floor alone, within eq. G7's lane on a slope; with ``whole``,
        beyond eq. G5's lane too)."""
        near_floor = near_only or (self.slope_near_floor and self.on_slope and not whole)  # eqs. G4 and G9
        slope_lane = self.slope_half_width if near_floor and self.on_slope else 0.0
        cached = self._geometry.get((shape, near_only, whole, slope_lane, near_floor))
        if cached is not None:
            return cached
        rows, columns = shape
        focal = (columns / 2) / math.tan(self.horizontal_fov / 2)
        centre_u, centre_v = columns / 2 - 0.5, rows / 2 - 0.5
        step = 2 if columns > 100 else 1  # every other column at full resolution: half the cost, as accurate
        if self.surface == "floor":
            first = int(math.ceil(centre_v + self.first_row * rows / 2))
            v, u = np.mgrid[first: rows - 1, 1: columns - 1: step]
        else:  # the ceiling: the same rows mirrored above the centre
            last = int(math.floor(centre_v - self.first_row * rows / 2))
            v, u = np.mgrid[1: last + 1, 1: columns - 1: step]
        u, v = u.ravel(), v.ravel()
        depth = self._height * focal / (v - centre_v)  # eq. G1 solved for x - a
        ground = np.stack([depth + self.camera_forward, -(u - centre_u) * depth / focal]).astype(np.float32)
        indices = v * columns + u
        if self.half_width > 0 and not whole:  # eq. G5: the lane beside the path alone
            lane = np.abs(ground[1]) <= self.half_width
            indices, ground, v = indices[lane], np.ascontiguousarray(ground[:, lane]), v[lane]
        if near_floor:  # the near floor of eq. G4 (within eq. G7's lane on a slope), or eq. G9's region
            near = v >= centre_v + self.near_row * rows / 2
            if slope_lane > 0:
                near &= np.abs(ground[1]) <= slope_lane
            indices, ground = indices[near], np.ascontiguousarray(ground[:, near])
        # |d pi / dd|^2 of eq. G6: the squared image motion of a forward step (eqs. G1 and G2 at rest), px^2 / m^2
        inverse = 1.0 / np.maximum(ground[0] - self.camera_forward, 0.2)
        flow = (focal * inverse * inverse) ** 2 * (ground[1] ** 2 + self._height**2)
        cached = (focal, centre_u, centre_v, indices, ground, flow.astype(np.float32))
        self._geometry[(shape, near_only, whole, slope_lane, near_floor)] = cached
        return cached

    def step(self, grey_image: np.ndarray) -> tuple[float, float]:
        """(distance, yaw change) since the previous image, m and rad (zero for the first image)."""
        pyramid = self._pyramid(grey_image)
        previous, self._previous = self._previous, pyramid
        if previous is None:
            return 0.0, 0.0
        distance, turn = self._solve(previous, pyramid, self.motion.copy())
        if self.support < _LOST_SUPPORT:  # the floor left the image under this motion: start again from rest
            support = self.support
            again = self._solve(previous, pyramid, np.zeros(2))
            if self.support > support:
                distance, turn = again
            else:
                self.support = support
        self.motion = np.array([distance, turn])
        return float(distance), float(turn)

    def _solve(self, previous: list[np.ndarray], current: list[np.ndarray], prior: np.ndarray, *,
               whole: bool = False) -> tuple[float, float]:
        """Eq. G3 coarse to fine from the prior, then eq. G4 (with ``whole``: over the whole floor, beyond eq. G5's
        lane too, and without eq. G4)."""
        distance, turn = prior
        for level, (old, new) in enumerate(zip(previous, current, strict=True)):
            finest = level == len(current) - 1  # coarser levels only start the next: stop them sooner
            distance, turn = self._align(old, new, distance, turn, prior, tolerance=1.0 if finest else 5.0,
                                         whole=whole, shared=self.shared_information and finest)
        # eq. G4: the yaw again on the near floor alone, from the full solution (not where eq. G9 solved on it)
        if self.near_row > 0 and not whole and not (self.slope_near_floor and self.on_slope):
            near_turn, information = self._align(previous[-1], current[-1], distance, turn, prior, near_only=True)
            if (information >= self.near_information * (self.robust_scale / _PRIOR_TURN) ** 2
                    and abs(near_turn - turn) <= self.near_tolerance):
                turn = near_turn
        return distance, turn

    def whole_floor_distance(self, previous: list[np.ndarray], current: list[np.ndarray], distance: float,
                             turn: float) -> tuple[float, float]:
        """Eq. G3 over the whole floor below the horizon, beyond eq. G5's lane too, coarse to fine from
        (``distance``, ``turn``), m and rad (also the prior's (d0, w0)): its distance alone.

        Where the lane shows no marks, the walls' feet beside it still lie on the floor plane, and their rows
        give the distance in metres (eq. G1). The walls above their feet bias the yaw (eq. G5), and a yaw held
        fixed would push that bias into the distance instead (measured on a blank floor 1–1.5 m from a textured
        wall: 15–25 % long, against 4–6 % with the yaw free), so both are solved and only the distance is
        kept. Returns (d, its information in the prior's weights, as :attr:`information`'s first entry);
        leaves :attr:`motion`, :attr:`information` and :attr:`support` as they were."""
        kept = self.information, self.support
        distance, _ = self._solve(previous, current, np.array([distance, turn]), whole=True)
        information = float(self.information[0])
        self.information, self.support = kept
        return float(distance), information

    def _align(self, old: np.ndarray, new: np.ndarray, distance: float, turn: float, prior: np.ndarray, *,
               tolerance: float = 1.0, near_only: bool = False, whole: bool = False,
               shared: bool = False) -> tuple[float, float]:
        """Gauss–Newton on eq. G3 at one resolution, until an update is below ``tolerance`` × (0.1 mm, 0.01 mrad)
        or ``iterations`` have run (:func:`~.kernels.ground_align`, one compiled pass over the pixels each).

        With ``near_only``, eq. G4: the yaw alone over the near floor, the distance held; returns the yaw and
        the near floor's information on it (Σ w J_w² at the last iteration) instead. With ``whole``, over the
        whole floor, beyond eq. G5's lane too (:meth:`whole_floor_distance`). With ``shared`` (the finest level,
        where ``shared_information`` is set), the information on the distance is eq. G8's.
        """
        focal, centre_u, centre_v, indices, ground, flow = self._floor(new.shape[1:], near_only, whole=whole)
        target = new[0].ravel()[indices]
        if shared:  # eq. G8: the current image's gradients at the floor pixels
            target_u, target_v = new[1].ravel()[indices], new[2].ravel()[indices]
        else:
            target_u = target_v = target
        weight_distance = (self.robust_scale / _PRIOR_DISTANCE) ** 2
        weight_turn = (self.robust_scale / _PRIOR_TURN) ** 2
        (distance, turn, information_distance, information_turn, support, near_information, done,
         standing) = ground_align(
            old, target, target_u, target_v, ground[0], ground[1], flow, focal, centre_u, centre_v, self._height,
            self.camera_forward, float(distance), float(turn), float(prior[0]), float(prior[1]), weight_distance,
            weight_turn, weight_distance * self.distance_certainty, self.min_information, self._crosswise,
            self.robust_scale, self.iterations, tolerance, near_only, shared,
            2 * math.pi * self.smoothing**2 / (2 if new.shape[2] > 100 else 1), self.smoothing)
        self.passes += done
        if near_only:
            return turn, near_information
        if information_distance >= 0:  # an iteration ran
            self.information = np.array([information_distance, information_turn])
            self.standing = standing
            self.support = support
        return distance, turn
