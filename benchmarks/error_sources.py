"""Where a drive's error comes from: the visual odometry's bias per level, and each loop closure's own error.

Run: ``python benchmarks/error_sources.py [--worlds building gen1:3 ...] [--laps 2] [--seed S] [--noise 0.5]
[--preset sim] [--config FILE] [--max-frames N]``. A measurement, not a test: it asserts nothing and is not
part of the pytest run.

What it does: for each world, drives its main route once (the frames ``neuroslam drive`` sees, recorded by
``benchmarks/sensitivity.py``'s :func:`record`), runs NeuroSLAM on them (with ``--seed``, uniform noise of
±``--noise`` grey levels added, as that benchmark does) and prints, against the simulator's ground truth:

- **odometry, per level** (each frame's self-motion against the true motion between the two frames):
  distance read over distance driven (1.000 is exact), the worst 200-frame stretch (a floor whose marks run
  along the path holds the last speed, or lets the pixel grid pull it to zero: both show here and not in a
  level's total), frames read under half their true distance, and the yaw error summed over the level's
  frames (degrees; what a loop closure has to take back) with its RMS per frame.
- **loop closures**: for each closure, where the map puts the robot against the experience it re-entered
  (``ExperienceMap.relative`` right after the closure: the link the closure adds) compared with where the
  robot truly was relative to that experience's true pose at its creation. Median, 90th percentile and
  largest horizontal error (m), the mean error along the experience's heading (m: positive when views are
  recognised before the place is reached), and the median and largest yaw error (degrees). A closure within
  the 2 m of ``false_loop_closures`` can still bend the map by its error.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from sensitivity import record

from neuroslam import presets
from neuroslam.config import load_config
from neuroslam.geometry import relative as relative_pose
from neuroslam.geometry import wrap
from neuroslam.lab.frames import Frame, MemoryStream
from neuroslam.lab.runner import run
from neuroslam.slam import NeuroSLAM
from neuroslam.vision.preprocessing import grey


def odometry_rows(distances: np.ndarray, yaw_changes: np.ndarray, poses: np.ndarray, levels: np.ndarray) -> list[str]:
    """One printed row per true level: distance ratio, worst stretch, collapses, yaw error sum and RMS."""
    true_distance = np.r_[0.0, np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1)]
    yaw_error = np.degrees(wrap(yaw_changes - np.r_[0.0, wrap(np.diff(poses[:, 3]))]))
    rows = []
    for level in np.unique(levels):
        frames = np.flatnonzero(levels == level)
        stretches = [distances[chunk].sum() / true_distance[chunk].sum()
                     for chunk in np.array_split(frames, max(1, len(frames) // 200)) if true_distance[chunk].sum() > 1]
        collapsed = int((distances[frames] < 0.5 * true_distance[frames]).sum())
        read, driven = distances[frames].sum(), true_distance[frames].sum()
        rows.append(f"  level {level:>2d}: {len(frames):5d} frames, distance read {read:7.1f} of {driven:7.1f} m "
                    f"({read / driven:.3f}; "
                    f"200-frame stretches {min(stretches, default=1):.3f}–{max(stretches, default=1):.3f}), "
                    f"{collapsed} frames under half; yaw error {yaw_error[frames].sum():+6.1f}° "
                    f"(RMS {np.sqrt(np.mean(yaw_error[frames] ** 2)):.3f}° a frame)")
    return rows


def closure_errors(closures: list[tuple[int, int, np.ndarray]], creation_frames: np.ndarray, poses: np.ndarray
                   ) -> np.ndarray:
    """(K, 4) each closure's link error (x along the experience's true heading, y left, z, yaw; m, rad):
    the robot's pose relative to the re-entered experience as the map has it, less the true one."""
    errors = []
    for frame, experience, relative in closures:
        then, now = poses[creation_frames[experience]], poses[frame]
        error = relative - relative_pose(then, now)
        error[3] = wrap(error[3])
        errors.append(error)
    return np.array(errors).reshape(-1, 4)


def measure(recorded: MemoryStream, config, noise: float, seed: int | None):
    """The runner on the recorded frames (with uniform noise of ±``noise`` grey levels when ``seed`` is given):
    (the run, each frame's distance read (m), yaw change read (rad), each loop closure's (frame, experience,
    the robot's pose relative to it as the map has it right after the closure))."""
    rng = None if seed is None else np.random.default_rng(seed)

    def noisy(frame: Frame) -> Frame:
        image = grey(frame.image)
        image = np.clip(image + rng.uniform(-noise, noise, image.shape[:2]).astype(np.float32) / 255, 0.0, 1.0)
        return dataclasses.replace(frame, image=image)

    distances, yaw_changes, closures = [], [], []
    times = np.array([frame.time for frame in recorded.frames])

    def keep(frame: Frame, estimate, slam) -> None:
        dt = frame.time - times[frame.index - 1] if frame.index else 0.0
        distances.append(estimate.self_motion.forward_speed * dt)
        yaw_changes.append(estimate.self_motion.yaw_rate * dt)
        if estimate.loop_closure:  # the link the closure adds: the robot relative to the re-entered experience
            closures.append((frame.index, estimate.experience_id, slam.experience_map.relative.copy()))

    stream = MemoryStream(recorded.frames, name=recorded.name, levels=recorded.levels,
                          description=recorded.describe(), transform=None if rng is None else noisy)
    return run(stream, NeuroSLAM(config), on_frame=keep), distances, yaw_changes, closures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["building", "gen1:3"], help="worlds to drive")
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--seed", type=int, default=None, help="add seeded noise to the frames (default: none)")
    parser.add_argument("--noise", type=float, default=0.5, help="uniform noise amplitude, grey levels of 255")
    parser.add_argument("--preset", default="sim")
    parser.add_argument("--config", default=None, help="TOML or JSON settings over the preset")
    parser.add_argument("--max-frames", type=int, default=None, help="cut each drive short (a quick check)")
    args = parser.parse_args()
    if args.laps < 1 or not args.noise > 0:
        parser.error(f"need --laps >= 1 and --noise > 0 (got {args.laps}, {args.noise})")
    config = presets.get(args.preset)
    if args.config is not None:
        config = load_config(args.config, base=config)
    for world_name in args.worlds:
        recorded = record(world_name, args.laps, args.max_frames)
        result, distances, yaw_changes, closures = measure(recorded, config, args.noise, args.seed)
        slam, poses, levels, images = result.slam, result.truth, result.true_levels, recorded.frames
        times = result.times
        themap = slam.experience_map
        creation_frames = np.minimum(np.searchsorted(times, themap.creation_times), len(times) - 1)
        print(f"{world_name} ({len(images)} frames{'' if args.seed is None else f', noise seed {args.seed}'})")
        print("\n".join(odometry_rows(np.array(distances), np.array(yaw_changes), poses, levels)))
        errors = closure_errors(closures, creation_frames, poses)
        if len(errors):
            horizontal = np.hypot(errors[:, 0], errors[:, 1])
            yaw = np.degrees(np.abs(errors[:, 3]))
            print(f"  {len(errors)} loop closures: horizontal error median {np.median(horizontal):.2f} m, "
                  f"90th percentile {np.percentile(horizontal, 90):.2f} m, largest {horizontal.max():.2f} m; "
                  f"along the heading {errors[:, 0].mean():+.2f} m on average; yaw error median "
                  f"{np.median(yaw):.1f}°, largest {yaw.max():.1f}°", flush=True)
        else:
            print("  no loop closures", flush=True)


if __name__ == "__main__":
    main()
