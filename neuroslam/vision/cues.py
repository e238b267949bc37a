"""Which cue observes each degree of freedom of a frame's motion, and the scales carried between cues.

:class:`CueSelectionMixin` is the part of :class:`~neuroslam.vision.odometry.VisualOdometry` that takes each
degree of freedom from the cue that observes it on this frame (the floor, the ceiling, the whole image's
alignment, the column profile), carries the metric scale from where the floor last gave it (eq. S1), holds
a speed where nothing observes the distance (the one observed at the same turn rate, eq. R8), for a bounded
time after the image last showed the robot moving, and marks the frame blind in what nothing observed
(:class:`~neuroslam.vision.motion.Observed`).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from .motion import Observed
from .profiles import profile_turn

__all__ = ["CueSelectionMixin"]

_NOMINAL_CEILING = 2.0  # m above the camera: where the ceiling's first alignment starts (a 2.5 m room)
# where the floor sees the distance, the ceiling's height is learnt on every fifth frame: it changes over
# seconds, not frames (twice a second at 10 Hz: 20 readings within scale_memory), at a fifth of the cost
_CEILING_EVERY = 5
# the floor's information on the distance (in the prior's weights) from which it outweighs the prior
_FIRM_FLOOR = 1.0
# a cue's scale is carried only where its readings were proportional to the floor's distances within this
# (the relative RMS misfit of eq. S1, which holds the floor's own frame-to-frame error too): a ceiling is a
# plane, facades and open sky are not. Measured: a flat ceiling over textured or sparsely tiled floors in
# the synthetic scenes of tests/scenes.py 0.01–0.26, the building's ceilings over its corridors 0.16–0.42,
# urban's facades and sky 0.43–0.69 (10th–90th percentiles)
_SCALE_MISFIT = 0.2
# eq. R8: the turn rate is averaged over this many seconds (the frame's own yaw is noisy), and a speed is
# taken from at least this many observed frames at about that turn rate (a second's at 10 frames a second)
_TURN_AVERAGE = 1.0
_TURN_MINIMUM = 10


def _scale(sums: np.ndarray) -> float:
    """Eq. S1's scale from its running sums (Σ d c, Σ c², Σ d²), or 0 where there is none or the readings c
    were not proportional to the distances d: relative misfit sqrt(1 - (Σ d c)² / (Σ c² Σ d²)) above
    :data:`_SCALE_MISFIT`."""
    products, readings, distances = sums
    if readings <= 0 or distances <= 0:
        return 0.0
    misfit = math.sqrt(max(0.0, 1.0 - products**2 / (readings * distances)))
    return products / readings if misfit <= _SCALE_MISFIT else 0.0


def _last_second(recent: deque[tuple[float, float]], dt: float, rate: float) -> float:
    """Append (``dt`` s, ``rate``) to ``recent``, drop what lies more than :data:`_TURN_AVERAGE` seconds back
    (keeping at least one entry), and return the time-weighted mean rate of what remains."""
    recent.append((dt, rate))
    span = sum(duration for duration, _ in recent)
    while len(recent) > 1 and span - recent[0][0] >= _TURN_AVERAGE:
        span -= recent.popleft()[0]
    return sum(duration * value for duration, value in recent) / span


class CueSelectionMixin:
    """The cue selection of the visual odometry (see the module); mixed into
    :class:`~neuroslam.vision.odometry.VisualOdometry`, whose state it reads and updates."""

    def _speed_before_bend(self, bend: float) -> float:
        """The speed a transition holds (m/s), from the speeds observed over the near floor's reach before it
        (eq. R6); ``bend`` is the transition's pitch change so far (rad, nose up positive).

        Before a ramp's top or foot the floor ahead is not one plane with the floor below the robot, and the
        ground-plane model (eq. G1) misplaces it: where the floor bends down (a descent's top, a climb's top)
        the pixels beyond the bend lie farther than the model puts them, their motion is less than a metre
        of travel moves a point at the modelled depth, and the distance reads short; where it bends up (a
        climb's foot, a descent's foot), nearer, and it reads long. The floor's information on the distance
        lies mostly in its near rows (a floor point's image motion per metre falls as 1 / depth²), so the
        readings bend as the bend comes within the near floor's reach (eq. G4's rows; without them, the
        floor's first row): about 1.7 m of travel before the transition at the testbed's camera, measured on
        a generated world's descent as 9 frames at 1 m/s, from 0.99 of the true speed to 0.57. The speeds
        observed over that reach are partly bent one way, and the rest are the speed itself; the held speed
        is the middle of the half the bend cannot have pulled its way, the upper quartile before a bend down
        and the lower quartile before a bend up:

            v_hold = Q_3/4 { v_k : s_k >= s - r }  if bend < 0,   Q_1/4 { ... }  if bend > 0              (R6)

        (s_k: the distance travelled at reading k, s: now, r: the near floor's reach from the turning axis).
        Without readings in that reach, or where the robot was reversing, the last speed stands."""
        config, ground = self.config, self._ground
        row = ground.near_row if ground.near_row > 0 else ground.first_row
        reach = config.camera_forward + config.camera_height / (row * math.tan(self.vertical_fov / 2))
        speeds = np.array([speed for travelled, speed in self._readings if travelled >= self._travelled - reach])
        if len(speeds) == 0 or speeds.min() < 0 or bend == 0:
            return self._speed
        return float(np.quantile(speeds, 0.75 if bend < 0 else 0.25))

    def _turn_rate(self, yaw_change: float, dt: float) -> float:
        """The turn rate |yaw rate| (rad/s) averaged over the last :data:`_TURN_AVERAGE` seconds, this frame's
        yaw change (rad, over ``dt`` s) included."""
        return _last_second(self._recent_turns, dt, abs(yaw_change) / dt)

    def _held_turn(self, yaw: float | None, dt: float) -> tuple[float | None, bool]:
        """The frame's yaw change (rad, over ``dt`` s): ``yaw`` where a cue observed it (and it joins the last
        second's observed turns), else the held turn (eq. R10) while ``yaw_hold`` allows, else None; and
        whether it was held.

        A robot that was turning when the camera went blind in yaw (a turn close to a blank wall, whose image
        has nothing that moves but the wall's foot and a corner) goes on turning, as a driving one goes on
        driving (eq. R8 holds its speed): the turn rate held is the mean of the observed yaw rates over the
        last :data:`_TURN_AVERAGE` seconds of frames whose yaw was observed, signed,

            w_hold = sum_k dt_k w_k / sum_k dt_k                                                      (R10)

        for at most ``yaw_hold`` seconds after the yaw was last observed. Without it such a turn is lost
        whole: a recorded two-lap drive of gen3:130 lost 201° on 47 frames of two blind turns, more than its
        13,700 other frames' heading errors together (``benchmarks/yaw_sources.py``)."""
        if self.config.yaw_hold <= 0:  # off: nothing to keep
            return yaw, False
        if yaw is not None:
            _last_second(self._observed_turns, dt, yaw / dt)
            self._yaw_blind_for = 0.0
            return yaw, False
        self._yaw_blind_for += dt
        if self._yaw_blind_for > self.config.yaw_hold or not self._observed_turns:
            return None, False
        span = sum(duration for duration, _ in self._observed_turns)
        return sum(duration * rate for duration, rate in self._observed_turns) / span * dt, True

    def _faint_image_yaw(self) -> float | None:
        """The whole image's yaw change (rad; eq. R5) on a frame whose image has too little information on the yaw
        to see it (below ``min_image_information``), where it stands out from the yaws around it by at least
        ``faint_yaw_contrast`` (eq. R11); else None, and None with the option off (0).

        The information per pixel measures how much an image could say about the yaw, not whether it does: it
        counts sensor noise as structure, so it is set well above noise, and a frame whose only structure is a
        corner, a poster and a wall's foot beside a blank wall falls below it. Such frames gave the column
        profile's yaw (NeuroSLAM eqs. 27–29) or none. The profile mistakes a slanted edge moving up or down the
        image for a turn, and the expansion of what lies to one side; eq. R5 fits both (its pitch, its expansion
        per column block). Over the profile's and the no-yaw frames of seven recorded drives of the benchmark's
        largely blind worlds, eq. R5's yaw where eq. R11 reached 1.5 was nearer the truth (summed absolute error
        2,024° → 1,197°), and it read the turns nobody had seen (gen3:130: 201° lost on 47 frames, eq. R5 4°
        off). Off by default: on the camera benchmark it left false closures on two worlds
        (docs/generalization.md, the thirty-third step)."""
        if self.config.faint_yaw_contrast <= 0:
            return None
        column_yaw, _ = self._alignment.column_yaw()
        return column_yaw if self._alignment.column_yaw_contrast() >= self.config.faint_yaw_contrast else None

    def _blind_speed(self, turn_rate: float) -> float:
        """The speed (m/s) held where nothing observes the distance (eq. R8), at the averaged turn rate
        ``turn_rate`` (rad/s).

        The last observed speed is a poor guess for a long blind stretch: a robot slows for a corner and speeds
        up after it, and a floor often turns blank at a corner (a wall's end, a change of room), so the last
        speed a floor read is the corner's, held for the whole straight after it (measured on a recorded two-lap
        drive of gen3:136: four blind straights of 34–37 m driven at 1 m/s read 8–12 m, the speed held 0.22–0.31
        m/s, read short by the floor's last frames as the robot slowed for the corner). The camera still
        sees the turn where it does not see the distance (the whole image's yaw, eq. R2 and R5), and a robot's
        speed follows how fast it turns. The speed held is the median of the speeds observed at about the same
        averaged turn rate among the last :data:`_TURN_READINGS` observed frames:

            v_hold = median { v_k : |w_k - w| <= b }                                                 (R8)

        (w_k, w: the turn rate averaged over the last second at reading k and now, b: ``blind_turn_band``).
        With fewer than :data:`_TURN_MINIMUM` such readings, with ``blind_turn_band`` 0, or where the last
        observed speed was not forward, the last observed speed stands.

        It models a robot whose speed follows its turning (a driver that slows for corners, as the testbed's
        does). Keeping the last speed where the turn rate is still the one it was observed at loses most of
        the gain (on gen3:136 the floor went blank while the robot, still straight, slowed for the corner).
        A robot whose speed is set otherwise (a learnt policy's commands) holds its typical speed at that turn
        rate over the last minute, not its last one; its wheels are the better source of the distance."""
        band, last = self.config.blind_turn_band, self._held_speed
        count = min(self._turn_count, len(self._turn_readings))
        if band <= 0 or last <= 0 or count < _TURN_MINIMUM:
            return last
        readings = self._turn_readings[:count]
        near = readings[np.abs(readings[:, 0] - turn_rate) <= band, 1]
        return float(np.median(near)) if len(near) >= _TURN_MINIMUM else last

    def _image_direction_speed(self, direction: int) -> float | None:
        """The speed (m/s) to hold in the direction ``direction`` (+1 forward, -1 backward) the whole image
        shows (eq. R12); None where fewer than :data:`_TURN_MINIMUM` of the last observed speeds went that way.

        A held speed is a single observed speed carried on (eq. R8 falls back to the last one), and one
        wrong minimum of the floor's alignment can make it backward: at a ramp's top, where the floor is not
        one plane, gen3:133's floor read -1.18 and -0.62 m/s on two frames, and -0.62 m/s was then held
        over 20 s of blank deck while the image's expansion (eq. R4) showed the robot driving forward (t = +7
        to +108): the odometry drove 21 m backwards. The image gives the motion's sign, not its size; the
        observed speeds give its size. Where the image shows the motion with significance
        (|t| >= ``forward_evidence``) against the sign of the speed held (or the speed held is 0), the speed
        held becomes the median of the last observed speeds that went the image's way,

            v_last = median { v_k : sign(v_k) = sign(t) }                                             (R12)

        and eq. R8 then holds the speed observed at the turn rate where it has enough readings, this where it
        has not.

        A single frame's expansion is not trusted alone against the observed speeds: with fewer than
        :data:`_TURN_MINIMUM` observed speeds the image's way (a robot that has not been seen to drive so,
        or a turn's expansion read the wrong way: t = -12 to -18 at gen3:133's blank corners driven
        forward), the speed held stands, and only the hold's clock runs (``blind_hold``). An option,
        ``odometry.held_direction``, off by default (docs/generalization.md, the forty-first step)."""
        count = min(self._turn_count, len(self._turn_readings))
        speeds = self._turn_readings[:count, 1]
        same_way = speeds[speeds * direction > 0]
        return float(np.median(same_way)) if len(same_way) >= _TURN_MINIMUM else None

    def _observed_motion(self, floor_distance: float, floor_yaw: float, aligned_yaw: float, image_sees_yaw: bool,
                         pitch_seen: bool, dt: float) -> tuple[float, float, Observed]:
        """Distance and yaw change of a frame off a transition, each from the cue that observes it.

        - Yaw: the floor's (eqs. G3–G4) where the floor has marks (it sees the distance: a floor showing only
          lines along the path, or only its edges against the walls, sees the yaw through them, and walls
          standing close take part in it with a bias, see :mod:`.ground_motion`) and the whole image's yaw
          (eq. R2) agrees with it within ``floor_yaw_tolerance`` (else the floor's solution, distance and yaw,
          is a wrong minimum and is not used); else the whole image's (walls, ceiling) where it sees the yaw
          (eq. R2's information), solved again with one expansion per column block (eq. R5 of :mod:`.pitch`: a
          wall's depth changes across the image, which one expansion leaves to the yaw); else the shift of the
          whole image's column profile (NeuroSLAM eqs. 27–29) where one shift stands out (:func:`profile_turn`:
          eq. R2 weighs the information per pixel, and a thin band of distant structure along an open horizon
          has too little of it, yet fits one shift only); else none.
        - Distance, in this order: the floor's where it sees it (with ``floor_half_width``, eq. G5's lane beside
          the path; where the lane does not see it firmly, the whole floor's, whose walls' feet lie on the floor
          plane, its distance alone: :meth:`~.ground_motion.GroundMotion.whole_floor_distance`); the ceiling's
          (eqs. G1–G3 on the image above the horizon, a plane H above the camera: it gives d / H) times the
          ceiling height the floor last gave it (off slopes only, unless ``odometry.ceiling_on_slopes``: a level
          ceiling over a ramp is not parallel to its floor); the expansion e of the upper image (walls, ceiling, eq. R1)
          times the scale the floor last gave it, where the image sees the motion; else held.

        The scale of each, H or s (metres of travel per unit: the ceiling's height above the camera, or about
        the mean depth of what is seen above the horizon), is the least-squares ratio of the floor's distances
        d to that cue's reading c over the frames where both see it, each weighted by exp(-age / scale_memory):

            s = sum_k lambda_k d_k c_k / sum_k lambda_k c_k^2                                        (S1)

        A ceiling's height is the same along a level, and usually from level to level: it carries the scale
        over a blank floor; the upper image's depth changes with where the robot is, so the expansion is the
        last resort before holding. Where nothing observes the distance, a speed is held (the one observed at
        about the same turn rate, eq. R8 of :meth:`_blind_speed`) for ``blind_hold`` seconds after the image
        last showed the robot moving that way (its expansion's t-statistic, eq. R4 of :mod:`.pitch`, at least
        ``forward_evidence``: a scale-free sign of forward motion), then it is 0; where nothing observes the
        yaw, there is no turn; the frame is marked blind in it (:class:`Observed`). The floor's prior for the
        next frame (eq. G3's (d0, w0)) becomes what was taken, so a blank floor does not carry a stale motion
        on.
        """
        config, ground, alignment = self.config, self._ground, self._alignment
        limit_distance, limit_yaw = config.max_speed * dt, config.max_yaw_rate * dt
        # a floor solution whose yaw the whole image contradicts is a wrong minimum of eq. G3: neither its yaw
        # nor its distance is taken (odometry.floor_yaw_tolerance)
        floor_sees = ground.sees_distance and (
            not image_sees_yaw or abs(floor_yaw - aligned_yaw) <= config.floor_yaw_tolerance)
        if floor_sees:
            yaw, yaw_source = floor_yaw, "floor"
        elif image_sees_yaw:  # the yaw again with the walls' depths apart (one expansion per column block, R5)
            column_yaw, _ = alignment.column_yaw()
            yaw, yaw_source = float(np.clip(column_yaw, -limit_yaw, limit_yaw)), "image"
        elif not config.faint_yaw_after_profile and (faint_yaw := self._faint_image_yaw()) is not None:  # eq. R11
            yaw, yaw_source = float(np.clip(faint_yaw, -limit_yaw, limit_yaw)), "image"
        else:  # the column profile's shift (NeuroSLAM eqs. 27–29), where one shift stands out
            bearings, expansion = None, 0.0
            if config.profile_expansion and self._profile_bearings is not None:  # eq. R9
                bearings = self._profile_bearings
                # the most a frame can expand: the fastest travel toward the nearest thing the camera sees,
                # the floor at the image's lower edge
                nearest = config.camera_height / math.tan(self.vertical_fov / 2)
                expansion = config.max_speed * dt / nearest
            shift, stands_out = profile_turn(*self._rotation_profiles, self._max_columns, bearings=bearings,
                                             max_expansion=expansion)
            if stands_out:
                yaw = float(np.clip(config.yaw_scale * shift * self._angle_per_sample, -limit_yaw, limit_yaw))
                yaw_source = "profile"
            elif config.faint_yaw_after_profile and (faint_yaw := self._faint_image_yaw()) is not None:  # R11 after
                yaw, yaw_source = float(np.clip(faint_yaw, -limit_yaw, limit_yaw)), "image"
            else:
                yaw, yaw_source = None, ""
        yaw, yaw_held = self._held_turn(yaw, dt)  # eq. R10
        if yaw_held:
            yaw_source = "held"
        turn_rate = self._turn_rate(yaw or 0.0, dt)  # eq. R8
        ceiling, memory = self._ceiling, math.exp(-dt / config.scale_memory)
        height = _scale(self._ceiling_sums)
        # the floor sees the distance firmly where its information outweighs the prior's (1); between
        # floor_min_information and that, a ceiling or upper image whose scale holds is read instead
        firm = floor_sees and ground.information[0] >= _FIRM_FLOOR
        if not firm and ground.half_width > 0 and self._ceiling_previous is not None:
            # the lane (eq. G5) does not see the distance firmly: the whole floor's distance, the walls' feet
            # beside the lane included (its yaw, which the walls bias, is not taken)
            whole_distance, whole_information = ground.whole_floor_distance(
                self._ceiling_previous, ground.pyramid, self._held_speed * dt, yaw or 0.0)
            if whole_information >= _FIRM_FLOOR:
                firm, floor_distance = True, float(np.clip(whole_distance, -limit_distance, limit_distance))
        # odometry.ceiling_on_slopes: over a ramp a level ceiling is not the plane parallel to the floor of eq. G1
        ceiling_plane = config.ceiling_on_slopes or not ground.on_slope
        distance, distance_source = None, ""
        if firm:
            distance, distance_source = floor_distance, "floor"
            # the scales' memory runs while the floor sees (a blank stretch keeps the last scales as they were);
            # they are learnt on every fifth such frame (_CEILING_EVERY)
            self._scale_sums *= memory
            self._ceiling_sums *= memory
            self._ceiling_countdown -= 1
            if floor_distance > 0 and self._ceiling_countdown <= 0:
                self._ceiling_countdown = _CEILING_EVERY
                if ceiling_plane:
                    reading, _ = ceiling.align(self._ceiling_previous, ground.pyramid,
                                               (floor_distance / (height or _NOMINAL_CEILING), yaw or 0.0))
                    if ceiling.sees_distance and reading > 0:
                        self._ceiling_sums += (floor_distance * reading, reading**2, floor_distance**2)
                expansion, expansion_information = alignment.upper_expansion() if image_sees_yaw else (0.0, 0.0)
                if expansion > 0 and expansion_information > 0:
                    self._scale_sums += (floor_distance * expansion, expansion**2, floor_distance**2)
        else:
            previous_distance = self._held_speed * dt
            if height > 0 and ceiling_plane:  # from the yaw taken above (the floor's own may be the wrong minimum)
                reading, ceiling_yaw = ceiling.align(self._ceiling_previous, ground.pyramid,
                                                     (previous_distance / height, yaw or 0.0))
                if (ceiling.information[0] / height**2 >= ceiling.min_information and reading >= 0
                        and (yaw is None or abs(ceiling_yaw - yaw) <= config.floor_yaw_tolerance)):
                    distance, distance_source = float(np.clip(height * reading, 0.0, limit_distance)), "ceiling"
            scale = _scale(self._scale_sums)
            if distance is None and image_sees_yaw and scale > 0:
                expansion, expansion_information = alignment.upper_expansion()
                if expansion_information / scale**2 >= ground.min_information * ground.distance_weight:
                    distance, distance_source = float(np.clip(scale * expansion, 0.0, limit_distance)), "image"
            if distance is None and floor_sees:
                distance, distance_source = floor_distance, "floor"
        if distance is not None:
            self._readings.append((self._travelled, distance / dt))
            self._turn_readings[self._turn_count % len(self._turn_readings)] = (turn_rate, distance / dt)
            self._turn_count += 1
            self._held_speed, self._blind_for, self._unobserved = distance / dt, 0.0, 0
        else:  # nothing sees the distance: a held speed (eq. R8), for blind_hold seconds after the image last
            # showed the robot moving in its direction (eq. R4's expansion, its scale unknown)
            evidence = config.forward_evidence
            direction = 0  # the motion's sign the image shows (eq. R4), 0 where it shows none
            if evidence > 0 and self._alignment is not None:
                significance = self._alignment.expansion_significance()
                direction = 1 if significance >= evidence else -1 if significance <= -evidence else 0
            if config.held_direction and direction * self._held_speed <= 0 < abs(direction):  # eq. R12
                image_way = self._image_direction_speed(direction)
                if image_way is not None:
                    self._held_speed = image_way
            moving = direction != 0 and direction * self._held_speed > 0
            self._blind_for = 0.0 if moving else self._blind_for + dt
            held = self._blind_for <= config.blind_hold
            distance, distance_source = (self._blind_speed(turn_rate) * dt, "held") if held else (0.0, "none")
            self._unobserved += 1
        if yaw is None:  # nothing sees the yaw and nothing is held (odometry.yaw_hold): no turn
            yaw, yaw_source = 0.0, "none"
        if distance_source != "floor" or yaw_source != "floor":
            ground.motion = np.array([distance, yaw])
        return distance, yaw, Observed(distance_source, yaw_source, "image" if pitch_seen else "held")
