"""Where the robot is, for a robot that acts on it: its self-motion, corrected where NeuroSLAM recognises a
place, and how sure it is.

NeuroSLAM's own estimate (:attr:`Estimate.pose`) is the experience map's: it jumps wherever the map says,
in the map's frame. A robot that navigates needs a pose in its task's frame that is never worse than the
odometry it was given. :class:`Localiser` keeps one:

- **Prediction.** Between recognitions the pose follows the self-motion NeuroSLAM integrated (the same
  speed, turn and climb), and its uncertainty grows: a standard deviation per degree of freedom. The
  heading's grows with the square root of the angle turned (each turn's error is independent) and linearly
  with the distance (a bias); the position's and the height's linearly with the distance driven, plus the
  distance times the heading's (a heading error bends the path it integrates).
- **Correction only on confirmed recognition.** A frame on which NeuroSLAM closes a loop (the confirmed rule,
  :func:`~neuroslam.loop_closure.confirm_place`) or merges into a loaded map gives a measurement of where the
  robot is: at a place this localiser laid, its own pose when it laid that experience (the heading turned by
  as much as NeuroSLAM's heading differs from the experience's then), with the uncertainty it had then; at a
  loaded map's place, the experience map's pose expressed in the task's frame, with ``map_error``. Both with
  the recognition's own (``recognition_error``). Not the experience map's pose of an own place: the map
  integrates the same self-motion but is bent by NeuroSLAM's own loop closures, and where the robot laid
  places while lost (20–30 m off, stalled in one spot for goal after goal), the map's poses of them were
  further off than the localiser's, yet carried the localiser's smaller uncertainty: recognising them moved
  the pose 10 m the wrong way (gen:4, docs/navigation.md). A measurement farther from the prediction than
  ``gate`` standard deviations of their difference is rejected (the plane and the height each through their
  own gate), unless ``persistence`` rejected ones in a row agree with one another: then the prediction is what
  is wrong, and the pose takes the measurement. An accepted one is fused with the inverse-variance weights of
  a Kalman update per degree of freedom. Repeated recognitions of one place are not independent (the place's
  error is a bias), so fusion never claims more than the measurement's own uncertainty over √2.
- **The floor's lines hold the heading** (``lines_error`` > 0; off by default). Buildings are laid out along
  two perpendicular directions, and the floor's straight lines show them in every frame (eq. M2 of
  :mod:`neuroslam.vision.structure`, :attr:`Estimate.floor_lines`). The first ``lines_reference`` frames in a
  row that see them and agree (their median deviation within ``lines_error``) fix the lines' direction in the
  task frame (the Cauchy-weighted mean of :func:`~neuroslam.relaxation.structure_axis`), as sure as the heading
  was then (fixed at the start, exactly; later, the heading's drift so far stays, and only its growth
  stops). Afterwards, every metre driven, the median of the headings the lines
  implied over that metre (the direction minus the frame's orientation, modulo 90°, nearest the prediction)
  is a measurement of the heading with ``lines_error``, through the gate, fused like a recognition's heading.
  The wheels' heading walks 9.1 mrad per root metre on the testbed (docs/testbed.md); the lines' does not.
- **A loaded map's frame is aligned robustly.** A map of an earlier drive is in that drive's frame. The
  session starts as an unknown start (its own frame, the task's start pose); once it merges into the map,
  each recognition pairs the predicted pose (task frame) with the map's (map frame), and the rigid
  transform between the frames (yaw, x, y, z) is fitted by weighted least squares over the first
  ``alignment_pairs`` pairs spread over at least ``alignment_spread`` metres, with pairs beyond three
  times their median residual dropped and the fit repeated. Until then the map corrects nothing: no snap to
  one experience's pose.

Units: metres, radians, seconds.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass

import numpy as np

from .config.checks import non_negative, positive, require
from .errors import InvalidInputError
from .estimate import Estimate
from .evaluation.registration import fit_yaw_translation, transform_points
from .geometry import compose, inverse, quarter_wrap, wrap
from .relaxation import structure_axis
from .slam import NeuroSLAM
from .vision.odometry import SelfMotion

logger = logging.getLogger(__name__)

__all__ = ["Localisation", "LocalisationConfig", "Localiser"]


@dataclass(frozen=True)
class LocalisationConfig:
    """How fast the self-motion drifts and how far a recognition is trusted.

    Attributes:
        distance_drift: horizontal position error per metre driven (1σ, m/m).
        height_drift: height error per metre driven (1σ, m/m).
        turn_drift: heading error per square root of the angle turned (1σ, rad/√rad).
        heading_drift: heading error per metre driven (1σ, rad/m).
        recognition_error: error of a recognised place's position beyond the map's own (1σ, m): a
            recognition places the robot within the confirmation tolerance of the experience.
        recognition_heading_error: its heading error (1σ, rad).
        map_error: position error of a loaded map's places (1σ, m); its heading error is
            ``map_error / 10`` rad (a metre of position error over ten metres of map).
        gate: a measurement farther than this many standard deviations from the prediction is rejected
            (the plane, x, y and heading, and the height each through their own gate).
        persistence: this many rejected measurements in a row that agree with one another (within twice
            their noise) are taken: then the prediction is what is wrong (wheels that slipped against an
            obstacle, a missed ramp's top), and the pose takes the latest with its noise.
        alignment_pairs: recognitions that align a loaded map with the task's frame.
        alignment_spread: the least extent of those recognitions' positions, m (a shorter baseline leaves
            the map's heading undetermined).
        lines_error: 1σ of the heading the floor's straight lines give over a metre of driving, rad; 0 leaves
            them out (the default). About 1°: their direction scatters 0.15–0.4° a frame in the median on
            marked floors, and a misread stretch (a wall's foot) is off by a few degrees.
        lines_reference: frames in a row seeing lines that agree, which fix their direction in the task frame.

    Presets (:meth:`preset`): ``wheel`` for wheel encoders (``distance_drift`` 0.02: the testbed's and a
    typical encoder's relative error, taken as if systematic; 0.005 rad per square root of the radians
    turned and 0.0005 rad per metre, about 3° per 100 m), ``visual`` for NeuroSLAM's own visual odometry
    (0.10 and 0.05: its distance reads tens of percent off on blank floors, docs/generalization.md).
    """

    distance_drift: float = 0.02
    height_drift: float = 0.02
    turn_drift: float = 0.005
    heading_drift: float = 0.0005
    recognition_error: float = 0.3
    recognition_heading_error: float = 0.05
    map_error: float = 0.5
    gate: float = 3.0
    persistence: int = 3
    alignment_pairs: int = 5
    alignment_spread: float = 5.0
    lines_error: float = 0.0
    lines_reference: int = 30

    def __post_init__(self) -> None:
        section = "localisation"
        non_negative(section, distance_drift=self.distance_drift, height_drift=self.height_drift,
                     turn_drift=self.turn_drift, heading_drift=self.heading_drift, lines_error=self.lines_error)
        positive(section, recognition_error=self.recognition_error, map_error=self.map_error, gate=self.gate,
                 recognition_heading_error=self.recognition_heading_error, alignment_spread=self.alignment_spread)
        require(f"{section}.persistence", self.persistence,
                isinstance(self.persistence, int) and not isinstance(self.persistence, bool) and self.persistence >= 2,
                "must be a whole number >= 2")
        require(f"{section}.alignment_pairs", self.alignment_pairs,
                isinstance(self.alignment_pairs, int) and not isinstance(self.alignment_pairs, bool)
                and self.alignment_pairs >= 2, "must be a whole number >= 2")
        require(f"{section}.lines_reference", self.lines_reference,
                isinstance(self.lines_reference, int) and not isinstance(self.lines_reference, bool)
                and self.lines_reference >= 3, "must be a whole number >= 3")

    @classmethod
    def preset(cls, odometry: str) -> LocalisationConfig:
        """The settings for a self-motion source: ``wheel`` or ``visual`` (see the class docstring)."""
        if odometry == "wheel":
            return cls()
        if odometry == "visual":
            return cls(distance_drift=0.10, height_drift=0.05, turn_drift=0.05, heading_drift=0.002)
        raise InvalidInputError("odometry", repr(odometry), "must be 'wheel' or 'visual'")


@dataclass
class Localisation:
    """The localiser's answer after one frame.

    Attributes:
        pose: (x, y, z, yaw) in the task's frame, m and rad.
        position_error: 1σ horizontal position uncertainty, m. height_error: 1σ, m. heading_error: 1σ, rad.
        corrected: a recognition corrected the pose (a part of it) this frame. rejected: a part of one was
            refused by its gate.
        aligned: the map NeuroSLAM is in is aligned with the task's frame (always, without a loaded map).
        estimate: NeuroSLAM's estimate for the frame (in the map's frame).
    """

    pose: np.ndarray
    position_error: float
    height_error: float
    heading_error: float
    corrected: bool
    rejected: bool
    aligned: bool
    estimate: Estimate


@dataclass
class _Place:
    """What the localiser knew when it laid an experience: its uncertainty (1σ, m, m, rad), and its own pose
    then (task frame) with NeuroSLAM's (map frame), or None for a loaded map's place."""

    position: float
    height: float
    heading: float
    pose: np.ndarray | None = None
    map_pose: np.ndarray | None = None


class Localiser:
    """A pose in the task's frame from NeuroSLAM and its self-motion (see the module's description).

    Args:
        slam: the NeuroSLAM to step (fresh, or with a loaded map: :meth:`NeuroSLAM.load`).
        start: the robot's pose in the task's frame at the first frame, (x, y, z, yaw), m and rad.
        config: drift and trust settings (:meth:`LocalisationConfig.preset`).
        loaded_map: ``slam`` holds a map of an earlier drive: the session starts as an unknown start in it
            (:meth:`NeuroSLAM.begin_session`) and its frame is aligned from recognitions.

    Example::

        slam = NeuroSLAM.load("runs/carpark")
        localiser = Localiser(slam, start_pose, LocalisationConfig.preset("wheel"), loaded_map=True)
        for image, t, wheels in frames:
            where = localiser.step(image, t, odometry=wheels)   # where.pose, where.position_error
    """

    def __init__(self, slam: NeuroSLAM, start: np.ndarray, config: LocalisationConfig | None = None, *,
                 loaded_map: bool = False):
        start = np.asarray(start, dtype=float)
        if start.shape != (4,) or not np.all(np.isfinite(start)):
            raise InvalidInputError("start", repr(start.tolist()), "must be (x, y, z, yaw), finite, m and rad")
        self.slam = slam
        self.config = config or LocalisationConfig()
        self.pose = start.copy()
        self.start = start.copy()
        self.sigma = np.zeros(3)  # position, height, heading: 1σ
        self._heading_base = 0.0  # the heading's 1σ at the last correction, and the turn and travel since
        self._turned = self._travelled = 0.0
        self.loaded_map = loaded_map
        if loaded_map:
            slam.begin_session(start="unknown")
        self._session_component = -1
        self._alignment: np.ndarray | None = None  # task frame ← SLAM frame, (x, y, z, yaw)
        self._alignment_error = 0.0
        self._pairs: list[tuple[np.ndarray, np.ndarray, float]] = []  # (task pose, map pose, weight)
        self._places: dict[int, _Place] = {}
        self._rejected: dict[str, list[np.ndarray]] = {"plane": [], "height": []}  # since the last accepted
        self._last_time: float | None = None
        self.lines_axis: float | None = None  # the floor lines' direction in the task frame, rad (modulo 90°)
        self.lines_axis_error = 0.0  # its 1σ: the heading's when it was fixed, rad
        self._lines_samples: list[float] = []  # the directions seen while fixing it
        self._lines_innovations: list[float] = []  # this metre's headings implied by the lines, less the prediction
        self._lines_travelled = 0.0  # m since the last lines' measurement
        self.lines_corrections = 0
        self.corrections = 0
        self.rejections = 0
        self.last: Localisation | None = None

    @property
    def aligned(self) -> bool:
        """The SLAM's current frame is tied to the task's frame."""
        return self._alignment is not None

    def step(self, image: np.ndarray, timestamp: float, odometry: SelfMotion | None = None) -> Localisation:
        """One frame: :meth:`NeuroSLAM.step` (same arguments; its errors, state unchanged), then predict and,
        on a confirmed recognition, correct."""
        first = self._last_time is None
        estimate = self.slam.step(image, timestamp, odometry)
        dt = 0.0 if first else float(timestamp) - self._last_time
        self._last_time = float(timestamp)
        self._predict(estimate.self_motion, dt)
        if self.config.lines_error > 0 and math.isfinite(estimate.floor_lines):
            self._lines(estimate.floor_lines)
        if first:  # the SLAM's own frame starts here: it is the task's start
            self._alignment = compose(self.start, inverse(estimate.pose))
            self._session_component = self.slam.experience_map.component
        component = self.slam.experience_map.component
        corrected = rejected = False
        if component != self._session_component:  # merged into the loaded map: a frame to align
            self._session_component = component
            self._alignment, self._pairs = None, []
            logger.info("merged into the loaded map; aligning its frame from recognitions")
        if estimate.loop_closure or estimate.merged:
            if self._alignment is None:
                self._collect(estimate)
            if self._alignment is not None:
                corrected, rejected = self._correct(estimate)
        if estimate.new_experience:
            self._places[estimate.experience_id] = _Place(*self.sigma, self.pose.copy(), estimate.pose.copy())
        self.last = Localisation(self.pose.copy(), float(self.sigma[0]), float(self.sigma[1]), float(self.sigma[2]),
                                 corrected, rejected, self.aligned, estimate)
        return self.last

    # prediction ----------------------------------------------------------------------------------------
    def _predict(self, motion: SelfMotion, dt: float) -> None:
        distance, turn, climb = motion.forward_speed * dt, motion.yaw_rate * dt, motion.climb_rate * dt
        x, y, z, yaw = self.pose
        middle = yaw + turn / 2
        self.pose = np.array([x + distance * math.cos(middle), y + distance * math.sin(middle), z + climb,
                              wrap(float(yaw + turn))])
        c = self.config
        travelled = abs(distance)
        self._lines_travelled += travelled
        self._turned += abs(turn)
        self._travelled += travelled
        # the turn's error is a random walk (variance per radian turned), the distance's a bias (per metre)
        self.sigma[2] = math.hypot(self._heading_base, c.turn_drift * math.sqrt(self._turned)) \
            + c.heading_drift * self._travelled
        self.sigma[0] += c.distance_drift * travelled + travelled * self.sigma[2]  # a heading error bends the path
        self.sigma[1] += c.height_drift * travelled

    # the floor's lines --------------------------------------------------------------------------------------
    def _lines(self, orientation: float) -> None:
        """Fix the lines' direction at the start; then, every metre, take the heading they imply."""
        c = self.config
        direction = float(self.pose[3] + orientation)
        if self.lines_axis is None:
            self._lines_samples = [*self._lines_samples[1 - c.lines_reference:], direction]
            samples = np.asarray(self._lines_samples)
            if len(samples) < c.lines_reference:
                return
            axis = structure_axis(np.zeros(len(samples)), samples, c.lines_error)
            if float(np.median(np.abs(quarter_wrap(samples - axis)))) <= c.lines_error:
                # the direction is as sure as the heading was: the lines hold the heading from here on, and
                # the heading is never surer than the direction it is held to
                self.lines_axis, self.lines_axis_error = axis, float(self.sigma[2])
                self._lines_travelled = 0.0
                logger.info("floor lines' direction fixed at %.1f° (1σ %.1f°) from %d frames", math.degrees(axis),
                            math.degrees(self.lines_axis_error), len(samples))
            return
        self._lines_innovations.append(float(quarter_wrap(self.lines_axis - direction)))
        if self._lines_travelled < 1.0:
            return
        innovation = float(np.median(self._lines_innovations))
        self._lines_innovations, self._lines_travelled = [], 0.0
        sigma, noise = float(self.sigma[2]), c.lines_error
        if abs(innovation) > c.gate * math.hypot(sigma, noise):
            return
        gain = sigma**2 / (sigma**2 + noise**2)
        self.pose[3] = wrap(float(self.pose[3] + gain * innovation))
        fused = math.sqrt(sigma**2 * noise**2 / (sigma**2 + noise**2))
        self.sigma[2] = min(sigma, max(fused, noise / math.sqrt(2), self.lines_axis_error))
        self._heading_base, self._turned, self._travelled = float(self.sigma[2]), 0.0, 0.0
        self.lines_corrections += 1

    # alignment of a loaded map ----------------------------------------------------------------------------
    def _collect(self, estimate: Estimate) -> None:
        """Pair the predicted pose with the map's; align once enough pairs spread far enough."""
        weight = 1.0 / (self.sigma[0] ** 2 + self.config.recognition_error ** 2)
        self._pairs.append((self.pose.copy(), estimate.pose.copy(), weight))
        positions = np.array([pair[1][:2] for pair in self._pairs])
        spread = float(np.max(np.ptp(positions, axis=0))) if len(positions) > 1 else 0.0
        if len(self._pairs) >= self.config.alignment_pairs and spread >= self.config.alignment_spread:
            self._alignment, self._alignment_error = align(self._pairs)
            logger.info("loaded map aligned from %d recognitions (residual %.2f m)", len(self._pairs),
                        self._alignment_error)

    # correction ----------------------------------------------------------------------------------------
    def _correct(self, estimate: Estimate) -> tuple[bool, bool]:
        """Fuse the recognised pose, the plane (x, y, heading) and the height each through its own gate
        (returns whether a part was corrected, whether a part was rejected)."""
        c = self.config
        place = self._places.get(estimate.experience_id)
        if place is None:  # a loaded map's place: where the map has it, through the fitted alignment
            measured = compose(self._alignment, estimate.pose)
            place, alignment_error = _Place(c.map_error, c.map_error, c.map_error / 10), self._alignment_error
        else:  # a place this localiser laid: where it was then, the uncertainty it had then (no alignment)
            measured = place.pose.copy()
            measured[3] = wrap(float(place.pose[3] + estimate.pose[3] - place.map_pose[3]))
            alignment_error = 0.0
        noise = np.array([math.hypot(place.position, c.recognition_error, alignment_error),
                          math.hypot(place.height, c.recognition_error),
                          math.hypot(place.heading, c.recognition_heading_error)])
        difference = np.array([measured[0] - self.pose[0], measured[1] - self.pose[1], measured[2] - self.pose[2],
                               wrap(float(measured[3] - self.pose[3]))])
        bound = c.gate * np.hypot(self.sigma, noise)
        corrected = rejected = False
        for group, inside in (("plane", math.hypot(*difference[:2]) <= bound[0] and abs(difference[3]) <= bound[2]),
                              ("height", abs(difference[2]) <= bound[1])):
            axes, sigmas = ((0, 1, 3), (0, 0, 2)) if group == "plane" else ((2,), (1,))
            history = self._rejected[group]
            if inside:
                history.clear()
                sigma, spread = self.sigma[list(sigmas)], noise[list(sigmas)]
                gain = sigma**2 / (sigma**2 + spread**2)
                self.pose[list(axes)] += gain * difference[list(axes)]
                fused = np.sqrt(sigma**2 * spread**2 / (sigma**2 + spread**2))
                self.sigma[list(sigmas)] = np.minimum(sigma, np.maximum(fused, spread / math.sqrt(2)))
                corrected = True
                continue
            history.append(difference[list(axes)])
            recent = np.array(history[-c.persistence:])
            agree = len(recent) == c.persistence and np.all(
                np.abs(recent - recent.mean(axis=0)) <= 2 * noise[list(sigmas)])
            if agree:  # the same correction, again and again: the prediction is what is wrong
                self.pose[list(axes)] += difference[list(axes)]
                self.sigma[list(sigmas)] = noise[list(sigmas)]
                history.clear()
                corrected = True
                logger.info("%s re-localised by %d agreeing recognitions (%s)", group, c.persistence,
                            np.round(difference[list(axes)], 2))
            else:
                rejected = True
        self.pose[3] = wrap(float(self.pose[3]))
        if corrected:
            self.corrections += 1
            self._heading_base, self._turned, self._travelled = float(self.sigma[2]), 0.0, 0.0
        if rejected:
            self.rejections += 1
            logger.debug("recognition at experience %d partly rejected (difference %s)", estimate.experience_id,
                         np.round(difference, 2))
        return corrected, rejected


def align(pairs: list[tuple[np.ndarray, np.ndarray, float]]) -> tuple[np.ndarray, float]:
    """The rigid transform (x, y, z, yaw) taking map poses to task poses from ``(task pose, map pose,
    weight)`` pairs: the weighted least-squares fit of :func:`~neuroslam.evaluation.registration.
    fit_yaw_translation`, refitted once without the pairs beyond three times the median residual. Returns
    it and the kept pairs' RMS residual, m."""
    task = np.array([pair[0][:3] for pair in pairs])
    mapped = np.array([pair[1][:3] for pair in pairs])
    weights = np.array([pair[2] for pair in pairs])
    keep = np.ones(len(pairs), dtype=bool)
    for _ in range(2):
        yaw, translation = fit_yaw_translation(mapped[keep], task[keep], weights[keep])
        residuals = np.linalg.norm(transform_points(mapped, yaw, translation) - task, axis=1)
        keep = residuals <= max(3 * float(np.median(residuals[keep])), 1e-9)
        if keep.sum() < 2:
            keep = residuals <= np.sort(residuals)[1]
    return np.array([*translation, yaw]), float(np.sqrt(np.mean(residuals[keep] ** 2)))
