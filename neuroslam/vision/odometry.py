"""Visual odometry from intensity profiles ("aidvo", NeuroSLAM eqs. 27–32), all four degrees of freedom from images.

- Yaw (NeuroSLAM eqs. 27–29): the column profile of the rotation region, resampled to columns equally spaced in
  angle (for a pinhole camera the pixel columns are not: a rotation moves the edges less than the
  centre; measured on the testbed, turns read 8 % short without it and 5 % with it), is matched against
  the previous frame's by the shift that minimises the mean absolute difference over the overlap; the
  shift, refined by a parabola through the three best differences, times the angle per column is the
  yaw change. Content moving right means the camera turned left: positive yaw.
- Speed (NeuroSLAM eq. 30): the mean absolute difference of the translation region's profiles at that shift,
  times ``speed_scale``, clipped to ``max_speed``.
- With ``planar_motion = "ground"`` (the default of the ``sim`` preset) the speed and the yaw come instead
  from aligning the floor below the horizon under a ground-plane model (:mod:`.ground_motion`, eqs.
  G1–G3): metric from the camera height, the same in every scene.
- Height with ``height_model = "transitions"`` (the default of the ``sim`` preset): the pitch change
  from aligning consecutive images under a pure rotation (eqs. R1–R2 of :mod:`.pitch`), taken only as
  whole transitions between level floors and ramps (eq. R3). On a transition frame the floor is not one
  plane, so the yaw is the rotation alignment's and the speed is held from those measured before it (it
  does not change over a ramp's foot; frames may be unevenly spaced): with ``planar_motion = "ground"``, the
  quartile of the last near floor's reach of readings that the bend ahead cannot have pulled its way (eq. R6
  of :mod:`.cues`), else the last one; elsewhere both come from the floor (eqs. G1–G3). The floor's alignment
  reads the distance d in the floor's own plane, so on a slope of pitch θ the frame moves the robot

      horizontal = d cos θ,   climb = d sin θ                                                         (R7)

  (the paper integrates d as horizontal: a 10° ramp then reads 1.5 % long, the same way both up and down, which
  moves every level above it and which no loop closure sees).
- Height with ``height_model = "profile"`` (NeuroSLAM eqs. 31–32, measured rather than switched from ground
  truth): the height region, offset by the yaw shift, is matched against the previous frame's by the
  vertical shift minimising the mean absolute difference (NeuroSLAM eq. 31 over the whole region rather than its
  row profile, which measured too noisy in the testbed: correlation with the true pitch change 0.50
  against 0.84). The shift times the angle per row is the change of pitch (content moving down: nose
  up), less ``pitch_flow_bias`` per metre driven (forward motion itself moves the floor down the image).
  The integrated pitch, slowly leaked back to level, times the distance is the climb.
- With ``planar_motion = "ground"`` and ``manhattan`` (off by default), each frame's yaw change is then turned
  towards the orientation of the floor's and the ceiling's straight lines, modulo 90° (eqs. M1–M3 of
  :mod:`.structure`), which the heading's drift does not move.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from ..config import VisualOdometryConfig
from ..errors import InvalidInputError, InvalidParameterError
from .cues import CueSelectionMixin
from .ground_motion import GroundMotion, blurred_with_gradients
from .motion import BLIND, Observed, SelfMotion
from .pitch import LevelTransitions, RotationAlignment
from .preprocessing import ROUNDING_LIMIT, check_noise, crop, noise_deviation, reduce_to_width, resize
from .profiles import best_shift, profile_turn, vertical_shift
from .structure import StructureHeading

__all__ = ["BLIND", "Observed", "SelfMotion", "VisualOdometry", "best_shift", "profile_turn", "vertical_shift"]

# the most observed speeds kept for eq. R6 (a near floor's reach is about 17 frames at 1 m/s and 10 Hz; a robot
# creeping slower than that keeps the last 64, 6.4 s)
_READINGS = 64
# eq. R8: how many observed speeds are remembered with their turn rates (a minute of frames at 10 a second:
# long enough to hold the straights and the turns of several corners, short enough to follow a new speed)
_TURN_READINGS = 600


def _finite_speed(forward_speed: float) -> float:
    """``forward_speed`` as a float, m/s; :class:`InvalidInputError` naming it where it is not a finite number."""
    try:
        speed = float(forward_speed)
    except (TypeError, ValueError):
        speed = math.nan
    if not math.isfinite(speed):
        raise InvalidInputError("forward_speed", repr(forward_speed), "must be a finite number (m/s)")
    return speed


class VisualOdometry(CueSelectionMixin):
    """Self-motion from consecutive grey images.

    Args:
        config: odometry parameters (Table 9).
        horizontal_fov, vertical_fov: the camera's fields of view, rad.
        panoramic: columns wrap around.

    Attributes:
        pitch: the current pitch estimate, rad (nose up positive).
        surface_speed: the last :meth:`step`'s speed along the surface driven on, m/s. With
            ``height_model = "transitions"`` the step's ``forward_speed`` is its horizontal part,
            ``surface_speed`` × cos(pitch) (eq. R7); with ``"profile"`` the two are equal (the paper's model
            integrates the distance as horizontal, and its pitch is calibrated for the climb, not measured).
        lines: with ``planar_motion = "ground"`` and ``manhattan``, the
            :class:`~.structure.StructureHeading` that turns the heading towards the floor's and the ceiling's
            straight lines (eq. M3); None otherwise.
        transitions: with ``height_model = "transitions"``, the :class:`~.pitch.LevelTransitions` that hold the
            pitch between ramps' feet and tops (eq. R3); None otherwise.
    """

    def __init__(self, config: VisualOdometryConfig = VisualOdometryConfig(), *,
                 horizontal_fov: float = math.radians(80), vertical_fov: float = math.radians(64),
                 panoramic: bool = False):
        config.validate("odometry")
        self.config = config
        self.horizontal_fov = horizontal_fov
        self.vertical_fov = vertical_fov
        self.panoramic = panoramic
        self.pitch = 0.0
        self.surface_speed = 0.0
        self._previous: dict[str, np.ndarray] | None = None
        # the last two frames' column profiles (NeuroSLAM eqs. 27–29), for the yaw where nothing else sees it
        self._rotation_profiles: tuple[np.ndarray, np.ndarray] | None = None
        self._equal_angle: dict[int, tuple[np.ndarray, float, np.ndarray | None]] = {}
        self._angle_per_sample = 0.0
        # each profile sample's bearing from the optical axis (rad; None for a panorama), for eq. R9
        self._profile_bearings: np.ndarray | None = None
        self._ground = None
        if config.planar_motion == "ground":
            if panoramic:
                raise InvalidParameterError("odometry.planar_motion", config.planar_motion,
                                            "needs a pinhole camera; use 'profile' for a panorama")
            self._ground = GroundMotion(horizontal_fov=horizontal_fov, camera_height=config.camera_height,
                                        camera_forward=config.camera_forward, near_row=config.near_floor_row,
                                        half_width=config.floor_half_width, aperture=config.floor_aperture,
                                        min_information=config.floor_min_information,
                                        slope_half_width=config.slope_half_width,
                                        slope_near_floor=config.slope_near_floor and config.near_floor_row > 0,
                                        shared_information=config.floor_shared_information is True)
        self._alignment = self.transitions = None
        self._speed = 0.0  # m/s, the last speed measured off a transition (held across one)
        # where nothing observes the distance, this speed is held (odometry.blind_hold)
        self._held_speed = 0.0  # m/s, the last observed speed
        self._blind_for = math.inf  # s since the distance was last observed (inf: never)
        self._unobserved = 0  # frames since the distance was last observed (off transitions)
        # eq. R6: the speeds observed over the last near floor's reach, (m travelled, m/s) each, oldest first
        self._readings: deque[tuple[float, float]] = deque(maxlen=_READINGS)
        self._travelled = 0.0  # m, the distance taken so far (each frame's, unsigned)
        # eq. R8: (turn rate averaged over the last second, rad/s; speed, m/s) at the last _TURN_READINGS observed
        # frames, a ring (reading k in row k % _TURN_READINGS; the median ignores the order), how many were
        # ever taken, and the last second's (dt s, |yaw rate| rad/s) that average the current turn rate
        self._turn_readings = np.zeros((_TURN_READINGS, 2))
        self._turn_count = 0
        self._recent_turns: deque[tuple[float, float]] = deque()
        # eq. R10: the last second's (dt s, yaw rate rad/s) of frames whose yaw was observed, and the seconds
        # since the yaw was last observed (inf: never)
        self._observed_turns: deque[tuple[float, float]] = deque()
        self._yaw_blind_for = math.inf
        self._bending = False  # whether the frame before was in a transition that held a speed
        # the metric scale of the upper image's expansion (m per unit), learnt where the floor sees the
        # distance: running sums of d e and e² (eq. S1, :meth:`_observed_motion`)
        self._scale_sums = np.zeros(3)
        # the ceiling's height above the camera (m), learnt the same way from its distance in units of that
        # height (eq. S1 with the ceiling's d / H instead of e)
        self._ceiling_sums = np.zeros(3)
        self._ceiling_countdown = 0
        self._ceiling = None
        if self._ground is not None and config.height_model == "transitions":
            self._ceiling = GroundMotion(horizontal_fov=horizontal_fov, camera_height=1.0,
                                         camera_forward=config.camera_forward, surface="ceiling",
                                         min_information=config.floor_min_information, aperture=config.floor_aperture,
                                         shared_information=config.floor_shared_information is True)
        self._finest: np.ndarray | None = None  # the last image blurred, with gradients (eqs. R1–R2)
        # eqs. M1–M3: the heading against the floor's and the ceiling's straight lines
        self.lines = (StructureHeading(horizontal_fov=horizontal_fov, strength=config.manhattan_strength,
                                       spread=config.manhattan_spread, window=config.manhattan_window,
                                       first_row=config.manhattan_first_row,
                                       rate=config.manhattan_rate)
                      if self._ground is not None and config.manhattan else None)
        if config.height_model == "transitions":
            if panoramic:
                raise InvalidParameterError("odometry.height_model", config.height_model,
                                            "needs a pinhole camera; use 'profile' for a panorama")
            region = config.height_region
            self._alignment = RotationAlignment(horizontal_fov=horizontal_fov,
                                                region=(region.top, region.bottom, region.left, region.right))
            self.transitions = LevelTransitions(transition_rate=config.transition_rate,
                                                 transition_min=config.transition_min, max_slope=config.max_slope,
                                                 level_snap=config.level_snap)

    def state_dict(self) -> dict[str, np.ndarray]:
        """The integrated pitch and the previous frame's profiles (and floor pyramid), for saving."""
        state = {"pitch": np.float64(self.pitch)}
        for name, profile in (self._previous or {}).items():
            state[f"previous.{name}"] = profile.copy()
        if self._ground is not None:
            state.update({f"ground.{key}": value for key, value in self._ground.state_dict().items()})
        if self.lines is not None:
            state.update({f"lines.{key}": value for key, value in self.lines.state_dict().items()})
        if self.transitions is not None:
            if self._ground is None and self._finest is not None:
                state["transitions.previous"] = self._finest.copy()
            state.update({"transitions.pitch": np.float64(self.transitions.pitch),
                          "transitions.run": np.float64(self.transitions.run),
                          "transitions.seen": np.bool_(self.transitions.seen),
                          "transitions.speed": np.float64(self._speed),
                          "transitions.yaw": np.float64(self._alignment.yaw),
                          "observed.held_speed": np.float64(self._held_speed),
                          "observed.blind_for": np.float64(self._blind_for),
                          "observed.unobserved": np.int64(self._unobserved),
                          "observed.scale_sums": self._scale_sums.copy(),
                          "observed.ceiling_sums": self._ceiling_sums.copy(),
                          "observed.ceiling_countdown": np.int64(self._ceiling_countdown),
                          "observed.readings": np.array(self._readings, dtype=float).reshape(-1, 2),
                          "observed.travelled": np.float64(self._travelled),
                          "observed.turn_readings": self._turn_readings_in_order(),
                          "observed.recent_turns": np.array(self._recent_turns, dtype=float).reshape(-1, 2),
                          "observed.observed_turns": np.array(self._observed_turns, dtype=float).reshape(-1, 2),
                          "observed.yaw_blind_for": np.float64(self._yaw_blind_for),
                          "observed.bending": np.bool_(self._bending)})
        return state

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it does not fit this configuration."""
        names = ("rotation", "translation", "height")
        present = [f"previous.{name}" in state for name in names]
        if any(present) and not all(present):
            raise ValueError("the previous frame's profiles are incomplete")
        has_ground = any(key.startswith("ground.") for key in state)
        if has_ground != (self._ground is not None):
            raise ValueError("the floor-alignment state does not match odometry.planar_motion")
        has_transitions = any(key.startswith("transitions.") for key in state)
        if has_transitions and self.transitions is None:
            raise ValueError("the transition state does not match odometry.height_model")
        if self._ground is not None:
            self._ground.load_state_dict({key[7:]: value for key, value in state.items() if key.startswith("ground.")})
        if self.lines is not None and "lines.heading" in state:  # a map saved before eq. M3 starts it afresh
            self.lines.load_state_dict({key[6:]: value for key, value in state.items() if key.startswith("lines.")})
        if self.transitions is not None:  # a map saved before height_model existed starts them afresh
            self.transitions.pitch = float(state.get("transitions.pitch", 0.0))
            self.transitions.run = float(state.get("transitions.run", 0.0))
            self.transitions.seen = bool(state.get("transitions.seen", self.transitions.run != 0.0))
            self._speed = float(state.get("transitions.speed", 0.0))
            self._alignment.yaw = float(state.get("transitions.yaw", 0.0))
            # a map saved before the odometry reported what it observed starts blind, with no scale
            self._held_speed = float(state.get("observed.held_speed", 0.0))
            self._blind_for = float(state.get("observed.blind_for", math.inf))
            self._unobserved = int(state.get("observed.unobserved", 0))
            self._scale_sums = np.asarray(state.get("observed.scale_sums", np.zeros(3)), dtype=float).copy()
            self._ceiling_sums = np.asarray(state.get("observed.ceiling_sums", np.zeros(3)), dtype=float).copy()
            self._ceiling_countdown = int(state.get("observed.ceiling_countdown", 0))
            readings = np.asarray(state.get("observed.readings", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
            self._readings = deque(((float(a), float(b)) for a, b in readings), maxlen=_READINGS)
            self._travelled = float(state.get("observed.travelled", 0.0))
            turns = np.asarray(state.get("observed.turn_readings", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
            turns = turns[-_TURN_READINGS:]
            self._turn_readings = np.zeros((_TURN_READINGS, 2))
            self._turn_readings[:len(turns)] = turns
            self._turn_count = len(turns)
            recent = np.asarray(state.get("observed.recent_turns", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
            self._recent_turns = deque((float(a), float(b)) for a, b in recent)
            observed = np.asarray(state.get("observed.observed_turns", np.zeros((0, 2))), dtype=float).reshape(-1, 2)
            self._observed_turns = deque((float(a), float(b)) for a, b in observed)
            self._yaw_blind_for = float(state.get("observed.yaw_blind_for", math.inf))
            self._bending = bool(state.get("observed.bending", False))
            if self._ground is not None:
                self._finest = self._ground.finest
            else:
                previous = state.get("transitions.previous")
                self._finest = None if previous is None else np.asarray(previous, dtype=np.float32).copy()
        self.pitch = float(state["pitch"])
        self._previous = ({name: np.asarray(state[f"previous.{name}"]).copy() for name in names}
                          if all(present) else None)

    def _turn_readings_in_order(self) -> np.ndarray:
        """Eq. R8's readings, (n, 2), oldest first (the ring unrolled), for saving."""
        count = min(self._turn_count, _TURN_READINGS)
        start = self._turn_count % _TURN_READINGS if self._turn_count > _TURN_READINGS else 0
        return np.roll(self._turn_readings, -start, axis=0)[:count].copy()

    def _equal_angle_columns(self, image_width: int) -> tuple[np.ndarray, float, np.ndarray | None]:
        """Where to sample the rotation region's column profile so that its columns are equally spaced in
        angle (a cylindrical profile, in which a rotation is a uniform shift even for a pinhole camera),
        the angle per sample, and each sample's bearing from the optical axis (rad; None for a panorama, eq.
        R9). Cached per image width."""
        cached = self._equal_angle.get(image_width)
        if cached is not None:
            return cached
        region = self.config.rotation_region
        width = self.config.profile_width
        left, right = round(region.left * image_width), max(round(region.right * image_width), 1)
        if self.panoramic:
            positions = (np.arange(width) + 0.5) * (right - left) / width - 0.5
            result = (positions, 2 * math.pi * (right - left) / image_width / width, None)
        else:
            focal = (image_width / 2) / math.tan(self.horizontal_fov / 2)  # pixels
            first = math.atan((left - image_width / 2) / focal)
            last = math.atan((right - image_width / 2) / focal)
            angles = first + (np.arange(width) + 0.5) * (last - first) / width
            positions = focal * np.tan(angles) + image_width / 2 - 0.5 - left
            result = (positions, (last - first) / width, angles)
        self._equal_angle[image_width] = result
        return result

    @property
    def image_stack(self) -> np.ndarray | None:
        """The last image as the direct alignments read it: (3, rows, columns) float32, the grey image
        blurred and its horizontal and vertical gradients (per pixel), at the working width; None before the
        first frame or without the ``transitions`` height model. A view, not a copy: what eqs. R1–R2 and
        M1–M2 (:meth:`~neuroslam.vision.structure.StructureHeading.correct`) take."""
        return self._finest

    @property
    def _max_columns(self) -> int:
        """The largest shift of the column profile searched by NeuroSLAM eq. 28, samples."""
        return max(1, int(round(self.config.max_column_shift * self.config.profile_width)))

    def _profiles(self, grey_image: np.ndarray) -> dict[str, np.ndarray]:
        width = self.config.profile_width
        rotation = crop(grey_image, self.config.rotation_region)
        translation = crop(grey_image, self.config.translation_region)
        height = crop(grey_image, self.config.height_region)
        positions, self._angle_per_sample, self._profile_bearings = self._equal_angle_columns(grey_image.shape[1])
        columns = rotation.mean(axis=0)
        return {
            "rotation": np.interp(positions, np.arange(len(columns)), columns).astype(np.float32),
            "translation": resize(translation, (1, width))[0],
            "height": resize(height, (max(4, height.shape[0] // 2), max(8, width // 2))),
        }

    def step(self, grey_image: np.ndarray, dt: float, *, noise: float | None = None) -> SelfMotion:
        """Self-motion since the previous image (zero for the first), for images ``dt`` seconds apart.

        ``noise``: the image's noise deviation (eq. V2, :func:`~.preprocessing.noise_deviation`, in the image's
        units) where the caller has it already; otherwise it is estimated where ``floor_shared_information`` is
        ``"noisy"``.

        Raises :class:`~neuroslam.errors.InvalidInputError` for a ``noise`` that is not a finite number >= 0
        (nothing is changed)."""
        motion = self._step(grey_image, dt, check_noise(noise))
        if self.lines is None or dt <= 0 or self._finest is None:
            return motion
        yaw_change = self.lines.correct(self._finest, motion.yaw_rate * dt, dt)  # eq. M3
        return SelfMotion(motion.forward_speed, yaw_change / dt, motion.climb_rate, motion.observed)

    def _step(self, grey_image: np.ndarray, dt: float, noise: float | None = None) -> SelfMotion:
        """:meth:`step` before eq. M3."""
        profiles = self._profiles(grey_image)
        previous, self._previous = self._previous, profiles
        self._ceiling_previous = None if self._ground is None else self._ground.pyramid
        if self._ground is not None:  # eq. G3a: eq. G3's prior on the distance loosens while nothing observes it
            self._ground.distance_certainty = 1.0 / (1 + self._unobserved)
        working = reduce_to_width(grey_image, self.config.working_width)  # the direct alignments' image
        if self._ground is not None and self.transitions is not None:  # eq. G7: on a slope, the near floor's lane
            self._ground.on_slope = abs(self.transitions.pitch) >= self.config.transition_min
        if self._ground is not None and self.config.floor_shared_information == "noisy":
            # eq. G8 on the frames whose image has sensor noise (eq. V2 above half a grey level)
            noisy = (noise_deviation(grey_image) if noise is None else noise) > ROUNDING_LIMIT
            self._ground.shared_information = noisy
            if self._ceiling is not None:
                self._ceiling.shared_information = noisy
        ground = None if self._ground is None else self._ground.step(working)
        finest_before = self._finest
        if self._alignment is not None:
            self._finest = self._ground.finest if ground is not None else blurred_with_gradients(working, 1.0)
        if previous is None or dt <= 0:
            self.surface_speed = 0.0
            return SelfMotion(0.0, 0.0, 0.0)
        config = self.config
        width = config.profile_width
        column_shift = 0.0
        self._rotation_profiles = (previous["rotation"], profiles["rotation"])  # for the yaw of last resort
        if ground is None or self.transitions is None:
            # NeuroSLAM eqs. 27–29; the profile shift also aligns the height region (NeuroSLAM eqs. 31–32)
            column_shift, _ = best_shift(previous["rotation"], profiles["rotation"], self._max_columns,
                                         circular=self.panoramic)
        if ground is not None:  # eqs. G1–G3 instead of NeuroSLAM eqs. 27–30 for the planar motion
            ground_distance, ground_turn = ground
            distance = float(np.clip(config.speed_scale * ground_distance, -config.max_speed * dt,
                                     config.max_speed * dt))
            yaw_change = float(np.clip(config.yaw_scale * ground_turn, -config.max_yaw_rate * dt,
                                       config.max_yaw_rate * dt))
        else:
            yaw_change = config.yaw_scale * column_shift * self._angle_per_sample
            yaw_change = float(np.clip(yaw_change, -config.max_yaw_rate * dt, config.max_yaw_rate * dt))
            # NeuroSLAM eq. 30: profile difference at the rotation's shift
            whole = int(round(column_shift))
            a, b = previous["translation"], profiles["translation"]
            if self.panoramic:
                difference = float(np.abs(np.roll(b, -whole) - a).mean())
            else:
                overlap_new = b[max(whole, 0): width + min(whole, 0)]
                overlap_old = a[max(-whole, 0): width + min(-whole, 0)]
                difference = float(np.abs(overlap_new - overlap_old).mean())
            distance = min(config.speed_scale * difference, config.max_speed * dt)
        if self.transitions is not None:
            return self._height_from_transitions(finest_before, distance, yaw_change, dt)

        # NeuroSLAM eqs. 31–32: the region over the columns both frames share after the yaw shift
        old, new = previous["height"], profiles["height"]
        columns = old.shape[1]
        half = int(round(column_shift * columns / width))
        if self.panoramic:
            new = np.roll(new, -half, axis=1)
        elif half:
            new = new[:, max(half, 0): columns + min(half, 0)]
            old = old[:, max(-half, 0): columns + min(-half, 0)]
        rows = old.shape[0]
        max_rows = max(1, int(round(config.max_row_shift * rows)))
        row_shift = vertical_shift(old, new, max_rows)
        # a pinhole camera's rows near the centre each span 1 / focal length radians
        fraction = config.height_region.bottom - config.height_region.top
        pitch_change = row_shift * 2 * math.tan(self.vertical_fov / 2) * fraction / rows
        pitch_change -= config.pitch_flow_bias * distance
        self.pitch = (self.pitch + pitch_change) * math.exp(-config.pitch_leak * dt)
        climb = config.climb_scale * distance * math.sin(self.pitch)
        climb = float(np.clip(climb, -config.max_climb_rate * dt, config.max_climb_rate * dt))
        self.surface_speed = distance / dt
        return SelfMotion(distance / dt, yaw_change / dt, climb / dt)

    def climb_rate_at(self, forward_speed: float) -> float:
        """The climb rate, m/s, at a forward speed another sensor measured (m/s; wheel encoders measure the
        travel along the surface, so on a ramp it is the speed along it), on the pitch the last :meth:`step`
        estimated: speed × sin(pitch) (times ``climb_scale`` with ``height_model = "profile"``, whose pitch
        that calibrates), within ± ``max_climb_rate``. Call it after :meth:`step` for the same frame.

        The camera's own distance is blind where a ramp's surface is blank (measured on generator-2 worlds:
        read at a few per cent of the truth for tens of metres of a ramp, so the height stopped climbing while
        the pitch was right); where the wheels measure the speed, theirs is the one to climb with.

        Raises:
            InvalidInputError: ``forward_speed`` is not a finite number (nothing is changed).
        """
        speed = _finite_speed(forward_speed)
        config = self.config
        gain = config.climb_scale if config.height_model == "profile" else 1.0
        return float(np.clip(gain * speed * math.sin(self.pitch), -config.max_climb_rate, config.max_climb_rate))

    def horizontal_speed_at(self, forward_speed: float) -> float:
        """The horizontal part, m/s, of a speed along the surface another sensor measured (m/s; wheel
        encoders'), on the pitch the last :meth:`step` estimated: speed × cos(pitch) with
        ``height_model = "transitions"`` (eq. R7; on a 10° ramp 1.5 % less than the speed), the speed itself with
        ``"profile"`` (see :attr:`surface_speed`). Call it after :meth:`step` for the same frame, beside
        :meth:`climb_rate_at`.

        Raises:
            InvalidInputError: ``forward_speed`` is not a finite number (nothing is changed).
        """
        speed = _finite_speed(forward_speed)
        return speed if self.config.height_model == "profile" else speed * math.cos(self.pitch)

    def _height_from_transitions(self, finest_before: np.ndarray | None, distance: float, yaw_change: float,
                                 dt: float) -> SelfMotion:
        """The frame's motion with ``height_model = "transitions"``: the pitch by eqs. R1–R3; on a transition
        frame the aligned yaw and the last speed measured off one replace the planar estimates; elsewhere,
        with ``planar_motion = "ground"``, each degree of freedom from the cue that observes it
        (:meth:`_observed_motion`)."""
        config = self.config
        observed = None
        if finest_before is not None:
            aligned_yaw, pitch_change = self._alignment.step(finest_before, self._finest, yaw_change)
            pixels = max(self._alignment.pixels, 1)
            image_sees_yaw = self._alignment.information[0] / pixels >= config.min_image_information
            pitch_seen = self._alignment.information[1] / pixels >= config.min_image_information
            # a transition commits only where a frame of it sees the pitch (eq. R3's consistent evidence); until
            # one does, its frames' motion is read as elsewhere
            in_transition = self.transitions.step(pitch_change, dt, seen=pitch_seen or self._ground is None)
            if in_transition and self.transitions.seen:
                if self._ground is not None and not self._bending:  # the transition's first held frame: eq. R6
                    self._speed = self._held_speed = self._speed_before_bend(self.transitions.run)
                self._bending = True
                distance = self._speed * dt
                yaw_change = float(np.clip(aligned_yaw, -config.max_yaw_rate * dt, config.max_yaw_rate * dt))
                if self._ground is not None:
                    observed = Observed("held", "image", "image")
            else:
                self._bending = False
                if self._ground is not None:
                    distance, yaw_change, observed = self._observed_motion(distance, yaw_change, aligned_yaw,
                                                                           image_sees_yaw, pitch_seen, dt)
                self._speed = distance / dt
        self._travelled += abs(distance)
        self.pitch = self.transitions.current
        self.surface_speed = distance / dt
        # the distance is along the surface driven on (the floor's alignment reads it in the floor's plane, a held
        # speed was read so): on a slope of pitch θ its horizontal part is d cos θ and its climb d sin θ (eq. R7)
        climb = float(np.clip(distance * math.sin(self.pitch), -config.max_climb_rate * dt, config.max_climb_rate * dt))
        return SelfMotion(distance * math.cos(self.pitch) / dt, yaw_change / dt, climb / dt, observed)
