"""The multilayered experience map (NeuroSLAM eqs. 21–25): a graph of experiences linked by 4-DoF odometry.

An experience (NeuroSLAM eq. 21) joins a conjunctive code (local view cell, 3D grid cell, head-direction cell)
with a pose (x, y, z, yaw) in the map frame. Each frame the current code is scored against every
experience (NeuroSLAM eq. 22, one vectorised pass); the best experience under the threshold becomes current, or a
new experience is created at the odometric pose and linked from the current one (NeuroSLAM eqs. 23–24). A link
stores the relative pose in its source's frame: distance, heading (direction of travel relative to the
source's yaw), facing (yaw change) and height change, plus the time it took. Re-entering an existing
experience closes a loop; relaxation (NeuroSLAM eq. 25) then pulls every pair of linked experiences towards the
relative pose their link stores, all links at once, each experience's correction divided by its
number of links (a plain sum diverges at experiences with several links); or, with ``relaxation =
"least-squares"`` (the ``sim`` default), the minimum of the same link errors is solved for directly
(:meth:`ExperienceMap._solve`), which spreads a loop's error over the whole loop.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import geometry
from .arrays import GrowingArray
from .cells.attractor import wrapped_distance
from .config import ExperienceMapConfig
from .geometry import compose, inverse, wrap
from .map_sessions import STATE_ARRAYS, MapSessionsMixin, neighbour_pairs
from .relaxation import SETTLED, StructureTerms, ViewHeadingTerms, relax_passes, solve_least_squares

__all__ = ["ExperienceMap", "MapUpdate"]

LEAST_SQUARES_TRIGGER = 1e-2  # m or rad: a loop closure with a smaller error does not start a solve


@dataclass(frozen=True)
class MapUpdate:
    """What one frame did to the map.

    Attributes:
        experience_id: the current experience after the update.
        new_experience: a new experience was created.
        loop_closure: an existing experience (other than the current one) was re-entered.
    """

    experience_id: int
    new_experience: bool
    loop_closure: bool


class ExperienceMap(MapSessionsMixin):
    """Experiences, links, matching and relaxation.

    Args:
        config: map parameters (Table 8).
        grid_size: cells of the grid-cell network (x, y, z), for wrapped code distances.
        direction_size: cells of the head-direction network (yaw, height).
        grid_cell_size: metres per grid cell (x, y, z), to turn a code difference into an offset.
    """

    def __init__(self, config: ExperienceMapConfig = ExperienceMapConfig(), *,
                 grid_size: tuple[int, int, int] = (36, 36, 36), direction_size: tuple[int, int] = (36, 36),
                 grid_cell_size: tuple[float, float, float] = (1.0, 1.0, 1.0)):
        config.validate("experience_map")
        self.config = config
        self.grid_size = grid_size
        self.direction_size = direction_size
        self.grid_cell_size = np.asarray(grid_cell_size, dtype=float)
        self._poses = GrowingArray(4, np.float64)
        self._grid_codes = GrowingArray(3, np.float64)
        self._direction_codes = GrowingArray(2, np.float64)
        self._templates = GrowingArray(0, np.int64)
        self._times = GrowingArray(0, np.float64)
        self._links = GrowingArray(2, np.int64)
        self._link_poses = GrowingArray(4, np.float64)  # distance, heading, facing, height change
        self._link_times = GrowingArray(0, np.float64)
        self._link_weights = GrowingArray(0, np.float64)  # of each link's errors in the least-squares map
        self._link_blind = GrowingArray(0, np.float64)  # each link's seconds blind in distance (eq. M5)
        self._degree = GrowingArray(0, np.int64)
        self._components = GrowingArray(0, np.int64)  # which connected map each experience belongs to
        self._sessions = GrowingArray(0, np.int64)  # which session made each experience
        self._odometers = GrowingArray(0, np.float64)  # the session's path length when each experience was made, m
        self._structure = GrowingArray(0, np.float64)  # the floor lines' orientation when each was made (eq. M4), rad
        # the view's yaw relative to its template, and its match difference, when each was made (eq. M6)
        self._view_yaws = GrowingArray(0, np.float64)
        self._view_differences = GrowingArray(0, np.float64)
        self._structure_odometer = 0.0  # m, the odometer when eq. M4 last started a solve
        self._blind_since = 0.0  # s since the current experience whose distance nothing observed (eq. M5)
        self._linked: set[tuple[int, int]] = set()
        self._by_template: dict[int, list[int]] = {}
        self._settled = True
        self.current = -1
        self.relative = np.zeros(4)  # odometric pose of the robot in the current experience's frame
        # the robot's pose in the current experience's frame as the next link carries it: the odometry since the last
        # experience made or closed onto, re-expressed on each re-entry; differs from relative only with
        # reentry_links_driven (a re-entry places the robot by the codes, but the link keeps the driven path)
        self.driven = np.zeros(4)
        self.loop_closures = 0
        self.component = 0  # the map the robot is in: new experiences join it, only its experiences match
        self.session = 0  # the current session (see begin_session)
        self.odometer = 0.0  # m, the path length driven in this session (|distance| summed by integrate)

    # the map as arrays -----------------------------------------------------------------------------------
    @property
    def size(self) -> int:
        """Number of experiences."""
        return self._poses.count

    @property
    def poses(self) -> np.ndarray:
        """(N, 4) experience poses x, y, z (m), yaw (rad)."""
        return self._poses.view

    @property
    def grid_codes(self) -> np.ndarray:
        """(N, 3) grid-cell codes, fractional cells."""
        return self._grid_codes.view

    @property
    def direction_codes(self) -> np.ndarray:
        """(N, 2) head-direction codes (yaw, height), fractional cells."""
        return self._direction_codes.view

    @property
    def template_ids(self) -> np.ndarray:
        """(N,) local view cell of each experience."""
        return self._templates.view

    @property
    def creation_times(self) -> np.ndarray:
        """(N,) time each experience was created, s."""
        return self._times.view

    @property
    def links(self) -> np.ndarray:
        """(L, 2) source and target experience of each link."""
        return self._links.view

    @property
    def link_poses(self) -> np.ndarray:
        """(L, 4) distance (m), heading (rad), facing (rad), height change (m) of each link."""
        return self._link_poses.view

    @property
    def components(self) -> np.ndarray:
        """(N,) the connected map each experience belongs to. Experiences of different components have
        poses in unrelated frames (separate sessions that have not merged yet)."""
        return self._components.view

    @property
    def sessions(self) -> np.ndarray:
        """(N,) the session that created each experience (0 for the first)."""
        return self._sessions.view

    @property
    def link_weights(self) -> np.ndarray:
        """(L,) weight of each link's squared errors in the least-squares map (1 for a driven link,
        ``closure_weight`` for a loop closure's)."""
        return self._link_weights.view

    @property
    def link_blind_times(self) -> np.ndarray:
        """(L,) seconds of each link on which nothing observed the distance (the visual odometry held it or read
        none; 0 for a link made before this was kept). Such a link's length weighs less than its direction in
        the least-squares map (eq. M5 of :mod:`neuroslam.relaxation`, :meth:`length_weights`)."""
        return self._link_blind.view

    @property
    def along_path_closures(self) -> int:
        """Eq. M8's links in the map (a place known across the path, not along it: the links infinitely blind in
        distance, :meth:`_link_along_path`); not loop closures."""
        return int(np.count_nonzero(np.isinf(self.link_blind_times)))

    @property
    def blind_since(self) -> float:
        """s since the current experience on which nothing observed the distance (what a link made now carries
        for eq. M5)."""
        return self._blind_since

    def length_weights(self) -> np.ndarray:
        """(L,) each link's weight along its direction of travel in the least-squares map (eq. M5): its weight
        times s² / (s² + (b t)²), s = ``link_length_error`` (m, a link's length where its distance was seen),
        b = ``blind_speed_error`` (m/s), t its seconds blind: the unseen distance's error grows with the time
        nothing saw it (a held speed, then none, is the same error every frame, so they add up)."""
        config = self.config
        return self.link_weights / (1 + (config.blind_speed_error * self.link_blind_times
                                         / config.link_length_error) ** 2)

    @property
    def odometers(self) -> np.ndarray:
        """(N,) the path length its session had driven when each experience was made, m (-inf: unknown, a
        map saved before it was kept)."""
        return self._odometers.view

    @property
    def view_yaws(self) -> np.ndarray:
        """(N,) rad, the view's yaw relative to its template when each experience was made (0 where the view
        was learned then; NaN where its match did not pin the yaw, and in a map saved before eq. M6)."""
        return self._view_yaws.view

    @property
    def view_differences(self) -> np.ndarray:
        """(N,) the view's match difference when each experience was made (0 where it was learned then)."""
        return self._view_differences.view

    @property
    def structure_orientations(self) -> np.ndarray:
        """(N,) the orientation of the floor's straight lines in each experience's frame when it was made (rad,
        modulo 90°: phi of eq. M2 of :mod:`neuroslam.vision.structure`); NaN where none were seen."""
        return self._structure.view

    @property
    def link_times(self) -> np.ndarray:
        """(L,) seconds between leaving the source and reaching the target."""
        return self._link_times.view

    @property
    def settled(self) -> bool:
        """No relaxation is pending: the last loop closure's error has been spread (or there was none)."""
        return self._settled

    def state_dict(self) -> dict[str, np.ndarray]:
        """Experiences, links and the robot's place among them, for saving (:meth:`load_state_dict`)."""
        state = {name: getattr(self, attribute).view.copy() for name, (attribute, _, _) in STATE_ARRAYS.items()}
        state.update(settled=np.bool_(self._settled), current=np.int64(self.current), relative=self.relative.copy(),
                     driven=self.driven.copy(),
                     loop_closures=np.int64(self.loop_closures), component=np.int64(self.component),
                     session=np.int64(self.session), odometer=np.float64(self.odometer),
                     structure_odometer=np.float64(self._structure_odometer),
                     blind_since=np.float64(self._blind_since))
        return state

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it is inconsistent."""
        grown = {}
        for name, (attribute, columns, dtype) in STATE_ARRAYS.items():
            if name == "link_weights" and name not in state and "links" in state:
                rows = np.ones(len(state["links"]))  # a map saved before links had weights: all alike
            elif name == "link_blind_times" and name not in state and "links" in state:
                rows = np.zeros(len(state["links"]))  # a map saved before eq. M5: every length observed
            elif name == "odometers" and name not in state and "poses" in state:
                rows = np.full(len(state["poses"]), -np.inf)  # a map saved before odometers were kept
            elif name == "structure_orientations" and name not in state and "poses" in state:
                rows = np.full(len(state["poses"]), np.nan)  # a map saved before eq. M4: no lines seen
            elif name in ("view_yaws", "view_differences") and name not in state and "poses" in state:
                rows = np.full(len(state["poses"]), np.nan)  # a map saved before eq. M6: no view's heading
            else:
                rows = state[name]
            try:
                grown[attribute] = GrowingArray.of(rows, columns, dtype)
            except ValueError as error:
                raise ValueError(f"{name}: {error}") from None
        size, links = grown["_poses"].count, grown["_links"].view
        if any(grown[attribute].count != size for attribute in ("_grid_codes", "_direction_codes", "_templates",
                                                                 "_times", "_degree", "_components", "_sessions",
                                                                 "_odometers", "_structure", "_view_yaws",
                                                                 "_view_differences")):
            raise ValueError("the per-experience arrays differ in length")
        if any(grown[attribute].count != len(links) for attribute in ("_link_poses", "_link_times", "_link_weights",
                                                                   "_link_blind")):
            raise ValueError("the per-link arrays differ in length")
        if len(links) and (links.min() < 0 or links.max() >= size):
            raise ValueError("a link names an experience that does not exist")
        current, relative = int(state["current"]), np.asarray(state["relative"], dtype=float)
        if not -1 <= current < size or (current == -1) != (size == 0) or relative.shape != (4,):
            raise ValueError(f"current experience {current} does not fit a map of {size}")
        for attribute, value in grown.items():
            setattr(self, attribute, value)
        self._linked = neighbour_pairs(links, self.link_blind_times)
        self._by_template = {}
        for experience, template in enumerate(self.template_ids):
            self._by_template.setdefault(int(template), []).append(experience)
        self._settled = bool(state["settled"])
        self.current = current
        self.relative = relative.copy()
        self.driven = np.asarray(state.get("driven", relative), dtype=float).copy()  # saved before: the same
        self.loop_closures = int(state["loop_closures"])
        self.component = int(state["component"])
        self.session = int(state["session"])
        self.odometer = float(state.get("odometer", 0.0))
        self._structure_odometer = float(state.get("structure_odometer", self.odometer))
        self._blind_since = float(state.get("blind_since", 0.0))

    def robot_pose(self) -> np.ndarray:
        """The robot's pose in the map: the current experience composed with the odometry since it."""
        if self.current < 0:
            return self.relative.copy()
        return compose(self.poses[self.current], self.relative)

    def _offset(self, experience: int, grid_code: np.ndarray, direction_code: np.ndarray) -> np.ndarray:
        """Where the robot is relative to ``experience``, from the difference of their codes: the grid-cell
        difference (wrapped, in metres) rotated into the experience's frame, and the yaw difference."""
        size = np.asarray(self.grid_size, dtype=float)
        difference = (np.asarray(grid_code) - self.grid_codes[experience] + size / 2) % size - size / 2
        metres = difference * self.grid_cell_size
        yaw = self.poses[experience, 3]
        c, s = math.cos(yaw), math.sin(yaw)
        yaw_cells = self.direction_size[0]
        turn = ((direction_code[0] - self.direction_codes[experience, 0] + yaw_cells / 2) % yaw_cells - yaw_cells / 2)
        return np.array([c * metres[0] + s * metres[1], -s * metres[0] + c * metres[1], metres[2],
                         turn * 2 * math.pi / yaw_cells])

    # per frame ----------------------------------------------------------------------------------------
    def integrate(self, distance: float, yaw_change: float, height_change: float, drift: float = 0.0, *,
                  blind_time: float = 0.0) -> None:
        """Add one frame of self-motion (m, rad, m) to the odometry since the current experience; ``drift``
        (rad) turns the direction of travel off the heading (the grid network's read-out, grid-network eq. 5);
        ``blind_time``: s of this frame on which nothing observed the distance (it was held or is zero; the
        frame's interval or 0), counted for the link the odometry will make (eq. M5)."""
        for pose in (self.relative, self.driven):
            heading = pose[3] + yaw_change / 2 + drift
            pose += [distance * math.cos(heading), distance * math.sin(heading), height_change, yaw_change]
        self.odometer += abs(distance)
        self._blind_since += blind_time

    def scores(self, template_id: int, grid_code: np.ndarray, direction_code: np.ndarray) -> np.ndarray:
        """NeuroSLAM eq. 22 against every experience: weighted view mismatch plus wrapped code distances (cells)."""
        view = (self.template_ids != template_id).astype(float)
        return self.config.view_weight * view + self.code_scores(np.arange(self.size), grid_code, direction_code)

    def code_scores(self, experiences: np.ndarray, grid_code: np.ndarray, direction_code: np.ndarray) -> np.ndarray:
        """NeuroSLAM eq. 22's code terms against ``experiences`` (ids): weighted wrapped code distances (cells)."""
        config = self.config
        return (config.grid_weight * wrapped_distance(self.grid_codes[experiences], grid_code, self.grid_size)
                + config.direction_weight * wrapped_distance(self.direction_codes[experiences], direction_code,
                                                             self.direction_size))

    def experiences_of(self, template_id: int) -> np.ndarray:
        """Ids of the experiences whose view is ``template_id``, oldest first."""
        return np.asarray(self._by_template.get(int(template_id), ()), dtype=np.int64)

    def _candidates(self, template_id: int) -> np.ndarray:
        """Experiences that can score under the threshold: those of the robot's component (the map it is
        in); when a different view alone costs more than the threshold, only those of this view (an exact
        shortcut, not an approximation)."""
        if self.config.view_weight > self.config.threshold:
            candidates = self.experiences_of(template_id)
        else:
            candidates = np.arange(self.size)
        return candidates[self.components[candidates] == self.component]

    def update(self, template_id: int, grid_code: np.ndarray, direction_code: np.ndarray, time: float, *,
               may_close_loop: bool = True, place: int = -1, structure: float = math.nan,
               view_yaw: float = 0.0, view_difference: float = 0.0, along_path: int = -1,
               along_path_yaw: float = 0.0) -> MapUpdate:
        """Match the current conjunctive code, create or re-enter an experience, relax after a loop closure.

        With ``may_close_loop`` False (an unconfirmed place under the ``confirmed`` rule) a match that
        would close a loop creates a new experience instead, unless the robot has not driven since it made
        the matched experience (:meth:`_on_the_spot`): then it is re-entered as the robot follows the map,
        with no link and no loop closure (its pose is the robot's place; no map correction is needed).
        ``place`` (an experience id of this view, or -1): the place a run of views confirmed; a loop closes
        there, not at whichever other experience of the view scores best (along a corridor a view has
        experiences every metre or two, and the drifted codes may lie nearer a neighbour of the confirmed
        one). When NeuroSLAM eq. 22 re-enters the current experience
        or one linked to it, that stands (the robot follows the map; no loop closes). ``structure``: the
        orientation of the floor's straight lines in the robot's frame this frame (rad, modulo 90°; NaN where
        none were seen), kept with an experience made now for eq. M4 (``structure_weight``). ``view_yaw`` (rad)
        and ``view_difference``: the view's yaw relative to its template (NaN where its match does not pin it)
        and its match difference (0 and 0 for a view learned on this frame), kept with an experience made now
        for eq. M6 (``view_heading_weight``). ``along_path`` (an experience id, or -1): a place the views
        confirmed across the path but not along it (eq. M8, ``along_path_closures``), the robot facing its yaw
        plus ``along_path_yaw`` (rad); an experience made now is linked to it by a link free along the place's
        heading (:meth:`_link_along_path`).
        """
        view = (view_yaw, view_difference)
        if self.current < 0:
            self._create(template_id, grid_code, direction_code, time, pose=self.relative.copy(),
                         structure=structure, view=view)
            self.relative[:] = 0
            self.driven[:] = 0
            self._restart_link()
            return MapUpdate(self.current, True, False)
        candidates = self._candidates(template_id)
        if len(candidates):
            config = self.config
            scores = (self.code_scores(candidates, grid_code, direction_code)
                      + config.view_weight * (self.template_ids[candidates] != template_id))
            best_index = int(np.argmin(scores))
            best, best_score = int(candidates[best_index]), float(scores[best_index])
        else:
            best, best_score = -1, math.inf
        closes_loop = self._closes_loop(best)
        if place >= 0 and closes_loop and best != place:  # close the loop where the views confirmed it
            best, best_score = place, float(self.code_scores(np.array([place]), grid_code, direction_code)[0])
            closes_loop = self._closes_loop(best)
        # a match the views have not confirmed, but made where the robot still is: re-entered without a link
        on_the_spot = closes_loop and not may_close_loop and self._on_the_spot(best)
        if best_score > self.config.threshold or (closes_loop and not may_close_loop and not on_the_spot):
            previous = self.current
            self._create(template_id, grid_code, direction_code, time, pose=self.robot_pose(), structure=structure,
                         view=view)
            self._link(previous, self.current, time)
            self.relative[:] = 0
            self.driven[:] = 0
            self._restart_link()
            if along_path >= 0:
                self._link_along_path(along_path, along_path_yaw, time)
            self._structure_due()
            self._relax(self.config.idle_passes)
            return MapUpdate(self.current, True, False)
        if best == self.current:
            self._relax(self.config.idle_passes)
            return MapUpdate(self.current, False, False)
        closes_loop = closes_loop and not on_the_spot
        previous = self.current
        offset = self._offset(best, grid_code, direction_code)
        if closes_loop:
            # the robot is at previous ⊕ odometry and at best ⊕ offset, so best = previous ⊕ odometry ⊖ offset
            self.relative = compose(self.driven, inverse(offset))
            self.driven = self.relative.copy()
            # the loop's error: where the odometry puts the re-entered experience against where it is
            expected = compose(self.poses[previous], self.relative)
            error = expected - self.poses[best]
            error[3] = float(wrap(error[3]))
            self._link(previous, best, time, weight=self.config.closure_weight)
            self.loop_closures += 1
            trigger = LEAST_SQUARES_TRIGGER if self.config.relaxation == "least-squares" else SETTLED
            if np.abs(error).max() >= trigger:
                self._settled = False
        # re-entering without a loop closure (the robot follows the map): with either option the driven path goes on
        # from the re-entered experience, re-expressed against it; with reentry_keeps_pose the robot stays there
        # too (driven and relative stay equal), else it goes where the codes say
        if closes_loop or not (self.config.reentry_keeps_pose or self.config.reentry_links_driven):
            self.relative = offset
            self.driven = offset.copy()
        else:
            self.driven = geometry.relative(self.poses[best], compose(self.poses[previous], self.driven))
            self.relative = self.driven.copy() if self.config.reentry_keeps_pose else offset
        self.current = best
        self._restart_link()
        self._relax(self.config.relaxation_passes if closes_loop else self.config.idle_passes)
        return MapUpdate(best, False, closes_loop)

    def _link_along_path(self, place: int, relative_yaw: float, time: float) -> None:
        """Eq. M8: link ``place`` → the current experience (just made) as a loop closure that says where the robot
        is across the path and which way it faces, not where along it. The link has no length and lies along
        the place's heading; its length weighs nothing (eq. M5's length weight, with no distance observed:
        infinitely blind), so the least-squares map is held across the place's heading (eq. M5's row across),
        in height and in yaw (the robot faces the place's yaw plus the view's ``relative_yaw``), with the
        weight of a loop closure. A solve starts where the link's error reaches the loop closures' trigger."""
        self._link(place, self.current, time, weight=self.config.closure_weight,
                   relative=np.array([0.0, 0.0, 0.0, relative_yaw]), blind=math.inf, heading=0.0)
        yaw = self.poses[place, 3]
        apart = self.poses[self.current, :3] - self.poses[place, :3]
        error = (abs(-math.sin(yaw) * apart[0] + math.cos(yaw) * apart[1]), abs(apart[2]),
                 abs(float(wrap(yaw + relative_yaw - self.poses[self.current, 3]))))
        if self.config.relaxation == "least-squares" and max(error) >= LEAST_SQUARES_TRIGGER:
            self._settled = False

    def _restart_link(self) -> None:
        """The odometry starts again from the current experience: no blind seconds counted for eq. M5 yet."""
        self._blind_since = 0.0

    def _on_the_spot(self, experience: int) -> bool:
        """The robot has driven less than ``confirmation_tolerance`` since it made ``experience`` (in this
        session): it cannot be more than that from where it made it, so re-entering it needs no confirming
        views (a robot turning on the spot meets its own experiences again after a revolution; re-entering
        them puts its heading back where the map has it, and grows the map no more)."""
        return bool(self.sessions[experience] == self.session
                    and self.odometer - self.odometers[experience] < self.config.confirmation_tolerance)

    def _closes_loop(self, experience: int) -> bool:
        """Re-entering ``experience`` would close a loop: it is neither the current one nor linked to it."""
        return experience >= 0 and experience != self.current and not self.linked(self.current, experience)

    # graph ----------------------------------------------------------------------------------------------
    def _create(self, template_id: int, grid_code: np.ndarray, direction_code: np.ndarray, time: float,
                pose: np.ndarray, structure: float = math.nan, view: tuple[float, float] = (0.0, 0.0)) -> None:
        self._poses.append(pose)
        self._grid_codes.append(grid_code)
        self._direction_codes.append(direction_code)
        self._templates.append(template_id)
        self._by_template.setdefault(int(template_id), []).append(self.size - 1)
        self._times.append(time)
        self._degree.append(0)
        self._components.append(self.component)
        self._sessions.append(self.session)
        self._odometers.append(self.odometer)
        self._structure.append(float(structure))
        self._view_yaws.append(float(view[0]))
        self._view_differences.append(float(view[1]))
        self.current = self.size - 1

    def _structure_due(self) -> None:
        """Start a solve every ``structure_interval`` metres driven while eq. M4 or eq. M6 is on: between loop
        closures the odometry's heading drifts away from the lines its new experiences saw (and from the
        headings its familiar views give), and a solve holds the map to them before the drift reaches the
        lines' own scatter."""
        config = self.config
        if ((config.structure_weight > 0 or config.view_heading_weight > 0) and config.relaxation == "least-squares"
                and self.odometer - self._structure_odometer >= config.structure_interval):
            self._structure_odometer = self.odometer
            self._settled = False

    def _link(self, source: int, target: int, time: float, *, weight: float = 1.0,
              relative: np.ndarray | None = None, blind: float | None = None, heading: float | None = None) -> None:
        """Link ``source`` → ``target`` with the odometry accumulated since ``source`` (NeuroSLAM eq. 23), or with
        ``relative`` (``target``'s pose in ``source``'s frame) and ``blind`` seconds; ``weight`` scales its
        squared errors in the least-squares map."""
        dx, dy, dz, dyaw = self.driven if relative is None else relative
        distance = math.hypot(dx, dy)
        # a link read as no travel (the distance blind) points the way the robot faced halfway along it (eq. M5)
        if heading is None:
            heading = math.atan2(dy, dx) if distance > 0 else float(wrap(dyaw)) / 2
        self._links.append((source, target))
        self._link_poses.append((distance, heading, float(wrap(dyaw)), dz))
        # seconds on the session's clock; a link from an experience of an earlier session records 0
        self._link_times.append(time - self.creation_times[source] if self.sessions[source] == self.session else 0.0)
        self._link_weights.append(weight)
        self._link_blind.append(self._blind_since if blind is None else blind)
        self._degree.data[source] += 1
        self._degree.data[target] += 1
        if math.isfinite(self._link_blind.view[-1]):  # eq. M8's links make no neighbours (:func:`neighbour_pairs`)
            self._linked.add((source, target))

    def _relax(self, passes: int) -> None:
        """Relax the map after a change: NeuroSLAM eq. 25's passes, or its least-squares map solved directly."""
        if self.config.relaxation == "least-squares":
            if not self._settled:
                self._solve()
            return
        self._relax_passes(passes)

    def _solve(self) -> None:
        """One call of :func:`~neuroslam.relaxation.solve_least_squares` on the robot's component (the other
        components are separate maps, each held by its own first experience)."""
        members = np.flatnonzero(self.components == self.component)
        local = np.full(self.size, -1)
        local[members] = np.arange(len(members))
        inside = local[self.links[:, 0]] >= 0
        structure = None
        if self.config.structure_weight > 0:
            seen = members[np.isfinite(self.structure_orientations[members])]
            structure = StructureTerms(local[seen], self.structure_orientations[seen], self.config.structure_weight,
                                       self.config.structure_tolerance, self.config.structure_families)
        views = None
        if self.config.view_heading_weight > 0:
            views = ViewHeadingTerms(*self._view_headings(members), self.config.view_heading_weight,
                                     self.config.view_heading_tolerance)
        poses, self._settled = solve_least_squares(
            self._poses.data[members], local[self.links[inside, 0]], local[self.links[inside, 1]],
            self.link_poses[inside], self._link_weights.view[inside], structure, self.length_weights()[inside],
            views)
        self._poses.data[members] = poses

    def view_headings(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. M6's observations in the robot's component: (sources, targets: experience ids; facings: rad,
        each target's yaw relative to its source's as its views measured it); see :meth:`_view_headings`."""
        members = np.flatnonzero(self.components == self.component)
        sources, targets, facings = self._view_headings(members)
        return members[sources], members[targets], facings

    def _view_headings(self, members: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Eq. M6's observations among ``members`` (ascending experience ids): each experience made on a view
        matched within ``view_heading_difference``, its yaw pinned (finite), faces its view's reference (the
        oldest member with its template, where the view was learned) turned by the difference of their view
        yaws, if that reference was made more than ``confirmation_age`` before it or in another session (a
        view seen again, not the same view a moment later). Returns (sources, targets, facings), indices into
        ``members``."""
        config = self.config
        templates = self.template_ids[members]
        # the oldest member of each template
        _, first, inverse = np.unique(templates, return_index=True, return_inverse=True)
        reference = first[inverse]
        times, sessions = self.creation_times[members], self.sessions[members]
        differences = self._view_differences.view[members]
        yaws = self._view_yaws.view[members]
        observed = np.flatnonzero((differences <= config.view_heading_difference)  # NaN (older maps) compares False
                                  & np.isfinite(yaws) & np.isfinite(yaws[reference])
                                  & (reference != np.arange(len(members)))
                                  & ((times - times[reference] > config.confirmation_age)
                                     | (sessions != sessions[reference])))
        sources = reference[observed]
        return sources, observed, yaws[observed] - yaws[sources]

    def _relax_passes(self, passes: int) -> None:
        """NeuroSLAM eq. 25's passes over the whole map (:func:`~neuroslam.relaxation.relax_passes`), unless it
        has settled since the last inconsistent link."""
        if passes == 0 or self._links.count == 0 or self._settled:
            return
        n = self.size
        poses, self._settled = relax_passes(self._poses.data[:n], self.links[:, 0], self.links[:, 1],
                                            self.link_poses, self._degree.view, self.config.correction, passes)
        self._poses.data[:n] = poses
