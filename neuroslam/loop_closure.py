"""Confirmed loop closure: the rule of the grid-network paper (section III), made geometric.

The paper accepts a loop closure "if more than six possible loop closures are detected in ten
consecutive frames, and these loop closures are consistent". Here a possible loop closure is a frame
whose view (local view cell) belongs to old experiences, and consistent means geometrically consistent:
the old experiences those frames matched are laid out in the map as the odometry of those frames says.
That is what rejects a single look-alike view, and a run of look-alike views in the wrong arrangement.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from .geometry import compose

__all__ = ["confirm_place"]


def confirm_place(
    window_poses: np.ndarray,
    window_templates: np.ndarray,
    relative_yaw: float,
    map_poses: np.ndarray,
    experiences_of: Callable[[int], np.ndarray],
    eligible: np.ndarray,
    robot: np.ndarray,
    *,
    radius: float,
    tolerance: float,
    matches: int,
    climb_error: float = 0.0,
    height_radius: float | None = None,
    window_alternatives: Sequence[Sequence[int]] | None = None,
    local_reach: bool = False,
    drift: float = 0.0,
    odometers: np.ndarray | None = None,
    sessions: np.ndarray | None = None,
    lead: int = 0,
) -> int:
    """The old experience the last frames confirm the robot is at, or -1.

    Each eligible experience of the newest frame's view is a hypothesis: the robot is there, facing its
    yaw plus the view's ``relative_yaw``. A hypothesis maps every window frame's odometry pose into the
    map (rotation about z by the yaw difference, then a translation; heights by their difference); a
    frame agrees when an eligible experience of its view lies within ``tolerance`` of where it is
    mapped: horizontally within ``tolerance``, vertically within ``tolerance`` plus ``climb_error`` times
    the horizontal distance between that frame and the current one (the odometry's heights drift faster
    than its positions). A view whose eligible experiences within ``radius`` of where the frame could be
    spread over more than ``2 * tolerance`` (seen along a uniform street, or at several places) is no
    evidence and never agrees: two such places are as far apart as two places the rival test below calls
    distinct, and the view cannot tell them apart (a corridor whose look repeats every 2–3 m).
    Hypotheses with at least ``matches`` agreeing frames are confirmed; the one whose agreeing frames
    fit best wins (the least mean distance from where it maps them to their views' experiences: a view
    seen over a metre or two also agrees, less closely, with a hypothesis shifted along the path by that
    much, which the robot's drifting estimate cannot tell apart), unless another
    confirmed one lies more than ``2 * tolerance`` from it (a place that several parts of the map explain
    equally is not confirmed; rivals are looked for up to ``2 * tolerance`` beyond the radii, since the
    estimate that centres the radii has drifted: a wrong place inside them must not win because the right
    one lies just outside).
    Hypotheses horizontally farther than ``radius`` from the estimate, or vertically farther than
    ``height_radius`` (default ``radius``), cannot win. A frame's ``window_alternatives`` (further
    templates its view matched within the threshold) are evidence too: the frame agrees when an
    experience of its view or of one of them lies where the hypothesis maps it. They do not make
    hypotheses, and the spread that makes a view no evidence is its own (as is the eligibility: a frame
    whose view has no eligible experience says nothing). All hypotheses at once; one pass per window
    frame.

    With ``local_reach`` (a merge: its ``radius`` is infinite, the robot could be anywhere in the other map),
    where a frame could be is judged per hypothesis instead: within ``2 * tolerance`` plus ``drift`` times
    the frame's distance from the current one of where that hypothesis maps it (two places the rival test
    calls distinct, widened by the odometry's drift over the window). A view seen at several places of
    the map is then no evidence for a hypothesis only where its places near that hypothesis's mapping spread
    over more than ``2 * tolerance``: without it, any view the map holds twice anywhere, 40–65 % of a one-lap
    map's (measured on generated worlds), counts for no hypothesis at all. Look-alike places stay guarded by
    the rival test: each of them that holds the current view is a hypothesis, and two confirmed ones more
    than ``2 * tolerance`` apart confirm nothing.

    With ``odometers`` (and ``sessions``), two confirmed places are distinct also where one pass laid them
    more than ``2 * tolerance`` apart (their odometer readings, in one session, differ by more than that but by
    no more than the window's own travel, over which the rule trusts the odometry), however close the map has
    since put them: a map bent by its closures can hold a place and one laid metres on from it within
    centimetres, and the better fit between them is then a guess.

    With ``lead`` (frames, 0: off), where the rule above confirms nothing, every view votes: a view seen at
    several places agrees with a hypothesis wherever one of its places lies where the hypothesis maps the
    frame. The hypothesis within the radii with the most agreeing frames (at least ``matches``; a tie goes to
    the better fit) is confirmed when every other hypothesis that is a distinct place (more than
    ``2 * tolerance`` from it, or laid apart as above) has at least ``lead`` fewer, both of all the agreeing
    frames and of those whose view is seen at one place (its places within ``radius + 2 * tolerance`` of
    where the hypothesis maps the frame, the reach rivals are looked for, spread over at most
    ``2 * tolerance``), and at least ``lead`` of the latter agree with it. A corridor whose look repeats
    gives a hypothesis shifted by its period as many frames as the true one, and nothing is confirmed; where
    the map has drifted by a tolerance the look-alike may fit more of the repeating views than the true place
    does, and where the current view was seen only at the look-alike the true place is no hypothesis at all,
    but the views seen at one place within that reach do not repeat at any shift a rival could have: those
    decide. (On a second lap the spread rule silences much of a window where the first lap saw its views at
    places a few metres apart, gen3:107: 8.8 of 20 frames, their places a median 6.4 m apart, and the loop
    stays open.)

    Args:
        window_poses: (K, 4) odometry poses (x, y, z, yaw; m, rad) of the window's frames, oldest first;
            the last is the current frame.
        window_templates: (K,) the view (template id) of each window frame.
        relative_yaw: rad, the current view's yaw relative to its template.
        map_poses: (M, 4) experience poses in the map. experiences_of: template id → experience ids.
        eligible: (M,) bool, experiences that may be revisited (old enough).
        robot: (4,) the robot's current estimate in the map.
        radius, tolerance, height_radius: m. matches: frames that must agree (the current frame counts).
        climb_error: m of height per m of travel the window's odometry may be off by.
        window_alternatives: per window frame, the other template ids its view matched (may be empty).
        local_reach: judge a view's spread per hypothesis (see above). drift: m per m of travel, with it.
        odometers: (M,) m, the distance its session had driven when each experience was made; sessions: (M,)
            each experience's session (all one session without it).
        lead: frames by which a place confirmed on every view's vote must lead every distinct rival; 0: off.
    """
    window_poses = np.asarray(window_poses, dtype=float)
    if len(window_poses) < matches:
        return -1
    now = window_poses[-1]
    hypotheses = experiences_of(int(window_templates[-1]))
    hypotheses = hypotheses[eligible[hypotheses]]
    height_radius = radius if height_radius is None else height_radius
    near = np.linalg.norm(map_poses[hypotheses, :2] - robot[:2], axis=1)
    rise = np.abs(map_poses[hypotheses, 2] - robot[2])
    # rivals: a place just beyond the radius that the views fit as well makes one inside it ambiguous
    margin = 2 * tolerance
    considered = (near <= radius + margin) & (rise <= height_radius + margin)
    hypotheses, within = hypotheses[considered], ((near <= radius) & (rise <= height_radius))[considered]
    if not within.any():
        return -1
    # per hypothesis, the odometry's frame in the map: the hypothesis's place, turned by the view's relative yaw
    frames = np.column_stack([map_poses[hypotheses, :3], map_poses[hypotheses, 3] + relative_yaw - now[3]])
    support = np.zeros(len(hypotheses), dtype=int)
    misfit = np.zeros(len(hypotheses))  # m, summed over the agreeing frames: the distance to the nearest agreeing place
    votes = np.zeros(len(hypotheses), dtype=int)  # with ``lead``: every view's agreeing frames, and their misfit
    vote_misfit = np.zeros(len(hypotheses))
    sole = np.zeros(len(hypotheses), dtype=int)  # with ``lead``: agreeing frames whose view is seen at one place
    if window_alternatives is None:
        window_alternatives = [()] * len(window_poses)
    for pose, template, alternatives in zip(window_poses, window_templates, window_alternatives, strict=True):
        places = experiences_of(int(template))
        places = places[eligible[places]]
        if len(places) == 0:
            continue
        dx, dy, dz = pose[:3] - now[:3]
        mapped = compose(frames, np.array([dx, dy, dz, 0.0]))[:, :3]
        gaps = np.linalg.norm(mapped[:, None, :2] - map_poses[None, places, :2], axis=2)
        if lead:  # per hypothesis: is this view seen at one place within the reach rivals are looked for?
            once = _extent(gaps <= radius + margin, map_poses[places, :2]) <= 2 * tolerance
        if local_reach:  # per hypothesis: the view's places near where it maps this frame
            extent = _extent(gaps <= 2 * tolerance + drift * math.hypot(dx, dy), map_poses[places, :2])
            evidence = extent <= 2 * tolerance  # (H,): for which hypotheses this view says where the robot is
        else:
            reach = gaps.min(axis=0) <= radius  # where this frame could be
            extent = np.ptp(map_poses[places[reach], :2], axis=0) if reach.any() else np.zeros(2)
            # a view seen along many metres (or at several places) within reach says little
            evidence = math.hypot(*extent) <= 2 * tolerance
            if not (evidence or lead):
                continue
        if len(alternatives):
            places = np.unique(np.concatenate([places, *(experiences_of(int(other)) for other in alternatives)]))
            places = places[eligible[places]]
            gaps = np.linalg.norm(mapped[:, None, :2] - map_poses[None, places, :2], axis=2)
        climbs = np.abs(mapped[:, None, 2] - map_poses[None, places, 2])
        agree = (gaps <= tolerance) & (climbs <= tolerance + climb_error * math.hypot(dx, dy))
        closest = np.where(agree, gaps, np.inf).min(axis=1, initial=np.inf)
        agreeing = agree.any(axis=1) & evidence
        support += agreeing
        misfit += np.where(agreeing, closest, 0.0)
        if lead:
            votes += agree.any(axis=1)
            vote_misfit += np.where(agree.any(axis=1), closest, 0.0)
            sole += agree.any(axis=1) & once
    travel = float(np.linalg.norm(np.diff(window_poses[:, :3], axis=0), axis=1).sum())

    def distinct(others: np.ndarray, place: int) -> np.ndarray:
        """Which of ``others`` are places distinct from ``place``: apart in the map, or laid apart by one pass."""
        far = np.linalg.norm(map_poses[others, :3] - map_poses[place, :3], axis=1) > 2 * tolerance
        if odometers is not None:  # places one pass laid apart are distinct, wherever the map has put them since
            apart = np.abs(odometers[others] - odometers[place])
            if sessions is not None:
                apart = np.where(sessions[others] == sessions[place], apart, 0.0)
            far |= (apart > 2 * tolerance) & (apart <= travel)
        return far

    confirmed = support >= matches
    if (confirmed & within).any():
        best = int(np.argmin(np.where(confirmed & within, misfit / np.maximum(support, 1), np.inf)))
        if not distinct(hypotheses[confirmed], hypotheses[best]).any():
            return int(hypotheses[best])
    if not lead:
        return -1
    # every view votes; the place must lead every distinct rival by ``lead`` frames
    candidates = (votes >= matches) & within
    if not candidates.any():
        return -1
    fit = np.where(candidates, vote_misfit / np.maximum(votes, 1), np.inf)
    best = int(np.lexsort((fit, -np.where(candidates, votes, -1)))[0])  # the most votes, then the best fit
    rivals = distinct(hypotheses, hypotheses[best])
    if sole[best] < lead or (rivals & ((votes > votes[best] - lead) | (sole > sole[best] - lead))).any():
        return -1
    return int(hypotheses[best])


def _extent(near: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """(H,) m, per hypothesis, the diagonal of the box around the places ``near`` it ((H, P) bool; ``xy`` (P, 2) m);
    0 where none is."""
    low = np.where(near[:, :, None], xy[None], np.inf).min(axis=1)
    high = np.where(near[:, :, None], xy[None], -np.inf).max(axis=1)
    return np.where(near.any(axis=1), np.hypot(*(high - low).T), 0.0)
