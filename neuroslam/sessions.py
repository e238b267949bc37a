"""Sessions: one map across several drives (the multisession paper, Menezes et al. 2023).

:class:`SessionsMixin` is the part of :class:`~neuroslam.slam.NeuroSLAM` that begins a new session in a held
map, holds further saved maps (``add_map``), finds where the robot's map meets another
(:meth:`SessionsMixin._merge_place`), merges the two (multisession eqs. 11–17, generalised to 4 DoF) and
fuses the experiences that duplicate each other.
"""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .arrays import GrowingArray
from .errors import InvalidInputError, InvalidParameterError
from .geometry import compose, inverse, relative, wrap
from .loop_closure import confirm_place
from .vision.odometry import VisualOdometry

if TYPE_CHECKING:
    from .slam import NeuroSLAM

__all__ = ["SessionsMixin", "WindowHistory"]

logger = logging.getLogger("neuroslam.slam")


class WindowHistory:
    """The confirmation window's entries since a session began, kept until the session's own map first merges
    into a loaded one (:meth:`SessionsMixin._close_before_merge` tests them again then; a later merge of the
    same session looks back no further). One row per entry (about one a metre): its frame index, time (s),
    odometry pose (x, y, z, yaw; m, rad), view (template id), the other templates its view matched (-1
    padded), the view's relative yaw (rad), the map's odometer (m), whether nothing observed the distance on
    it, and the seconds nothing observed it since the experience the robot was at (eq. M5)."""

    def __init__(self, views: int):
        self.frames = GrowingArray(0, np.int64)
        self.times = GrowingArray(0, np.float64)
        self.poses = GrowingArray(4, np.float64)
        self.templates = GrowingArray(0, np.int64)
        self.alternatives = GrowingArray(max(views - 1, 1), np.int64)
        self.relative_yaws = GrowingArray(0, np.float64)
        self.odometers = GrowingArray(0, np.float64)
        self.blind = GrowingArray(0, np.bool_)
        self.blind_seconds = GrowingArray(0, np.float64)

    NAMES = ("frames", "times", "poses", "templates", "alternatives", "relative_yaws", "odometers", "blind",
             "blind_seconds")

    @property
    def count(self) -> int:
        return self.frames.count

    def state_dict(self) -> dict[str, np.ndarray]:
        """The rows as arrays, by :attr:`NAMES`."""
        return {name: getattr(self, name).view.copy() for name in self.NAMES}

    @classmethod
    def from_state(cls, state: dict[str, np.ndarray], views: int, frames: int, templates: int) -> WindowHistory:
        """The history :meth:`state_dict` gave, of a session at ``frames`` frames with ``templates`` views;
        ValueError if its arrays do not fit together or name a frame or view that does not exist."""
        history = cls(views)
        for name in cls.NAMES:
            template = getattr(history, name)
            columns = template.data.shape[1] if template.data.ndim == 2 else 0
            setattr(history, name, GrowingArray.of(state[name], columns, template.data.dtype))
        if len({getattr(history, name).count for name in cls.NAMES}) != 1:
            raise ValueError("the window history's arrays differ in length")
        entries = history.frames.view
        if len(entries) and (entries.min() < 0 or entries.max() >= frames or np.any(np.diff(entries) <= 0)):
            raise ValueError("the window history names frames out of order or that do not exist")
        views_named = np.concatenate([history.templates.view, history.alternatives.view.ravel()])
        if np.any(views_named >= templates) or np.any(history.templates.view < 0):
            raise ValueError("the window history names a view that does not exist")
        return history

    def add(self, frame: int, time: float, pose: np.ndarray, template: int, alternatives: tuple[int, ...],
            relative_yaw: float, odometer: float, blind: bool, blind_seconds: float, *, replace: bool) -> None:
        """Append an entry, or overwrite the newest (``replace``: the window replaced its newest entry)."""
        others = np.full(self.alternatives.data.shape[1], -1, dtype=np.int64)
        others[: len(alternatives)] = alternatives[: len(others)]
        row = (frame, time, pose, template, others, relative_yaw, odometer, blind, blind_seconds)
        for array, value in zip((getattr(self, name) for name in self.NAMES), row, strict=True):
            if replace and array.count:
                array.data[array.count - 1] = value
            else:
                array.append(value)


class SessionsMixin:
    """Sessions and merging (see the module); mixed into :class:`~neuroslam.slam.NeuroSLAM`."""

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
        self.view_associations.forget_activations()
        self._frame_experiences = GrowingArray(0, np.int64)
        self._frame_offsets = GrowingArray(4, np.float64)
        self.frames = 0
        self.last = None
        self.merges = []
        self.closures_before_merge = []
        self._unmerged = WindowHistory(self.config.experience_map.confirmation_views)
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
        if not isinstance(other, type(self)):
            raise InvalidInputError("map", type(other).__name__, "must be a NeuroSLAM or the path of a map file")
        if other.config != self.config:
            raise InvalidInputError("map", "with another configuration", "must share this SLAM's configuration")
        themap = self.experience_map
        count = self.local_view.count
        component_offset = 1 + max(int(themap.components.max()) if themap.size else 0,
                                   int(self.view_associations.component[:count].max()) if count else 0,
                                   themap.component)
        first = self.local_view.extend(other.local_view)
        added = other.local_view.count
        self.view_associations.extend(other.view_associations, first, added, component_offset)
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
        self._unmerged = None  # the robot is in the loaded map: its map will not merge into it
        direction = themap.direction_codes[place].copy()
        direction[0] += view.relative_yaw / self.head_direction.yaw_cell_size
        self.grid_cells.network.reset(themap.grid_codes[place])
        self.head_direction.network.reset(direction)
        logger.info("known start: at experience %d (view %d)", place, view.template_id)

    def _merge_place(self, template: int, relative_yaw: float) -> int:
        """An experience of another map (component) that the last frames confirm the robot is at, or -1.

        :func:`~neuroslam.loop_closure.confirm_place` over each other component that holds the current
        view, with no search radius (where the robot is in that map is unknown): every window frame's view
        must lie where the hypothesis puts it, and a view is no evidence for a hypothesis where its places near
        where that hypothesis puts the frame spread over more than twice the tolerance (``local_reach``: within
        twice the tolerance plus ``confirmation_drift`` per metre of the window). A view the map holds again
        far away still says where the robot is; a run of views along one lane of a repetitive place that also
        fits a look-alike lane (the car park's deck, whose north and south lanes look the same) confirms both
        lanes, and two rival places confirm nothing. Two components both confirmed: nothing (ambiguous).
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
                                  matches=config.confirmation_matches, climb_error=config.confirmation_climb_error,
                                  local_reach=True, drift=config.confirmation_drift)
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
        associations = self.view_associations
        views = np.flatnonzero(associations.component[:count] == moving)
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
            offset = ((associations.grid[views] - old_grid + grid_size / 2) % grid_size - grid_size / 2) * cell
            c, s = math.cos(yaw), math.sin(yaw)
            rotated = np.stack([c * offset[:, 0] - s * offset[:, 1], s * offset[:, 0] + c * offset[:, 1],
                                offset[:, 2]], axis=1) / cell
            turn = (associations.direction[views] - old_direction + direction_size / 2) % direction_size \
                - direction_size / 2
            associations.grid[views] = (new_grid + rotated) % grid_size
            associations.direction[views] = (new_direction + turn) % direction_size
            associations.component[views] = staying
        themap.move_component(moving, staying, yaw, translation, grid_codes, direction_codes)
        place = self._fuse_duplicates(moved, place)
        self._since_closure = 0.0
        self.closures_before_merge = []
        if robot_moves and self.config.experience_map.loop_closure == "confirmed":
            self._close_before_merge()
        elif robot_moves:
            self._unmerged = None
        logger.info("merged map %d (%d experiences, %d views) into map %d at experience %d: yaw %.1f deg, "
                    "shift (%.2f, %.2f, %.2f) m", moving, len(moved), len(views), staying, place, math.degrees(yaw),
                    *translation)
        if robot_moves:
            return self._relocate(place, relative_yaw, grid_code, direction_code)
        return grid_code, direction_code

    def _close_before_merge(self) -> None:
        """The loop closures a merge makes possible among the frames driven before it (issue 23's multisession).

        Before the merge the session's own map was joined to nothing: where its frames re-drove places of the
        loaded map, no loop could close (the merge's test, without a search radius, counts no view seen at
        several places), and that part of its map hangs from the merge alone, its far end as far off as the
        odometry drifted. Now the robot's place in the loaded map is known at the merge, and at each earlier
        frame to within the odometry's drift over the distance between them. So the confirmation window's
        entries since the session began are tested again, newest first, as the frames would have been tested
        had the maps been one: by :func:`~neuroslam.loop_closure.confirm_place` (the ``confirmed`` rule's test;
        only under that rule) over the window of the entry and the ``confirmation_window - 1`` after it, driven
        backwards so that the entry is its newest frame, with its view's relative yaw, the loaded maps'
        experiences eligible, and the search radius ``confirmation_tolerance`` plus ``confirmation_drift`` per
        metre driven from the merge or from the last closure found. A blind entry is refused unless
        ``confirmation_blind``; the newest ``confirmation_matches - 1`` entries have windows too short (they
        are the merge's own window, whose duplicates were fused). A confirmed entry links the session's
        experience its frame was at to the confirmed place as a live loop closure would
        (:meth:`ExperienceMap.close_later`: the robot there, facing its yaw plus the view's relative yaw); an
        experience is linked once, and not to a place it is linked to already. Only the session's first merge
        that moves its map looks back. The closures found are kept, (frame, experience), in
        :attr:`closures_before_merge` for scoring."""
        history, self._unmerged = self._unmerged, None
        config = self.config.experience_map
        if history is None or history.count < config.confirmation_matches:
            return
        themap = self.experience_map
        trajectory = self.trajectory()  # every frame in the merged map
        anchors = self._frame_experiences.view
        offsets = self._frame_offsets.view
        mine = themap.sessions == themap.session
        eligible = ~mine & (themap.components == themap.component)
        correction = np.zeros(4)  # the last closure found: where it put its frame against the trajectory
        odometer = themap.odometer
        linked = set()
        for entry in range(history.count - 1, -1, -1):
            frame = int(history.frames.view[entry])
            if frame >= len(anchors):  # the merging frame itself
                continue
            source = int(anchors[frame])
            if not mine[source] or source in linked or (history.blind.view[entry] and not config.confirmation_blind):
                continue
            # the window of the entry and those after it, driven backwards: the entry is its newest frame
            window = np.arange(min(history.count, entry + config.confirmation_window) - 1, entry - 1, -1)
            if len(window) < config.confirmation_matches:
                continue
            relative_yaw = float(history.relative_yaws.view[entry])
            place = self._confirm(
                history.poses.view[window], history.templates.view[window],
                [tuple(int(other) for other in row if other >= 0) for row in history.alternatives.view[window]],
                relative_yaw, eligible, compose(correction, trajectory[frame]),
                odometer - float(history.odometers.view[entry]))
            if place < 0 or themap.components[place] != themap.component or themap.linked(source, place):
                continue
            facing = np.array([0.0, 0.0, 0.0, relative_yaw])
            themap.close_later(source, place, compose(offsets[frame], inverse(facing)),
                               float(history.times.view[entry]), float(history.blind_seconds.view[entry]))
            correction = compose(compose(themap.poses[place], facing), inverse(trajectory[frame]))
            odometer = float(history.odometers.view[entry])
            linked.add(source)
            self.closures_before_merge.append((frame, place))
        if self.closures_before_merge:
            logger.info("the merge confirmed %d loop closures among the %d frames before it",
                        len(self.closures_before_merge), int(history.frames.view[-1]) + 1)

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
