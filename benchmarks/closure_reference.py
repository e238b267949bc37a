"""Is a world's error the map's or the odometry's? Each drive's odometry with every loop closed exactly.

Run: ``python benchmarks/closure_reference.py RUN [--force]``, where RUN is the output folder of
``benchmarks/generalization.py`` (its ``drives/*/`` hold ``groundtruth.tum``, ``odometry.tum`` and
``metrics.json``). A measurement, not a test: it asserts nothing and is not part of the pytest run. About
10 s a drive here.

What it does, per drive: a pose graph (x, y, z, yaw) with one node every ``STEP`` frames, linked by the
drive's own self-motion (``odometry.tum``: what NeuroSLAM integrated, its heights included) and by an
*exact* loop closure wherever the robot truly came back: a node within ``RADIUS`` of an earlier node (at
least ``SEPARATION`` nodes before it) and facing within ``HEADING`` of the way it faced there (a forward
camera recognises a place only facing the same way), every third such node, with the true relative pose
between the two. The links weigh as the least-squares map's do (driven 1, closures ``closure_weight``
0.1, eq. 25's squared errors), and the graph is solved by ``scipy.optimize.least_squares``. Its Sim(3) ATE
is the **reference**: what the map would make of this odometry if it recognised every revisit and knew
exactly where it was. It is a reference, not a bound: NeuroSLAM's map replaces a revisit's frames by the
experiences of the first visit (and can do better than the reference where the odometry's error is
concentrated in a few frames), and it closes fewer loops, less exactly (so it can do worse).

A world whose reference misses the benchmark's "halves" target (≤ 2 m and ≤ 0.5 × the odometry's ATE) misses them
because of its odometry and its route (how often and where it comes back), whatever the loop closures do.
It writes ``RUN/closure_reference.csv`` (one row per drive) and prints the table and how many worlds the
reference and the SLAM meet the targets on.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from generalization import TARGETS, measure_drives
from scipy.optimize import least_squares
from scipy.sparse import coo_matrix

from neuroslam.datasets import read_groundtruth
from neuroslam.evaluation.trajectory import ate_rmse
from neuroslam.geometry import relative, wrap

STEP = 10  # frames per node: 1 m at the testbed's 1 m/s and 10 frames/s
RADIUS = 1.0  # m, how near an earlier node a revisit must pass (the confirmation tolerance)
HEADING = 0.5  # rad, how nearly it must face the same way
SEPARATION = 60  # nodes (about 60 m) between a node and the earlier ones it may close a loop with
CLOSURE_WEIGHT = 0.1  # ExperienceMapConfig.closure_weight
HALVES, MEETS_HALVES = TARGETS["halves"]  # the generalization benchmark's target: its words and its test


def revisits(truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(earlier, later) node indices where the robot truly came back facing the same way (see the module)."""
    earlier, later = [], []
    for node in range(SEPARATION, len(truth), 3):
        before = truth[: node - SEPARATION]
        near = np.linalg.norm(before[:, :3] - truth[node, :3], axis=1)
        turned = np.abs(wrap(before[:, 3] - truth[node, 3]))
        candidates = np.flatnonzero((near < RADIUS) & (turned < HEADING))
        if len(candidates):
            earlier.append(int(candidates[np.argmin(near[candidates])]))
            later.append(node)
    return np.array(earlier, dtype=int), np.array(later, dtype=int)


def reference_map(odometry: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, int]:
    """The pose graph of the module docstring solved: (nodes' poses (N, 4), loop closures used)."""
    n = len(odometry)
    earlier, later = revisits(truth)
    sources = np.r_[np.arange(n - 1), earlier]
    targets = np.r_[np.arange(1, n), later]
    measured = np.vstack([relative(odometry[:-1], odometry[1:]), relative(truth[earlier], truth[later])])
    weights = np.sqrt(np.r_[np.ones(n - 1), np.full(len(earlier), CLOSURE_WEIGHT)])
    links = len(sources)

    def residuals(flat: np.ndarray) -> np.ndarray:
        poses = flat.reshape(n, 4)
        a, b = poses[sources], poses[targets]
        c, s = np.cos(a[:, 3]), np.sin(a[:, 3])
        return np.concatenate([
            (a[:, 0] + c * measured[:, 0] - s * measured[:, 1] - b[:, 0]) * weights,
            (a[:, 1] + s * measured[:, 0] + c * measured[:, 1] - b[:, 1]) * weights,
            (a[:, 2] + measured[:, 2] - b[:, 2]) * weights,
            wrap(a[:, 3] + measured[:, 3] - b[:, 3]) * weights,
            (poses[0] - odometry[0]) * 100.0])  # the first node holds the graph in place

    rows, columns = [], []
    for block in range(4):
        for nodes in (sources, targets):
            for variable in range(4):
                rows.append(block * links + np.arange(links))
                columns.append(4 * nodes + variable)
    rows.append(4 * links + np.arange(4))
    columns.append(np.arange(4))
    rows, columns = np.concatenate(rows), np.concatenate(columns)
    sparsity = coo_matrix((np.ones(len(rows)), (rows, columns)), shape=(4 * links + 4, 4 * n)).tocsr()
    sparsity.data[:] = 1
    solution = least_squares(residuals, odometry.ravel(), jac_sparsity=sparsity, method="trf", x_scale="jac",
                             max_nfev=60)
    return solution.x.reshape(n, 4), len(earlier)


def measure(drive: Path) -> dict:
    """One row: the drive's odometry and SLAM ATE (m, Sim(3), from its metrics.json), the reference's (over the
    nodes) and the closures the reference used."""
    metrics = json.loads((drive / "metrics.json").read_text())
    truth = read_groundtruth(drive / "groundtruth.tum").poses
    odometry = read_groundtruth(drive / "odometry.tum").poses  # a TUM trajectory like any other
    if len(truth) != len(odometry):
        raise SystemExit(f"{drive}: {len(truth)} ground-truth rows for {len(odometry)} odometry rows")
    nodes = np.arange(0, len(truth), STEP)
    solved, closures = reference_map(odometry[nodes], truth[nodes])
    return {"world": metrics["world"], "odometry": metrics.get("odometry", "visual"),
            "ate_odometry_m": metrics["ate_rmse_m"]["odometry"],
            "ate_reference_m": ate_rmse(solved[:, :3], truth[nodes, :3]),
            "ate_slam_m": metrics["ate_rmse_m"]["slam"], "reference_closures": closures}


def meets(ate: float, odometry: float) -> bool:
    """The benchmark's "halves" target for one world (:data:`generalization.TARGETS`)."""
    return bool(MEETS_HALVES({"slam": ate, "odometry": odometry}))


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("closure_reference", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    print(f"{'world':10s} {'odometry':>9s} {'reference':>10s} {'SLAM':>7s} {'closures':>9s}")
    for row in rows:
        print(f"{row['world']:10s} {row['ate_odometry_m']:9.2f} {row['ate_reference_m']:10.2f} "
              f"{row['ate_slam_m']:7.2f} {row['reference_closures']:9d}")
    reference = sum(meets(row["ate_reference_m"], row["ate_odometry_m"]) for row in rows)
    slam = sum(meets(row["ate_slam_m"], row["ate_odometry_m"]) for row in rows)
    ratio = np.median([row["ate_slam_m"] / row["ate_reference_m"] for row in rows])
    print(f"{len(rows)} worlds: {HALVES} holds for the reference on {reference}, for the SLAM on {slam}; "
          f"SLAM / reference median {ratio:.2f}.")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
