"""How much do the accuracy numbers of a drive move when its images change imperceptibly?

Run: ``python benchmarks/sensitivity.py [--worlds carpark urban ...] [--seeds 3] [--noise 0.5] [--laps 2]
[--preset sim] [--config FILE] [--max-frames N]``. A measurement, not a test: it asserts nothing and is not
part of the pytest run.

What it does: for each world, drives its main route once with the testbed's :class:`sim.ScriptedDrive` (the
frames ``neuroslam drive`` sees: 160×120 RGB at 10 Hz, 1 m/s) and keeps the frames; then runs NeuroSLAM
(camera only, the preset given, with a ``--config`` file's settings over it; the runner,
:func:`neuroslam.lab.runner.run`, on a :class:`~neuroslam.lab.frames.MemoryStream`) on them ``1 + --seeds`` times:
once as recorded (what ``neuroslam drive WORLD`` scores, up to the timing of the frames) and once per seed
with uniform noise of ±``--noise`` grey levels (of 255) added to the grey image, below the 8-bit rounding of
a camera. Each run is scored as
``metrics.json`` scores it (:meth:`neuroslam.lab.runner.Run.metrics`: Sim(3)-aligned ATE of the final
trajectory, false closures, level accuracy). It prints one row per run and, per world, the range over
the runs. A wide range means the number in a table is one draw of a lottery, not a property of the
system: which views match, and so which loops close, can flip on a grey level.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from tqdm import tqdm

import sim
from neuroslam import presets
from neuroslam.config import Config, load_config
from neuroslam.lab.frames import DriveStream, Frame, MemoryStream
from neuroslam.lab.runner import run
from neuroslam.slam import NeuroSLAM
from neuroslam.vision.preprocessing import grey


def record(world_name: str, laps: int, max_frames: int | None = None) -> MemoryStream:
    """The drive's frames (image, time, truth), rendered once, to replay."""
    drive = sim.ScriptedDrive(world_name, laps=laps, max_frames=max_frames)
    stream = DriveStream(drive)
    with tqdm(total=int(stream.total), unit="m", desc=f"render {world_name}", leave=False) as bar:
        frames = []
        for frame in stream:
            frames.append(frame)
            bar.update(min(int(frame.progress), bar.total) - bar.n)
    return MemoryStream(frames, name=world_name, levels=stream.levels, description=stream.describe())


def score(config: Config, recorded: MemoryStream, noise: float, seed: int | None) -> dict:
    """One SLAM run on the frames (with noise when ``seed`` is not None), scored as ``metrics.json`` is."""
    rng = None if seed is None else np.random.default_rng(seed)

    def noisy(frame: Frame) -> Frame:
        image = grey(frame.image)
        image = np.clip(image + rng.uniform(-noise, noise, image.shape[:2]).astype(np.float32) / 255, 0.0, 1.0)
        return dataclasses.replace(frame, image=image)

    stream = MemoryStream(recorded.frames, name=recorded.name, levels=recorded.levels,
                          description=recorded.describe(), transform=None if rng is None else noisy)
    return run(stream, NeuroSLAM(config), progress=False).metrics()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["carpark", "urban", "building", "gen1:1", "gen1:2", "gen1:3"],
                        help="worlds to drive (default: the README's accuracy table)")
    parser.add_argument("--seeds", type=int, default=3, help="noisy runs per world besides the recorded one")
    parser.add_argument("--noise", type=float, default=0.5, help="uniform noise amplitude, grey levels of 255")
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--preset", default="sim")
    parser.add_argument("--config", default=None,
                        help="TOML or JSON settings over the preset (as `neuroslam drive --config`)")
    parser.add_argument("--max-frames", type=int, default=None, help="cut each drive short (a quick check)")
    args = parser.parse_args()
    if args.seeds < 0 or not args.noise > 0 or args.laps < 1:
        parser.error(f"need --seeds >= 0, --noise > 0, --laps >= 1 (got {args.seeds}, {args.noise}, {args.laps})")
    config = presets.get(args.preset)
    if args.config is not None:
        config = load_config(args.config, base=config)
    print(f"{'world':9s} {'run':>9s} {'closures (false)':>17s} {'SLAM ATE':>9s} {'online':>7s} {'odometry':>9s} "
          f"{'ratio':>6s} {'level':>6s}")
    for world_name in args.worlds:
        recorded = record(world_name, args.laps, args.max_frames)
        rows = []
        for seed in [None, *range(1, args.seeds + 1)]:
            metrics = score(config, recorded, args.noise, seed)
            ate = metrics["ate_rmse_m"]
            rows.append((ate["slam"], ate["odometry"], metrics["false_loop_closures"]))
            label = "recorded" if seed is None else f"noise {seed}"
            print(f"{world_name:9s} {label:>9s} {metrics['loop_closures']:>10d} ({metrics['false_loop_closures']:>3d})"
                  f" {ate['slam']:>9.2f} {ate['slam_online']:>7.2f} {ate['odometry']:>9.2f}"
                  f" {ate['slam'] / ate['odometry']:>6.2f}"
                  f" {metrics['level_accuracy']:>6.3f}", flush=True)
        slam_ate, odometry_ate, false = np.array(rows).T
        ratio = slam_ate / odometry_ate
        print(f"{world_name:9s} {'range':>9s} {'false ' + f'{int(false.min())}–{int(false.max())}':>17s}"
              f" {slam_ate.min():>4.2f}–{slam_ate.max():<4.2f} {'':>7s}"
              f" {odometry_ate.min():>4.2f}–{odometry_ate.max():<4.2f}"
              f" {ratio.min():.2f}–{ratio.max():.2f}", flush=True)


if __name__ == "__main__":
    main()
