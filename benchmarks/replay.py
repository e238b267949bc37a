"""The generalization benchmark on recorded drives: record the worlds once, then score settings in minutes.

Run::

    python benchmarks/replay.py record --data DATA [--worlds ... | --handwritten] [--workers 2]
    python benchmarks/replay.py score DATA --out RUN [--odometry wheel] [--grid FIELD=VALUE ...] [--workers 2]

A measurement, not a test. ``record`` drives the benchmark's worlds (the same list, laps and seeds as
``benchmarks/generalization.py``: the three built-ins and ``gen3:100``–``gen3:139``, or ``--worlds``, or the
hand-written MJCF worlds) with ``neuroslam record`` into ``DATA/NAME`` (frames, ground truth, the wheels; about
90 MB a world, 4 GB for the 43; about 45 minutes with 2 workers). A world already recorded is skipped.

``score`` replays every dataset under ``DATA`` through the runner, as ``neuroslam run`` does, with the ``sim``
preset and one ``--grid`` setting over it, camera only unless ``--odometry`` says otherwise, and scores each as
the benchmark does: ``RUN/results.csv``, ``RUN/worlds.md`` and ``RUN/summary.json``, and the same printed
distribution and targets (:func:`generalization.distribution`). The scripted drive does not depend on the
SLAM (the route steers the robot), so a replay is the drive: camera only, its numbers are the benchmark's to the
last digit (the frames are lossless PNG); with the wheels to within centimetres (a recording keeps the wheels'
pose, whose speed is the chord over a frame, within 0.1 % of the arc the encoders rolled). A replay leaves out the
drive's rendering and physics and the sweep's plots: the 43 worlds in 35–45 minutes with 2 workers against about 75
for the drives (a few large maps take 5–9 minutes each and hold the tail). What it cannot measure is what changes
the frames: the camera's settings, the generator, the route.
"""

from __future__ import annotations

import argparse
import csv
import json
import multiprocessing
import subprocess
import sys
from pathlib import Path

from generalization import BUILT_IN, HANDWRITTEN, SEEDS, distribution, report, table, world_rows
from tqdm import tqdm

from neuroslam.lab.sweep import expand_worlds, flatten, parse_grid

DATASET_FILES = ("dataset.json", "groundtruth.tum", "wheel_odometry.tum")


def dataset_name(world: str) -> str:
    """The folder a world's recording goes in: ``gen3:115`` → ``gen3_115``, an MJCF file → its stem."""
    return Path(world).stem if world.endswith(".xml") else world.replace(":", "_")


def _record(task: tuple[str, Path, int | None]) -> tuple[str, str]:
    """One world's recording (``neuroslam record``, 2 laps); (world, "" or the error's last line)."""
    world, folder, max_frames = task
    command = [sys.executable, "-m", "neuroslam.lab.cli", "record", world, "--out", str(folder), "--overwrite"]
    if max_frames is not None:
        command += ["--max-frames", str(max_frames)]
    if world.endswith(".xml"):
        command += ["--route", str(Path(world).with_suffix("")) + ".routes.json"]
    done = subprocess.run(command, capture_output=True, text=True)
    lines = (done.stderr or done.stdout).strip().splitlines()
    return world, "" if done.returncode == 0 else (lines[-1] if lines else f"exit {done.returncode}")


def _score(task: tuple[Path, str, tuple]) -> dict:
    """One dataset replayed and scored in a worker: the sweep's row (status, world, flattened metrics)."""
    folder, odometry, setting = task
    from neuroslam.lab.frames import FolderStream
    from neuroslam.lab.runner import run
    from neuroslam.lab.sweep import setting_config
    from neuroslam.slam import NeuroSLAM

    world = json.loads((folder / "dataset.json").read_text()).get("world", folder.name)
    try:
        config = setting_config(setting)
        stream = FolderStream(folder, groundtruth=folder / "groundtruth.tum",
                              wheel_odometry=folder / "wheel_odometry.tum")
        result = run(stream, NeuroSLAM(config), odometry=odometry, progress=False)
        return {"status": "ok", "world": world, "dataset": folder.name, **flatten(result.metrics())}
    except Exception as error:  # one row either way: the others go on
        return {"status": "failed", "world": world, "dataset": folder.name,
                "error": f"{type(error).__name__}: {error}".splitlines()[0]}


def record(args: argparse.Namespace) -> int:
    worlds = HANDWRITTEN if args.handwritten else (expand_worlds(args.worlds) if args.worlds
                                                    else BUILT_IN + [f"gen3:{seed}" for seed in SEEDS])
    args.data.mkdir(parents=True, exist_ok=True)
    tasks = [(world, args.data / dataset_name(world), args.max_frames) for world in worlds
             if not all((args.data / dataset_name(world) / name).exists() for name in DATASET_FILES)]
    print(f"{len(worlds) - len(tasks)} of {len(worlds)} worlds already recorded in {args.data}")
    failed = 0
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        for world, error in tqdm(pool.imap_unordered(_record, tasks), total=len(tasks), unit="world"):
            if error:
                failed += 1
                print(f"failed: {world}: {error}")
    return 1 if failed else 0


def score(args: argparse.Namespace) -> int:
    folders = sorted(path.parent for path in args.data.glob("*/dataset.json")
                     if all((path.parent / name).exists() for name in DATASET_FILES))
    if not folders:
        print(f"replay: no recorded drives under {args.data} (run: replay.py record --data {args.data})",
              file=sys.stderr)
        return 2
    grid = parse_grid(args.grid)
    if len(grid) != 1:
        print("replay: --grid takes one value per field (the benchmark judges one setting)", file=sys.stderr)
        return 2
    if (args.out / "results.csv").exists() and not args.overwrite:
        print(f"replay: {args.out / 'results.csv'} exists (--overwrite replaces it)", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    tasks = [(folder, args.odometry, grid[0]) for folder in folders]
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        results = list(tqdm(pool.imap(_score, tasks), total=len(tasks), unit="drive"))
    fields = list(dict.fromkeys(key for result in results for key in result))
    with (args.out / "results.csv").open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=fields)
        writer.writeheader()
        writer.writerows(results)
    rows = world_rows(results)
    if not rows:
        print("replay: no drive finished", file=sys.stderr)
        return 1
    summary = distribution(rows)
    failed = [f"{result['world']}: {result['error']}" for result in results if result["status"] != "ok"]
    summary.update({"odometry": args.odometry, "setting": dict(grid[0]), "data": str(args.data), "failed": failed})
    (args.out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (args.out / "worlds.md").write_text(table(rows))
    print("\n".join(report(summary)))
    for line in failed:
        print(f"failed: {line}")
    print(f"per world: {args.out / 'worlds.md'}")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    recorder = commands.add_parser("record", help="record the benchmark's drives once")
    recorder.add_argument("--data", type=Path, required=True, help="folder of the recordings (one folder a world)")
    chosen = recorder.add_mutually_exclusive_group()
    chosen.add_argument("--worlds", nargs="+", help="other worlds instead of the benchmark's (gen:A-B ranges too)")
    chosen.add_argument("--handwritten", action="store_true", help="the hand-written MJCF worlds of benchmarks/worlds/")
    recorder.add_argument("--workers", type=int, default=2, help="recordings at once (default: 2)")
    recorder.add_argument("--max-frames", type=int, help="stop each drive after this many frames (a short try)")
    scorer = commands.add_parser("score", help="replay every recording with one setting and score it")
    scorer.add_argument("data", type=Path, help="folder of the recordings")
    scorer.add_argument("--out", type=Path, required=True, help="output folder (results.csv, worlds.md, summary.json)")
    scorer.add_argument("--overwrite", action="store_true", help="replace an earlier score in --out")
    scorer.add_argument("--odometry", choices=["visual", "wheel"], default="visual",
                        help="the replay's self-motion (default: visual, camera only)")
    scorer.add_argument("--grid", nargs="+", default=[], metavar="FIELD=VALUE",
                        help="one configuration setting over the default preset (one value per field)")
    scorer.add_argument("--workers", type=int, default=2, help="replays at once (default: 2)")
    args = parser.parse_args(argv)
    if args.workers < 1:
        parser.error(f"--workers: must be at least 1, got {args.workers}")
    return record(args) if args.command == "record" else score(args)


if __name__ == "__main__":
    sys.exit(main())
