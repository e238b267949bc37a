"""Speed of NeuroSLAM per frame: the typical step, the worst case, the cost at three resolutions, each
component as the map grows, and the least-squares relaxation after a loop closure.

Run: ``python benchmarks/slam_speed.py [--frames N] [--templates 100 1000 10000] [--quick]``. One core
(``OMP_NUM_THREADS=1``), the ``sim`` preset. Prints:

- a **calibration workload** (a fixed mix of numpy FFTs, a matrix product, a sort and a Python loop, its
  least time over 15 runs) timed in the same run before and after the measurements, and every figure below
  also as a multiple of the first, so runs on differently loaded machines (this project's shared machines
  move by up to 2×) can be compared; where the two calibrations differ, the machine's load changed during
  the run;
- the **typical step**: the median ms of ``NeuroSLAM.step`` on the testbed's car-park frames at 160×120
  (a drive of its main route, rendered before timing) with 1,000 templates and as many experiences;
- the **worst case**: novel frames (uniform random images, each unlike the last, so every alignment starts
  far from its solution and runs to its caps) with 10,000 templates: median, 95th percentile and maximum,
  and the median's ratio to the typical step;
- the **resolutions**: the typical step on the car park rendered at 160×120, 320×240 and 640×480, and each
  one's ratio to 160×120 (``odometry.working_width`` sets the size the alignments run at);
- whether the compiled loops run on the **vector units** (:mod:`neuroslam.compiled`);
- the **alignment passes** per frame (each a pass over a few thousand pixels: a Gauss–Newton iteration or a
  cost), median and maximum, on the car park and on novel frames: the odometry's bounded work;
- with ``--drive``, **the drive**: ``NeuroSLAM.step`` over the car park's whole two-lap drive (5,870 frames,
  rendered first: about 1½ minutes more, 340 MB of frames), from an empty map as ``neuroslam drive`` runs
  it: the mean ms over the first lap and over the second, whose views are familiar (the place confirmation
  runs on nearly every frame, and the least-squares relaxation on each loop closure), and over the drive,
  each also in calibration units; and the share of the drive's time spent confirming places
  (:func:`neuroslam.loop_closure.confirm_place`, the rival test included);
- each **component** with the map filled to each ``--templates`` count (random templates, experiences in a
  chain), and the least-squares relaxation's cost on the frame that closes a lap of that many experiences
  (it runs on loop-closure frames only).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the targets are stated

import numpy as np

from neuroslam import NeuroSLAM, presets
from neuroslam.vision.preprocessing import grey


def calibration_ms(repeats: int = 15) -> float:
    """The least ms of ``repeats`` runs of a fixed workload of the kinds NeuroSLAM's step does (FFTs, a matrix
    product, a sort, a short Python loop): the unit the other figures are also given in. The least, not the
    median: other work on a shared machine only ever adds to a run's time."""
    rng = np.random.default_rng(0)
    cube = rng.random((48, 48, 16)).astype(np.float32)
    matrix = rng.random((192, 192)).astype(np.float32)
    values = rng.random(20000)
    samples = []
    for _ in range(repeats):
        started = time.perf_counter()
        for _ in range(5):
            np.fft.irfftn(np.fft.rfftn(cube), s=cube.shape, axes=(0, 1, 2))
            matrix @ matrix
            np.sort(values)
            total = 0.0
            for k in range(2000):
                total += k * 0.5
        samples.append(time.perf_counter() - started)
    return 1000 * min(samples)


def drive_frames() -> tuple[list[np.ndarray], np.ndarray]:
    """The car park's whole two-lap drive of its main route (160×120): every frame's image, and the laps
    completed at each frame."""
    import sim

    images, laps = [], []
    with sim.ScriptedDrive("carpark", laps=2, seed=0) as drive:
        for frame in drive:
            images.append(frame.image)
            laps.append(frame.lap)
    return images, np.array(laps)


def drive_steps(images: list[np.ndarray], laps: np.ndarray) -> tuple[float, float, float, float]:
    """Mean ms of ``NeuroSLAM.step`` over the drive's first lap, its second and the whole drive (from an empty
    map, the first frame left out), and the share of the time in the place confirmation."""
    import neuroslam.slam as slam_module

    confirm_place = slam_module.confirm_place
    confirming = [0.0]

    def timed(*args, **kwargs):  # the confirmation's own time, the rival test included
        started = time.perf_counter()
        try:
            return confirm_place(*args, **kwargs)
        finally:
            confirming[0] += time.perf_counter() - started

    slam = NeuroSLAM(presets.get("sim"))
    timings = []
    slam_module.confirm_place = timed
    try:
        for k, image in enumerate(images):
            started = time.perf_counter()
            slam.step(image, 0.1 * (k + 1))
            timings.append(time.perf_counter() - started)
    finally:
        slam_module.confirm_place = confirm_place
    timings = 1000 * np.array(timings[1:])
    second = laps[1:] >= 1
    return (float(timings[~second].mean()), float(timings[second].mean()), float(timings.mean()),
            confirming[0] * 1000 / timings.sum())


def frames(count: int, width: int = 160, height: int = 120) -> list[np.ndarray]:
    """``count`` camera frames of the car park's main route at ``width`` × ``height`` (the testbed renders them)."""
    import sim

    camera = dataclasses.replace(sim.CameraConfig(), width=width, height=height)
    with sim.ScriptedDrive("carpark", max_frames=count, seed=0, camera=camera) as drive:
        return [frame.image for frame in drive]


def novel_frames(count: int, seed: int = 2) -> list[np.ndarray]:
    """``count`` uniform random 160×120 RGB frames: each unlike the one before."""
    rng = np.random.default_rng(seed)
    return [rng.integers(0, 256, (120, 160, 3), dtype=np.uint8) for _ in range(count)]


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


def steps(images: list[np.ndarray], templates: int) -> tuple[np.ndarray, np.ndarray]:
    """ms of each ``NeuroSLAM.step`` over ``images`` on a map of ``templates`` (the first frame, which has no
    previous one, left out), and the alignment passes of each frame: (ms, passes (frames, 2): floor, rotation)."""
    slam = filled(templates)
    odometry = slam.visual_odometry
    floor, rotation = odometry._ground, odometry._alignment

    def counts() -> tuple[int, int]:  # (0, 0) on code from before the counters (a baseline checkout)
        return getattr(floor, "passes", 0), getattr(rotation, "passes", 0)

    timings, passes = [], []
    for k, image in enumerate(images):
        before = counts()
        started = time.perf_counter()
        slam.step(image, 0.1 * (k + 1))
        timings.append(time.perf_counter() - started)
        passes.append(np.subtract(counts(), before))
    return 1000 * np.array(timings[1:]), np.array(passes[1:])


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


def headline(count: int, drive: bool = False) -> None:
    """The calibration, the typical step, the worst case, the resolutions, with ``drive`` the drive, and the
    passes (see the module)."""
    unit = calibration_ms()

    def line(label: str, ms: float, extra: str = "") -> None:
        print(f"  {label:<46}{ms:8.2f} ms  {ms / unit:6.3f} x cal.{extra}")

    warm = filled(10)  # compile the alignment loops (numba) before any timing
    for k, image in enumerate(frames(3)):
        warm.step(image, 0.1 * (k + 1))
    typical, typical_passes = steps(frames(count + 1), 1000)
    typical_ms = float(np.median(typical))
    print("typical step (car park, 160x120, 1,000 templates)")
    line("median", typical_ms)
    novel, novel_passes = steps(novel_frames(count + 1), 10000)
    print("worst case (novel random frames, 160x120, 10,000 templates)")
    line("median", float(np.median(novel)), f"  {np.median(novel) / typical_ms:5.2f} x typical")
    slow = float(np.percentile(novel, 95))
    line("95th percentile", slow, f"  {slow / typical_ms:5.2f} x typical")
    line("maximum", float(novel.max()), f"  {novel.max() / typical_ms:5.2f} x typical")
    print("resolution (car park, 1,000 templates; odometry.working_width 160)")
    for width, height in ((160, 120), (320, 240), (640, 480)):
        timings, _ = (typical, None) if width == 160 else steps(frames(count + 1, width, height), 1000)
        line(f"{width}x{height} median", float(np.median(timings)),
             f"  {np.median(timings) / typical_ms:5.2f} x 160x120")
    if drive:
        images, laps = drive_frames()
        first, second, whole, confirming = drive_steps(images, laps)
        print(f"the drive (car park, 2 laps, {len(images):,d} frames from an empty map), mean")
        line("first lap", first)
        line("second lap", second, f"  {second / typical_ms:5.2f} x typical")
        line("whole drive", whole, f"  {whole / typical_ms:5.2f} x typical")
        print(f"  {'confirming places':<46}{100 * confirming:8.1f} % of the drive's time")
    unit_after = calibration_ms()
    print(f"calibration workload: {unit:.2f} ms before, {unit_after:.2f} ms after (the first is the unit of "
          "the 'x cal.' column)")
    try:
        from neuroslam.compiled import vectorised
        vector = "yes" if vectorised() else "no (slower; same results)"
    except ImportError:  # a baseline checkout from before neuroslam.compiled
        vector = "n/a"
    print(f"compiled loops on the vector units (ordered reductions): {vector}")
    print("alignment passes per frame (floor / rotation), median and maximum")
    for label, passes in (("car park", typical_passes), ("novel frames", novel_passes)):
        print(f"  {label:<46}{np.median(passes[:, 0]):5.0f} / {np.median(passes[:, 1]):3.0f}   "
              f"max {passes[:, 0].max():3d} / {passes[:, 1].max():3d}")
    print()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=200, help="frames timed per case (default: 200)")
    parser.add_argument("--templates", type=int, nargs="+", default=[100, 1000, 10000],
                        help="map sizes of the components' table (default: 100 1000 10000)")
    parser.add_argument("--quick", action="store_true", help="the headline figures alone (no components' table)")
    parser.add_argument("--drive", action="store_true",
                        help="also time the car park's whole two-lap drive, lap by lap (about 1 1/2 minutes more)")
    args = parser.parse_args()
    headline(args.frames, drive=args.drive)
    if args.quick:
        return
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
