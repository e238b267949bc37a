"""Does the accuracy hold on worlds nobody tuned on? The distribution over many generated worlds.

Run: ``python benchmarks/generalization.py --out runs/generalization [--odometry wheel] [--quick]
[--handwritten] [--camera-noise] [--generator N] [--workers 2] [--laps 2] [--grid FIELD=VALUE ...]``. A
measurement, not a test: it asserts nothing and is not part of the pytest run. About an hour with 2 workers on
an idle 2-core machine (464,000 frames at about 14 ms each; 2½ hours beside other work; ``--quick``: 59,000
frames, about 15 minutes; ``--handwritten``: about 3 minutes).

What it does: drives the main route of every world below (2 laps, camera only unless ``--odometry`` says
otherwise, the default preset) through ``neuroslam sweep`` on a local Ray instance, one drive per worker,
and scores each drive as ``metrics.json`` does. The worlds are the three built-ins and 40 generated ones,
seeds 100 to 139 of the generator's latest version (``--generator 1``: of version 1, on which the first
measurements were made): a range fixed before any result was seen, disjoint from the development worlds
``gen1:1``–``gen1:3`` (and so not chosen to flatter or to embarrass the method). ``--quick`` drives the first
10 generated worlds and the car park, 1 lap. ``--handwritten`` drives the hand-written MJCF worlds of
``benchmarks/worlds/`` instead (:data:`HANDWRITTEN`: worlds a person wrote as MJCF files, outside the
generator's family; ``benchmarks/worlds/README.md`` says what each is for).

It writes ``OUT/results.csv`` (the sweep's rows: every number of every drive's metrics), ``OUT/worlds.md``
(one row per world: SLAM and odometry ATE, their ratio, false closures, level accuracy, the shares of
frames the odometry was blind in each degree of freedom, and which targets it meets) and
``OUT/summary.json``, and prints the distribution: median, 90th percentile and worst SLAM ATE and ratio,
and how many worlds meet each of the project's accuracy targets (:data:`TARGETS`), over every world and
again without those blind in distance or yaw on more than a quarter of their frames (:data:`BLIND_LIMIT`:
counted apart, not hidden). Running it again into
the same folder drives only what is missing and summarises the whole.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np
from tqdm import tqdm

from neuroslam.lab.sweep import expand_worlds, parse_grid, run_sweep
from sim.arenas import GENERATOR_VERSION, GENERATOR_VERSIONS

BUILT_IN = ["carpark", "urban", "building"]
# MJCF files written by hand, not by the generator (``--handwritten``), each with its NAME.routes.json
HANDWRITTEN = sorted(str(path) for path in (Path(__file__).resolve().parent / "worlds").glob("*.xml"))
SEEDS = range(100, 140)  # fixed before any result was seen
# ``--camera-noise``: a small camera's sensor at 8 bits (read noise 2 grey levels, photon noise 4 at white) and
# a 20 ms shutter (2 cm of travel at 1 m/s: under a pixel of blur on the near floor)
CAMERA_NOISE = {"read_noise": 2.0, "shot_noise": 4.0, "exposure": 0.02}

# The project's accuracy targets per world (issue 23): name → (description, test on one world's row).
TARGETS = {
    "halves": ("SLAM ATE ≤ 0.5 × odometry's and ≤ 2 m",
               lambda r: r["slam"] <= 0.5 * r["odometry"] and r["slam"] <= 2.0),
    "no_catastrophe": ("SLAM ATE ≤ 5 m and ≤ odometry's", lambda r: r["slam"] <= 5.0 and r["slam"] <= r["odometry"]),
    "no_false_closure": ("no false loop closure", lambda r: r["false_closures"] == 0),
    "on_the_floor": ("level accuracy ≥ 0.95",
                     lambda r: r["level_accuracy"] is not None and r["level_accuracy"] >= 0.95),
}
# the share of worlds each target must hold on
TARGET_SHARES = {"halves": 0.90, "no_catastrophe": 1.0, "no_false_closure": 1.0, "on_the_floor": 0.95}
# A world whose odometry saw nothing of its distance or of its yaw on more than this share of its frames (the
# blind shares of metrics.json) is largely unobservable for the camera: a blank floor with walls and ceiling
# too far, too faint or absent. Issue 23 asks for such worlds to be counted apart, not hidden: the summary
# counts every world, and again the others alone. A quarter is a round share fixed for that, not fitted.
BLIND_LIMIT = 0.25


def _number(value) -> float | None:
    if value in (None, "", "None", "null"):
        return None
    return float(value)


def world_rows(results: list[dict]) -> list[dict]:
    """One summary row per drive that finished: the numbers the targets and the table need."""
    rows = []
    for result in results:
        if result.get("status") != "ok":
            continue
        slam, odometry = _number(result["ate_rmse_m.slam"]), _number(result["ate_rmse_m.odometry"])
        row = {
            "world": result["world"],
            "distance": _number(result.get("distance_m")),
            "slam": slam,
            "odometry": odometry,
            "ratio": slam / odometry if odometry else math.inf,
            "closures": int(float(result["loop_closures"])),
            # eq. M8's links (an option) are judged as loop closures are
            "false_closures": int(float(result["false_loop_closures"]))
            + int(float(result.get("false_along_path_closures") or 0)),
            "level_accuracy": _number(result.get("level_accuracy")),
            "experiences": int(float(result["experiences"])),
            "blind": {key.split(".", 1)[1]: float(value) for key, value in result.items()
                      if key.startswith("blind_share.") and value not in ("", None)},
        }
        row["targets"] = {name: bool(test(row)) for name, (_, test) in TARGETS.items()}
        rows.append(row)
    return rows


def distribution(rows: list[dict]) -> dict:
    """Median, 90th percentile and worst SLAM ATE and ratio, and per target how many worlds meet it."""
    slam = np.array([row["slam"] for row in rows])
    ratio = np.array([row["ratio"] for row in rows])
    summary = {"worlds": len(rows)}
    for name, values in (("slam_ate_m", slam), ("ratio", ratio)):
        summary[name] = {"median": float(np.median(values)), "p90": float(np.percentile(values, 90)),
                         "worst": float(values.max())}
    summary["targets"] = {}
    for name, (description, _) in TARGETS.items():
        met = sum(row["targets"][name] for row in rows)
        summary["targets"][name] = {"description": description, "met": met, "required_share": TARGET_SHARES[name],
                                    "holds": met >= math.ceil(TARGET_SHARES[name] * len(rows))}
    summary["all_targets"] = sum(all(row["targets"].values()) for row in rows)
    blind = [row for row in rows if largely_blind(row)]
    if blind and len(blind) < len(rows):
        summary["largely_blind"] = {"limit": BLIND_LIMIT, "worlds": [row["world"] for row in blind],
                                    "others": distribution([row for row in rows if not largely_blind(row)])}
    return summary


def largely_blind(row: dict) -> bool:
    """The world's odometry was blind in distance or yaw on more than :data:`BLIND_LIMIT` of its frames."""
    return max(row["blind"].get("distance", 0.0), row["blind"].get("yaw", 0.0)) > BLIND_LIMIT


def _cell(value, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}"


def _shown(world: str) -> str:
    """A world as the tables name it: an MJCF file by its file name, others as given."""
    return Path(world).name if world.endswith(".xml") else world


def table(rows: list[dict]) -> str:
    """The per-world markdown table, worst SLAM ATE first."""
    blind_names = sorted({name for row in rows for name in row["blind"]})
    header = ["world", "distance (m)", "SLAM ATE (m)", "odometry ATE (m)", "ratio", "closures (false)",
              "level accuracy", *(f"blind {name}" for name in blind_names), "targets missed"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in sorted(rows, key=lambda r: -r["slam"]):
        missed = [name for name, met in row["targets"].items() if not met]
        cells = [_shown(row["world"]), _cell(row["distance"], 0), _cell(row["slam"]), _cell(row["odometry"]),
                 _cell(row["ratio"]), f"{row['closures']} ({row['false_closures']})", _cell(row["level_accuracy"], 3),
                 *(_cell(row["blind"].get(name), 3) for name in blind_names), ", ".join(missed) or "none"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def report(summary: dict) -> list[str]:
    """The printed distribution."""
    lines = [f"{summary['worlds']} worlds"]
    for name, label in (("slam_ate_m", "SLAM ATE (m)"), ("ratio", "SLAM / odometry")):
        s = summary[name]
        lines.append(f"  {label:16s} median {s['median']:.2f}  90th percentile {s['p90']:.2f}  worst {s['worst']:.2f}")
    for target in summary["targets"].values():
        verdict = "holds" if target["holds"] else "misses"
        lines.append(f"  {target['description']:40s} {target['met']:3d} of {summary['worlds']} "
                     f"(needs {target['required_share']:.0%}: {verdict})")
    lines.append(f"  {'every target':40s} {summary['all_targets']:3d} of {summary['worlds']}")
    blind = summary.get("largely_blind")
    if blind:
        lines.append(f"{len(blind['worlds'])} of them blind in distance or yaw on more than {blind['limit']:.0%} of "
                     f"their frames ({', '.join(map(_shown, blind['worlds']))}); the others alone:")
        lines.extend(report(blind["others"]))
    return lines


def measure_drives(name: str, description: str, measure, argv: list[str] | None) -> list[dict] | None:
    """A per-drive measurement over a run of this benchmark: parse ``RUN [--force]``, apply ``measure``
    (a drive folder → one dict row) to every ``RUN/drives/*`` with a metrics.json and write the rows to
    ``RUN/NAME.csv``. Returns the rows, or None after printing one line (no drives, or the CSV exists
    without ``--force``)."""
    parser = argparse.ArgumentParser(prog=f"{name}.py", description=description)
    parser.add_argument("run", type=Path, help="output folder of benchmarks/generalization.py")
    parser.add_argument("--force", action="store_true", help=f"replace an existing {name}.csv")
    args = parser.parse_args(argv)
    drives = sorted(path.parent for path in args.run.glob("drives/*/metrics.json"))
    if not drives:
        print(f"{name}: no drives/*/metrics.json under {args.run}", file=sys.stderr)
        return None
    out = args.run / f"{name}.csv"
    if out.exists() and not args.force:
        print(f"{name}: {out} exists (--force replaces it)", file=sys.stderr)
        return None
    rows = [measure(drive) for drive in tqdm(drives, unit="drive")]
    with out.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"Written: {out}")
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="output folder (results.csv, worlds.md, drives/)")
    parser.add_argument("--odometry", choices=["visual", "wheel", "visual-inertial"], default="visual",
                        help="the drives' self-motion (default: visual, camera only)")
    parser.add_argument("--quick", action="store_true", help="10 generated worlds and the car park, 1 lap")
    parser.add_argument("--camera-noise", action="store_true",
                        help=f"a real camera's noise: {CAMERA_NOISE} (grey levels of 255; s)")
    parser.add_argument("--laps", type=int, help="laps per drive (default: 2, or 1 with --quick)")
    parser.add_argument("--workers", type=int, default=2, help="drives at once (default: 2)")
    chosen = parser.add_mutually_exclusive_group()
    chosen.add_argument("--worlds", nargs="+", help="other worlds instead of the benchmark's (gen:A-B ranges too)")
    chosen.add_argument("--handwritten", action="store_true",
                        help=f"the {len(HANDWRITTEN)} hand-written MJCF worlds of benchmarks/worlds/ instead")
    parser.add_argument("--generator", type=int, choices=GENERATOR_VERSIONS, default=GENERATOR_VERSION,
                        help=f"the world generator's version (default: the latest, {GENERATOR_VERSION}; 1 and 2 give "
                             "the worlds measured before versions 2 and 3)")
    parser.add_argument("--grid", nargs="+", default=[], metavar="FIELD=VALUE",
                        help="one configuration setting over the default preset (one value per field)")
    args = parser.parse_args(argv)
    generated = [f"gen{args.generator}:{seed}" for seed in SEEDS]
    if args.handwritten:
        worlds = HANDWRITTEN
    elif args.worlds:
        worlds = expand_worlds(args.worlds)
    else:
        worlds = ["carpark", *generated[:10]] if args.quick else BUILT_IN + generated
    laps = args.laps or (1 if args.quick else 2)
    grid = parse_grid(args.grid)
    if len(grid) != 1:
        parser.error("--grid: one value per field (the benchmark judges one setting)")
    results, failed = run_sweep(worlds, 1, grid, args.out, laps=laps, workers=args.workers, odometry=args.odometry,
                                camera=CAMERA_NOISE if args.camera_noise else None)
    wanted = set(worlds)
    rows = [row for row in world_rows(results) if row["world"] in wanted]
    if not rows:
        print("no drive finished", file=sys.stderr)
        return 1
    summary = distribution(rows)
    summary.update({"odometry": args.odometry, "laps": laps, "camera": CAMERA_NOISE if args.camera_noise else None,
                    "failed": failed})
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (args.out / "worlds.md").write_text(table(rows))
    print("\n".join(report(summary)))
    for result in results:
        if result.get("status") == "failed":
            print(f"failed: {result['world']}: {result['error']}")
    print(f"per world: {args.out / 'worlds.md'}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
