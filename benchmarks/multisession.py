"""Does a second session that starts on another level merge into the first one's map, and only truly?

Run: ``python benchmarks/multisession.py --out runs/multisession [--worlds gen:100-104] [--laps 1]
[--max-frames N] [--config FILE]``. A measurement, not a test: it asserts nothing and is not part of the pytest
run. About 25 minutes here for the default five worlds; ``--config`` sets NeuroSLAM's settings over the preset
(``neuroslam drive --config``) in the first and the single session, and the second keeps them with the map it
loads.

What it does, per world (camera only, the default preset): a first session drives the ``main`` route
(``--laps`` laps, from the ground floor) and saves its map; a second session drives the ``upper`` route (the
same loop begun on level 1, where the first never began) with ``--load-map`` of the first, starting unknown;
and a single session drives ``main`` for twice the laps, as the map one robot would have made of both. The
worlds are the first five of the generalization benchmark's generated worlds (``gen:100``–``gen:104``),
fixed before any result was seen.

It writes ``OUT/WORLD/{first,second,single}/`` (each drive's outputs), ``OUT/multisession.md`` (one row per
world) and ``OUT/summary.json``, and prints the table. Each row also splits the merged map's error by where its
experiences came from (:func:`merged_map_parts`): the second session's experiences made before its first
merge (its own partial map, joined to the loaded one only at the merge), and the map without them. Issue 23's
target, per world: one merge or more, none false, and the merged map's error (``map_rmse_m`` of the second
session: its experiences after the merge, the first session's included) at most 1.25 × the single session's.
Running it again into the same folder drives only what is missing.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
from pathlib import Path

import numpy as np

from neuroslam.evaluation.metrics import align
from neuroslam.lab.cli import main as neuroslam
from neuroslam.lab.sweep import expand_worlds
from neuroslam.maps import read_map
from neuroslam.tum import read_tum

WORLDS = ["gen:100", "gen:101", "gen:102", "gen:103", "gen:104"]  # the generalization benchmark's first five
MAP_RATIO = 1.25  # the merged map's error at most this times one session's


def _drive(out: Path, world: str, *arguments: str) -> dict:
    """One ``neuroslam drive`` into ``out`` (skipped when its metrics exist); its metrics.json."""
    metrics = out / "metrics.json"
    if not metrics.exists():
        with contextlib.redirect_stdout(io.StringIO()):
            code = neuroslam(["drive", world, *arguments, "--out", str(out)])
        if code != 0:
            raise SystemExit(f"neuroslam drive {world} {' '.join(arguments)} failed with exit code {code}")
    return json.loads(metrics.read_text())


def merged_map_parts(second: Path, merge_frames: list[int]) -> dict:
    """The second session's merged map, split by where its experiences came from: ``before_merge`` (the
    second session's experiences made before its first merge: its own partial map, which the merge joined
    to the loaded one at one place), their count, their RMSE (m) within the whole map's Sim(3) alignment
    (``map_rmse_m``'s), and the RMSE of the map without them (aligned on its own). None where there was no
    merge or the map carries no truth."""
    empty = {"before_merge": 0, "before_merge_rmse_m": None, "map_without_them_rmse_m": None}
    if not merge_frames:
        return empty
    _, arrays = read_map(second / "map.npz")
    truth = arrays.get("extra.experience_truth")
    if truth is None:
        return empty
    components, sessions = arrays["experience_map.components"], arrays["experience_map.sessions"]
    mine = components == components[np.argmax(sessions)]  # the robot's map (the newest session's component)
    made, mapped = truth[mine, :3], arrays["experience_map.poses"][mine, :3]
    merge_time = read_tum(second / "slam.tum")[0][merge_frames[0]]
    before = ((sessions[mine] == sessions.max()) & (arrays["experience_map.creation_times"][mine] < merge_time))
    known = np.all(np.isfinite(made), axis=1)
    errors = np.linalg.norm(align(mapped[known], made[known]) - made[known], axis=1)
    rest = known & ~before
    without = align(mapped[rest], made[rest]) - made[rest]
    return {"before_merge": int(np.count_nonzero(before & known)),
            "before_merge_rmse_m": float(np.sqrt(np.mean(errors[before[known]] ** 2))) if np.any(before & known)
            else None,
            "map_without_them_rmse_m": float(np.sqrt(np.mean(np.sum(without ** 2, axis=1)))) if rest.sum() >= 3
            else None}


def measure(world: str, out: Path, laps: int, max_frames: int | None, config: Path | None = None) -> dict:
    """The three drives of one world, with the settings of ``config`` over the preset (None: the preset's) in
    the first and the single session; the second keeps the configuration of the map it loads (the first's).
    One row of the table."""
    limit = ["--max-frames", str(max_frames)] if max_frames else []
    settings = ["--config", str(config)] if config is not None else []
    first = _drive(out / "first", world, "--route", "main", "--laps", str(laps), *limit, *settings)
    second = _drive(out / "second", world, "--route", "upper", "--laps", str(laps), "--load-map", str(out / "first"),
                    *limit)
    single = _drive(out / "single", world, "--route", "main", "--laps", str(2 * laps), *limit, *settings)
    merged, alone = second["map_rmse_m"], single["map_rmse_m"]
    ratio = merged / alone if merged is not None and alone else None
    return {
        "world": world, "merges": second["merges"], "false_merges": second["false_merges"],
        "map_components": second["map_components"], "merged_map_rmse_m": merged, "single_map_rmse_m": alone,
        "map_ratio": ratio, "first_slam_ate_m": first["ate_rmse_m"]["slam"],
        "second_slam_ate_m": second["ate_rmse_m"]["slam"],
        **merged_map_parts(out / "second", second.get("merge_frames") or []),
        "meets": bool(second["merges"] >= 1 and second["false_merges"] == 0 and ratio is not None
                      and ratio <= MAP_RATIO),
    }


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:.2f}"


def table(rows: list[dict]) -> str:
    """The per-world table as Markdown."""
    lines = ["| world | merges (false) | separate maps | merged map error (m) | one session's (m) | ratio | "
             "first / second session SLAM ATE (m) | meets the target | made before the merge: experiences, error (m) | "
             "map without them (m) |", "|---|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        lines.append(
            f"| {row['world']} | {row['merges']} ({row['false_merges']}) | {row['map_components']} | "
            f"{_number(row['merged_map_rmse_m'])} | {_number(row['single_map_rmse_m'])} | "
            f"{_number(row['map_ratio'])} | "
            f"{_number(row['first_slam_ate_m'])} / {_number(row['second_slam_ate_m'])} | "
            f"{'yes' if row['meets'] else 'no'} | {row['before_merge']}, {_number(row['before_merge_rmse_m'])} | "
            f"{_number(row['map_without_them_rmse_m'])} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="output folder")
    parser.add_argument("--worlds", nargs="+", default=WORLDS,
                        help="worlds with an 'upper' route (default: gen:100-104; gen:A-B ranges too)")
    parser.add_argument("--laps", type=int, default=1, help="laps per session (default: 1; the single drives twice)")
    parser.add_argument("--max-frames", type=int, help="stop every drive after this many frames (a smoke test)")
    parser.add_argument("--config", type=Path,
                        help="TOML or JSON file of NeuroSLAM settings over the preset for the first and the "
                             "single session (neuroslam drive --config); the second keeps its loaded map's")
    args = parser.parse_args(argv)
    if args.laps < 1:
        parser.error(f"--laps {args.laps}: must be at least 1")
    if args.out.exists() and not args.out.is_dir():
        parser.error(f"--out {str(args.out)!r}: exists and is not a folder")
    if args.config is not None and not args.config.is_file():
        parser.error(f"--config {str(args.config)!r}: no such file")
    rows = []
    for world in expand_worlds(args.worlds):
        print(f"{world} ...", file=sys.stderr, flush=True)
        rows.append(measure(world, args.out / world.replace(":", "_"), args.laps, args.max_frames, args.config))
    text = table(rows)
    (args.out / "multisession.md").write_text(text)
    summary = {"worlds": len(rows), "meet_the_target": sum(row["meets"] for row in rows), "rows": rows,
               "laps": args.laps, "max_frames": args.max_frames,
               "config": None if args.config is None else args.config.read_text()}
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(text, end="")
    print(f"{summary['meet_the_target']} of {len(rows)} worlds meet the target (a merge, none false, merged map "
          f"error ≤ {MAP_RATIO} × one session's)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
