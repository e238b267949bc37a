"""The NeuroSLAM pipeline: one :meth:`NeuroSLAM.step` per camera frame.

Per frame, in the paper's order (Algorithm 1):

1. vision: grey image, visual odometry (or the caller's own self-motion) and the local view cells;
2. head-direction cells: attractor dynamics and path integration by the yaw and height change;
3. grid cells: attractor dynamics and path integration by the translation along the decoded yaw;
4. local view calibration: a familiar view injects the activity it learned (NeuroSLAM eqs. 10–11) into both
   networks; a new view learns the current packets;
5. experience map: the odometry since the current experience, matching, creation, loop closure and
   relaxation (NeuroSLAM eqs. 21–25). With ``loop_closure = "confirmed"`` (the ``sim`` default) a loop may close
   only where the last frames' views confirm an old place (:mod:`neuroslam.loop_closure`), and the
   packets are first moved to that place's codes.

Every frame's state stays inspectable: ``grid_cells.activity``, ``head_direction.activity``, the last
:class:`Estimate`, the map arrays. Saving and loading are :mod:`neuroslam.state`'s, sessions and merging
:mod:`neuroslam.sessions`', the view cells' learned associations :mod:`neuroslam.associations`'.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from pathlib import Path

import numpy as np

from . import presets
from .arrays import GrowingArray
from .associations import ViewAssociations
from .cells import GridCells, HeadDirectionCells
from .cells.grid_network import GridNetwork
from .config import Config
from .errors import InvalidInputError
from .estimate import Estimate
from .experience_map import ExperienceMap
from .geometry import compose, wrap
from .loop_closure import confirm_place
from .sessions import SessionsMixin, WindowHistory
from .state import MAP_FILE, StateMixin
from .vision.ground_motion import blurred_with_gradients
from .vision.local_view import LocalViewCells
from .vision.odometry import SelfMotion, VisualOdometry
from .vision.preprocessing import grey, noise_deviation, reduce_to_width
from .vision.structure import StructureHeading

__all__ = ["MAP_FILE", "Estimate", "NeuroSLAM"]

logger = logging.getLogger(__name__)

#: m: a path curving tighter than this turns on the spot (the robot's half length); see ``confirmation_turn``
SPOT_RADIUS = 0.5
FLOAT_IMAGE_SLACK = 1e-3  # a float image may overshoot [0, 1] by this much (resampling ringing); it is clipped


class NeuroSLAM(SessionsMixin, StateMixin):
    """Brain-inspired 4-DoF SLAM.

    Args:
        config: a :class:`~neuroslam.config.Config`, a preset name (see :mod:`neuroslam.presets`), a path
            to a TOML or JSON file of settings, or None for the defaults (the ``sim`` preset).

    Example::

        slam = NeuroSLAM("sim")
        for image, t in frames:
            estimate = slam.step(image, t)
        slam.experience_map.poses
    """

    def __init__(self, config: Config | str | Path | None = None):
        self.config = presets.resolve(config)
        c = self.config
        self.visual_odometry = VisualOdometry(c.odometry, horizontal_fov=c.horizontal_fov, vertical_fov=c.vertical_fov,
                                              panoramic=c.panoramic)
        self.local_view = LocalViewCells(c.local_view, horizontal_fov=c.horizontal_fov, panoramic=c.panoramic)
        self.grid_cells = GridCells(c.grid_cells)
        self.head_direction = HeadDirectionCells(c.head_direction)
        # the Burak–Fiete network, when it integrates the planar self-motion (config.integrator)
        self.grid_network = GridNetwork(c.grid_network) if c.integrator == "grid-network" else None
        self.experience_map = ExperienceMap(c.experience_map, grid_size=c.grid_cells.size,
                                            direction_size=c.head_direction.size, grid_cell_size=c.grid_cells.cell_size)
        # what each template learned: the packets' codes, its decay, the map it was learned in
        self.view_associations = ViewAssociations()
        # the floor's straight lines, read each frame for the map's eq. M4 (a pinhole camera only)
        self._lines = (StructureHeading(horizontal_fov=c.horizontal_fov, strength=c.odometry.manhattan_strength,
                                        first_row=c.odometry.manhattan_first_row)
                       if c.experience_map.structure_weight > 0 and c.experience_map.relaxation == "least-squares"
                       and not c.panoramic else None)
        self._image_shape: tuple[int, ...] | None = None
        self._last_time: float | None = None
        self._odometry_pose = np.zeros(4)
        # the last frames' (odometry pose, template id, other matching templates), for the confirmed
        # loop-closure rule
        self._recent: deque[tuple[np.ndarray, int, tuple[int, ...]]] = deque(
            maxlen=c.experience_map.confirmation_window)
        self._since_closure = 0.0  # m driven since the robot was last on an old experience (or closed a loop)
        # per frame: its experience and the robot's pose relative to it (x, y, z, yaw), for trajectory()
        self._frame_experiences = GrowingArray(0, np.int64)
        self._frame_offsets = GrowingArray(4, np.float64)
        self.frames = 0
        self.last: Estimate | None = None
        self.merges: list[tuple[int, int]] = []  # this session's merges: (frame index, experience merged at)
        # the loop closures the latest merge found among the frames before it: (frame index, experience); read
        # on the merging frame (a later merge, a new session or loading a map empties it)
        self.closures_before_merge: list[tuple[int, int]] = []
        self._unmerged: WindowHistory | None = None  # window entries until the session's map merges
        self._known_start = False  # the next frame should find the robot in the loaded map (begin_session)
        self.map_extra: dict[str, np.ndarray] = {}  # the caller's arrays kept with a loaded map (see save)
        self.map_metadata: dict = {}  # the notes kept with a loaded map

    @property
    def odometry_pose(self) -> np.ndarray:
        """(x, y, z, yaw): the self-motion integrated without any map correction, m and rad."""
        return self._odometry_pose.copy()

    # input checks (nothing changes when they fail) -----------------------------------------------------
    def _check(self, image: np.ndarray, timestamp: float, odometry: SelfMotion | None) -> np.ndarray:
        array = np.asarray(image)
        if array.ndim not in (2, 3) or (array.ndim == 3 and array.shape[2] not in (1, 3)):
            raise InvalidInputError("image", f"shape {array.shape}", "must be HxW grey or HxWx3 RGB")
        if array.size == 0 or min(array.shape[:2]) < 8:
            raise InvalidInputError("image", f"shape {array.shape}", "must be at least 8x8 pixels")
        if not (array.dtype == np.uint8 or np.issubdtype(array.dtype, np.floating)):
            raise InvalidInputError("image", f"dtype {array.dtype}", "must be uint8 or floats in [0, 1]")
        if np.issubdtype(array.dtype, np.floating):
            low, high = float(array.min()), float(array.max())  # NaN propagates, infinity is out of range
            if not (math.isfinite(low) and math.isfinite(high)):
                raise InvalidInputError("image", "with NaN or infinity", "must be finite")
            if low < -FLOAT_IMAGE_SLACK or high > 1.0 + FLOAT_IMAGE_SLACK:
                raise InvalidInputError("image", f"floats from {low!r} to {high!r}",
                                        "float images must lie in [0, 1] (pass 0-255 images as uint8)")
            if low < 0.0 or high > 1.0:  # interpolation overshoot (a resize's ringing): clipped
                array = np.clip(array, 0.0, 1.0)
        if self._image_shape is not None and array.shape != self._image_shape:
            raise InvalidInputError("image", f"shape {array.shape}",
                                    f"differs from the first frame's {self._image_shape}")
        if not isinstance(timestamp, (int, float, np.integer, np.floating)) or not math.isfinite(timestamp):
            raise InvalidInputError("timestamp", repr(timestamp), "must be a finite number of seconds")
        if self._last_time is not None and timestamp <= self._last_time:
            raise InvalidInputError("timestamp", repr(timestamp), f"must increase (previous: {self._last_time!r})")
        if odometry is not None:
            if not isinstance(odometry, SelfMotion):
                shape = f" of shape {np.shape(odometry)}" if isinstance(odometry, (np.ndarray, list, tuple)) else ""
                raise InvalidInputError("odometry", f"{type(odometry).__name__}{shape}",
                                        "must be a SelfMotion(forward_speed m/s, yaw_rate rad/s, climb_rate m/s)")
            odometry.validate()
        if array.ndim == 3 and array.shape[2] == 1:
            array = array[:, :, 0]
        return array

    # the pipeline ----------------------------------------------------------------------------------------
    def step(self, image: np.ndarray, timestamp: float, odometry: SelfMotion | None = None) -> Estimate:
        """Process one frame.

        Args:
            image: HxWx3 RGB or HxW grey, uint8 or floats in [0, 1]; every frame the same size.
            timestamp: seconds, increasing.
            odometry: self-motion from another source (wheels, IMU, VIO); visual odometry otherwise.

        Raises:
            InvalidInputError: a bad image, timestamp or odometry; the SLAM state is left unchanged.
        """
        array = self._check(image, timestamp, odometry)
        image_grey = grey(array)
        dt = 0.0 if self._last_time is None else float(timestamp) - self._last_time
        config = self.config
        # eq. V2, once for the views' noise floor (eq. V1) and the floor's information (eq. G8's "noisy")
        noise = (noise_deviation(image_grey) if config.local_view.noise_floor > 0 or (
            odometry is None and config.odometry.floor_shared_information == "noisy") else None)
        motion = odometry if odometry is not None else self.visual_odometry.step(image_grey, dt, noise=noise)
        distance, yaw_change, climb = motion.forward_speed * dt, motion.yaw_rate * dt, motion.climb_rate * dt

        view = self.local_view.observe(self.local_view.thumbnail(image_grey, noise=noise))
        if self._known_start:
            self._known_start = False
            self._start_in_map(view)

        self.head_direction.step(yaw_change, climb)
        direction_code = self.head_direction.decode()
        heading = direction_code[0] * self.head_direction.yaw_cell_size
        # the direction of travel off the odometric heading that the grid network's read-out gives (grid-network eq. 5),
        # rad; the network is driven along the heading accumulated from the rotations (as the paper does:
        # the head-direction packet jumps when a view calibrates it, which the network would follow late)
        drift = 0.0
        if self.grid_network is not None:
            travel = self._odometry_pose[3] + yaw_change / 2
            dx, dy = self.grid_network.integrate(distance, travel, dt)
            if distance > 0:
                drift = wrap(math.atan2(dy, dx) - travel)
        self.grid_cells.step((distance * math.cos(heading + drift), distance * math.sin(heading + drift), climb))
        grid_code = self.grid_cells.decode()

        themap = self.experience_map
        if view.new:
            self._learn_view(view.template_id, grid_code, direction_code, float(timestamp))
        elif self.view_associations.component[view.template_id] == themap.component:  # the injection moves the packets
            self._recall_view(view.template_id, view.relative_yaw, float(timestamp))
            grid_code = self.grid_cells.decode()
            direction_code = self.head_direction.decode()
        x, y, z, yaw = self._odometry_pose
        middle = yaw + yaw_change / 2 + drift
        self._odometry_pose = np.array([x + distance * math.cos(middle), y + distance * math.sin(middle), z + climb,
                                        wrap(float(yaw + yaw_change))])
        blind = motion.observed is not None and motion.observed.blind[0]  # nothing observed the distance
        blind_time = dt if blind else 0.0
        # the robot's pose in the map includes this frame's motion
        themap.integrate(distance, yaw_change, climb, drift, blind_time=blind_time)
        may_close_loop, merged, place = True, False, -1
        self._since_closure += distance
        entry = (self._odometry_pose, view.template_id,
                 view.alternatives[: self.config.experience_map.confirmation_views - 1])
        kept = len(self._recent) < 2 or self._kept(self._recent[-1][0], self._recent[-2][0])
        if kept:
            self._recent.append(entry)
        else:
            self._recent[-1] = entry
        if self._unmerged is not None:
            self._unmerged.add(self.frames, float(timestamp), *entry, view.relative_yaw, themap.odometer, blind,
                               themap.blind_since, replace=not kept)
        # a blind frame's view places the robot along its path only to within metres (confirmation_blind):
        # neither a merge nor a loop closure is confirmed on it
        refused = view.new or (blind and not self.config.experience_map.confirmation_blind)
        if not refused:
            place = self._merge_place(view.template_id, view.relative_yaw)
            if place >= 0:
                grid_code, direction_code = self._merge(place, view.relative_yaw, grid_code, direction_code)
                merged = True
        along_path = -1
        # eq. M6's rule: the view's yaw relative to its template counts where its match pins the column shift
        pinned = view.new or view.difference < self.local_view.column_contrasts[view.template_id] / 2
        if self.config.experience_map.loop_closure == "confirmed" and not merged:
            # with confirmation_pinned_yaw, a view that does not pin its yaw leaves the heading to the odometry
            keep_heading = self.config.experience_map.confirmation_pinned_yaw and not pinned
            # with closure_window_pose, where the window says the robot stands against its place (m, in the map)
            offset = np.zeros(3) if self.config.experience_map.closure_window_pose else None
            place = -1 if refused else self._confirmed_place(view.relative_yaw, float(timestamp),
                                                             keep_heading=keep_heading, offset=offset)
            may_close_loop = place >= 0
            if may_close_loop:
                grid_code, direction_code = self._relocate(place, view.relative_yaw, grid_code, direction_code,
                                                           keep_heading=keep_heading, offset=offset)
            elif not refused and self.config.experience_map.confirmation_along_path and pinned:
                # eq. M8, where the view's match pins its yaw (as eq. M6's below): the link holds the yaw
                along_path = self._confirmed_place(view.relative_yaw, float(timestamp), along_path=True)

        floor_lines = self._floor_lines(image_grey, visual=odometry is None)
        # eq. M6: the view's yaw relative to its template, where its match pins the column shift (NaN where not)
        view_yaw = view.relative_yaw if pinned else math.nan
        update = themap.update(view.template_id, grid_code, direction_code, float(timestamp),
                               may_close_loop=may_close_loop, place=-1 if merged else place,  # the confirmed place
                               structure=floor_lines, view_yaw=view_yaw, view_difference=view.difference,
                               along_path=along_path, along_path_yaw=view.relative_yaw)
        if update.loop_closure or (not update.new_experience and self._is_old(update.experience_id, float(timestamp))):
            self._since_closure = 0.0  # on an old experience: localised in the map
        self._frame_experiences.append(update.experience_id)
        self._frame_offsets.append(self.experience_map.relative)
        self._image_shape = array.shape
        self._last_time = float(timestamp)
        if merged:
            self.merges.append((self.frames, update.experience_id))
        self.frames += 1
        self.last = Estimate(float(timestamp), themap.robot_pose(), update.experience_id,
                             view.template_id, update.loop_closure, update.new_experience, view.new, motion,
                             grid_code, direction_code, merged, floor_lines)
        if update.loop_closure:
            logger.debug("frame %d: loop closed at experience %d", self.frames, update.experience_id)
        return self.last

    def _floor_lines(self, image_grey: np.ndarray, *, visual: bool) -> float:
        """The orientation of the floor's straight lines in the robot's frame (rad, modulo 90°; eq. M2), or NaN
        where eq. M4 is off or the floor's edges do not lie mostly along two perpendicular directions. From the
        visual odometry's image of this frame when it ran (``visual``), else from the image itself."""
        if self._lines is None:
            return math.nan
        stack = self.visual_odometry.image_stack if visual else None
        if stack is None:
            stack = blurred_with_gradients(reduce_to_width(image_grey, self.config.odometry.working_width), 1.0)
        orientation, strength = self._lines.edge_orientation(stack, 1)
        return orientation if strength >= self._lines.strength else math.nan

    def trajectory(self) -> np.ndarray:
        """(N, 4) every frame's pose (x, y, z, yaw; m, rad) in the map as it is now.

        Each frame is re-expressed through the experience it was at, with the robot's pose relative to
        that experience then: a loop closure that moved the experiences moves the frames with them. This
        is the trajectory SLAM evaluations score (the final estimate, as a keyframe SLAM writes it at
        shutdown); :attr:`Estimate.pose` is the estimate as it was at each frame (online).
        """
        experiences = self._frame_experiences.view
        if len(experiences) == 0:
            return np.zeros((0, 4))
        anchors = self.experience_map.poses[experiences]
        offsets = self._frame_offsets.view
        return compose(anchors, offsets)

    def _kept(self, newest: np.ndarray, before: np.ndarray) -> bool:
        """The confirmation window's newest entry (the latest frame's odometry pose) stays: it lies
        ``confirmation_spacing`` beyond the entry before it, or, turning on the spot (a path curving tighter
        than :data:`SPOT_RADIUS`), ``confirmation_turn`` round from it. Otherwise the next frame replaces it."""
        config = self.config.experience_map
        if config.confirmation_spacing == 0:
            return True
        moved = float(np.linalg.norm(newest[:3] - before[:3]))
        turned = abs(wrap(float(newest[3] - before[3])))
        return moved >= config.confirmation_spacing or (
            0 < config.confirmation_turn <= turned and moved <= SPOT_RADIUS * turned)

    def _confirmed_place(self, relative_yaw: float, time: float, *, along_path: bool = False,
                         keep_heading: bool = False, offset: np.ndarray | None = None) -> int:
        """The old experience the last frames confirm (:func:`~neuroslam.loop_closure.confirm_place`), or -1.

        Old: made more than ``confirmation_age`` ago. The search radius grows with the distance driven
        since the robot was last on an old experience (``confirmation_drift`` per metre, and
        ``confirmation_climb_error`` per metre for heights). With ``along_path``, eq. M8's test instead. With
        ``keep_heading``, every hypothesis faces the robot's heading in the map, not its place's yaw turned by the
        view's ``relative_yaw`` (a view whose match does not pin its yaw). ``offset`` (a (3,) array, or None): filled
        with where the window says the robot is against the place (m, in the map; ``confirm_place``'s ``offset``).
        """
        themap = self.experience_map
        eligible = self._old(time) & (themap.components == themap.component)
        robot = themap.robot_pose()
        return self._confirm(np.array([entry[0] for entry in self._recent]),
                             np.array([entry[1] for entry in self._recent]), [entry[2] for entry in self._recent],
                             relative_yaw, eligible, robot, self._since_closure, along_path=along_path,
                             heading=float(robot[3]) if keep_heading else None, offset=offset)

    def _confirm(self, poses: np.ndarray, templates: np.ndarray, alternatives: list, relative_yaw: float,
                 eligible: np.ndarray, robot: np.ndarray, since: float, *, along_path: bool = False,
                 heading: float | None = None, offset: np.ndarray | None = None) -> int:
        """:func:`~neuroslam.loop_closure.confirm_place` over a window (odometry poses, views and their other
        matching templates, the newest last) with this configuration's tolerances, the search radius grown by
        ``since`` metres driven without a loop closure; the confirmed experience, or -1."""
        config = self.config.experience_map
        return confirm_place(
            poses, templates, relative_yaw, self.experience_map.poses, self.experience_map.experiences_of,
            eligible, robot, window_alternatives=alternatives,
            radius=config.confirmation_tolerance + config.confirmation_drift * since,
            height_radius=config.confirmation_tolerance + config.confirmation_climb_error * since,
            tolerance=config.confirmation_tolerance, matches=config.confirmation_matches,
            climb_error=config.confirmation_climb_error,
            odometers=self.experience_map.odometers if config.confirmation_laid_apart else None,
            sessions=self.experience_map.sessions,
            rival_spread=config.confirmation_rival_spread * config.confirmation_tolerance, along_path=along_path,
            local_reach=config.confirmation_local_reach and not along_path, drift=config.confirmation_drift,
            rival_shifts=config.confirmation_rival_shifts and not along_path,
            rival_odds=config.confirmation_rival_odds or None, heading=heading, offset=offset)

    def _is_old(self, experience: int, time: float) -> bool:
        """One experience's entry of :meth:`_old` (without computing the others)."""
        themap = self.experience_map
        return bool(themap.creation_times[experience] < time - self.config.experience_map.confirmation_age
                    or themap.sessions[experience] < themap.session)

    def _old(self, time: float) -> np.ndarray:
        """(N,) experiences made more than ``confirmation_age`` ago, or in an earlier session."""
        themap = self.experience_map
        return ((themap.creation_times < time - self.config.experience_map.confirmation_age)
                | (themap.sessions < themap.session))

    def _relocate(self, place: int, relative_yaw: float, grid_code: np.ndarray, direction_code: np.ndarray, *,
                  keep_heading: bool = False, offset: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Move both packets to a confirmed place's codes, unless NeuroSLAM eq. 22 already matches it there.
        With ``keep_heading`` the head-direction packet keeps its yaw (the odometry's) and moves in height only.
        With ``offset`` (m, in the map; ``closure_window_pose``), the grid packet moves to the place's code moved
        horizontally by it, whether or not eq. 22 matches: the window, not the robot's own estimate, says where
        the robot stands against the place (the window's heights carry the odometry's climb error: the place's
        height stays).

        The packets are shifted whole (the same exact shift as path integration, NeuroSLAM eqs. 6–9 and 17–20),
        so they keep their resting shape. Returns the decoded codes afterwards.
        """
        themap = self.experience_map
        target_grid = themap.grid_codes[place].copy()
        if offset is not None:
            target_grid[:2] += np.asarray(offset[:2], dtype=float) / themap.grid_cell_size[:2]
        target_direction = themap.direction_codes[place].copy()
        if keep_heading:
            target_direction[0] = direction_code[0]
        else:
            target_direction[0] += relative_yaw / self.head_direction.yaw_cell_size
        config = self.config.experience_map
        score = (config.grid_weight * self.grid_cells.distance(grid_code, target_grid)
                 + config.direction_weight * self.head_direction.distance(direction_code, target_direction))
        if score <= config.threshold and offset is None:
            return grid_code, direction_code
        grid_size = np.asarray(self.config.grid_cells.size, dtype=float)
        direction_size = np.asarray(self.config.head_direction.size, dtype=float)
        self.grid_cells.network.step((target_grid - grid_code + grid_size / 2) % grid_size - grid_size / 2)
        self.head_direction.network.step(
            (target_direction - direction_code + direction_size / 2) % direction_size - direction_size / 2)
        logger.debug("relocated to experience %d (code distance %.1f cells)", place, score)
        return self.grid_cells.decode(), self.head_direction.decode()

    def _learn_view(self, template: int, grid_code: np.ndarray, direction_code: np.ndarray, time: float) -> None:
        """NeuroSLAM eq. 10: a new local view cell associates with the current grid and head-direction packets."""
        self.view_associations.learn(template, grid_code, direction_code, self.experience_map.component, time)

    def _recall_view(self, template: int, relative_yaw: float, time: float) -> None:
        """NeuroSLAM eq. 11: a familiar view injects its learned packets, weakened while it keeps being seen
        (:meth:`~neuroslam.associations.ViewAssociations.recall`)."""
        associations = self.view_associations
        scale = associations.recall(template, time)
        direction = associations.direction[template].copy()
        direction[0] += relative_yaw / self.head_direction.yaw_cell_size
        self.grid_cells.inject(associations.grid[template], self.config.grid_cells.view_injection * scale)
        self.head_direction.inject(direction, self.config.head_direction.view_injection * scale)
        self.grid_cells.normalise()
        self.head_direction.normalise()
