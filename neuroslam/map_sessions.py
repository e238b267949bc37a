"""The experience map's side of sessions: beginning one, holding another map, moving and fusing maps.

:class:`MapSessionsMixin` is the part of :class:`~neuroslam.experience_map.ExperienceMap` that the
multisession paper's operations need (Menezes et al. 2023): a new session's clock, entering a known
experience, appending another map as a component of its own (``absorb``), moving one component into
another's frame (multisession eqs. 13–15), and fusing experiences that duplicate each other, with the links
re-expressed so that no relative pose changes.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .arrays import GrowingArray
from .geometry import compose, inverse, wrap

if TYPE_CHECKING:
    from .experience_map import ExperienceMap

__all__ = ["STATE_ARRAYS", "MapSessionsMixin"]

# what state_dict() saves: state name → (attribute, columns, dtype)
STATE_ARRAYS = {
    "poses": ("_poses", 4, np.float64), "grid_codes": ("_grid_codes", 3, np.float64),
    "direction_codes": ("_direction_codes", 2, np.float64), "template_ids": ("_templates", 0, np.int64),
    "creation_times": ("_times", 0, np.float64), "links": ("_links", 2, np.int64),
    "link_poses": ("_link_poses", 4, np.float64), "link_times": ("_link_times", 0, np.float64),
    "link_weights": ("_link_weights", 0, np.float64), "link_blind_times": ("_link_blind", 0, np.float64),
    "degree": ("_degree", 0, np.int64), "components": ("_components", 0, np.int64),
    "sessions": ("_sessions", 0, np.int64), "odometers": ("_odometers", 0, np.float64),
    "structure_orientations": ("_structure", 0, np.float64),
    "view_yaws": ("_view_yaws", 0, np.float64), "view_differences": ("_view_differences", 0, np.float64),
}


def neighbour_pairs(links: np.ndarray, blind_times: np.ndarray) -> set[tuple[int, int]]:
    """The (source, target) pairs of the links that make two experiences neighbours on the robot's path: every
    link but eq. M8's (a place known across the path, not along it; infinitely blind in distance), which
    says nothing of how far apart its experiences lie, so that the robot may not step from one to the other
    without a loop closure."""
    return {(int(a), int(b)) for (a, b), blind in zip(links, blind_times, strict=True) if math.isfinite(blind)}


class MapSessionsMixin:
    """Sessions and merging on the map (see the module); mixed into
    :class:`~neuroslam.experience_map.ExperienceMap`."""

    def begin_session(self) -> None:
        """Start a new session in a new, empty component: the next update creates its first experience at
        the origin of the component's own frame (its pose relative to the other components is unknown
        until a merge, :meth:`move_component`)."""
        self.session = int(self.sessions.max()) + 1 if self.size else self.session + 1
        self.component = int(self.components.max()) + 1 if self.size else self.component
        self.current = -1
        self.relative = np.zeros(4)
        self.driven = np.zeros(4)
        self.odometer = 0.0
        self._restart_link()

    def enter(self, experience: int, relative: np.ndarray) -> None:
        """Put the robot at ``experience`` (its pose relative to it: ``relative``, x, y, z, yaw) and continue
        in that experience's component (a session that starts inside a known map)."""
        self.current = int(experience)
        self.component = int(self.components[experience])
        self.relative = np.asarray(relative, dtype=float).copy()
        self.driven = self.relative.copy()
        self._restart_link()

    def linked(self, first: int, second: int) -> bool:
        """A link joins the two experiences (either way)."""
        return (first, second) in self._linked or (second, first) in self._linked

    def close_later(self, source: int, target: int, relative: np.ndarray, time: float, blind: float) -> None:
        """A loop closure found after the frame it belongs to (:meth:`NeuroSLAM._close_before_merge`): link
        ``source`` → ``target`` with ``relative`` (``target``'s pose in ``source``'s frame: x, y, z, yaw; m,
        rad) as a loop closure (``closure_weight``), counted in :attr:`loop_closures`; ``time``: s, that
        frame's; ``blind``: s between ``source`` and that frame on which nothing observed the distance (eq.
        M5). The map is solved again at its next relaxation."""
        self._link(source, target, time, weight=self.config.closure_weight, relative=relative, blind=blind)
        self.loop_closures += 1
        self._settled = False

    def move_component(self, component: int, into: int, yaw: float, translation: np.ndarray,
                       grid_codes: np.ndarray, direction_codes: np.ndarray) -> np.ndarray:
        """Merge ``component`` into ``into``: its experiences rotate by ``yaw`` (rad, about z through the
        origin) and then shift by ``translation`` (x, y, z; m), take the given codes ((K, 3) grid and (K, 2)
        head-direction cells, one row per moved experience in id order), and join ``into``. Returns the ids
        moved. Links are unchanged (they are relative); the map is relaxed by the loop closure that follows."""
        moved = np.flatnonzero(self.components == component)
        poses = self._poses.data[moved]
        self._poses.data[moved] = compose(np.array([*translation[:3], yaw]), poses)
        self._grid_codes.data[moved] = grid_codes
        self._direction_codes.data[moved] = direction_codes
        self._components.data[moved] = into
        if self.component == component:
            self.component = into
        return moved

    def fuse(self, duplicates: dict[int, int]) -> np.ndarray:
        """Remove experiences that duplicate others (``duplicate: kept``; a kept one is no duplicate itself).

        A duplicate's links are moved to the one it duplicates, re-expressed through the duplicate's pose
        relative to it (so a moved link says of the kept experience what it said of the duplicate, and the
        map's shape is unchanged by the fusion: a duplicate lies within a metre and a few degrees of the
        one it duplicates, and a link that took it for exactly there would bend the map by that offset at
        every fused pair); links that would join an experience to itself are dropped, the robot's pose is
        kept if it was at a duplicate, ids close up, and a least-squares solve is started.
        Returns the new id of every old experience, (N,).
        """
        n = self.size
        replacement = np.arange(n)
        for duplicate, kept in duplicates.items():
            replacement[duplicate] = kept
        if np.any(np.isin(replacement[list(duplicates.values())], list(duplicates))):
            raise ValueError("a kept experience is itself a duplicate")
        self._reexpress_links(replacement)
        keep = np.ones(n, dtype=bool)
        keep[list(duplicates)] = False
        remap = (np.cumsum(keep) - 1)[replacement]
        if self.current >= 0:
            robot = self.robot_pose()
            self.relative = compose(inverse(self.poses[replacement[self.current]]), robot)
            self.driven = self.relative.copy()
            self.current = int(remap[self.current])
        links = remap[self.links]
        joined = links[:, 0] != links[:, 1]
        for name, (attribute, columns, dtype) in STATE_ARRAYS.items():
            rows = getattr(self, attribute).view
            if name in ("links", "link_poses", "link_times", "link_weights", "link_blind_times"):
                rows = (links if name == "links" else rows)[joined]
            elif name != "degree":
                rows = rows[keep]
            else:
                rows = np.zeros(int(keep.sum()), dtype=np.int64)
            setattr(self, attribute, GrowingArray.of(rows, columns, dtype))
        kept_links = self.links
        self._degree = GrowingArray.of(np.bincount(kept_links.ravel(), minlength=self.size), 0, np.int64)
        self._linked = neighbour_pairs(kept_links, self.link_blind_times)
        self._by_template = {}
        for experience, template in enumerate(self.template_ids):
            self._by_template.setdefault(int(template), []).append(experience)
        self._settled = False
        return remap

    def _reexpress_links(self, replacement: np.ndarray) -> None:
        """Rewrite the relative pose of every link whose source or target ``replacement`` moves onto another
        experience (NeuroSLAM eq. 23's link, composed with the moved end's pose relative to its replacement)."""
        links = self.links
        moved = np.flatnonzero((replacement[links[:, 0]] != links[:, 0]) | (replacement[links[:, 1]] != links[:, 1]))
        if len(moved) == 0:
            return
        poses = self.poses
        distance, heading, facing, height = self._link_poses.data[moved].T
        # the link as a relative pose (x, y, z, yaw) in its source's frame
        relative = np.stack([distance * np.cos(heading), distance * np.sin(heading), height, facing], axis=1)
        sources, targets = links[moved, 0], links[moved, 1]
        # the old source seen from the new one, then the link, then on from the old target to the new one
        relative = compose(compose(inverse(poses[replacement[sources]]), poses[sources]), relative)
        relative = compose(relative, compose(inverse(poses[targets]), poses[replacement[targets]]))
        self._link_poses.data[moved] = np.stack([np.hypot(relative[:, 0], relative[:, 1]),
                                                 np.arctan2(relative[:, 1], relative[:, 0]),
                                                 wrap(relative[:, 3]), relative[:, 2]], axis=1)

    def absorb(self, other: ExperienceMap, template_offset: int, component_offset: int) -> None:
        """Append another map's experiences and links (a second loaded map) as components and sessions of
        their own: view ids shifted by ``template_offset``, component ids by ``component_offset``; the
        robot's place is unchanged."""
        experience_offset = self.size
        session_offset = int(self.sessions.max()) + 1 if self.size else 0
        for name, (attribute, _, _) in STATE_ARRAYS.items():
            rows = getattr(other, attribute).view
            rows = {"template_ids": rows + template_offset, "links": rows + experience_offset,
                    "components": rows + component_offset, "sessions": rows + session_offset}.get(name, rows)
            getattr(self, attribute).extend(rows)
        self._linked |= neighbour_pairs(other.links + experience_offset, other.link_blind_times)
        for experience in range(experience_offset, self.size):
            self._by_template.setdefault(int(self.template_ids[experience]), []).append(experience)
        self.session = max(self.session, int(self.sessions.max()) if self.size else 0)
