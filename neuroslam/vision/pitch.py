"""Pitch from the camera alone: the rotation between frames by direct alignment, and level floors joined by
ramps.

Neither is in the NeuroSLAM paper; together they replace NeuroSLAM eqs. 31–32's height when
``odometry.height_model = "transitions"`` (the ``sim`` preset's default). NeuroSLAM eq. 31's row shift, integrated
frame after frame, drifts: forward motion alone moves the image vertically by a scene-dependent amount
(0.002–0.024 rad per metre on the testbed's worlds), and a turn close to a wall reads as tens of degrees of
pitch. Both are removed here.

**Rotation alignment** (eqs. R1–R2). A camera that turns by ``psi`` (yaw, left positive) and pitches by
``theta`` (nose up positive) between two frames sees the ray ``r = (x, y, f)`` of a current pixel (x right,
y down, from the image centre; f the focal length in pixels) along ``R_yaw(psi) R_pitch(theta) r`` in the
previous camera, whatever its depth. Forward motion adds a flow away from the image centre; over the
central part of the image it is modelled as one expansion ``e``. The previous pixel is

    p = (1 - e) f (r'_x / r'_z, r'_y / r'_z),    r' = R_yaw(psi) R_pitch(theta) r                  (R1)

and (psi, theta, e) minimise the robust (Huber) photometric error over the central region

    E(psi, theta, e) = sum_q rho(I_prev(p(q)) - I_now(q))                                          (R2)

by Gauss–Newton from the previous frame's yaw, and also from the floor's yaw (eq. G3) when the two
differ, keeping the lower error. Being a rotation, the pitch is exact for any depth; where the floor
bends (the foot and the top of a ramp) the plane model of eq. G3 fails and this yaw is the one to use.

**Level floors joined by ramps** (eq. R3). Multi-storey car parks and buildings have level floors joined
by ramps of constant slope: the pitch is piecewise constant and changes only where the robot rolls over a
ramp's foot or top, quickly (about 10° over the robot's length). Such a *transition* is a run of frames
whose pitch change exceeds ``transition_rate`` (rad/s) with one sign; when it ends its total is added to
the pitch,

    theta_after = theta_before + sum over the run of delta theta                                   (R3)

if the total is at least ``transition_min`` and the new pitch no steeper than ``max_slope`` (a turn near
a textureless wall can still read as a large pitch change; no ramp is that steep); after a transition
back towards level, a pitch within ``level_snap`` of level is level (the up and down transitions of a
ramp, each measured within about 10 %, cancel to within a degree or two). A transition from level is a
slope however gentle (a 5° ramp's foot read as 3.7° is a ramp). Levels lie between ramps, so a slope never
turns straight into the opposite one: a transition back towards level that would carry the pitch through
it, however far, is a top (or foot) read too large, and the pitch is level. Each rule mends a way the
height ran away on generator-2 worlds (docs/generalization.md, fourth step).
Between transitions the pitch holds, so no drift accumulates on level floors or along a ramp. Measured on
two laps of each of the six worlds of the testbed (before the SLAM): every one of the 8–16 transitions
found, none false, the odometry's height within 0.12–0.33 m RMS of the truth (NeuroSLAM eqs. 31–32: 1–130 m).

A run is committed only on consistent evidence: at least one of its frames must see the pitch (the
image's information on it, eq. R2, above the odometry's ``min_image_information``) and itself change at the
transition rate, with the run's sign. Frames that see the pitch less may still join a run, but a run
made of them alone starts or steepens no slope: a uniform image or a turn beside a blank wall reads noise
at any rate. A ramp's top against a dim, blank upper level is read mostly on such frames (gen2:110: -3.4°
and -3.9° unseen, then -2.4° seen, for a 10° ramp); taking the seen frames alone missed it. An unseen run
does end a slope where it brings the pitch back to within ``level_snap`` of level or through it: a
coincidence noise does not make, and the world model's (see :class:`LevelTransitions`).

Slopes that change gradually (a curved ramp) are not followed: that is the model's limit.

**Is the camera still moving?** (eq. R4). The expansion e of eq. R1 over its standard error is a
t-statistic, :meth:`RotationAlignment.expansion_significance`: large and positive where the image grows (the
camera moves forward, whatever the scene's depth), about 0 at rest or turning on the spot (a rotation is
eq. R1's exactly). It gives the motion's sign, not its size: where nothing observes the distance, the visual
odometry keeps the last speed while it shows the robot moving (``odometry.forward_evidence``).

**Walls at their own depths** (eq. R5). A forward step moves each point by an expansion of its own, d / X;
eq. R1's single expansion leaves a wall near on one side, whose depth changes across the image, partly to
the yaw. :meth:`RotationAlignment.column_yaw` solves eq. R2 again with one expansion per column block
(:data:`COLUMN_BLOCKS`), each a vertical surface's single depth: the yaw the visual odometry takes where the
floor does not see it.

**Does a faint image see the yaw?** (eq. R11). Gauss–Newton's information on the yaw is read from the previous
image's gradients, and sensor noise has them too. :meth:`RotationAlignment.column_yaw_contrast` asks the cost
instead: the median of eq. R5's cost with the yaw moved a few pixels either way over its cost at the solution.
A structure both images share fits one yaw; noise, which the next image does not repeat, fits every yaw
alike (0.95–1.12). With ``odometry.faint_yaw_contrast`` the visual odometry takes eq. R5's yaw where the
information per pixel is too low but this contrast is high enough, before the column profile's.
"""

from __future__ import annotations

import math

import numpy as np

from .kernels import rotation_cost, rotation_normal, rotation_solve

__all__ = ["LevelTransitions", "RotationAlignment"]

_DAMPING = 1e-2  # Tikhonov term added to the Gauss–Newton normal equations (intensity² · rad⁻²)
_MIN_SUPPORT = 0.5  # below this share of the region's pixels still in the previous image, no solution
_TOLERANCE = 1e-4  # rad: an update of yaw and pitch below this (0.01 pixel) ends the iterations
# the RMS difference of two 8-bit quantised images of one scene (each off by a uniform 1/255 step: variance
# 1/12 of a step squared, twice): the least residual eq. R4 divides by
_QUANTISATION = 1.0 / (255.0 * math.sqrt(6.0))
# eq. R5's column blocks: 16 across the image, 5 degrees of the testbed's 80-degree view each. A wall parallel
# to the path stands at a depth inversely proportional to a column's distance from the centre, so across a
# block its depth changes by the ratio of the block's edges' distances: at most 4/3 from the third block out
# from the centre (2 beside it, where such a wall is far ahead), against a quadrant's whole half image
COLUMN_BLOCKS = 16
_RETRY = math.radians(1)  # a second start from the floor's yaw when it differs from the previous yaw by more
# eq. R11: the yaw is moved by these (pixels at the image centre) either way: beyond the blurred image's
# noise grain (its blur is one pixel), within the column profile's search (NeuroSLAM eq. 28)
_CONTRAST_PIXELS = (1.0, 2.0, 4.0)


class RotationAlignment:
    """The camera's yaw and pitch change between consecutive images (eqs. R1–R2).

    Args:
        horizontal_fov: the camera's horizontal field of view, rad (square pixels assumed).
        region: (top, bottom, left, right) of the aligned region, fractions of the image.
        robust_scale: Huber threshold on the intensity residual (images in [0, 1]).
        iterations: most Gauss–Newton iterations (stops once the yaw and pitch updates are below 1e-4 rad,
            0.01 pixel).
    """

    def __init__(self, *, horizontal_fov: float, region: tuple[float, float, float, float] = (0.2, 0.8, 0.1, 0.9),
                 robust_scale: float = 0.05, iterations: int = 8):
        self.horizontal_fov = horizontal_fov
        self.region = region
        self.robust_scale = robust_scale
        self.iterations = iterations
        self.yaw = 0.0  # rad, the last frame's aligned yaw change (the next frame's first start)
        # the last frame's information on (yaw, pitch, expansion): each the inverse of its entry of the inverse
        # normal matrix of eq. R2 (the other two free), intensity² per rad² (per unit for e)
        self.information = np.zeros(3)
        self.cost = math.inf  # the last frame's mean Huber cost of eq. R2 at its solution (images in [0, 1])
        self._last: tuple = (None, None, np.zeros(3), False)  # the last step's images, solution, and success
        # the last column_yaw's solution, its mean Huber cost and its marginal information on the yaw (eq. R11)
        self._column: tuple = (None, math.inf, 0.0)
        self._pixels: dict[tuple[int, int], tuple] = {}
        # passes over the region's pixels so far (Gauss–Newton iterations and cost evaluations), for the cost
        self.passes = 0

    def _grid(self, shape: tuple[int, int], upper: bool = False) -> tuple:
        """Per image size: focal length, the region's pixels (flat indices), their centred coordinates and
        column blocks (eq. R5); with ``upper``, those above the image centre alone."""
        cached = self._pixels.get((shape, upper))
        if cached is not None:
            return cached
        if upper:
            focal, indices, x, y, blocks = self._grid(shape)
            above = y < 0
            cached = (focal, indices[above], x[above], y[above], blocks[above])
            self._pixels[(shape, upper)] = cached
            return cached
        rows, columns = shape
        top, bottom, left, right = self.region
        step = 2 if columns > 100 else 1
        v, u = np.mgrid[int(top * rows): max(int(bottom * rows), int(top * rows) + 1): step,
                        int(left * columns): max(int(right * columns), int(left * columns) + 1): step]
        u, v = u.ravel(), v.ravel()
        focal = (columns / 2) / math.tan(self.horizontal_fov / 2)
        x = (u - (columns / 2 - 0.5)).astype(np.float32)
        y = (v - (rows / 2 - 0.5)).astype(np.float32)
        blocks = np.minimum(u * COLUMN_BLOCKS // columns, COLUMN_BLOCKS - 1).astype(np.intp)
        cached = (focal, v * columns + u, x, y, blocks)
        self._pixels[(shape, upper)] = cached
        return cached

    def step(self, previous: np.ndarray, current: np.ndarray, floor_yaw: float) -> tuple[float, float]:
        """(yaw change, pitch change), rad, from the previous to the current image.

        ``previous`` and ``current`` are (3, rows, columns) stacks of a blurred grey image and its
        horizontal and vertical gradients (the finest level of :class:`~.ground_motion.GroundMotion`'s
        pyramid); ``floor_yaw`` is eq. G3's yaw change for the same frame (a second start).
        """
        starts = [self.yaw]
        if abs(floor_yaw - self.yaw) > _RETRY:
            starts.append(floor_yaw)
        best = None
        for start in starts:
            solution = self._solve(previous, current, np.array([start, 0.0, 0.0]))
            if best is None or solution[1] < best[1]:
                best = solution
        parameters, cost, information = best
        if not math.isfinite(cost):
            parameters, information = np.array([floor_yaw, 0.0, 0.0]), np.zeros(3)
        yaw, pitch = float(parameters[0]), float(parameters[1])
        self.yaw, self.information, self.cost = yaw, information, cost
        self._last = (previous, current, parameters, math.isfinite(cost))
        self._column = (None, math.inf, 0.0)  # eq. R11 reads this frame's column_yaw only
        return yaw, pitch

    @property
    def pixels(self) -> int:
        """Pixels of the aligned region at the last image size (the information above is summed over them)."""
        last = self._last[1]
        return 0 if last is None else len(self._grid(last.shape[1:])[1])

    def expansion_significance(self) -> float:
        """The last frame's expansion e of eq. R1 over its standard error: a t-statistic, positive for an image
        that grows (the camera moving forward), about 0 at rest or turning in place.

            z = e sqrt(I_e) / sigma,    sigma = max(sqrt(2 C), sigma_q)                                (R4)

        with I_e the marginal information on e (:attr:`information`), C the mean Huber cost at the solution
        (r² / 2 for small residuals r, so sqrt(2 C) is their root mean square: sensor noise, and where the
        camera moves, what one expansion does not explain) and sigma_q = 1 / (255 sqrt 6) the difference of two
        8-bit quantised images (two identical frames would otherwise divide 0 by 0); 0 where the step found no
        solution."""
        if not (self._last[3] and math.isfinite(self.cost)):
            return 0.0
        sigma = max(math.sqrt(2.0 * self.cost), _QUANTISATION)
        return float(self._last[2][2]) * math.sqrt(max(float(self.information[2]), 0.0)) / sigma

    def column_yaw(self) -> tuple[float, float]:
        """The last frame's yaw solved again with one expansion per column block (eq. R5: eq. R1 with e taking
        :data:`COLUMN_BLOCKS` values, one per equal block of the image's columns), from :meth:`step`'s
        solution: (yaw change rad, its marginal information Σ w J², intensity² per rad²); (the yaw, 0) where
        the step found none or this solve diverged.

        A forward step d moves a point at depth X from (x, y) to (x, y)(1 + d / X) (from the image centre):
        an expansion e = d / X of its own. Eq. R2 with pixel q's expansion that of its column block b(q):

            E(psi, theta, e_1 ... e_K) = sum_q rho(I_prev(p(q; psi, theta, e_b(q))) - I_now(q))      (R5)
 A vertical surface (a wall, a pillar, a facade) stands at one depth
        along an image column of a level camera, so one expansion per narrow column block fits its flow
        exactly, whatever its distance; one expansion for the image (eq. R1), or one per quadrant, leaves a
        wall's depth changing across the image to the yaw: a wall near on one side turns a straight path
        (measured on two recorded generated worlds' blind frames, straight: one expansion +20° and +94°,
        quadrants -48° and +68°, column blocks -7° and +15°; synthetic, ``tests/scenes.py``, 8 m beside a tiled
        wall: +5.9°, +1.9°, -0.4°). The block's expansion is pinned by the vertical flow of its horizontal
        edges (a wall's top and foot, windows), so it does not absorb the yaw; a block with none gives its
        expansion and leaves the yaw to the others. The pitch is solved with them (a level floor's ceiling or
        floor rows fit no column's single depth, but their error is alike left and right of the centre)."""
        previous, current, parameters, found = self._last
        self._column = (None, math.inf, 0.0)
        if not found:
            return float(parameters[0]), 0.0
        start = np.concatenate([parameters[:2], np.full(COLUMN_BLOCKS, parameters[2])])
        solution, cost, information = self._solve(previous, current, start)
        if not math.isfinite(cost):
            return float(parameters[0]), 0.0
        self._column = (solution, cost, float(information[0]))
        return float(solution[0]), float(information[0])

    def column_yaw_contrast(self) -> float:
        """How much the last :meth:`column_yaw` solution's yaw stands out from the yaws around it (eq. R11): the
        median of eq. R5's mean Huber cost with the yaw moved :data:`_CONTRAST_PIXELS` (pixels at the image
        centre) either way, everything else held, over the cost at the solution; 0 where there was none.

        Gauss–Newton's information on the yaw is read from the previous image's gradients alone, and sensor
        noise has gradients too: under 3.5 grey levels of noise a uniform image has as much of it per pixel
        as a faint real edge. Where the gradients are a structure both images share, the cost is least at the
        solution and grows away from it; where they are noise, which the next image does not repeat, the cost
        is the two images' noise at every yaw (the solution's own is least only by the noise it fitted):

            contrast = median_k C(psi* + k) / C(psi*),   k in +-{1, 2, 4} pixels                     (R11)

        The column profile's best shift stands out by the same test (NeuroSLAM eq. 28,
        :func:`~neuroslam.vision.profiles.profile_turn`)."""
        solution, cost, information = self._column
        previous, current = self._last[0], self._last[1]
        if solution is None or information <= _DAMPING:
            return 0.0
        focal, indices, x, y, blocks = self._grid(current.shape[1:])
        target = current[0].ravel()[indices]
        costs = []
        for pixels in _CONTRAST_PIXELS:
            for sign in (1.0, -1.0):
                moved = solution.copy()
                moved[0] += sign * pixels / focal
                moved_cost, _ = rotation_cost(previous, target, x, y, blocks, moved, focal, self.robust_scale)
                self.passes += 1
                costs.append(moved_cost)
        return float(np.median(costs)) / max(cost, _QUANTISATION**2 / 2)

    def upper_expansion(self) -> tuple[float, float]:
        """The last frame's eq. R2 over the region's pixels above the image centre alone, for the expansion
        only (yaw and pitch held at :meth:`step`'s solution), by two Gauss–Newton steps from the whole
        region's: (expansion, information Σ w J_e²); (0, 0) where the step found none. The whole region's
        expansion mixes the floor's flow with the walls'; the floor's changes with its texture (a blank floor
        shows only its edges), the upper image's does not."""
        previous, current, parameters, found = self._last
        if not found:
            return 0.0, 0.0
        focal, indices, x, y, _ = self._grid(current.shape[1:], upper=True)
        target = current[0].ravel()[indices]
        labels = np.zeros(len(x), dtype=np.intp)
        single = parameters[:3].copy()
        information = 0.0
        for _ in range(2):
            self.passes += 1
            normal, gradient = rotation_normal(previous, target, x, y, labels, single, focal, self.robust_scale)
            information = float(normal[2, 2])
            if information <= _DAMPING:
                return 0.0, 0.0
            single[2] -= float(gradient[2]) / information
        return float(single[2]), information

    def _solve(self, previous: np.ndarray, current: np.ndarray, start: np.ndarray
               ) -> tuple[np.ndarray, float, np.ndarray]:
        """Gauss–Newton on eq. R2 from ``start`` = (yaw, pitch, e) or (yaw, pitch, e_1 ... e_K) with one
        expansion per column block (eq. R5), at most ``iterations`` times (:func:`~.kernels.rotation_solve`, one
        compiled pass over the pixels each); returns the parameters, the mean Huber cost and the marginal
        information on each parameter (at the last linearisation)."""
        focal, indices, x, y, blocks = self._grid(current.shape[1:])
        target = current[0].ravel()[indices]
        start = np.array(start, dtype=float)
        labels = blocks if len(start) > 3 else np.zeros(len(x), dtype=np.intp)
        parameters, information, done = rotation_solve(previous, target, x, y, labels, start, focal, self.robust_scale,
                                                    self.iterations, _DAMPING, _TOLERANCE)
        self.passes += done
        if not np.all(np.isfinite(parameters)):
            return start, math.inf, np.zeros(len(start))
        cost, support = rotation_cost(previous, target, x, y, labels, parameters, focal, self.robust_scale)
        self.passes += 1
        if support < _MIN_SUPPORT:
            return parameters, math.inf, information
        return parameters, cost, information


class LevelTransitions:
    """Piecewise-constant pitch from per-frame pitch changes (eq. R3).

    A run of frames changing the pitch at ``transition_rate`` or faster, one sign throughout, is a transition;
    it commits when it ends, and only where one of its frames saw the pitch (the image's information on it
    above the odometry's ``min_image_information``), except at the end of a slope: a run back towards level
    that lands within ``level_snap`` of it, or carries the pitch through it, commits unseen (and the pitch is
    level). The world is level floors joined by ramps, so a slope is always ended, and a run that cancels it
    to within a few degrees, or more than cancels it, is itself the evidence (noise does not make that
    coincidence); missing it leaves the height climbing without end (measured on the wheel benchmark of
    400f57b: a ramp's foot seen at 0.6–0.85 of ``min_image_information`` a frame, read +10.6° against the
    slope's -10.6°, refused, and gen2:120's height 66 m off after 4,000 frames; on gen2:116 a ramp's top
    against a blank upper level, seen at 0.03–0.06, read -19.8° against +11.8°, refused, and the height
    40 m off a lap later), while a wrong one costs the rest of the ramp (and, where the ramp's true end is
    then seen and read as a new slope from level, the height until the next transition).

    Args:
        transition_rate: pitch change per second above which a frame belongs to a transition, rad/s.
        transition_min: smallest total of a transition, rad.
        max_slope: steepest slope; a transition that would leave the pitch steeper is refused (unless it runs
            back through level: then level), rad.
        level_snap: a pitch this close to level after a transition back towards level is level, rad.
    """

    def __init__(self, *, transition_rate: float, transition_min: float, max_slope: float, level_snap: float):
        self.transition_rate = transition_rate
        self.transition_min = transition_min
        self.max_slope = max_slope
        self.level_snap = level_snap
        self.pitch = 0.0  # rad, the pitch before the transition in progress
        self.run = 0.0  # rad, the pitch change of the transition in progress (0: none)
        self.seen = False  # whether a frame of the run in progress saw the pitch (else it shows in no pitch)

    @property
    def current(self) -> float:
        """The pitch now, rad: with the transition in progress once a frame of it saw the pitch, while it stays
        within ``max_slope``."""
        pitch = self.pitch + (self.run if self.seen else 0.0)
        return pitch if abs(pitch) <= self.max_slope else self.pitch

    def step(self, pitch_change: float, dt: float, *, seen: bool = True) -> bool:
        """Take one frame's pitch change (rad, over ``dt`` seconds) and whether the image saw the pitch on it;
        True when the frame is in a transition (one that may still come to nothing, if no frame of it sees
        the pitch)."""
        moving = abs(pitch_change) > self.transition_rate * dt
        if moving and (self.run == 0.0 or (self.run > 0) == (pitch_change > 0)):
            self.run += pitch_change
            self.seen = self.seen or seen
            return True
        self._commit()
        self.run = pitch_change if moving else 0.0
        self.seen = moving and seen
        return moving

    def _commit(self) -> None:
        """End the transition in progress: eq. R3, if a frame of it saw the pitch or it ends a slope (see the
        class)."""
        run, seen, self.run, self.seen = self.run, self.seen, 0.0, False
        pitch = self.pitch + run
        if abs(run) < self.transition_min:
            return
        towards_level = self.pitch != 0.0 and (run > 0) != (self.pitch > 0)
        # back to level, or through it (a slope never turns straight into the opposite one: a top read too large)
        ends_slope = towards_level and (abs(pitch) < self.level_snap or (pitch > 0) != (self.pitch > 0))
        if not seen and not ends_slope:  # an unseen run changes nothing, except the end of a slope
            return
        if ends_slope:
            self.pitch = 0.0
        elif abs(pitch) <= self.max_slope:  # no ramp is steeper: refused
            self.pitch = pitch
