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
:class:`Estimate`, the map arrays.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import presets
from .arrays import GrowingArray
from .cells import GridCells, HeadDirectionCells
from .cells.grid_network import GridNetwork
from .config import Config
from .errors import InvalidInputError, InvalidParameterError
from .experience_map import ExperienceMap
from .geometry import compose, relative, wrap
from .loop_closure import confirm_place
from .maps import MapFileError, read_map, write_map
from .vision.local_view import LocalViewCells
from .vision.odometry import SelfMotion, VisualOdometry
from .vision.preprocessing import grey

__all__ = ["Estimate", "NeuroSLAM"]

logger = logging.getLogger(__name__)

MAP_FILE = "map.npz"  # the map's file name in a run's output folder
VIEW_DECAY_TIME = 10.0  # s: how fast a repeatedly seen view regains its full calibration strength


@dataclass(frozen=True)
class Estimate:
    """The SLAM state after one frame.

    Attributes:
        timestamp: the frame's time, s.
        pose: (x, y, z, yaw) in the map frame, m and rad.
        experience_id: the current experience. template_id: the active local view cell.
        loop_closure: an existing experience was re-entered this frame.
        new_experience, new_template: created this frame.
        self_motion: the self-motion used for this frame.
        grid_cell: decoded 3D grid-cell packet, fractional cells. head_direction_cell: (yaw, height) cells.
        merged: this frame merged the robot's map into another (a loaded map it recognised).
    """

    timestamp: float
    pose: np.ndarray
    experience_id: int
    template_id: int
    loop_closure: bool
    new_experience: bool
    new_template: bool
    self_motion: SelfMotion
    grid_cell: np.ndarray
    head_direction_cell: np.ndarray
    merged: bool = False


#: m: a path curving tighter than this turns on the spot (the robot's half length); see ``confirmation_turn``
SPOT_RADIUS = 0.5
FLOAT_IMAGE_SLACK = 1e-3  # a float image may overshoot [0, 1] by this much (resampling ringing); it is clipped


class NeuroSLAM:
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
        self._view_grid = np.zeros((64, 3))
        self._view_direction = np.zeros((64, 2))
        self._view_decay = np.zeros((64, 2))  # (decay, time of last activation)
        self._view_component = np.zeros(64, dtype=np.int64)  # the map (component) each view was learned in
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
        motion = odometry if odometry is not None else self.visual_odometry.step(image_grey, dt)
        distance, yaw_change, climb = motion.forward_speed * dt, motion.yaw_rate * dt, motion.climb_rate * dt

        view = self.local_view.observe(self.local_view.thumbnail(image_grey))
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
        elif self._view_component[view.template_id] == themap.component:  # the injection moves the packets
            self._recall_view(view.template_id, view.relative_yaw, float(timestamp))
            grid_code = self.grid_cells.decode()
            direction_code = self.head_direction.decode()
        x, y, z, yaw = self._odometry_pose
        middle = yaw + yaw_change / 2 + drift
        self._odometry_pose = np.array([x + distance * math.cos(middle), y + distance * math.sin(middle), z + climb,
                                        wrap(float(yaw + yaw_change))])
        themap.integrate(distance, yaw_change, climb, drift)  # the robot's pose in the map includes this frame's motion
        may_close_loop, merged, place = True, False, -1
        self._since_closure += distance
        entry = (self._odometry_pose, view.template_id,
                 view.alternatives[: self.config.experience_map.confirmation_views - 1])
        if len(self._recent) < 2 or self._kept(self._recent[-1][0], self._recent[-2][0]):
            self._recent.append(entry)
        else:
            self._recent[-1] = entry
        if not view.new:
            place = self._merge_place(view.template_id, view.relative_yaw)
            if place >= 0:
                grid_code, direction_code = self._merge(place, view.relative_yaw, grid_code, direction_code)
                merged = True
        if self.config.experience_map.loop_closure == "confirmed" and not merged:
            place = -1 if view.new else self._confirmed_place(view.relative_yaw, float(timestamp))
            may_close_loop = place >= 0
            if may_close_loop:
                grid_code, direction_code = self._relocate(place, view.relative_yaw, grid_code, direction_code)

        update = themap.update(view.template_id, grid_code, direction_code, float(timestamp),
                               may_close_loop=may_close_loop, place=-1 if merged else place)  # the confirmed place
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
                             grid_code, direction_code, merged)
        if update.loop_closure:
            logger.debug("frame %d: loop closed at experience %d", self.frames, update.experience_id)
        return self.last

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

    # saving and loading ----------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, np.ndarray]:
        """Every part of the state, as named arrays (dotted names: ``grid_cells.activity``,
        ``experience_map.poses``, ...): what :meth:`save` writes and :meth:`load_state_dict` restores."""
        state: dict[str, np.ndarray] = {}
        parts = {"odometry": self.visual_odometry, "local_view": self.local_view,
                 "grid_cells": self.grid_cells.network, "head_direction": self.head_direction.network,
                 "experience_map": self.experience_map}
        if self.grid_network is not None:
            parts["grid_network"] = self.grid_network
        for prefix, part in parts.items():
            state.update({f"{prefix}.{key}": value for key, value in part.state_dict().items()})
        templates = self.local_view.count
        recent_poses = np.array([entry[0] for entry in self._recent]).reshape(-1, 4)
        width = max((len(entry[2]) for entry in self._recent), default=0)
        recent_alternatives = np.full((len(self._recent), width), -1, dtype=np.int64)  # -1: none
        for row, entry in enumerate(self._recent):
            recent_alternatives[row, : len(entry[2])] = entry[2]
        state.update({
            "slam.view_grid": self._view_grid[:templates].copy(),
            "slam.view_direction": self._view_direction[:templates].copy(),
            "slam.view_decay": self._view_decay[:templates].copy(),
            "slam.view_component": self._view_component[:templates].copy(),
            "slam.merges": np.array(self.merges, dtype=np.int64).reshape(-1, 2),
            "slam.known_start": np.bool_(self._known_start),
            "slam.image_shape": np.array(self._image_shape or (), dtype=np.int64),
            "slam.last_time": np.float64(math.nan if self._last_time is None else self._last_time),
            "slam.odometry_pose": self._odometry_pose.copy(),
            "slam.recent_poses": recent_poses,
            "slam.recent_templates": np.array([entry[1] for entry in self._recent], dtype=np.int64),
            "slam.recent_alternatives": recent_alternatives,
            "slam.since_closure": np.float64(self._since_closure),
            "slam.frame_experiences": self._frame_experiences.view.copy(),
            "slam.frame_offsets": self._frame_offsets.view.copy(),
            "slam.frames": np.int64(self.frames),
        })
        if self.last is not None:
            last = self.last
            state.update({
                "last.timestamp": np.float64(last.timestamp), "last.pose": np.asarray(last.pose, dtype=float),
                "last.ids": np.array([last.experience_id, last.template_id], dtype=np.int64),
                "last.flags": np.array([last.loop_closure, last.new_experience, last.new_template]),
                "last.self_motion": np.array([last.self_motion.forward_speed, last.self_motion.yaw_rate,
                                              last.self_motion.climb_rate]),
                "last.grid_cell": np.asarray(last.grid_cell, dtype=float),
                "last.head_direction_cell": np.asarray(last.head_direction_cell, dtype=float),
            })
        return state

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output (for this configuration).

        Raises:
            ValueError: a part is missing or does not fit the configuration or the rest of the state; the
                SLAM is then left exactly as it was.
        """
        backup = {name: np.array(value, copy=True) for name, value in self.state_dict().items()}
        try:
            self._load_state(state)
        except Exception:
            self._load_state(backup)  # all or nothing: a valid state of this SLAM restores without fail
            raise

    def _load_state(self, state: dict[str, np.ndarray]) -> None:
        def part(prefix: str) -> dict[str, np.ndarray]:
            return {key[len(prefix) + 1:]: value for key, value in state.items() if key.startswith(prefix + ".")}

        try:
            templates = len(state["local_view.templates"])
            view_grid, view_direction, view_decay = (np.asarray(state[f"slam.view_{name}"], dtype=float)
                                                     for name in ("grid", "direction", "decay"))
            if view_grid.shape != (templates, 3) or view_direction.shape != (templates, 2) \
                    or view_decay.shape != (templates, 2):
                raise ValueError(f"the view associations do not match the {templates} templates")
            template_ids = np.asarray(state["experience_map.template_ids"])
            if len(template_ids) and (template_ids.min() < 0 or template_ids.max() >= templates):
                raise ValueError("an experience names a template that does not exist")
            self.visual_odometry.load_state_dict(part("odometry"))
            self.local_view.load_state_dict(part("local_view"))
            self.grid_cells.network.load_state_dict(part("grid_cells"))
            self.head_direction.network.load_state_dict(part("head_direction"))
            self.experience_map.load_state_dict(part("experience_map"))
            if self.grid_network is not None:
                self.grid_network.load_state_dict(part("grid_network"))
            capacity = max(64, templates)
            self._view_grid, self._view_direction, self._view_decay = (
                np.concatenate([array, np.zeros((capacity - templates, array.shape[1]))])
                for array in (view_grid, view_direction, view_decay))
            view_component = np.asarray(state["slam.view_component"], dtype=np.int64)
            if view_component.shape != (templates,):
                raise ValueError(f"the view components do not match the {templates} templates")
            self._view_component = np.concatenate([view_component, np.zeros(capacity - templates, dtype=np.int64)])
            self.merges = [(int(frame), int(experience)) for frame, experience in
                           np.asarray(state["slam.merges"], dtype=np.int64).reshape(-1, 2)]
            self._known_start = bool(state["slam.known_start"])
            shape = tuple(int(n) for n in state["slam.image_shape"])
            self._image_shape = shape or None
            last_time = float(state["slam.last_time"])
            self._last_time = None if math.isnan(last_time) else last_time
            self._odometry_pose = np.asarray(state["slam.odometry_pose"], dtype=float).copy()
            poses, templates = np.asarray(state["slam.recent_poses"], dtype=float), state["slam.recent_templates"]
            # maps saved before the alternatives were kept have none
            alternatives = state.get("slam.recent_alternatives", np.zeros((len(templates), 0), dtype=np.int64))
            alternatives = np.asarray(alternatives, dtype=np.int64)
            if alternatives.ndim != 2 or len(alternatives) != len(templates):
                raise ValueError(f"recent alternatives have shape {alternatives.shape}, expected "
                                 f"({len(templates)}, K)")
            recent = zip(poses, templates, alternatives, strict=True)
            self._recent = deque(((pose.copy(), int(template), tuple(int(other) for other in others if other >= 0))
                                  for pose, template, others in recent),
                                 maxlen=self.config.experience_map.confirmation_window)
            self._since_closure = float(state["slam.since_closure"])
            self._frame_experiences = GrowingArray.of(state["slam.frame_experiences"], 0, np.int64)
            self._frame_offsets = GrowingArray.of(state["slam.frame_offsets"], 4, np.float64)
            self.frames = int(state["slam.frames"])
            if len(self._frame_experiences.view) and self._frame_experiences.view.max() >= self.experience_map.size:
                raise ValueError("a frame names an experience that does not exist")
            self.last = None
            if "last.timestamp" in state:
                speed, yaw_rate, climb_rate = (float(value) for value in state["last.self_motion"])
                experience, template = (int(value) for value in state["last.ids"])
                closure, new_experience, new_template = (bool(value) for value in state["last.flags"])
                self.last = Estimate(float(state["last.timestamp"]), np.asarray(state["last.pose"]).copy(),
                                     experience, template, closure, new_experience, new_template,
                                     SelfMotion(speed, yaw_rate, climb_rate),
                                     np.asarray(state["last.grid_cell"]).copy(),
                                     np.asarray(state["last.head_direction_cell"]).copy())
        except KeyError as error:
            raise ValueError(f"the state lacks {error.args[0]!r}") from None

    def save(self, path: str | Path, *, extra: dict[str, np.ndarray] | None = None,
             metadata: dict | None = None) -> Path:
        """Save everything needed to continue exactly where this session is (see :mod:`neuroslam.maps`).

        Args:
            path: the file to write (conventionally ``map.npz``); replaced atomically.
            extra: the caller's own arrays to keep with the map (stored as ``extra.NAME``; e.g. the
                ground-truth pose of each experience, for scoring later sessions).
            metadata: JSON-serialisable notes kept in the header (world, route, ...).

        Returns:
            The path written. Raises :class:`~neuroslam.maps.MapFileError` if it cannot be written.
        """
        arrays = self.state_dict()
        for name, array in (extra or {}).items():
            arrays[f"extra.{name}"] = np.asarray(array)
        header = {"library": _library_version(), "config": self.config.to_dict(), "metadata": metadata or {}}
        written = write_map(path, header, arrays)
        logger.info("saved map to %s: %d templates, %d experiences, %d frames", written, self.local_view.count,
                    self.experience_map.size, self.frames)
        return written

    @classmethod
    def load(cls, path: str | Path) -> NeuroSLAM:
        """A NeuroSLAM that continues exactly where the session saved in ``path`` stopped.

        ``path`` is a map file or a run's output folder holding ``map.npz``. Raises
        :class:`~neuroslam.maps.MapFileError` (saying what is wrong) for a missing, truncated,
        corrupted, foreign or newer-version file; nothing is changed then.
        """
        path = Path(path)
        if path.is_dir() and (path / MAP_FILE).is_file():
            path = path / MAP_FILE
        header, arrays = read_map(path)
        try:
            config = Config.from_dict(header["config"])
        except InvalidParameterError as error:
            raise MapFileError(path, f"its configuration is invalid here ({error})") from None
        slam = cls(config)
        try:
            slam.load_state_dict({name: array for name, array in arrays.items() if not name.startswith("extra.")})
        except (ValueError, TypeError, IndexError) as error:
            raise MapFileError(path, f"inconsistent state ({error})") from None
        slam.map_extra = {name[6:]: array for name, array in arrays.items() if name.startswith("extra.")}
        slam.map_metadata = dict(header.get("metadata") or {})
        logger.info("loaded map %s: %d templates, %d experiences, %d frames", path, slam.local_view.count,
                    slam.experience_map.size, slam.frames)
        return slam

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

    def _confirmed_place(self, relative_yaw: float, time: float) -> int:
        """The old experience the last frames confirm (:func:`~neuroslam.loop_closure.confirm_place`), or -1.

        Old: made more than ``confirmation_age`` ago. The search radius grows with the distance driven
        since the robot was last on an old experience (``confirmation_drift`` per metre, and
        ``confirmation_climb_error`` per metre for heights).
        """
        config = self.config.experience_map
        themap = self.experience_map
        eligible = self._old(time) & (themap.components == themap.component)
        return confirm_place(
            np.array([entry[0] for entry in self._recent]), np.array([entry[1] for entry in self._recent]),
            relative_yaw, themap.poses, themap.experiences_of, eligible, themap.robot_pose(),
            window_alternatives=[entry[2] for entry in self._recent],
            radius=config.confirmation_tolerance + config.confirmation_drift * self._since_closure,
            height_radius=config.confirmation_tolerance + config.confirmation_climb_error * self._since_closure,
            tolerance=config.confirmation_tolerance, matches=config.confirmation_matches,
            climb_error=config.confirmation_climb_error)

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

    # sessions and merging ----------------------------------------------------------------------------------
    def begin_session(self, start: str = "unknown") -> None:
        """Start a new session (a new drive) in the map this SLAM holds (a loaded one).

        The clock, the visual odometry, the odometry pose, the confirmation window and the per-frame
        trajectory start afresh; the map, the templates and the cells' associations stay.

        Args:
            start: ``"unknown"`` (scenario ii of the multisession paper): the session builds a partial map
                of its own, which merges into the loaded map once the last frames confirm a place of it
                (the same confirmation as a loop closure, :func:`~neuroslam.loop_closure.confirm_place`,
                without a search radius). ``"known"`` (scenario i): the robot starts inside the map; the
                first frame's view, if it matches a stored template, places the robot at that template's
                (latest) experience and resets both packets to its codes, and mapping continues there. If
                the first view matches nothing, or was seen at places more than ``2 ×
                confirmation_tolerance`` apart, the session goes on as an unknown start.
        """
        if start not in ("unknown", "known"):
            raise InvalidParameterError("start", start, "must be 'unknown' or 'known'")
        c = self.config
        self.visual_odometry = VisualOdometry(c.odometry, horizontal_fov=c.horizontal_fov, vertical_fov=c.vertical_fov,
                                              panoramic=c.panoramic)
        self._image_shape = None
        self._last_time = None
        self._odometry_pose = np.zeros(4)
        self._recent.clear()
        self._since_closure = 0.0
        self._view_decay[:] = 0.0
        self._frame_experiences = GrowingArray(0, np.int64)
        self._frame_offsets = GrowingArray(4, np.float64)
        self.frames = 0
        self.last = None
        self.merges = []
        self.experience_map.begin_session()
        self._known_start = start == "known"
        logger.info("session %d begins (%s start) with %d templates, %d experiences in %d maps",
                    self.experience_map.session, start, self.local_view.count, self.experience_map.size,
                    len(np.unique(self.experience_map.components)))

    def add_map(self, other: NeuroSLAM | str | Path) -> None:
        """Hold another saved map as well (its own component, merged only when recognised).

        Args:
            other: a NeuroSLAM, or a map file (or run folder) to :meth:`load`.

        Its templates, view associations, experiences and links are appended (ids shifted); it must have
        been built with the same configuration. Call :meth:`begin_session` afterwards.

        Raises:
            InvalidInputError: ``other`` is not a map or has another configuration; MapFileError: the file
                cannot be loaded. Nothing is changed then.
        """
        if isinstance(other, (str, Path)):
            other = type(self).load(other)
        if not isinstance(other, NeuroSLAM):
            raise InvalidInputError("map", type(other).__name__, "must be a NeuroSLAM or the path of a map file")
        if other.config != self.config:
            raise InvalidInputError("map", "with another configuration", "must share this SLAM's configuration")
        themap = self.experience_map
        count = self.local_view.count
        component_offset = 1 + max(int(themap.components.max()) if themap.size else 0,
                                   int(self._view_component[:count].max()) if count else 0, themap.component)
        first = self.local_view.extend(other.local_view)
        added = other.local_view.count
        capacity = max(64, 2 * (first + added))
        for name in ("_view_grid", "_view_direction", "_view_decay", "_view_component"):
            mine, theirs = getattr(self, name), getattr(other, name)
            grown = np.zeros((capacity, *mine.shape[1:]), dtype=mine.dtype)
            grown[:first] = mine[:first]
            grown[first: first + added] = theirs[:added]
            setattr(self, name, grown)
        self._view_component[first: first + added] += component_offset
        themap.absorb(other.experience_map, template_offset=first, component_offset=component_offset)

    def _start_in_map(self, view) -> None:
        """Scenario i: put the robot at the latest experience of the first frame's view, packets reset there.

        A view whose experiences lie more than ``2 × confirmation_tolerance`` apart (seen along a lane, or at
        several places) does not say where the robot is: then, as for a new view, the session goes on as
        an unknown start and merges once a run of views confirms the place."""
        themap = self.experience_map
        experiences = themap.experiences_of(view.template_id) if not view.new else np.zeros(0, dtype=np.int64)
        if len(experiences) == 0:
            logger.warning("known start: the first view matches no stored template; mapping as an unknown start")
            return
        spread = np.linalg.norm(np.ptp(themap.poses[experiences, :3], axis=0))
        if spread > 2 * self.config.experience_map.confirmation_tolerance:
            logger.warning("known start: the first view was seen at places %.1f m apart; mapping as an unknown "
                           "start until a run of views confirms the place", spread)
            return
        place = int(experiences[-1])
        themap.enter(place, np.array([0.0, 0.0, 0.0, view.relative_yaw]))
        direction = themap.direction_codes[place].copy()
        direction[0] += view.relative_yaw / self.head_direction.yaw_cell_size
        self.grid_cells.network.reset(themap.grid_codes[place])
        self.head_direction.network.reset(direction)
        logger.info("known start: at experience %d (view %d)", place, view.template_id)

    def _merge_place(self, template: int, relative_yaw: float) -> int:
        """An experience of another map (component) that the last frames confirm the robot is at, or -1.

        :func:`~neuroslam.loop_closure.confirm_place` over each other component that holds the current
        view, with no search radius (where the robot is in that map is unknown): every window frame's view
        must lie where the hypothesis puts it, and views seen at several places of that map are no evidence
        (without a radius to bound them, a run of views along one lane of a repetitive place would otherwise
        also fit a look-alike lane: measured on the car park's deck, whose north and south lanes look the
        same). Two components both confirmed: nothing (ambiguous).
        """
        themap = self.experience_map
        experiences = themap.experiences_of(template)
        others = np.unique(themap.components[experiences])
        others = others[others != themap.component]
        if len(others) == 0 or len(self._recent) < self.config.experience_map.confirmation_matches:
            return -1
        config = self.config.experience_map
        poses = np.array([entry[0] for entry in self._recent])
        templates = np.array([entry[1] for entry in self._recent])
        found = []
        for component in others:
            place = confirm_place(poses, templates, relative_yaw, themap.poses, themap.experiences_of,
                                  themap.components == component, themap.robot_pose(), radius=math.inf,
                                  height_radius=math.inf, tolerance=config.confirmation_tolerance,
                                  matches=config.confirmation_matches, climb_error=config.confirmation_climb_error)
            if place >= 0:
                found.append(place)
        return found[0] if len(found) == 1 else -1

    def _merge(self, place: int, relative_yaw: float, grid_code: np.ndarray, direction_code: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
        """Merge the robot's map (component) and the map of ``place`` (multisession paper, section 3).

        The younger of the two (the higher component id: the partial map of this session, or the later
        of two loaded maps) moves into the older one's frame, which stays. The correspondence: the robot,
        in its map, is at ``place`` facing its yaw plus the view's ``relative_yaw``. The 4-DoF transform
        (a rotation about z by the yaw difference, then a translation; multisession eqs. 13–14 with the yaw) maps the
        moving side of it onto the staying side. Every experience of the moving map is moved by it (multisession eq. 15)
        and given the codes its new pose has relative to the correspondence (grid cells: the metric
        offset over the cell sizes, wrapped; head direction: the yaw and height offsets); every view
        learned in the moving map has its associations moved the same way (multisession eqs. 11–12: the offset to its
        first experience rotated by the yaw difference, not only translated). When the robot's map moved,
        both packets move to ``place``'s codes (an exact shift); otherwise they stay. Experiences of the
        moving map that duplicate one of the other (same view, within ``confirmation_tolerance``) are
        fused into it. The loop closure that follows in the same frame links the two maps (multisession eq. 17).
        Returns the decoded codes afterwards.
        """
        themap = self.experience_map
        mine, theirs = themap.component, int(themap.components[place])
        robot = themap.robot_pose()
        at_place = themap.poses[place].copy()
        at_place[3] += relative_yaw
        place_direction = themap.direction_codes[place] + [relative_yaw / self.head_direction.yaw_cell_size, 0.0]
        robot_moves = mine > theirs
        moving, staying = (mine, theirs) if robot_moves else (theirs, mine)
        # the correspondence on each side: (pose, grid code, head-direction code)
        before, after = (robot, grid_code, direction_code), (at_place, themap.grid_codes[place], place_direction)
        if not robot_moves:
            before, after = after, before
        yaw = wrap(float(after[0][3] - before[0][3]))
        # the motion (translation, yaw) that takes the moving side's pose onto the staying side's
        translation = after[0][:3] - compose(np.array([0.0, 0.0, 0.0, yaw]), before[0])[:3]
        moved = np.flatnonzero(themap.components == moving)
        grid_codes, direction_codes = self._codes_after(themap.poses[moved], yaw, translation, after)
        # the views learned in the moving map: associations relative to their first experience, rotated
        count = self.local_view.count
        views = np.flatnonzero(self._view_component[:count] == moving)
        if len(views):
            first = {}
            for experience, template in zip(moved[::-1], themap.template_ids[moved][::-1], strict=True):
                first[int(template)] = int(experience)  # iterating backwards leaves the first
            index = {int(e): k for k, e in enumerate(moved)}
            old_grid = np.array([themap.grid_codes[first[v]] if v in first else before[1] for v in views])
            old_direction = np.array([themap.direction_codes[first[v]] if v in first else before[2] for v in views])
            new_grid = np.array([grid_codes[index[first[v]]] if v in first else after[1] for v in views])
            new_direction = np.array([direction_codes[index[first[v]]] if v in first else after[2] for v in views])
            grid_size = np.asarray(self.config.grid_cells.size, dtype=float)
            direction_size = np.asarray(self.config.head_direction.size, dtype=float)
            cell = np.asarray(self.config.grid_cells.cell_size, dtype=float)
            offset = ((self._view_grid[views] - old_grid + grid_size / 2) % grid_size - grid_size / 2) * cell
            c, s = math.cos(yaw), math.sin(yaw)
            rotated = np.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1],
                                offset[:, 2]], axis=1) / cell
            turn = (self._view_direction[views] - old_direction + direction_size / 2) % direction_size \
                - direction_size / 2
            self._view_grid[views] = (new_grid + rotated) % grid_size
            self._view_direction[views] = (new_direction + turn) % direction_size
            self._view_component[views] = staying
        themap.move_component(moving, staying, yaw, translation, grid_codes, direction_codes)
        place = self._fuse_duplicates(moved, place)
        self._since_closure = 0.0
        logger.info("merged map %d (%d experiences, %d views) into map %d at experience %d: yaw %.1f deg, "
                    "shift (%.2f, %.2f, %.2f) m", moving, len(moved), len(views), staying, place, math.degrees(yaw),
                    *translation)
        if robot_moves:
            return self._relocate(place, relative_yaw, grid_code, direction_code)
        return grid_code, direction_code

    def _fuse_duplicates(self, moved: np.ndarray, place: int) -> int:
        """After a merge: each moved experience with the same view as an experience of the map it joined,
        within ``confirmation_tolerance`` of it (the frames driven while the merge was being confirmed),
        is fused with it (:meth:`ExperienceMap.fuse`; the older of the two stays), so the shared part is
        mapped once. The frames anchored at a fused experience keep their poses. Returns ``place``'s new id."""
        themap = self.experience_map
        tolerance = self.config.experience_map.confirmation_tolerance
        is_moved = np.zeros(themap.size, dtype=bool)
        is_moved[moved] = True
        duplicates = {}
        for experience in moved:
            others = themap.experiences_of(int(themap.template_ids[experience]))
            others = others[~is_moved[others]]
            if len(others) == 0:
                continue
            gaps = np.linalg.norm(themap.poses[others, :2] - themap.poses[experience, :2], axis=1)
            heights = np.abs(themap.poses[others, 2] - themap.poses[experience, 2])
            gaps[heights > tolerance] = np.inf
            if gaps.min() <= tolerance:
                twin = int(others[np.argmin(gaps)])
                older, newer = min(twin, int(experience)), max(twin, int(experience))
                if older not in duplicates and newer not in duplicates.values():
                    duplicates[newer] = older  # the older experience stays
        if not duplicates:
            return place
        frames = self._frame_experiences.view
        trajectory = self.trajectory()
        remap = themap.fuse(duplicates)
        fused = np.isin(frames, list(duplicates))
        self._frame_experiences = GrowingArray.of(remap[frames], 0, np.int64)
        if fused.any():  # re-express those frames relative to the experience they now belong to
            anchors = themap.poses[remap[frames[fused]]]
            offsets = relative(anchors, trajectory[fused])
            self._frame_offsets.data[np.flatnonzero(fused)] = offsets
        self.merges = [(frame, int(remap[experience])) for frame, experience in self.merges]
        logger.info("fused %d experiences of the merged map into the ones they duplicate", len(duplicates))
        return int(remap[place])

    def _codes_after(self, poses: np.ndarray, yaw: float, translation: np.ndarray,
                     anchor: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """Grid and head-direction codes of experiences at ``poses`` moved by (``yaw``, ``translation``), from
        their metric offsets to ``anchor`` = (pose, grid code, head-direction code), wrapped."""
        moved = compose(np.array([*translation[:3], yaw]), poses)
        pose, grid_code, direction_code = anchor
        grid_size = np.asarray(self.config.grid_cells.size, dtype=float)
        direction_size = np.asarray(self.config.head_direction.size, dtype=float)
        cell = np.asarray(self.config.grid_cells.cell_size, dtype=float)
        height_cell = self.config.head_direction.height_cell_size
        grid = (grid_code + (moved[:, :3] - pose[:3]) / cell) % grid_size
        turn = wrap(moved[:, 3] - pose[3])
        direction = np.stack([direction_code[0] + turn / self.head_direction.yaw_cell_size,
                              direction_code[1] + (moved[:, 2] - pose[2]) / height_cell], axis=1)
        return grid, direction % direction_size

    def _relocate(self, place: int, relative_yaw: float, grid_code: np.ndarray, direction_code: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Move both packets to a confirmed place's codes, unless NeuroSLAM eq. 22 already matches it there.

        The packets are shifted whole (the same exact shift as path integration, NeuroSLAM eqs. 6–9 and 17–20),
        so they keep their resting shape. Returns the decoded codes afterwards.
        """
        themap = self.experience_map
        target_grid = themap.grid_codes[place]
        target_direction = themap.direction_codes[place].copy()
        target_direction[0] += relative_yaw / self.head_direction.yaw_cell_size
        config = self.config.experience_map
        score = (config.grid_weight * self.grid_cells.distance(grid_code, target_grid)
                 + config.direction_weight * self.head_direction.distance(direction_code, target_direction))
        if score <= config.threshold:
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
        if template >= len(self._view_grid):
            self._view_grid = np.concatenate([self._view_grid, np.zeros_like(self._view_grid)])
            self._view_direction = np.concatenate([self._view_direction, np.zeros_like(self._view_direction)])
            self._view_decay = np.concatenate([self._view_decay, np.zeros_like(self._view_decay)])
            self._view_component = np.concatenate([self._view_component, np.zeros_like(self._view_component)])
        self._view_component[template] = self.experience_map.component
        self._view_grid[template] = grid_code
        self._view_direction[template] = direction_code
        self._view_decay[template] = (1.0, time)

    def _recall_view(self, template: int, relative_yaw: float, time: float) -> None:
        """NeuroSLAM eq. 11: a familiar view injects its learned packets.

        The decay rule: every activation adds 1 to the view's decay, which falls back exponentially
        (time constant 10 s); the injected energy is the configured strength divided by (1 + decay), so
        a view seen frame after frame (a robot standing still) does not overwhelm path integration.
        """
        decay, last = self._view_decay[template]
        decay = decay * math.exp(-(time - last) / VIEW_DECAY_TIME) + 1.0
        self._view_decay[template] = (decay, time)
        scale = 1.0 / (1.0 + decay)
        direction = self._view_direction[template].copy()
        direction[0] += relative_yaw / self.head_direction.yaw_cell_size
        self.grid_cells.inject(self._view_grid[template], self.config.grid_cells.view_injection * scale)
        self.head_direction.inject(direction, self.config.head_direction.view_injection * scale)
        self.grid_cells.normalise()
        self.head_direction.normalise()


def _library_version() -> str:
    from . import __version__

    return __version__
