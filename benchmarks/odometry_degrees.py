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
drive straight, and gives the distance read over the distance driven. The straight frames' yaw error is
also given per 100 m driven, apart on the floors and on the ramps (frames whose true height lies more than
:data:`OFF_FLOOR` from every floor of ``metrics.json``'s ``levels``), uphill and downhill: a ramp read turned
moves every level above it, which no loop closure on either level sees (``benchmarks/level_placement.py``).
So does a ramp read long or short, the same way up and down: the horizontal distance read over the distance
driven is given on the ramps too, uphill and downhill.

It writes ``RUN/odometry_degrees.csv`` (one row per drive) and prints the table and the medians.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from generalization import measure_drives

from neuroslam.datasets import read_groundtruth
from neuroslam.evaluation.metrics import nearest_level
from neuroslam.evaluation.trajectory import ate_rmse

TURNING = np.radians(0.5)  # rad a frame: a frame turning more than this is a turn, the others drive straight
OFF_FLOOR = 0.15  # m: a frame whose true height is farther than this from every floor is on a ramp


def per_100_m(error_deg: np.ndarray, distance: np.ndarray, frames: np.ndarray) -> float:
    """Yaw error (deg) summed over ``frames`` (a mask of steps) per 100 m of their true distance; NaN where
    they drove under a metre."""
    driven = float(distance[frames].sum())
    return float(100 * error_deg[frames].sum() / driven) if driven >= 1.0 else math.nan


def ratio(distance: np.ndarray, true_distance: np.ndarray, frames: np.ndarray) -> float:
    """The horizontal distance read over the distance driven on ``frames`` (a mask of steps); NaN where they
    drove under a metre."""
    driven = float(true_distance[frames].sum())
    return float(distance[frames].sum() / driven) if driven >= 1.0 else math.nan


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
    levels = np.asarray(metrics["levels"], dtype=float)
    heights = truth[1:, 2]  # each step's height at its end
    on_ramp = np.abs(heights - levels[nearest_level(heights, levels)]) > OFF_FLOOR
    straight, rising = ~turning, true_climb > 0
    return {"world": metrics["world"], "ate_odometry_m": ate_rmse(odometry[:, :3], truth[:, :3]),
            "ate_rebuilt_m": ate_rmse(rebuild(distance, yaw, climb), truth[:, :3]),
            "ate_yaw_fixed_m": ate_rmse(rebuild(distance, true_yaw, climb), truth[:, :3]),
            "ate_distance_fixed_m": ate_rmse(rebuild(true_distance, yaw, climb), truth[:, :3]),
            "ate_height_fixed_m": ate_rmse(rebuild(distance, yaw, true_climb), truth[:, :3]),
            "yaw_error_turning_deg": float(yaw_error[turning].sum()),
            "yaw_error_straight_deg": float(yaw_error[~turning].sum()),
            "straight_floor_deg_per_100m": per_100_m(yaw_error, true_distance, straight & ~on_ramp),
            "straight_uphill_deg_per_100m": per_100_m(yaw_error, true_distance, straight & on_ramp & rising),
            "straight_downhill_deg_per_100m": per_100_m(yaw_error, true_distance, straight & on_ramp & ~rising),
            "distance_ratio": float(distance.sum() / max(true_distance.sum(), 1e-9)),
            "uphill_distance_ratio": ratio(distance, true_distance, on_ramp & rising),
            "downhill_distance_ratio": ratio(distance, true_distance, on_ramp & ~rising)}


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("odometry_degrees", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    print(f"{'world':10} {'odometry':>8} {'yaw fixed':>9} {'distance':>8} {'height':>7} "
          f"{'yaw err turning':>15} {'straight':>8} {'distance read':>13} "
          f"{'straight °/100 m: floor':>23} {'uphill':>6} {'downhill':>8} {'ramps read: uphill':>18} {'downhill':>8}")
    for row in rows:
        print(f"{row['world']:10} {row['ate_odometry_m']:8.2f} {row['ate_yaw_fixed_m']:9.2f} "
              f"{row['ate_distance_fixed_m']:8.2f} {row['ate_height_fixed_m']:7.2f} "
              f"{row['yaw_error_turning_deg']:+15.0f} {row['yaw_error_straight_deg']:+8.0f} "
              f"{row['distance_ratio']:13.3f} {row['straight_floor_deg_per_100m']:+23.1f} "
              f"{row['straight_uphill_deg_per_100m']:+6.1f} {row['straight_downhill_deg_per_100m']:+8.1f} "
              f"{row['uphill_distance_ratio']:18.3f} {row['downhill_distance_ratio']:8.3f}")
    median = {key: float(np.nanmedian([row[key] for row in rows])) for key in rows[0] if key != "world"}
    positive = sum(row["yaw_error_straight_deg"] > 0 for row in rows)
    print(f"{len(rows)} drives, median ATE (m): odometry {median['ate_odometry_m']:.2f}, rebuilt "
          f"{median['ate_rebuilt_m']:.2f}, yaw fixed {median['ate_yaw_fixed_m']:.2f}, distance fixed "
          f"{median['ate_distance_fixed_m']:.2f}, height fixed {median['ate_height_fixed_m']:.2f}; median |yaw "
          f"error| turning {np.median([abs(r['yaw_error_turning_deg']) for r in rows]):.0f}°, straight "
          f"{np.median([abs(r['yaw_error_straight_deg']) for r in rows]):.0f}° (counter-clockwise on {positive}); "
          f"median straight yaw error per 100 m: floors {median['straight_floor_deg_per_100m']:+.1f}°, uphill "
          f"{median['straight_uphill_deg_per_100m']:+.1f}°, downhill {median['straight_downhill_deg_per_100m']:+.1f}°; "
          f"median distance read on the ramps: uphill {median['uphill_distance_ratio']:.3f}, downhill "
          f"{median['downhill_distance_ratio']:.3f} of the distance driven (beyond 5 % long on "
          f"{sum(max(r['uphill_distance_ratio'], r['downhill_distance_ratio']) > 1.05 for r in rows)} drives).")
    return 0


if __name__ == "__main__":
    sys.exit(main())
