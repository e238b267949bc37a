"""Drives per minute of ``neuroslam sweep`` on this machine with 1 and 2 Ray workers.

Run: ``python benchmarks/sweep_speed.py [--drives 4] [--frames 300]`` (needs the ``scale`` extra). Each
setting runs the same drives (generated worlds gen:1..N, one seed, ``--max-frames`` frames each) into a
fresh folder on a local Ray instance; prints the wall time (Ray's start-up, about 6 s, included) and drives
per minute.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from neuroslam.lab.sweep import run_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--drives", type=int, default=4)
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    worlds = [f"gen:{seed}" for seed in range(1, args.drives + 1)]
    print(f"{args.drives} drives of {args.frames} frames")
    print(f"{'workers':>8} {'wall s':>8} {'drives/min':>11}")
    for workers in args.workers:
        with tempfile.TemporaryDirectory() as folder:
            started = time.perf_counter()
            rows, failed = run_sweep(worlds, 1, [()], Path(folder), laps=1, max_frames=args.frames,
                                     workers=workers, progress=False)
            wall = time.perf_counter() - started
        assert failed == 0, rows
        print(f"{workers:>8} {wall:>8.1f} {60 * args.drives / wall:>11.2f}", flush=True)


if __name__ == "__main__":
    main()
