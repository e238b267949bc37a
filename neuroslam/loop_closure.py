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

__all__ = ["confirm_place", "rival_shift_support"]


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
    rival_spread: float | None = None,
    along_path: bool = False,
    rival_shifts: bool = False,
    rival_odds: float | None = None,
    heading: float | None = None,
    offset: np.ndarray | None = None,
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

    With ``rival_spread`` (m, default ``2 * tolerance``), confirmed hypotheses are rivals beyond that distance
    from the winner instead (in the map, and by the odometers below): at ``tolerance``, a place is confirmed
    only where every place the window explains as well lies within the precision the rule asks of each frame.
    Two confirmed places 1–2 tolerances apart are the same place to the rival test at ``2 * tolerance``, and
    the better fit between them is a guess whose error can reach ``2 * tolerance``.

    With ``odometers`` (and ``sessions``), two confirmed places are distinct also where one pass laid them
    more than ``2 * tolerance`` (or ``rival_spread``) apart (their odometer readings, in one session, differ by
    more than that but by no more than the window's own travel, over which the rule trusts the odometry),
    however close the map has since put them: a map bent by its closures can hold a place and one laid metres
    on from it within centimetres, and the better fit between them is then a guess.

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
        rival_spread: m, how far from the winner a confirmed hypothesis makes it ambiguous (default
            ``2 * tolerance``).
        along_path: the test of eq. M8 instead (a place known across the path, not along it): a view seen along
            many metres is evidence too, and the confirmed hypotheses may spread along the winner's heading as
            far as they like, but no farther than ``rival_spread`` across it (nor in height); the rule of places
            one pass laid apart does not apply (they are the stretch the place may lie anywhere along).
            The winner's place then says where the robot is across the path and which way it faces, not where
            along it (:meth:`~neuroslam.experience_map.ExperienceMap.update`'s ``along_path``).
        rival_shifts: the rival test over every place the window explains, not only the current view's places
            (:func:`rival_shift_support`): the winner is not confirmed where the window's own views put
            ``matches`` frames where a copy of the winner shifted by more than the rival spread maps them (a
            look-alike one period on along a street whose look repeats, whose place the current view's template
            does not hold). A shifted copy is a rival where it lies within the search radius (and its margin)
            of the robot's estimate, or no farther from the winner than the winner from the estimate (and the
            margin): accepting the winner says the estimate was that far off, so a copy as far from it is as
            plausible a correction. Not with ``along_path``.
        rival_odds: with ``rival_shifts``, weigh a shifted copy against the winner by where the robot's estimate
            says it is, instead of the reach above: the estimate's error taken as Gaussian with the search radius
            as its 2σ bound (σ = ``radius / 2`` horizontally), a copy is a rival where the winner is less than
            ``rival_odds`` times as likely a place as it, ``d_copy² − d_winner² ≤ 2σ² ln(rival_odds)`` (their
            horizontal distances from the estimate), and its height lies within the height reach. A look that
            repeats every bay then does not refuse a well-localised robot its own place (the copies one bay on
            lie far out in the estimate's tail), and refuses a robot that has driven long enough unrecognised
            for a bay to lie within its error. And where the search radius is within ``2 * tolerance`` (σ within
            one tolerance: the robot is on or near a place it recognised), a copy shifted by no more than
            ``2 * tolerance`` is no rival: with places laid a metre apart and a view seen along two or three of
            them, every window frame agrees with a copy one place on as well as with the winner, the same
            evidence counted twice, and where the estimate itself is held that closely the better fit between
            them errs by no more than the estimate could. None: the reach rule.
        heading: rad, the robot's heading in the map, or None. Given, every hypothesis faces it (maps the window
            by the odometry's heading) instead of its place's yaw plus ``relative_yaw``: for a view whose match
            does not pin its yaw (:class:`~neuroslam.slam.NeuroSLAM`'s ``confirmation_pinned_yaw``).
        offset: a (3,) array, or None. Given, and a place confirmed, it is filled with where the window says the
            robot is against the place (x, y, z in the map; m): the median, over the window frames that agree
            with the winner, of the vector from where the winner maps each frame to the nearest of its view's
            places that makes it agree. The place is where the current view was learned; a view is seen along
            a metre or two, so the robot may stand anywhere along that stretch, and the window's frames, each
            placed by its own view to within that stretch, say where along it (:class:`~neuroslam.slam.NeuroSLAM`'s
            ``closure_window_pose``). Left as it was where nothing is confirmed, and with ``along_path``.
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
    yaws = map_poses[hypotheses, 3] + relative_yaw if heading is None else np.full(len(hypotheses), heading)
    frames = np.column_stack([map_poses[hypotheses, :3], yaws - now[3]])
    support = np.zeros(len(hypotheses), dtype=int)
    misfit = np.zeros(len(hypotheses))  # m, summed over the agreeing frames: the distance to the nearest agreeing place
    counted = []  # with offset: per window frame that counted, (pose, its places, whether it is evidence)
    if window_alternatives is None:
        window_alternatives = [()] * len(window_poses)
    places = _window_places(window_templates, window_alternatives, experiences_of, eligible)
    kept = [index for index, (own, _) in enumerate(places) if len(own)]  # a view without a place says nothing
    if kept:
        # every kept frame at once: where each hypothesis maps it (H, K), its view's places and all its places
        # (its alternatives' too) flattened along one axis, each with the frame it belongs to
        steps = window_poses[kept, :3] - now[:3]
        distances = [math.hypot(dx, dy) for dx, dy, _ in steps]  # m, each frame's from the current one
        c, s = np.cos(frames[:, 3]), np.sin(frames[:, 3])
        mapped_x = frames[:, 0, None] + c[:, None] * steps[None, :, 0] - s[:, None] * steps[None, :, 1]
        mapped_y = frames[:, 1, None] + s[:, None] * steps[None, :, 0] + c[:, None] * steps[None, :, 1]
        mapped_z = frames[:, 2, None] + steps[None, :, 2]
        mapped_xy = np.stack([mapped_x, mapped_y], axis=2)
        own, own_frame, own_starts = _flatten([places[index][0] for index in kept])
        every, every_frame, every_starts = _flatten([places[index][1] for index in kept])
        gaps = np.linalg.norm(mapped_xy[:, own_frame] - map_poses[None, own, :2], axis=2)  # (H, own places)
        if local_reach:  # per hypothesis: the view's places near where it maps this frame
            near = gaps <= (2 * tolerance + drift * np.array(distances))[own_frame]
            xy = map_poses[own, :2]
            low = np.minimum.reduceat(np.where(near[:, :, None], xy[None], np.inf), own_starts, axis=1)
            high = np.maximum.reduceat(np.where(near[:, :, None], xy[None], -np.inf), own_starts, axis=1)
            spans = np.moveaxis(high - low, 2, 0)  # (2, H, K)
            extent = np.where(np.logical_or.reduceat(near, own_starts, axis=1), np.hypot(*spans), 0.0)
            evidence = extent <= 2 * tolerance  # (H, K): for which hypotheses each view says where the robot is
            counts = np.ones(len(kept), dtype=bool)
        else:
            reach = gaps.min(axis=0) <= radius  # where each frame could be
            xy = map_poses[own, :2]
            low = np.minimum.reduceat(np.where(reach[:, None], xy, np.inf), own_starts, axis=0)
            high = np.maximum.reduceat(np.where(reach[:, None], xy, -np.inf), own_starts, axis=0)
            spans = np.where(np.logical_or.reduceat(reach, own_starts)[:, None], high - low, 0.0)
            # a view seen along many metres (or at several places) within reach says little
            counts = np.array([along_path or math.hypot(*span) <= 2 * tolerance for span in spans])
            evidence = np.broadcast_to(counts, (len(hypotheses), len(kept)))  # a frame that says little: none
        gaps = np.linalg.norm(mapped_xy[:, every_frame] - map_poses[None, every, :2], axis=2)  # (H, all places)
        height_tolerances = tolerance + climb_error * np.array(distances)
        agree = _agree(mapped_z[:, every_frame], gaps, map_poses[every, 2], tolerance, height_tolerances[every_frame])
        agreeing = np.logical_or.reduceat(agree, every_starts, axis=1) & evidence  # (H, K)
        support = agreeing.sum(axis=1)
        nearest = np.minimum.reduceat(np.where(agree, gaps, np.inf), every_starts, axis=1)
        for column in np.where(agreeing, nearest, 0.0).T:  # frame by frame, in the window's order
            misfit += column
        if offset is not None:
            counted = [(window_poses[index], places[index][1], evidence[:, k] if local_reach else True)
                       for k, index in enumerate(kept) if counts[k]]
    confirmed = support >= matches
    if not (confirmed & within).any():
        return -1
    best = int(np.argmin(np.where(confirmed & within, misfit / np.maximum(support, 1), np.inf)))
    rivals, winner = hypotheses[confirmed], hypotheses[best]
    distinct = 2 * tolerance if rival_spread is None else rival_spread
    apart = map_poses[rivals, :3] - map_poses[winner, :3]
    if along_path:  # eq. M8: only the spread across the winner's heading, and in height, makes it ambiguous
        yaw = map_poses[winner, 3]
        across = np.abs(-math.sin(yaw) * apart[:, 0] + math.cos(yaw) * apart[:, 1])
        return int(winner) if max(across.max(), np.abs(apart[:, 2]).max()) <= distinct else -1
    spread = np.linalg.norm(apart, axis=1).max()
    if spread > distinct:
        return -1
    if odometers is not None:  # places one pass laid apart are distinct, wherever the map has put them since
        travel = float(np.linalg.norm(np.diff(window_poses[:, :3], axis=0), axis=1).sum())
        apart = np.abs(odometers[rivals] - odometers[winner])
        if sessions is not None:
            apart = np.where(sessions[rivals] == sessions[winner], apart, 0.0)
        if ((apart > distinct) & (apart <= travel)).any():
            return -1
    if rival_shifts:
        reach = np.array([radius + margin, height_radius + margin])
        correction = map_poses[winner, :3] - np.asarray(robot[:3], dtype=float)
        shift_reach = np.array([math.hypot(*correction[:2]) + margin, abs(correction[2]) + margin])
        # with rival_odds, near the last recognised place a copy one place on is the same evidence (see above)
        shift_distinct = 2 * tolerance if rival_odds is not None and radius <= 2 * tolerance else distinct
        if _shift_support(window_poses, places, frames[best], map_poses, robot, reach=reach,
                          shift_reach=None if rival_odds is not None else shift_reach, tolerance=tolerance,
                          climb_error=climb_error, distinct=shift_distinct, odds=rival_odds,
                          sigma=radius / 2) >= matches:
            return -1
    if offset is not None:  # the winner agrees on at least ``matches`` frames: the median is over them
        offset[:] = _window_offset(counted, best, frames[best], now, map_poses, tolerance, climb_error)
    return int(winner)


def _window_offset(counted: list, best: int, frame: np.ndarray, now: np.ndarray, map_poses: np.ndarray,
                   tolerance: float, climb_error: float) -> np.ndarray:
    """:func:`confirm_place`'s ``offset`` (m, x, y, z in the map): over the window frames that agree with the
    hypothesis ``best`` (whose frame in the map is ``frame``), the median of the vector from where it maps each to
    the nearest of its places that makes it agree. ``counted``: (odometry pose, places, evidence) of each window
    frame the confirmation counted, evidence True or per hypothesis. Run once, on a confirmed place."""
    residuals = []
    for pose, places, evidence in counted:
        if not (evidence if np.ndim(evidence) == 0 else evidence[best]):
            continue
        dx, dy, dz = pose[:3] - now[:3]
        mapped = compose(frame[None], np.array([dx, dy, dz, 0.0]))[0, :3]
        gaps = np.linalg.norm(map_poses[places, :2] - mapped[:2], axis=1)[None]
        agree = _agree(mapped[None, 2:3], gaps, map_poses[places, 2], tolerance,
                       tolerance + climb_error * math.hypot(dx, dy))[0]
        if agree.any():
            residuals.append(map_poses[places[np.argmin(np.where(agree, gaps[0], np.inf))], :3] - mapped)
    return np.median(np.array(residuals), axis=0)


def _agree(mapped_heights: np.ndarray, gaps: np.ndarray, heights: np.ndarray, tolerance: float,
           height_tolerance: float | np.ndarray) -> np.ndarray:
    """(H, P) whether each of P places (``heights``, m) lies where each of H hypotheses maps a window frame
    (``mapped_heights``, m, (H, 1), or (H, P): each place's own frame's): horizontally within ``tolerance``
    (``gaps``, (H, P), m) and vertically within ``height_tolerance`` (m; one, or (P,))."""
    return (gaps <= tolerance) & (np.abs(mapped_heights - heights[None]) <= height_tolerance)


def _window_places(window_templates: np.ndarray, window_alternatives: Sequence[Sequence[int]],
                   experiences_of: Callable[[int], np.ndarray],
                   eligible: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per window frame, its view's eligible places and its places with its alternatives' (ids; the same array
    where it has no alternatives, else sorted: ``experiences_of`` gives each view's in increasing order)."""
    places, merged, owners = [], [], []
    for index, (template, alternatives) in enumerate(zip(window_templates, window_alternatives, strict=True)):
        own = experiences_of(int(template))
        own = own[eligible[own]]
        places.append((own, own))
        if len(alternatives):
            merged.extend([own, *(experiences_of(int(other)) for other in alternatives)])
            owners.extend([index] * (len(alternatives) + 1))
    if merged:  # every frame's union at once: one sort of (frame, place) keys
        lengths = [len(ids) for ids in merged]
        ids = np.concatenate(merged).astype(np.int64, copy=False)
        frames = np.repeat(np.array(owners, dtype=np.int64), lengths)
        keep = eligible[ids]
        keys = np.unique(frames[keep] * len(eligible) + ids[keep])
        frames, ids = np.divmod(keys, len(eligible))
        bounds = np.searchsorted(frames, np.arange(len(places) + 1))
        for index in set(owners):
            places[index] = (places[index][0], ids[bounds[index]:bounds[index + 1]])
    return places


def _flatten(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Non-empty id arrays laid end to end: the ids, the index of the array each came from, and where each
    array starts (for ``ufunc.reduceat``)."""
    lengths = np.array([len(array) for array in arrays])
    return (np.concatenate(arrays), np.repeat(np.arange(len(arrays)), lengths),
            np.concatenate([[0], np.cumsum(lengths)[:-1]]))


def rival_shift_support(
    window_poses: np.ndarray,
    window_templates: np.ndarray,
    window_alternatives: Sequence[Sequence[int]],
    frame: np.ndarray,
    map_poses: np.ndarray,
    experiences_of: Callable[[int], np.ndarray],
    eligible: np.ndarray,
    robot: np.ndarray,
    *,
    reach: np.ndarray,
    tolerance: float,
    climb_error: float,
    distinct: float,
    shift_reach: np.ndarray | None = None,
    odds: float | None = None,
    sigma: float = math.inf,
) -> int:
    """The most window frames that agree with one shifted copy of a hypothesis (frames; 0 if none).

    ``frame`` (x, y, z, yaw; m, rad) is where a hypothesis puts the current frame's odometry pose in the map;
    each window frame is mapped by it as in :func:`confirm_place`. A copy of the hypothesis shifted by a vector
    ``c`` (its mapping of every frame moved by ``c``) is a rival when ``c`` is longer than ``distinct`` and the
    shifted place lies within ``reach`` (horizontal, vertical; m) of the ``robot``'s estimate, or ``c`` itself is
    within ``shift_reach`` (horizontal, vertical; m; None: no such allowance). With ``odds``, horizontally a copy
    is a rival instead where the hypothesis is less than ``odds`` times as likely a place under a Gaussian of
    ``sigma`` (m) about the robot's estimate (its squared distance from the estimate at most the hypothesis's
    plus ``2 sigma² ln odds``), and vertically within ``reach`` (give no ``shift_reach`` with it: the odds weigh
    a copy far from the estimate already). The shifts tried
    are those from where the hypothesis maps a frame to its view's eligible places (and its alternatives'); a
    frame agrees with the copy shifted by ``c`` when one of its places lies within ``tolerance`` of its shifted
    mapping horizontally and ``tolerance`` plus ``climb_error`` per metre of its distance from the current frame
    vertically, as a frame agrees with a hypothesis. The view rule's "no evidence" does not apply here: a view
    seen along many metres explains a shifted place as well as the hypothesis's.

    This is the rival test over every place the window explains as well, not only the places of the current
    view: along a street whose look repeats every few metres, the window fits the place one period on as well
    as the one it confirms, though the current view's template may not hold that place.
    """
    window_poses = np.asarray(window_poses, dtype=float)
    places = _window_places(window_templates, window_alternatives, experiences_of, eligible)
    return _shift_support(window_poses, places, frame, map_poses, robot, reach=reach, tolerance=tolerance,
                          climb_error=climb_error, distinct=distinct, shift_reach=shift_reach, odds=odds, sigma=sigma)


def _shift_support(window_poses: np.ndarray, places: list[tuple[np.ndarray, np.ndarray]], frame: np.ndarray,
                   map_poses: np.ndarray, robot: np.ndarray, *, reach: np.ndarray, tolerance: float,
                   climb_error: float, distinct: float, shift_reach: np.ndarray | None, odds: float | None,
                   sigma: float) -> int:
    """:func:`rival_shift_support` over the window's places (:func:`_window_places`)."""
    now = window_poses[-1]
    kept = [index for index, (_, every) in enumerate(places) if len(every)]
    if not kept:
        return 0
    steps = window_poses[kept, :3] - now[:3]
    c, s = np.cos(frame[None, 3]), np.sin(frame[None, 3])
    mapped = np.stack([frame[0] + c * steps[:, 0] - s * steps[:, 1], frame[1] + s * steps[:, 0] + c * steps[:, 1],
                       frame[2] + steps[:, 2]], axis=1)  # (K, 3): where the hypothesis maps each frame
    every, owner, _ = _flatten([places[index][1] for index in kept])
    vectors = map_poses[every, :3] - mapped[owner]  # (N, 3): from the mapping of a frame to each of its places
    height_tolerance = (tolerance + climb_error * np.array([math.hypot(dx, dy) for dx, dy, _ in steps]))[owner]
    shifted = frame[:3] + vectors  # where the shifted copy puts the current frame
    if odds is not None:
        winner = np.sum((frame[:2] - robot[:2]) ** 2)
        plausible = np.sum((shifted[:, :2] - robot[:2]) ** 2, axis=1) - winner <= 2 * sigma**2 * math.log(odds)
        possible = plausible & (np.abs(shifted[:, 2] - robot[2]) <= reach[1])
    else:
        possible = ((np.linalg.norm(shifted[:, :2] - robot[:2], axis=1) <= reach[0])
                    & (np.abs(shifted[:, 2] - robot[2]) <= reach[1]))
    if shift_reach is not None:  # no farther from the hypothesis than it lies from the estimate
        possible |= ((np.linalg.norm(vectors[:, :2], axis=1) <= shift_reach[0])
                     & (np.abs(vectors[:, 2]) <= shift_reach[1]))
    candidate = (np.linalg.norm(vectors, axis=1) > distinct) & possible
    if not candidate.any():
        return 0
    tried = vectors[candidate]
    agree = ((np.linalg.norm(tried[:, None, :2] - vectors[None, :, :2], axis=2) <= tolerance)
             & (np.abs(tried[:, None, 2] - vectors[None, :, 2]) <= height_tolerance[None]))
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])  # owners are in window order
    return int(np.logical_or.reduceat(agree, starts, axis=1).sum(axis=1).max())
