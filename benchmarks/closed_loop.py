"""Speed of the whole loop: the testbed drives a route and NeuroSLAM runs on every camera frame.

Run: ``python benchmarks/closed_loop.py [--frames N] [--worlds carpark urban ...] [--preset sim]``. For each
world the robot drives the main route at 1 m/s with the 160×120 camera at 10 Hz (a frame = 0.1 s simulated;
physics at 5 ms steps with 50 Hz control) and ``NeuroSLAM.step`` (visual odometry) runs on each frame, as
``neuroslam drive`` does. Prints closed-loop frames per wall-clock second and the milliseconds per frame
(means) spent in physics (with control), rendering, SLAM and in the rest of the loop (reading ground
truth, odometry and IMU into the frame), with each one's share of the total, then their mean over the
worlds (its frames/s is that of the mean total). The first frame (GL context creation, SLAM start-up) is not timed.
"""

from __future__ import annotations

import argparse
import time

import sim  # importing sim selects headless rendering before mujoco loads
from neuroslam import NeuroSLAM, presets

PARTS = ("physics", "render", "slam", "other")


def measure(world: str, frames: int, preset: str = "sim") -> dict[str, float]:
    """Closed-loop timings of ``frames`` frames of ``world``'s main route.

    Returns ms per frame (means) for ``physics``, ``render``, ``slam``, ``other`` and ``total``, and the
    number of timed ``frames`` (fewer than asked when the route ends first).
    """
    slam = NeuroSLAM(presets.get(preset))
    drive = sim.ScriptedDrive(world, max_frames=frames + 1, seed=0)
    slam_seconds, timed = 0.0, 0
    with drive:
        for frame in drive:
            started = time.perf_counter()
            slam.step(frame.image, frame.time)
            if frame.index == 0:  # untimed: the first render creates the GL context, the first step sets up SLAM
                physics0, render0 = drive.timings["physics"], drive.timings["render"]
                loop_started = time.perf_counter()
                continue
            slam_seconds += time.perf_counter() - started
            timed += 1
        total = time.perf_counter() - loop_started
    if timed == 0:
        raise SystemExit(f"{world}: the drive ended after one frame")
    ms = {"physics": drive.timings["physics"] - physics0, "render": drive.timings["render"] - render0,
          "slam": slam_seconds, "total": total}
    ms = {name: 1000 * seconds / timed for name, seconds in ms.items()}
    ms["other"] = ms["total"] - ms["physics"] - ms["render"] - ms["slam"]
    ms["frames"] = timed
    return ms


def row(label: str, frames: str, ms: dict[str, float]) -> str:
    """One table line: frames per second, then ms and % of the total for each part, then the total ms."""
    cells = "".join(f"{ms[part]:>9.2f} {100 * ms[part] / ms['total']:>4.0f}%" for part in PARTS)
    return f"{label:<10} {frames:>6} {1000 / ms['total']:>9.1f}{cells} {ms['total']:>9.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=600, help="frames timed per world (default: 600)")
    parser.add_argument("--worlds", nargs="+", default=["carpark", "urban", "building", "gen1:1"],
                        help="built-in worlds, gen:SEED or MJCF paths (default: carpark urban building gen1:1)")
    parser.add_argument("--preset", default="sim", help="NeuroSLAM parameter preset (default: sim)")
    args = parser.parse_args()
    if args.frames < 1:
        parser.error("--frames must be at least 1")
    print(f"closed loop, 160x120 camera at 10 Hz, preset {args.preset!r}: ms per frame (share of the total)")
    print(f"{'world':<10} {'frames':>6} {'frames/s':>9}" + "".join(f"{name + ' ms':>15}" for name in PARTS)
          + f" {'total ms':>9}")
    results = []
    for world in args.worlds:
        ms = measure(world, args.frames, args.preset)
        results.append(ms)
        print(row(world, str(int(ms["frames"])), ms), flush=True)
    if len(results) > 1:
        mean = {name: sum(ms[name] for ms in results) / len(results) for name in (*PARTS, "total")}
        print(row("mean", "", mean))


if __name__ == "__main__":
    main()
