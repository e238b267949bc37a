"""Saving and restoring a whole NeuroSLAM: every part's state as named arrays, and map files.

:class:`StateMixin` is the part of :class:`~neuroslam.slam.NeuroSLAM` that turns its state into named arrays
(``state_dict``), restores them all or nothing (``load_state_dict``), and writes and reads map files
(``save``, ``load``; the format is :mod:`neuroslam.maps`).
"""

from __future__ import annotations

import logging
import math
from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .arrays import GrowingArray
from .config import Config
from .errors import InvalidParameterError
from .estimate import Estimate
from .maps import MapFileError, read_map, write_map
from .sessions import WindowHistory
from .vision.odometry import SelfMotion

if TYPE_CHECKING:
    from .slam import NeuroSLAM

__all__ = ["MAP_FILE", "StateMixin"]

logger = logging.getLogger("neuroslam.slam")

MAP_FILE = "map.npz"  # the map's file name in a run's output folder


class StateMixin:
    """Saving and loading (see the module); mixed into :class:`~neuroslam.slam.NeuroSLAM`."""

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
            **{f"slam.{name}": array for name, array in self.view_associations.state_dict(templates).items()},
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
        if self._unmerged is not None:  # a session whose own map has not merged yet
            state.update({f"slam.unmerged.{name}": array for name, array in self._unmerged.state_dict().items()})
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
            self.view_associations.load_state_dict(part("slam"), templates)
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
            unmerged = {key.removeprefix("slam.unmerged."): value for key, value in state.items()
                        if key.startswith("slam.unmerged.")}
            self._unmerged = (WindowHistory.from_state(unmerged, self.config.experience_map.confirmation_views,
                                                       self.frames, self.local_view.count) if unmerged else None)
            self.closures_before_merge = []
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


def _library_version() -> str:
    from . import __version__

    return __version__
