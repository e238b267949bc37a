"""Where a final map's error lies: the map re-solved with its driven links made exact, one part at a time.

Run: ``python benchmarks/exact_odometry.py RUN [--force]``, where ``RUN`` is a folder written by
``benchmarks/generalization.py`` (it reads ``RUN/drives/*/{map.npz, groundtruth.tum, metrics.json}``). A
measurement, not a test: it asserts nothing and is not part of the pytest run. A few seconds a drive here.

``benchmarks/closure_reference.py`` keeps a drive's odometry and closes every loop exactly; this is its
complement: it keeps the map's own loop closures and makes the odometry exact. Per drive, the final map's
links (NeuroSLAM eq. 23: distance, heading from the source's yaw, facing, height change) are split into the
driven ones (weight 1: from an experience to the next, the odometry between them) and the loop closures
(weight ``closure_weight``, less than 1). Each driven link's measurement is replaced by the truth between its
two experiences (their ground-truth poses when they were made), in part or whole, and the map solved again
to convergence by the library's own least squares (:func:`neuroslam.relaxation.solve_least_squares`, from
the final map's poses). The experiences' Sim(3) ATE (m) of each:

- ``map``: the final map as written (``metrics.json``'s ``map_rmse_m``);
- ``exact``: every part of the driven links exact, the loop closures as the map made them: what the map's
  own closures leave when the odometry is perfect (the closures' placement error, a floor under the map);
- ``exact_no_closures``: the same without the closures (0 up to round-off: a check of the construction);
- ``exact_distance``, ``exact_yaw`` (heading and facing), ``exact_height``: one part exact, the others as
  measured, the closures kept.

A map whose ``exact`` error is near its ``map`` error owes it to its closures; one whose ``exact`` error is
small owes it to its odometry, and the one-part columns say whether a single part would do (they need
not: errors of different parts can cancel, and making one exact exposes the other). Also per drive: the
loop-closure links' error against the truth (where a closure puts its target from its source's true pose,
horizontal, m): median and 90th percentile.

It writes ``RUN/exact_odometry.csv`` (one row per drive) and prints the table and the medians.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from generalization import measure_drives

from neuroslam.datasets import read_groundtruth
from neuroslam.evaluation.trajectory import ate_rmse
from neuroslam.geometry import wrap
from neuroslam.maps import read_map
from neuroslam.relaxation import solve_least_squares

SOLVES = 40  # calls of solve_least_squares at most (3 Gauss–Newton iterations each) until the map settles
PARTS = {"exact": "dyh", "exact_distance": "d", "exact_yaw": "y", "exact_height": "h"}


def experience_truth(drive: Path, creation_times: np.ndarray) -> np.ndarray:
    """(n, 4) each experience's ground-truth pose (x, y, z, yaw; m, rad) when it was made."""
    truth = read_groundtruth(drive / "groundtruth.tum")
    rows = np.clip(np.searchsorted(truth.times, creation_times - 1e-6), 0, len(truth.times) - 1)
    return truth.poses[rows]


def exact_links(link_poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, truth: np.ndarray,
                driven: np.ndarray, parts: str) -> np.ndarray:
    """``link_poses`` with the driven links' ``parts`` (d: distance, y: heading and facing, h: height change)
    replaced by the truth between their experiences."""
    exact = link_poses.copy()
    delta = truth[targets[driven]] - truth[sources[driven]]
    if "d" in parts:
        exact[driven, 0] = np.hypot(delta[:, 0], delta[:, 1])
    if "y" in parts:
        exact[driven, 1] = wrap(np.arctan2(delta[:, 1], delta[:, 0]) - truth[sources[driven], 3])
        exact[driven, 2] = wrap(delta[:, 3])
    if "h" in parts:
        exact[driven, 3] = delta[:, 2]
    return exact


def solved(poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, link_poses: np.ndarray,
           weights: np.ndarray) -> np.ndarray:
    """The least-squares map of these links from ``poses``, to convergence (at most :data:`SOLVES` calls)."""
    for _ in range(SOLVES):
        poses, settled = solve_least_squares(poses, sources, targets, link_poses, weights)
        if settled:
            break
    return poses


def closure_errors(link_poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Each loop-closure link's horizontal error (m): where it puts its target from its source's true pose,
    against the target's true position."""
    distance, heading = link_poses[:, 0], link_poses[:, 1]
    direction = truth[sources, 3] + heading
    placed = truth[sources, :2] + distance[:, None] * np.column_stack([np.cos(direction), np.sin(direction)])
    return np.linalg.norm(placed - truth[targets, :2], axis=1)


def measure(drive: Path) -> dict:
    """One row of the module docstring's measurements."""
    metrics = json.loads((drive / "metrics.json").read_text())
    _, arrays = read_map(drive / "map.npz")
    poses = arrays["experience_map.poses"]
    links = arrays["experience_map.links"].astype(int)
    sources, targets = links[:, 0], links[:, 1]
    link_poses, weights = arrays["experience_map.link_poses"], arrays["experience_map.link_weights"]
    truth = experience_truth(drive, arrays["experience_map.creation_times"])
    driven = weights >= 1.0
    row = {"world": metrics["world"], "odometry": metrics.get("odometry", "visual"),
           "ate_odometry_m": metrics["ate_rmse_m"]["odometry"], "ate_slam_m": metrics["ate_rmse_m"]["slam"],
           "map": ate_rmse(poses[:, :3], truth[:, :3]), "closures": int((~driven).sum())}
    for name, parts in PARTS.items():
        exact = exact_links(link_poses, sources, targets, truth, driven, parts)
        row[name] = ate_rmse(solved(poses, sources, targets, exact, weights)[:, :3], truth[:, :3])
        if name == "exact":
            row["exact_no_closures"] = ate_rmse(solved(poses, sources[driven], targets[driven], exact[driven],
                                                       weights[driven])[:, :3], truth[:, :3])
    errors = closure_errors(link_poses[~driven], sources[~driven], targets[~driven], truth)
    row["closure_error_median_m"] = float(np.median(errors)) if len(errors) else 0.0
    row["closure_error_p90_m"] = float(np.percentile(errors, 90)) if len(errors) else 0.0
    return row


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("exact_odometry", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    columns = ["map", "exact", "exact_no_closures", "exact_distance", "exact_yaw", "exact_height",
               "closure_error_median_m", "closure_error_p90_m"]
    print(f"{'world':10s} {'odometry':>9s} " + " ".join(f"{name[:14]:>14s}" for name in columns))
    for row in rows:
        print(f"{row['world']:10s} {row['ate_odometry_m']:9.2f} "
              + " ".join(f"{row[name]:14.2f}" for name in columns))
    print(f"{'median':10s} {np.median([row['ate_odometry_m'] for row in rows]):9.2f} "
          + " ".join(f"{np.median([row[name] for row in rows]):14.2f}" for name in columns))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
