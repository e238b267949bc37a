"""Which degree of freedom carries each drive's odometry error: its yaw, its distance or its height?

Run: ``python benchmarks/odometry_degrees.py RUN [--force]``, where ``RUN`` is a folder written by
``benchmarks/generalization.py`` (it reads ``RUN/drives/*/{odometry.tum, groundtruth.tum, metrics.json}``).
A measurement, not a test: it asserts nothing and is not part of the pytest run. Seconds per drive.

What it does, per drive: it rebuilds the odometry's path from its own per-frame increments (distance along
the mean heading, yaw change, height change), then rebuilds it again three times with one degree of freedom
taken from the ground truth instead: the true yaw changes ("yaw fixed"), the true distances ("distance
fixed"), the true height changes ("height fixed"). The Sim(3) ATE of each (m) says how much of the
odometry's error that degree of freedom carries: a drive whose "yaw fixed" ATE is a fraction of the
odometry's owes its error to the yaw. It also splits the yaw error (degrees, summed over the drive, positive
counter-clockwise) between the frames that turn more than 0.5° (5°/s at 10 frames/s) and the frames that
drive straight, and gives the distance read over the distance driven.

It writes ``RUN/odometry_degrees.csv`` (one row per drive) and prints the table and the medians.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from generalization import measure_drives

from neuroslam.datasets import read_groundtruth
from neuroslam.evaluation.trajectory import ate_rmse

TURNING = np.radians(0.5)  # rad a frame: a frame turning more than this is a turn, the others drive straight


def rebuild(distances: np.ndarray, yaw: np.ndarray, climbs: np.ndarray) -> np.ndarray:
    """(N, 3) positions from N - 1 per-frame distances (m, horizontal), N unwrapped yaws (rad) and N - 1
    height changes (m), each step taken along the mean of its two yaws, starting at the origin."""
    heading = yaw[:-1] + np.diff(yaw) / 2
    return np.c_[np.r_[0.0, np.cumsum(distances * np.cos(heading))],
                 np.r_[0.0, np.cumsum(distances * np.sin(heading))], np.r_[0.0, np.cumsum(climbs)]]


def measure(drive: Path) -> dict:
    """One row: the odometry's ATE (m, Sim(3)) as driven, rebuilt, and rebuilt with each degree of freedom
    fixed; the yaw error (deg) on turning and straight frames; the distance read over the distance driven."""
    metrics = json.loads((drive / "metrics.json").read_text())
    truth = read_groundtruth(drive / "groundtruth.tum").poses
    odometry = read_groundtruth(drive / "odometry.tum").poses
    if len(truth) != len(odometry):
        raise SystemExit(f"{drive}: {len(truth)} ground-truth rows for {len(odometry)} odometry rows")
    steps = {name: (np.linalg.norm(np.diff(poses[:, :2], axis=0), axis=1), np.unwrap(poses[:, 3]),
                    np.diff(poses[:, 2])) for name, poses in (("truth", truth), ("odometry", odometry))}
    (true_distance, true_yaw, true_climb), (distance, yaw, climb) = steps["truth"], steps["odometry"]
    true_turn, turn = np.diff(true_yaw), np.diff(yaw)
    turning = np.abs(true_turn) > TURNING
    yaw_error = np.degrees(turn - true_turn)
    return {"world": metrics["world"], "ate_odometry_m": ate_rmse(odometry[:, :3], truth[:, :3]),
            "ate_rebuilt_m": ate_rmse(rebuild(distance, yaw, climb), truth[:, :3]),
            "ate_yaw_fixed_m": ate_rmse(rebuild(distance, true_yaw, climb), truth[:, :3]),
            "ate_distance_fixed_m": ate_rmse(rebuild(true_distance, yaw, climb), truth[:, :3]),
            "ate_height_fixed_m": ate_rmse(rebuild(distance, yaw, true_climb), truth[:, :3]),
            "yaw_error_turning_deg": float(yaw_error[turning].sum()),
            "yaw_error_straight_deg": float(yaw_error[~turning].sum()),
            "distance_ratio": float(distance.sum() / max(true_distance.sum(), 1e-9))}


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("odometry_degrees", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    print(f"{'world':10} {'odometry':>8} {'yaw fixed':>9} {'distance':>8} {'height':>7} "
          f"{'yaw err turning':>15} {'straight':>8} {'distance read':>13}")
    for row in rows:
        print(f"{row['world']:10} {row['ate_odometry_m']:8.2f} {row['ate_yaw_fixed_m']:9.2f} "
              f"{row['ate_distance_fixed_m']:8.2f} {row['ate_height_fixed_m']:7.2f} "
              f"{row['yaw_error_turning_deg']:+15.0f} {row['yaw_error_straight_deg']:+8.0f} "
              f"{row['distance_ratio']:13.3f}")
    median = {key: float(np.median([row[key] for row in rows])) for key in rows[0] if key != "world"}
    positive = sum(row["yaw_error_straight_deg"] > 0 for row in rows)
    print(f"{len(rows)} drives, median ATE (m): odometry {median['ate_odometry_m']:.2f}, rebuilt "
          f"{median['ate_rebuilt_m']:.2f}, yaw fixed {median['ate_yaw_fixed_m']:.2f}, distance fixed "
          f"{median['ate_distance_fixed_m']:.2f}, height fixed {median['ate_height_fixed_m']:.2f}; median |yaw "
          f"error| turning {np.median([abs(r['yaw_error_turning_deg']) for r in rows]):.0f}°, straight "
          f"{np.median([abs(r['yaw_error_straight_deg']) for r in rows]):.0f}° (counter-clockwise on {positive}).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
