"""Whose is the camera odometry's heading bias: the estimator's, or the scene's? The mirror test.

Run: ``python benchmarks/odometry_mirror.py [--worlds gen2:128 ...] [--laps 2] [--max-frames 3000]
[--preset sim] [--config FILE]``. A measurement, not a test: it asserts nothing and is not part of the pytest
run. About a minute per world here (rendering, then the odometry twice).

What it does, per world: drives its main route (the frames ``neuroslam drive`` sees, recorded by
``benchmarks/sensitivity.py``'s :func:`record`), runs the visual odometry alone on the frames as rendered and
on the same frames mirrored left to right, and sums the yaw error (degrees, positive counter-clockwise)
over the frames that drive straight (true turn under 0.02°), split by the cue the odometry took the frame's
yaw from (``Observed.yaw``: floor, image, profile, none). Mirroring turns the scene's left into its right
and every true turn into its opposite. An estimator without a left-right bias of its own gives the mirrored
frames the opposite error; one whose geometry leans (a principal point off by part of a pixel, an
asymmetric pixel sampling) keeps part of its error's sign. It also prints the robot's own lateral slip on
those frames (m, from the ground truth): a robot that crabs would bias any camera the same way.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np
from sensitivity import record
from tqdm import tqdm

from neuroslam import presets
from neuroslam.config import load_config
from neuroslam.vision.odometry import VisualOdometry
from neuroslam.vision.preprocessing import grey

STRAIGHT = math.radians(0.02)  # rad a frame: a frame turning less than this drives straight


def straight_error(config, images: list[np.ndarray], times: np.ndarray, true_turn: np.ndarray,
                   mirrored: bool) -> dict[str, float]:
    """The yaw error (deg) summed over the straight frames, per yaw source, with the frames mirrored or not."""
    odometry = VisualOdometry(config.odometry, horizontal_fov=config.horizontal_fov,
                              vertical_fov=config.vertical_fov, panoramic=config.panoramic)
    yaw, sources = [], []
    for index, image in enumerate(tqdm(images, desc="mirrored" if mirrored else "as rendered", leave=False)):
        dt = 0.0 if index == 0 else float(times[index] - times[index - 1])
        motion = odometry.step(np.ascontiguousarray(image[:, ::-1]) if mirrored else image, dt)
        if index:
            yaw.append(motion.yaw_rate * dt)
            sources.append(motion.observed.yaw if motion.observed is not None else "all")
    error = np.array(yaw) - (-true_turn if mirrored else true_turn)
    sources = np.array(sources)
    straight = np.abs(true_turn) < STRAIGHT
    result = {source: math.degrees(float(error[straight & (sources == source)].sum()))
              for source in sorted(set(sources[straight]))}
    result["total"] = math.degrees(float(error[straight].sum()))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["gen2:128"], help="worlds to drive")
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--max-frames", type=int, default=3000, help="cut each drive short (0: the whole drive)")
    parser.add_argument("--preset", default="sim")
    parser.add_argument("--config", default=None, help="TOML or JSON settings over the preset")
    args = parser.parse_args(argv)
    if args.laps < 1 or args.max_frames < 0:
        print(f"--laps {args.laps} / --max-frames {args.max_frames}: must be at least 1 / 0", file=sys.stderr)
        return 2
    config = presets.get(args.preset)
    if args.config:
        config = load_config(args.config, base=config)
    for world_name in args.worlds:
        recorded = record(world_name, args.laps, args.max_frames or None).frames
        times, poses = np.array([frame.time for frame in recorded]), np.array([frame.truth.pose for frame in recorded])
        images = [grey(frame.image) for frame in recorded]
        heading = np.unwrap(poses[:, 3])
        true_turn = np.diff(heading)
        straight = np.abs(true_turn) < STRAIGHT
        middle = heading[:-1] + true_turn / 2
        step = np.diff(poses[:, :2], axis=0)
        lateral = -np.sin(middle) * step[:, 0] + np.cos(middle) * step[:, 1]
        print(f"{world_name}: {len(images)} frames, {int(straight.sum())} straight; the robot's lateral slip on "
              f"them {lateral[straight].sum() * 1000:+.1f} mm in all")
        for mirrored in (False, True):
            errors = straight_error(config, images, times, true_turn, mirrored)
            parts = ", ".join(f"{source} {value:+.1f}" for source, value in errors.items())
            print(f"  {'mirrored   ' if mirrored else 'as rendered'}  straight frames' yaw error (deg): {parts}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
