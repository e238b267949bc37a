"""Speed of the whole loop: the testbed drives a route and NeuroSLAM runs on every camera frame.

Run: ``python benchmarks/closed_loop.py [--frames N] [--worlds carpark urban ...] [--preset sim]``. For each
world the robot drives the main route at 1 m/s with the 160×120 camera at 10 Hz (a frame = 0.1 s simulated;
physics at 5 ms steps with 50 Hz control) and ``NeuroSLAM.step`` (visual odometry) runs on each frame, as
``neuroslam drive`` does. Prints closed-loop frames per wall-clock second and the milliseconds per frame
(means) spent in physics (with control), rendering, SLAM and in the rest of the loop (reading ground
truth, odometry and IMU into the frame), with each one's share of the total, then their mean over the
worlds (its frames/s is that of the mean total). The first frame (GL context creation, SLAM start-up) is not timed.

Then the **replay**, as ``neuroslam run`` does it: the first world's frames are recorded to a temporary folder
as ``neuroslam record`` writes them (PNG frames, ground truth, wheel odometry), and the runner
(:func:`neuroslam.lab.runner.run`) replays them through NeuroSLAM; printed: frames per second in all,
the ms per frame of SLAM and of reading the frames (decoding the PNGs, the ground truth and wheels), and
the frames per second excluding SLAM (reading and the runner's own bookkeeping). ``--no-replay`` skips it.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

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


def replay(world: str, frames: int, preset: str = "sim") -> dict[str, float]:
    """Record ``frames`` frames of ``world``'s main route as ``neuroslam record`` does, then replay them through
    NeuroSLAM with the runner: frames per second in all and excluding SLAM, ms per frame of SLAM and of
    reading the frames."""
    import numpy as np
    from PIL import Image

    from neuroslam.lab.frames import FolderStream
    from neuroslam.lab.runner import run
    from neuroslam.tum import write_tum, yaw_quaternion

    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        (out / "frames").mkdir()
        times, poses, quaternions, wheels = [], [], [], []
        with sim.ScriptedDrive(world, max_frames=frames, seed=0) as drive:
            for frame in drive:
                Image.fromarray(frame.image).save(out / "frames" / f"{frame.index:06d}.png")
                times.append(frame.time)
                poses.append(frame.ground_truth.position)
                quaternions.append(frame.ground_truth.quaternion)
                wheels.append((frame.odometry.x, frame.odometry.y, frame.odometry.yaw))
        times, wheels = np.array(times), np.array(wheels)
        write_tum(out / "groundtruth.tum", times, np.array(poses), np.array(quaternions))
        write_tum(out / "wheel_odometry.tum", times, np.c_[wheels[:, :2], np.zeros(len(wheels))],
                  yaw_quaternion(wheels[:, 2]))
        result = run(FolderStream(out), NeuroSLAM(presets.get(preset)), progress=False)
        count = len(times)
        read = result.stream.timings()["read"]
        return {"frames": count, "frames/s": count / result.elapsed, "slam ms": 1000 * result.slam_seconds / count,
                "read ms": 1000 * read / count,
                "frames/s excluding SLAM": count / (result.elapsed - result.slam_seconds)}


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
    parser.add_argument("--no-replay", action="store_true", help="skip the replay of recorded frames")
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
    if not args.no_replay:
        numbers = replay(args.worlds[0], args.frames, args.preset)
        print(f"\nreplay of {int(numbers['frames'])} recorded frames of {args.worlds[0]} (neuroslam run): "
              f"{numbers['frames/s']:.1f} frames/s, SLAM {numbers['slam ms']:.2f} ms and reading "
              f"{numbers['read ms']:.2f} ms a frame; {numbers['frames/s excluding SLAM']:.0f} frames/s excluding SLAM")


if __name__ == "__main__":
    main()
