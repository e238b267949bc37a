"""How wrong is each link of the experience map? Every driven link against the ground truth.

Run: ``python benchmarks/link_errors.py RUN [--force]``, where RUN is the output folder of
``benchmarks/generalization.py`` (its ``drives/*/`` hold ``map.npz`` and ``groundtruth.tum``). A measurement,
not a test: it asserts nothing and is not part of the pytest run. About a second a drive.

The least-squares map (:func:`neuroslam.relaxation.solve_least_squares`) weighs each link's squared errors: 1
m² of position against 1 rad² of yaw, and a link whose distance was blind for t seconds its length by s² / (s²
+ (b t)²), s = ``link_length_error``, b = ``blind_speed_error`` (eq. M5). Those weights are a noise model;
this script measures the noise. For every link the odometry made to a new experience (target = source + 1,
weight 1: not a loop closure), the true relative pose between the two experiences' creation frames, in the
source's frame, against the link's: the errors forward (along the robot's heading), sideways, in height and in
yaw. The errors are split by the link's seconds blind in distance (``link_blind_times`` of the map, saved by
maps made since eq. M5; older maps count as all seen): none, up to half a second, and more; and the seen links
by their duration, for ``link_length_error``. It writes ``RUN/link_errors.csv`` (one row per drive: counts and
sums of squares per group, so that drives pool exactly) and prints the root mean squares pooled over the
drives, and the variance ratios the map's weights stand for: blind forward against seen forward, and yaw
(rad²) against position (m²).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from exact_odometry import experience_truth
from generalization import measure_drives

from neuroslam.geometry import relative, wrap

GROUPS = {"seen": (-1.0, 0.0), "blind_short": (0.0, 0.5), "blind_long": (0.5, np.inf)}  # s blind (lower excluded)
SHORT = 0.35  # s: the seen links this brief give ``link_length_error``
QUANTITIES = ("forward", "side", "height", "yaw")


def measure(drive: Path) -> dict:
    """One row: per group of seconds blind (and for the brief seen links), the number of driven links and the
    sums of their squared errors (forward, side and height in m², yaw in rad²), of their squared seconds
    blind (s²) and of their true lengths (m)."""
    metrics = json.loads((drive / "metrics.json").read_text())
    with np.load(drive / "map.npz") as saved:
        state = {name.split(".", 1)[1]: saved[name] for name in saved.files if name.startswith("experience_map.")}
    links, link_poses, weights = state["links"], state["link_poses"], state["link_weights"]
    blind_times = state.get("link_blind_times", np.zeros(len(links)))
    times = state["creation_times"]
    driven = (links[:, 1] == links[:, 0] + 1) & (weights == 1.0) & (state["sessions"][links[:, 0]] == 0)
    truth = experience_truth(drive, times)  # each experience's true pose when it was made
    true_relative = relative(truth[links[driven, 0]], truth[links[driven, 1]])
    distance, heading, facing, height = link_poses[driven].T
    errors = {"forward": distance * np.cos(heading) - true_relative[:, 0],
              "side": distance * np.sin(heading) - true_relative[:, 1],
              "height": height - true_relative[:, 2],
              "yaw": wrap(facing - true_relative[:, 3])}
    length = np.hypot(true_relative[:, 0], true_relative[:, 1])
    blind = blind_times[driven]
    duration = times[links[driven, 1]] - times[links[driven, 0]]
    row = {"world": metrics["world"], "odometry": metrics.get("odometry", "visual")}
    groups = {name: (blind > low) & (blind <= high) for name, (low, high) in GROUPS.items()}
    groups["seen_brief"] = (blind == 0) & (duration <= SHORT)
    for group, members in groups.items():
        row[f"{group}_links"] = int(members.sum())
        row[f"{group}_length_m"] = float(length[members].sum())
        row[f"{group}_blind_squares"] = float(np.sum(blind[members] ** 2))
        for quantity in QUANTITIES:
            row[f"{group}_{quantity}_squares"] = float(np.sum(errors[quantity][members] ** 2))
    return row


def pooled(rows: list[dict], group: str, quantity: str) -> float:
    """Root mean square of ``quantity``'s error over the links of ``group`` in every drive (m or rad)."""
    count = sum(row[f"{group}_links"] for row in rows)
    return float(np.sqrt(sum(row[f"{group}_{quantity}_squares"] for row in rows) / count)) if count else float("nan")


def main(argv: list[str] | None = None) -> int:
    rows = measure_drives("link_errors", __doc__.split("\n\n")[0], measure, argv)
    if rows is None:
        return 2
    print(f"{'links':>12s} {'count':>7s} {'length (m)':>10s} {'blind (s)':>9s} "
          + " ".join(f"{q:>10s}" for q in QUANTITIES))
    for group in (*GROUPS, "seen_brief"):
        count = sum(row[f"{group}_links"] for row in rows)
        length = sum(row[f"{group}_length_m"] for row in rows) / count if count else float("nan")
        blind = pooled(rows, group, "blind")
        print(f"{group:>12s} {count:7d} {length:10.3f} {blind:9.2f} "
              + " ".join(f"{pooled(rows, group, q):10.4f}" for q in QUANTITIES))
    seen = pooled(rows, "seen_brief", "forward")
    print(f"link_length_error (the brief seen links' forward error): {seen:.3f} m")
    for group in GROUPS:
        if group != "seen":
            excess = max(pooled(rows, group, "forward") ** 2 - seen ** 2, 0.0)
            print(f"blind_speed_error from the {group} links: {np.sqrt(excess) / pooled(rows, group, 'blind'):.2f} m/s")
    position = np.hypot(pooled(rows, "seen_brief", "forward"), pooled(rows, "seen_brief", "side")) / np.sqrt(2)
    print(f"brief seen links: position variance per axis (m²) / yaw variance (rad²): "
          f"{(position / pooled(rows, 'seen_brief', 'yaw')) ** 2:.2f}, the weight of 1 rad² of yaw against 1 m² "
          "of position that these errors stand for (the map weighs them 1 : 1)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
