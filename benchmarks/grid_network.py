"""The grid network's accuracy/speed trade-off: Euler steps of the Burak–Fiete network per frame.

Run: ``python benchmarks/grid_network.py [--steps 2 5 10 20 40] [--size 128]``. Each setting integrates the
same 200 m drive (1 m/s, 10 frames a second, straights and turns of both signs) from exact velocity input,
as the network's path integrator (eq. 5), and prints the position error at the end and at worst, as a
share of the distance, the spread (standard deviation) of each frame's direction of travel about the true
one, and the milliseconds per frame on one core (the network's steps and the read-out).
More steps let the lattice flow further each frame, which the read-out measures more precisely.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from neuroslam.cells.grid_network import GridNetwork
from neuroslam.config import GridNetworkConfig


def route(frames: int = 2000) -> np.ndarray:
    """Headings (rad) of a 200 m drive at 0.1 m a frame: straights joined by turns of both signs."""
    headings = np.concatenate([np.zeros(300), np.linspace(0, math.pi / 2, 80), np.full(400, math.pi / 2),
                               np.linspace(math.pi / 2, -math.pi / 4, 150), np.full(500, -math.pi / 4),
                               np.linspace(-math.pi / 4, math.pi, 200), np.full(370, math.pi)])
    return headings[:frames]


def measure(steps: int, size: int) -> tuple[float, float, float, float]:
    """(error at the end %, worst error %, direction spread per frame in degrees, ms per frame) for
    ``steps`` network steps a frame."""
    network = GridNetwork(GridNetworkConfig(size=size, steps_per_frame=steps))
    headings = route()
    step = 0.1
    truth = np.cumsum(np.stack([step * np.cos(headings), step * np.sin(headings)], axis=1), axis=0)
    started = time.perf_counter()
    steps_taken = np.array([network.integrate(step, heading, 0.1) for heading in headings])
    milliseconds = 1000 * (time.perf_counter() - started) / len(headings)
    estimate = np.cumsum(steps_taken, axis=0)
    errors = np.linalg.norm(estimate - truth, axis=1)
    distance = step * len(headings)
    directions = np.degrees(np.angle(np.exp(1j * (np.arctan2(steps_taken[:, 1], steps_taken[:, 0]) - headings))))
    return 100 * errors[-1] / distance, 100 * errors.max() / distance, float(directions.std()), milliseconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, nargs="+", default=[2, 5, 10, 20, 40])
    parser.add_argument("--size", type=int, default=128, help="neurons along each side (default: 128)")
    args = parser.parse_args()
    print(f"n = {args.size}, 200 m from exact velocity")
    print(f"{'steps/frame':>12} {'end error %':>12} {'worst %':>9} {'direction sd deg':>17} {'ms/frame':>9}")
    for steps in args.steps:
        end, worst, spread, milliseconds = measure(steps, args.size)
        print(f"{steps:>12} {end:>12.2f} {worst:>9.2f} {spread:>17.2f} {milliseconds:>9.2f}", flush=True)


if __name__ == "__main__":
    main()
