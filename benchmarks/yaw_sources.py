"""Where the wheels' and the camera's heading errors come from, on scripted drives.

Run: ``python benchmarks/yaw_sources.py WORLD [WORLD ...] [--laps N]`` (default: 1 lap a world). A
measurement, not a test: it asserts nothing and is not part of the pytest run. About a minute a world here.

Per frame it compares three turns with the true one (the change of the true yaw since the previous frame):
the wheels' (the encoders' turn rate times the frame time), and the camera's (NeuroSLAM's visual odometry,
by the cue it took the yaw from: ``floor``, ``image`` or ``profile``). Per world it prints

- the wheels' heading drift, rad per metre, on flat straight driving (``|true turn| < 0.003 rad`` a frame,
  slope under 3 %) and their turn scale (the least-squares slope of their turn against the true one on
  frames turning more than 0.01 rad);
- the wheels' and the camera's accumulated heading error over the drive, degrees, the camera's by cue;
- the horizontal ATE (m, after the best rigid 2-D fit) of dead reckoning with the wheels' speed and each
  heading: the wheels' own, the true one (what the wheels' distance alone is worth), the camera's where
  it observed the yaw (the wheels' elsewhere), and the wheels' turned toward the floor's and the ceiling's
  straight lines (eqs. M1–M3 of :mod:`neuroslam.vision.structure` with the ``sim`` preset's ``manhattan_*``
  settings, applied to the wheels' turn: the library applies them to the visual odometry's own yaw only,
  and only where ``odometry.manhattan`` is on).
"""

from __future__ import annotations

import argparse

import numpy as np

import sim
from neuroslam import NeuroSLAM
from neuroslam.evaluation.registration import fit_yaw_translation, transform_points
from neuroslam.lab.frames import DriveStream
from neuroslam.vision.preprocessing import grey
from neuroslam.vision.structure import StructureHeading

CUES = ("floor", "image", "profile")


def _ate(estimate: np.ndarray, truth: np.ndarray) -> float:
    """Horizontal RMSE (m) after the best rotation about z and translation (the closed-form fit the map
    comparison uses)."""
    flat = [np.column_stack([points, np.zeros(len(points))]) for points in (estimate, truth)]
    yaw, translation = fit_yaw_translation(*flat)
    moved = transform_points(flat[0], yaw, translation)
    return float(np.sqrt(np.mean(np.sum((moved - flat[1])[:, :2] ** 2, axis=1))))


def _dead_reckoning(start: np.ndarray, yaw0: float, steps: np.ndarray, turns: np.ndarray) -> np.ndarray:
    heading = yaw0 + np.cumsum(turns) - turns / 2
    return start + np.c_[np.cumsum(steps * np.cos(heading)), np.cumsum(steps * np.sin(heading))]


def measure(world: str, laps: int) -> None:
    slam = NeuroSLAM("sim")
    odometry, settings = slam.visual_odometry, slam.config.odometry
    lines = StructureHeading(horizontal_fov=slam.config.horizontal_fov, strength=settings.manhattan_strength,
                             spread=settings.manhattan_spread, window=settings.manhattan_window,
                             first_row=settings.manhattan_first_row, rate=settings.manhattan_rate)
    rows, cues, previous = [], [], None
    with sim.ScriptedDrive(world, laps=laps, seed=0) as drive:
        for frame in DriveStream(drive):
            dt = 0.0 if previous is None else frame.time - previous
            previous = frame.time
            camera = odometry.step(grey(frame.image), dt)
            wheel_turn = frame.wheels.yaw_rate * dt
            lined = lines.correct(odometry.image_stack, wheel_turn, dt) if dt > 0 else 0.0  # eq. M3
            rows.append((dt, *frame.truth.pose, frame.wheels.forward_speed, frame.wheels.yaw_rate, camera.yaw_rate,
                         lined))
            cues.append(camera.observed.yaw if camera.observed is not None else "none")
    data = np.array(rows)
    dt, position, height, yaw = data[:, 0], data[:, 1:3], data[:, 3], data[:, 4]
    steps, wheel_turn, camera_turn = data[:, 5] * dt, data[:, 6] * dt, data[:, 7] * dt
    cues = np.array(cues)
    true_turn = np.r_[0.0, np.angle(np.exp(1j * np.diff(yaw)))]
    moved = np.r_[0.0, np.linalg.norm(np.diff(position, axis=0), axis=1)]
    slope = np.abs(np.r_[0.0, np.diff(height)]) / np.maximum(moved, 1e-6)
    straight = (np.abs(true_turn) < 0.003) & (slope < 0.03) & (moved > 0.02)
    drift = float((wheel_turn - true_turn)[straight].sum() / moved[straight].sum())
    turning = np.abs(true_turn) > 0.01
    scale = float(wheel_turn[turning] @ true_turn[turning] / (true_turn[turning] @ true_turn[turning]))
    seen = np.isin(cues, CUES)
    heading = {"wheels": wheel_turn, "true": true_turn, "camera": np.where(seen, camera_turn, wheel_turn),
               "lines": data[:, 8]}
    ate = {name: _ate(_dead_reckoning(position[0], yaw[0], steps, turns), position)
           for name, turns in heading.items()}
    by_cue = ", ".join(f"{cue} {np.degrees((camera_turn - true_turn)[cues == cue].sum()):+.1f} "
                       f"({np.mean(cues == cue):.0%})" for cue in (*CUES, "none") if np.any(cues == cue))
    print(f"{world}: {moved.sum():.0f} m, {len(data)} frames")
    print(f"  wheels: drift {drift * 1e3:+.2f} mrad/m on flat straight driving, turn scale {scale:.4f}, "
          f"heading error {np.degrees((wheel_turn - true_turn).sum()):+.1f} deg over the drive")
    print(f"  camera heading error by cue, deg (share of frames): {by_cue}")
    print(f"  dead-reckoning ATE with the wheels' speed: wheels' heading {ate['wheels']:.2f} m, true heading "
          f"{ate['true']:.2f} m, camera's heading {ate['camera']:.2f} m, wheels' turned by the lines (eq. M3) "
          f"{ate['lines']:.2f} m")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("worlds", nargs="+", metavar="WORLD")
    parser.add_argument("--laps", type=int, default=1)
    args = parser.parse_args()
    for world in args.worlds:
        measure(world, args.laps)


if __name__ == "__main__":
    main()
