"""How much of a drive's error is its levels placed wrong against each other, and how much lies within them.

Run: ``python benchmarks/level_placement.py RUN [--force]``, where ``RUN`` is a folder written by
``benchmarks/generalization.py`` (it reads ``RUN/drives/*/{metrics.json, groundtruth.tum, slam.tum}``). A
measurement, not a test: it asserts nothing and is not part of the pytest run. Under a second a drive here.

A multi-level map's levels are joined only by the ramps' odometry: a ramp read a few per cent long, or turned
a degree, moves the whole level above it, the same way on every lap, where loop closures on either level
cannot see it. Per drive, the SLAM trajectory (``slam.tum``) after the benchmark's Sim(3) alignment
(``ate_slam_m``, ``metrics.json``'s) is split by the level each frame truly is on (the nearest floor); each
level's frames are then aligned again on their own by a rigid SE(3) fit (``ate_levels_apart_m``: the error
left within the levels), and that fit's rotation about the vertical and its shift at the level's centre are
the level's misplacement (``level_yaw_deg``, ``level_shift_m``: the largest over the drive's levels).
``placement_share`` is the share of the squared error the levels' own fits remove. A fit per level has more
freedom than one for the whole drive, so it removes some error on a single level too (``levels`` 1: the
share is that freedom's alone). Ramp frames count with the nearer floor.

It writes ``RUN/level_placement.csv`` (one row per drive) and prints the table, and the medians over the
drives not largely blind (``generalization.largely_blind``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from generalization import BLIND_LIMIT, measure_drives

from neuroslam.evaluation.metrics import align, nearest_level
from neuroslam.evaluation.trajectory import umeyama
from neuroslam.tum import read_tum


def measure(drive: Path) -> dict:
    """One drive's row (see the module)."""
    metrics = json.loads((drive / "metrics.json").read_text())
    truth = read_tum(drive / "groundtruth.tum")[1]
    estimate = align(read_tum(drive / "slam.tum")[1], truth)
    levels = nearest_level(truth[:, 2], np.asarray(metrics["levels"], dtype=float))
    within = np.zeros(len(truth))
    yaws, shifts = [], []
    for level in np.unique(levels):
        on = levels == level
        if on.sum() < 3:
            continue
        _, rotation, translation = umeyama(estimate[on], truth[on], with_scale=False)
        within[on] = np.sum((estimate[on] @ rotation.T + translation - truth[on]) ** 2, axis=1)
        centre = estimate[on].mean(axis=0)
        yaws.append(abs(math.degrees(math.atan2(rotation[1, 0], rotation[0, 0]))))
        shifts.append(float(np.linalg.norm((rotation @ centre + translation - centre)[:2])))
    whole = float(np.sqrt(np.mean(np.sum((estimate - truth) ** 2, axis=1))))
    apart = float(np.sqrt(np.mean(within)))
    blind = metrics.get("blind_share") or {}
    return {"world": metrics.get("world", drive.name), "levels": len(np.unique(levels)), "ate_slam_m": whole,
            "ate_levels_apart_m": apart, "placement_share": 1 - (apart / whole) ** 2 if whole > 0 else 0.0,
            "level_yaw_deg": max(yaws, default=0.0), "level_shift_m": max(shifts, default=0.0),
            "largely_blind": max(blind.get("distance") or 0.0, blind.get("yaw") or 0.0) > BLIND_LIMIT}


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("level_placement", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    columns = ["levels", "ate_slam_m", "ate_levels_apart_m", "placement_share", "level_yaw_deg", "level_shift_m"]
    print(f"{'world':10s} " + " ".join(f"{name[:18]:>18s}" for name in columns) + "  largely blind")
    for row in rows:
        print(f"{row['world']:10s} " + " ".join(f"{row[name]:18.2f}" for name in columns)
              + f"  {'yes' if row['largely_blind'] else ''}")
    seen = [row for row in rows if not row["largely_blind"]]
    if seen:
        print(f"{'median':10s} " + " ".join(f"{np.median([row[name] for row in seen]):18.2f}" for name in columns)
              + f"  (the {len(seen)} drives not largely blind)")
        print(f"SLAM ATE within 2 m: {sum(row['ate_slam_m'] <= 2 for row in seen)} of {len(seen)}; with each level "
              f"fitted apart: {sum(row['ate_levels_apart_m'] <= 2 for row in seen)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
