"""Speed of NeuroSLAM per frame: each component and the whole ``step()``, as the map grows.

Run: ``python benchmarks/slam_speed.py [--frames N] [--templates 100 1000 10000]``. Frames are the
testbed's 160×120 camera frames from a drive through the car park (rendered once before timing); before
timing, the map is filled with the given number of random templates and as many experiences in a chain,
so matching and relaxation work on a map of that size. Prints the median milliseconds per frame on one core,
and the cost of one least-squares relaxation (``experience_map.relaxation = "least-squares"``) after a loop
closure that closes a lap of that many experiences (it runs on loop-closure frames only).
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated

import numpy as np

from neuroslam import NeuroSLAM, presets
from neuroslam.vision.preprocessing import grey


def frames(count: int) -> list[np.ndarray]:
    """``count`` camera frames of the car park's main route (the testbed renders them)."""
    import sim

    with sim.ScriptedDrive("carpark", max_frames=count, seed=0) as drive:
        return [frame.image for frame in drive]


def filled(templates: int, seed: int = 1) -> NeuroSLAM:
    """A SLAM whose map already holds ``templates`` templates and as many experiences in a chain."""
    slam = NeuroSLAM(presets.get("sim"))
    rng = np.random.default_rng(seed)
    rows, columns = slam.config.local_view.thumbnail
    for k in range(templates):
        thumbnail = rng.standard_normal((rows, columns)).astype(np.float32)
        slam.local_view.add(thumbnail)
        slam._learn_view(k, slam.grid_cells.decode(), slam.head_direction.decode(), 0.0)
        slam.experience_map.integrate(1.0, 0.01, 0.0)
        slam.experience_map.update(k, rng.uniform(0, 36, 3), rng.uniform(0, 36, 2), float(k))
    return slam


def median_ms(samples: list[float]) -> float:
    return 1000 * statistics.median(samples)


def measure(templates: int, count: int) -> dict[str, float]:
    images = frames(count + 1)
    slam = filled(templates)
    timings: dict[str, list[float]] = {name: [] for name in
                                       ("grey", "visual odometry", "local view", "head direction", "grid cells",
                                        "experience map", "step")}
    greys = [grey(image) for image in images]
    odometry = slam.visual_odometry
    odometry.step(greys[0], 0.1)
    for k in range(1, count + 1):
        started = time.perf_counter()
        grey(images[k])
        timings["grey"].append(time.perf_counter() - started)
        started = time.perf_counter()
        odometry.step(greys[k], 0.1)
        timings["visual odometry"].append(time.perf_counter() - started)
        started = time.perf_counter()
        thumbnail = slam.local_view.thumbnail(greys[k])
        slam.local_view.compare(thumbnail, slam.local_view.candidates(thumbnail))
        timings["local view"].append(time.perf_counter() - started)
        started = time.perf_counter()
        slam.head_direction.step(0.01, 0.0)
        slam.head_direction.decode()
        timings["head direction"].append(time.perf_counter() - started)
        started = time.perf_counter()
        slam.grid_cells.step((0.1, 0.0, 0.0))
        slam.grid_cells.decode()
        timings["grid cells"].append(time.perf_counter() - started)
        started = time.perf_counter()
        slam.experience_map.integrate(0.1, 0.0, 0.0)
        slam.experience_map.update(k % templates, slam.grid_cells.decode(), slam.head_direction.decode(), 0.1 * k)
        timings["experience map"].append(time.perf_counter() - started)
    slam = filled(templates)
    for k in range(count + 1):
        started = time.perf_counter()
        slam.step(images[k], 0.1 * (k + 1))
        timings["step"].append(time.perf_counter() - started)
    return {name: median_ms(values[1:]) for name, values in timings.items()}


def closure_solve_ms(experiences: int) -> tuple[float, float, int]:
    """The least-squares relaxation after closing a lap of ``experiences`` experiences 0.3 m apart whose
    odometry turned 2 % too far (about 7° over the lap): ms on the closing frame (at most 3 Gauss–Newton
    iterations), ms until the map has settled (the solve goes on over the next frames), and those frames."""
    import math

    from neuroslam.config import ExperienceMapConfig
    from neuroslam.experience_map import ExperienceMap

    experience_map = ExperienceMap(ExperienceMapConfig(threshold=0.5, relaxation="least-squares"),
                                   grid_size=(10**6, 10**6, 100))
    experience_map.update(0, np.zeros(3), np.zeros(2), 0.0)
    for k in range(1, experiences):
        experience_map.integrate(0.3, 2 * math.pi / experiences * 1.02, 0.0)
        experience_map.update(k, np.array([10.0 * k, 0.0, 0.0]), np.zeros(2), float(k))
    experience_map.integrate(0.3, 0.0, 0.0)
    started = time.perf_counter()
    update = experience_map.update(0, np.zeros(3), np.zeros(2), float(experiences))
    assert update.loop_closure
    first = time.perf_counter() - started
    frames = 1
    while not experience_map.settled:
        experience_map._relax(0)
        frames += 1
    return 1000 * first, 1000 * (time.perf_counter() - started), frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=200, help="frames timed per map size (default: 200)")
    parser.add_argument("--templates", type=int, nargs="+", default=[100, 1000, 10000])
    args = parser.parse_args()
    results = {n: measure(n, args.frames) for n in args.templates}
    names = list(next(iter(results.values())))
    print("median ms per frame, 160x120, preset 'sim', one core")
    print(f"{'component':<16}" + "".join(f"{n:>12,d} templates"[-22:] for n in args.templates))
    for name in names:
        print(f"{name:<16}" + "".join(f"{results[n][name]:>22.3f}" for n in args.templates))
    print("\nleast-squares relaxation after closing a lap (loop-closure frames only)")
    for n in args.templates:
        first, total, frames = closure_solve_ms(n)
        print(f"{n:>8,d} experiences: {first:8.1f} ms on the closing frame, {total:8.1f} ms over {frames} frames "
              "until settled")


if __name__ == "__main__":
    main()
