"""The NeuroSLAM pipeline: one :meth:`NeuroSLAM.step` per camera frame.

Per frame, in the paper's order (Algorithm 1):

1. vision: grey image, visual odometry (or the caller's own self-motion) and the local view cells;
2. head-direction cells: attractor dynamics and path integration by the yaw and height change;
3. grid cells: attractor dynamics and path integration by the translation along the decoded yaw;
4. local view calibration: a familiar view injects the activity it learned (eqs. 10–11) into both
   networks; a new view learns the current packets;
5. experience map: the odometry since the current experience, matching, creation, loop closure and
   relaxation (eqs. 21–25). With ``loop_closure = "confirmed"`` (the ``sim`` default) a loop may close
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

from .cells import GridCells, HeadDirectionCells
from .config import Config, load_config
from .errors import InvalidInputError, InvalidParameterError
from .experience_map import ExperienceMap, _Growing
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
        self.config = _resolve(config)
        c = self.config
        self.visual_odometry = VisualOdometry(c.odometry, horizontal_fov=c.horizontal_fov, vertical_fov=c.vertical_fov,
                                              panoramic=c.panoramic)
        self.local_view = LocalViewCells(c.local_view, horizontal_fov=c.horizontal_fov, panoramic=c.panoramic)
        self.grid_cells = GridCells(c.grid_cells)
        self.head_direction = HeadDirectionCells(c.head_direction)
        self.experience_map = ExperienceMap(c.experience_map, grid_size=c.grid_cells.size,
                                            direction_size=c.head_direction.size, grid_cell_size=c.grid_cells.cell_size)
        self._view_grid = np.zeros((64, 3))
        self._view_direction = np.zeros((64, 2))
        self._view_decay = np.zeros((64, 2))  # (decay, time of last activation)
        self._image_shape: tuple[int, ...] | None = None
        self._last_time: float | None = None
        self._odometry_pose = np.zeros(4)
        # the last frames' (odometry pose, template id), for the confirmed loop-closure rule
        self._recent: deque[tuple[np.ndarray, int]] = deque(maxlen=c.experience_map.confirmation_window)
        self._since_closure = 0.0  # m driven since the robot was last on an old experience (or closed a loop)
        # per frame: its experience and the robot's pose relative to it (x, y, z, yaw), for trajectory()
        self._frame_experiences = _Growing(0, np.int64)
        self._frame_offsets = _Growing(4, np.float64)
        self.frames = 0
        self.last: Estimate | None = None
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
        if np.issubdtype(array.dtype, np.floating) and not np.all(np.isfinite(array)):
            raise InvalidInputError("image", "with NaN or infinity", "must be finite")
        if self._image_shape is not None and array.shape != self._image_shape:
            raise InvalidInputError("image", f"shape {array.shape}",
                                    f"differs from the first frame's {self._image_shape}")
        if not isinstance(timestamp, (int, float, np.integer, np.floating)) or not math.isfinite(timestamp):
            raise InvalidInputError("timestamp", repr(timestamp), "must be a finite number of seconds")
        if self._last_time is not None and timestamp <= self._last_time:
            raise InvalidInputError("timestamp", repr(timestamp), f"must increase (previous: {self._last_time!r})")
        if odometry is not None:
            if not isinstance(odometry, SelfMotion):
                raise InvalidInputError("odometry", type(odometry).__name__, "must be a SelfMotion")
            try:
                odometry.validate()
            except ValueError as error:
                raise InvalidInputError("odometry", str(error), "must be finite") from None
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

        self.head_direction.step(yaw_change, climb)
        direction_code = self.head_direction.decode()
        heading = direction_code[0] * self.head_direction.yaw_cell_size
        self.grid_cells.step((distance * math.cos(heading), distance * math.sin(heading), climb))
        grid_code = self.grid_cells.decode()

        if view.new:
            self._learn_view(view.template_id, grid_code, direction_code, float(timestamp))
        else:  # the injection moves the packets: read them out again
            self._recall_view(view.template_id, view.relative_yaw, float(timestamp))
            grid_code = self.grid_cells.decode()
            direction_code = self.head_direction.decode()
        x, y, z, yaw = self._odometry_pose
        middle = yaw + yaw_change / 2
        self._odometry_pose = np.array([x + distance * math.cos(middle), y + distance * math.sin(middle), z + climb,
                                        math.atan2(math.sin(yaw + yaw_change), math.cos(yaw + yaw_change))])
        may_close_loop = True
        self._since_closure += distance
        if self.config.experience_map.loop_closure == "confirmed":
            spacing = self.config.experience_map.confirmation_spacing
            # the newest entry is the latest frame; it stays once it lies ``spacing`` beyond the one before
            if (len(self._recent) < 2 or spacing == 0
                    or np.linalg.norm(self._recent[-1][0][:3] - self._recent[-2][0][:3]) >= spacing):
                self._recent.append((self._odometry_pose, view.template_id))
            else:
                self._recent[-1] = (self._odometry_pose, view.template_id)
            place = -1 if view.new else self._confirmed_place(view.relative_yaw, float(timestamp))
            may_close_loop = place >= 0
            if may_close_loop:
                grid_code, direction_code = self._relocate(place, view.relative_yaw, grid_code, direction_code)

        self.experience_map.integrate(distance, yaw_change, climb)
        update = self.experience_map.update(view.template_id, grid_code, direction_code, float(timestamp),
                                            may_close_loop=may_close_loop)
        if update.loop_closure or (not update.new_experience and self.experience_map.creation_times[
                update.experience_id] < timestamp - self.config.experience_map.confirmation_age):
            self._since_closure = 0.0  # on an old experience: localised in the map
        self._frame_experiences.append(update.experience_id)
        self._frame_offsets.append(self.experience_map.relative)
        self._image_shape = array.shape
        self._last_time = float(timestamp)
        self.frames += 1
        self.last = Estimate(float(timestamp), self.experience_map.robot_pose(), update.experience_id,
                             view.template_id, update.loop_closure, update.new_experience, view.new, motion,
                             grid_code, direction_code)
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
        cos, sin = np.cos(anchors[:, 3]), np.sin(anchors[:, 3])
        yaw = anchors[:, 3] + offsets[:, 3]
        return np.stack([anchors[:, 0] + cos * offsets[:, 0] - sin * offsets[:, 1],
                         anchors[:, 1] + sin * offsets[:, 0] + cos * offsets[:, 1],
                         anchors[:, 2] + offsets[:, 2], np.arctan2(np.sin(yaw), np.cos(yaw))], axis=1)

    # saving and loading ----------------------------------------------------------------------------------
    def state_dict(self) -> dict[str, np.ndarray]:
        """Every part of the state, as named arrays (dotted names: ``grid_cells.activity``,
        ``experience_map.poses``, ...): what :meth:`save` writes and :meth:`load_state_dict` restores."""
        state: dict[str, np.ndarray] = {}
        parts = {"odometry": self.visual_odometry, "local_view": self.local_view,
                 "grid_cells": self.grid_cells.network, "head_direction": self.head_direction.network,
                 "experience_map": self.experience_map}
        for prefix, part in parts.items():
            state.update({f"{prefix}.{key}": value for key, value in part.state_dict().items()})
        templates = self.local_view.count
        recent_poses = np.array([pose for pose, _ in self._recent]).reshape(-1, 4)
        state.update({
            "slam.view_grid": self._view_grid[:templates].copy(),
            "slam.view_direction": self._view_direction[:templates].copy(),
            "slam.view_decay": self._view_decay[:templates].copy(),
            "slam.image_shape": np.array(self._image_shape or (), dtype=np.int64),
            "slam.last_time": np.float64(math.nan if self._last_time is None else self._last_time),
            "slam.odometry_pose": self._odometry_pose.copy(),
            "slam.recent_poses": recent_poses,
            "slam.recent_templates": np.array([template for _, template in self._recent], dtype=np.int64),
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
                SLAM may then be half restored, so use a fresh instance (as :meth:`load` does).
        """
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
            capacity = max(64, templates)
            self._view_grid, self._view_direction, self._view_decay = (
                np.concatenate([array, np.zeros((capacity - templates, array.shape[1]))])
                for array in (view_grid, view_direction, view_decay))
            shape = tuple(int(n) for n in state["slam.image_shape"])
            self._image_shape = shape or None
            last_time = float(state["slam.last_time"])
            self._last_time = None if math.isnan(last_time) else last_time
            self._odometry_pose = np.asarray(state["slam.odometry_pose"], dtype=float).copy()
            recent = zip(np.asarray(state["slam.recent_poses"], dtype=float), state["slam.recent_templates"],
                         strict=True)
            self._recent = deque(((pose.copy(), int(template)) for pose, template in recent),
                                 maxlen=self.config.experience_map.confirmation_window)
            self._since_closure = float(state["slam.since_closure"])
            self._frame_experiences = _Growing.of(state["slam.frame_experiences"], 0, np.int64)
            self._frame_offsets = _Growing.of(state["slam.frame_offsets"], 4, np.float64)
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

    def _confirmed_place(self, relative_yaw: float, time: float) -> int:
        """The old experience the last frames confirm (:func:`~neuroslam.loop_closure.confirm_place`), or -1.

        Old: made more than ``confirmation_age`` ago. The search radius grows with the distance driven
        since the robot was last on an old experience (``confirmation_drift`` per metre, and
        ``confirmation_climb_error`` per metre for heights).
        """
        config = self.config.experience_map
        themap = self.experience_map
        return confirm_place(
            np.array([pose for pose, _ in self._recent]), np.array([template for _, template in self._recent]),
            relative_yaw, themap.poses, themap.experiences_of, themap.creation_times < time - config.confirmation_age,
            themap.robot_pose(), radius=config.confirmation_tolerance + config.confirmation_drift * self._since_closure,
            height_radius=config.confirmation_tolerance + config.confirmation_climb_error * self._since_closure,
            tolerance=config.confirmation_tolerance, matches=config.confirmation_matches,
            climb_error=config.confirmation_climb_error)

    def _relocate(self, place: int, relative_yaw: float, grid_code: np.ndarray, direction_code: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
        """Move both packets to a confirmed place's codes, unless eq. 22 already matches it there.

        The packets are shifted whole (the same exact shift as path integration, eqs. 6–9), so they keep
        their resting shape. Returns the decoded codes afterwards.
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
        """Eq. 10: a new local view cell associates with the current grid and head-direction packets."""
        if template >= len(self._view_grid):
            self._view_grid = np.concatenate([self._view_grid, np.zeros_like(self._view_grid)])
            self._view_direction = np.concatenate([self._view_direction, np.zeros_like(self._view_direction)])
            self._view_decay = np.concatenate([self._view_decay, np.zeros_like(self._view_decay)])
        self._view_grid[template] = grid_code
        self._view_direction[template] = direction_code
        self._view_decay[template] = (1.0, time)

    def _recall_view(self, template: int, relative_yaw: float, time: float) -> None:
        """Eq. 11: a familiar view injects its learned packets.

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


def _resolve(config: Config | str | Path | None) -> Config:
    if config is None:
        return Config()
    if isinstance(config, Config):
        return config
    if isinstance(config, (str, Path)):
        text = str(config)
        if text.endswith((".toml", ".json")) or Path(text).is_file():
            return load_config(text)
        from . import presets

        return presets.get(text)
    raise InvalidParameterError("config", type(config).__name__, "must be a Config, a preset name or a file path")
