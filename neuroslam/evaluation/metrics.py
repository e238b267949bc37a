"""SLAM metrics against ground truth: relative pose error, map error, loop-closure and floor-level scores.

Conventions follow the SLAM-evaluation standard (evo; Zhang and Scaramuzza 2018): absolute errors after a
Sim(3) (or SE(3)) Umeyama alignment, relative errors over fixed travelled distances, RMSE throughout.
Poses are (x, y, z, yaw) in metres and radians.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..geometry import relative
from .trajectory import umeyama

#: A place is on a level when its true height is within this of the level's floor (m). The robot's base rests
#: 1 mm below a floor's height; on the testbed's ramps (at most 15°) 0.1 m of height is at most 0.37 m along
#: the ramp from its foot.
FLOOR_TOLERANCE = 0.1

__all__ = ["FLOOR_TOLERANCE", "align", "associate", "false_loop_closure_mask", "false_loop_closures",
           "level_accuracy", "nearest_level", "observation_shares", "rpe_rmse", "run_metrics", "trajectory_errors"]


def align(estimate: np.ndarray, truth: np.ndarray, *, with_scale: bool = True) -> np.ndarray:
    """``estimate`` positions (N × 3) mapped onto ``truth`` by the best Sim(3) (or SE(3)) alignment."""
    scale, rotation, translation = umeyama(estimate, truth, with_scale=with_scale)
    return scale * np.asarray(estimate, dtype=float) @ rotation.T + translation


def rpe_rmse(estimate: np.ndarray, truth: np.ndarray, *, segment: float = 10.0) -> float | None:
    """Relative position error (m, RMSE) over segments of ``segment`` metres of true travel.

    For every frame i the partner j is the first frame at least ``segment`` metres further along the true
    path; the error is the difference between the estimated and the true displacement from i to j, each
    expressed in its own frame i (rotated by minus that frame's yaw), so a constant offset or heading of
    the whole trajectory costs nothing. None when the path is shorter than one segment.
    """
    estimate = np.asarray(estimate, dtype=float)
    truth = np.asarray(truth, dtype=float)
    travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(truth[:, :3], axis=0), axis=1))])
    partners = np.searchsorted(travelled, travelled + segment)
    starts = np.flatnonzero(partners < len(truth))
    if len(starts) == 0:
        return None
    ends = partners[starts]

    def local(poses: np.ndarray) -> np.ndarray:
        return relative(poses[starts], poses[ends])[:, :3]

    errors = np.linalg.norm(local(estimate) - local(truth), axis=1)
    return float(math.sqrt(np.mean(errors**2)))


def trajectory_errors(estimate: np.ndarray, truth: np.ndarray) -> dict[str, float | None]:
    """One trajectory's errors against the truth, as ``metrics.json`` reports each: ``ate_rmse_m`` (after a
    Sim(3) alignment), ``ate_se3_rmse_m`` (SE(3)) and ``rpe_rmse_m`` (10 m segments), in metres; None where
    the run is too short (fewer than 3 poses, or a path shorter than one segment).

    Args:
        estimate, truth: (N, 4) poses x, y, z (m), yaw (rad), matched by index.
    """
    positions = truth[:, :3]
    enough = len(truth) >= 3
    return {"ate_rmse_m": _rmse(align(estimate[:, :3], positions), positions) if enough else None,
            "ate_se3_rmse_m": (_rmse(align(estimate[:, :3], positions, with_scale=False), positions)
                               if enough else None),
            "rpe_rmse_m": rpe_rmse(estimate, truth)}


def associate(estimate_times: np.ndarray, truth_times: np.ndarray, max_difference: float = 0.01
              ) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of an estimate's and the truth's poses taken at the same time (s), as TUM tools pair them: each
    estimate time with the nearest truth time, kept where they are at most ``max_difference`` apart and
    that truth time is no other estimate time's nearer partner. Returns (estimate indices, truth indices),
    increasing."""
    estimate_times = np.asarray(estimate_times, dtype=float)
    truth_times = np.asarray(truth_times, dtype=float)
    if len(truth_times) == 0 or len(estimate_times) == 0:
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    order = np.argsort(truth_times)
    sorted_times = truth_times[order]
    after = np.clip(np.searchsorted(sorted_times, estimate_times), 1, len(sorted_times) - 1)
    before = after - 1
    nearer = np.where(np.abs(sorted_times[before] - estimate_times) <= np.abs(sorted_times[after] - estimate_times),
                      before, after)
    if len(sorted_times) == 1:
        nearer = np.zeros(len(estimate_times), dtype=int)
    gaps = np.abs(sorted_times[nearer] - estimate_times)
    estimate_index = np.flatnonzero(gaps <= max_difference)
    truth_index = order[nearer[estimate_index]]
    # one estimate per truth time: the nearest
    ranked = np.lexsort((gaps[estimate_index], truth_index))
    keep = np.ones(len(ranked), dtype=bool)
    keep[1:] = truth_index[ranked][1:] != truth_index[ranked][:-1]
    chosen = np.sort(ranked[keep])
    return estimate_index[chosen], truth_index[chosen]


def nearest_level(heights: np.ndarray, levels: np.ndarray) -> np.ndarray:
    """(N,) index of the floor (heights ``levels``, m) nearest each of ``heights`` (N, m)."""
    levels = np.asarray(levels, dtype=float)
    return np.abs(np.asarray(heights, dtype=float).reshape(-1)[:, None] - levels[None]).argmin(axis=1)


def level_accuracy(aligned_heights: np.ndarray, true_levels: np.ndarray, levels: np.ndarray) -> float:
    """Share of frames whose (aligned) estimated height is nearest to the floor of their true level."""
    return float(np.mean(nearest_level(aligned_heights, levels) == np.asarray(true_levels)))


def false_loop_closure_mask(positions_now: np.ndarray, positions_then: np.ndarray, levels_now: np.ndarray,
                            levels_then: np.ndarray, *, distance: float = 2.0, floors: np.ndarray | None = None,
                            floor_tolerance: float = FLOOR_TOLERANCE) -> np.ndarray:
    """Which loop closures are false: the two places (the robot's true position now, m, against the matched
    experience's when it was made) are more than ``distance`` metres apart in 3-D, or on different levels.

    With ``floors`` (the floor heights, m) a place is on a level only when its true height is within
    ``floor_tolerance`` (m) of that level's floor; a place on a ramp lies between two levels, on neither, and
    there the 3-D distance alone decides (two places 0.2 m apart on one ramp, either side of its half-way
    height, are the same place). Without ``floors`` the level indices are compared everywhere.
    """
    now = np.asarray(positions_now, dtype=float).reshape(-1, 3)
    then = np.asarray(positions_then, dtype=float).reshape(-1, 3)
    different = np.asarray(levels_now) != np.asarray(levels_then)
    if floors is not None:
        floors = np.asarray(floors, dtype=float).reshape(-1)

        def on_floor(heights: np.ndarray) -> np.ndarray:
            return np.min(np.abs(heights[:, None] - floors[None]), axis=1, initial=np.inf) <= floor_tolerance

        different &= on_floor(now[:, 2]) & on_floor(then[:, 2])
    return (np.linalg.norm(now - then, axis=1) > distance) | different


def false_loop_closures(positions_now: np.ndarray, positions_then: np.ndarray, levels_now: np.ndarray,
                        levels_then: np.ndarray, *, distance: float = 2.0, floors: np.ndarray | None = None,
                        floor_tolerance: float = FLOOR_TOLERANCE) -> int:
    """How many loop closures are false (:func:`false_loop_closure_mask`)."""
    return int(np.count_nonzero(false_loop_closure_mask(
        positions_now, positions_then, levels_now, levels_then, distance=distance, floors=floors,
        floor_tolerance=floor_tolerance)))


def false_along_path_mask(place_poses: np.ndarray, positions: np.ndarray, place_levels: np.ndarray,
                          levels: np.ndarray, *, distance: float = 2.0, floors: np.ndarray | None = None,
                          floor_tolerance: float = FLOOR_TOLERANCE) -> np.ndarray:
    """Which of eq. M8's links (a place known across the path, not along it) are false: the linked experience's
    true position, moved along the place's true heading to lie beside the place, is more than ``distance``
    metres from it in 3-D (across the path and in height), or on another level (:func:`false_loop_closure_mask`'s
    rules, ramps included). ``place_poses``: (K, 4) the places' true poses (m, rad); ``positions``: (K, 3) the
    linked experiences' true positions (m); levels: their true levels."""
    places = np.asarray(place_poses, dtype=float).reshape(-1, 4)
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    heading = np.column_stack([np.cos(places[:, 3]), np.sin(places[:, 3])])
    along = np.sum((positions[:, :2] - places[:, :2]) * heading, axis=1)
    beside = positions.copy()
    beside[:, :2] -= along[:, None] * heading
    return false_loop_closure_mask(beside, places[:, :3], levels, place_levels, distance=distance, floors=floors,
                                   floor_tolerance=floor_tolerance)


def run_metrics(
    *,
    truth: np.ndarray,
    true_levels: np.ndarray | None,
    levels: np.ndarray | None,
    estimate: np.ndarray,
    odometry: np.ndarray,
    experience_positions: np.ndarray,
    experience_truth: np.ndarray,
    closure_frames: np.ndarray,
    closure_truth: np.ndarray,
    experience_levels: np.ndarray | None = None,
    closure_levels: np.ndarray | None = None,
    online_estimate: np.ndarray | None = None,
    merge_frames: np.ndarray | None = None,
    merge_truth: np.ndarray | None = None,
    merge_levels: np.ndarray | None = None,
) -> dict:
    """The accuracy numbers of one run, as plain data for ``metrics.json``.

    Args:
        truth: (N, 4) true poses per frame. true_levels: (N,) true level index per frame, or None.
        levels: floor heights, m, or None (then no level accuracy, and closures are judged by distance).
        estimate, odometry: (N, 4) SLAM and odometry poses per frame; the SLAM poses as in the final map
            (:meth:`neuroslam.slam.NeuroSLAM.trajectory`), as SLAM evaluations score a finished run.
        online_estimate: (N, 4) the SLAM estimate as it was at each frame, or None; scored as
            ``slam_online`` beside ``slam`` and ``odometry``.
        experience_positions: (M, 3) final experience positions. experience_truth: (M, 3) the true position
            where each was made (NaN where unknown: such experiences are left out of the map error).
            experience_levels: (M,) their true level indices, or None.
        closure_frames: (C,) the frame of every loop closure. closure_truth, closure_levels: (C, 3) and (C,)
            the true position and level where the re-entered experience was made.
        merge_frames, merge_truth, merge_levels: the same for the merges of a session that loaded maps
            (adds ``merges``, ``merge_frames`` and ``false_merges``), or None.

    Returns ``ate_rmse_m`` and ``ate_se3_rmse_m`` ({slam, odometry[, slam_online]}), ``rpe_rmse_m`` (the same,
    10 m segments), ``map_rmse_m``, ``loop_closures``, ``false_loop_closures``,
    ``true_loop_closures_per_level`` ({level index as text: the closures that are not false, by the level
    nearest the robot's true height}, None without levels) and ``level_accuracy``; a number that
    needs more frames than the run has is None. A closure on a ramp is judged as in
    :func:`false_loop_closure_mask` with the floors ``levels``.
    """
    positions = truth[:, :3]
    enough = len(truth) >= 3
    known_levels = true_levels is not None and levels is not None
    if true_levels is None:
        true_levels = np.zeros(len(truth), dtype=int)
    result: dict = {"ate_rmse_m": {}, "ate_se3_rmse_m": {}, "rpe_rmse_m": {}}
    scored = [("slam", estimate), ("odometry", odometry)]
    if online_estimate is not None:
        scored.append(("slam_online", online_estimate))
    for name, poses in scored:
        for key, value in trajectory_errors(poses, truth).items():
            result[key][name] = value
    experience_truth = np.asarray(experience_truth, dtype=float).reshape(-1, 3)
    known = np.all(np.isfinite(experience_truth), axis=1)
    made, mapped = experience_truth[known], np.asarray(experience_positions, dtype=float)[known]
    result["map_rmse_m"] = _rmse(align(mapped, made), made) if len(made) >= 3 else None
    now = np.asarray(closure_frames, dtype=int)
    then = np.asarray(closure_truth, dtype=float).reshape(-1, 3)
    then_levels = np.zeros(len(now), dtype=int) if closure_levels is None else np.asarray(closure_levels)
    result["loop_closures"] = int(len(now))
    floors = levels if known_levels else None
    true_closure = ~false_loop_closure_mask(positions[now], then, true_levels[now], then_levels, floors=floors)
    result["false_loop_closures"] = int(np.count_nonzero(~true_closure))
    result["true_loop_closures_per_level"] = (
        {str(level): int(np.sum(true_closure & (true_levels[now] == level))) for level in range(len(levels))}
        if known_levels else None)
    result["level_accuracy"] = (level_accuracy(align(estimate[:, :3], positions)[:, 2], true_levels, levels)
                                if enough and known_levels else None)
    if merge_frames is not None:
        merge_frames = np.asarray(merge_frames, dtype=int)
        merge_then = np.asarray(merge_truth, dtype=float).reshape(-1, 3)
        merge_then_levels = (np.zeros(len(merge_frames), dtype=int) if merge_levels is None
                             else np.asarray(merge_levels))
        result["merges"] = int(len(merge_frames))
        result["merge_frames"] = [int(frame) for frame in merge_frames]
        # a merge with a place of unknown truth (a map saved without it) cannot be judged: None
        result["false_merges"] = (None if not np.all(np.isfinite(merge_then)) else false_loop_closures(
            positions[merge_frames], merge_then, true_levels[merge_frames], merge_then_levels, floors=floors))
    return result


def observation_shares(observed: Sequence) -> dict:
    """What the camera observed over a run: ``metrics.json``'s ``blind_share`` and ``self_motion_sources``.

    Args:
        observed: per frame, the :class:`~neuroslam.vision.odometry.Observed` of its self-motion, or None
            where the source does not say (the first frame; the paper's profile odometry).

    Returns:
        ``{"blind_share": {"distance", "yaw", "height"}, "self_motion_sources": {dof: {source: share}}}``:
        per degree of freedom, the share of the frames that report it in which nothing observed it (held or
        none), and the share of each source; None for both where no frame reports.
    """
    reports = [item for item in observed if item is not None]
    if not reports:
        return {"blind_share": None, "self_motion_sources": None}
    names = ("distance", "yaw", "height")
    blind = np.array([item.blind for item in reports], dtype=float).mean(axis=0)
    sources = {}
    for name in names:
        values, counts = np.unique([getattr(item, name) for item in reports], return_counts=True)
        sources[name] = {str(value): float(count / len(reports)) for value, count in zip(values, counts, strict=True)}
    return {"blind_share": {name: float(share) for name, share in zip(names, blind, strict=True)},
            "self_motion_sources": sources}


def _rmse(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(((a - b) ** 2).sum(axis=1).mean()))
