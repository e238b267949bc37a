"""Save and load speed and file size of NeuroSLAM map files as the map grows.

Run: ``python benchmarks/map_files.py [--experiences 1000 10000]``. Each map holds that many templates (random
thumbnails) and experiences in a chain (as in ``slam_speed.py``), then a few real camera frames so that every
part of the state is filled. Prints the median of five saves and loads (ms) and the file size (MB); the
file is written to a temporary folder on the local disk.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from slam_speed import filled, frames  # benchmarks/ is the script's folder

from neuroslam import NeuroSLAM


def measure(experiences: int, folder: Path, repeats: int = 5) -> tuple[float, float, float]:
    """(save ms, load ms, MB) for a map of ``experiences`` templates and experiences."""
    slam = filled(experiences)
    for index, image in enumerate(frames(5)):
        slam.step(image, 1e6 + 0.1 * index)
    path = folder / f"map{experiences}.npz"
    saves, loads = [], []
    for _ in range(repeats):
        started = time.perf_counter()
        slam.save(path)
        saves.append(time.perf_counter() - started)
        started = time.perf_counter()
        NeuroSLAM.load(path)
        loads.append(time.perf_counter() - started)
    return 1000 * statistics.median(saves), 1000 * statistics.median(loads), path.stat().st_size / 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--experiences", type=int, nargs="+", default=[1000, 10000])
    args = parser.parse_args()
    print(f"{'experiences':>12} {'save ms':>9} {'load ms':>9} {'file MB':>9}")
    with tempfile.TemporaryDirectory() as folder:
        for experiences in args.experiences:
            save, load, megabytes = measure(experiences, Path(folder))
            print(f"{experiences:>12} {save:>9.1f} {load:>9.1f} {megabytes:>9.2f}", flush=True)


if __name__ == "__main__":
    main()
