"""The localiser on a scripted drive: how often NeuroSLAM's recognitions correct it, lap by lap.

Run: ``python benchmarks/localisation_laps.py [WORLD ...] [--laps N] [--odometry wheel|visual]`` (default: the
car park, 2 laps, the wheels). A measurement, not a test: it asserts nothing and is not part of the pytest
run. About a minute a world here.

A scripted drive re-drives its route every lap, the setting in which NeuroSLAM's confirmed recognition (16
of the last 20 metre-spaced frames on one old place) fires; navigation's paths between random places rarely
do (docs/navigation.md). Per world it drives the route with :class:`neuroslam.localisation.Localiser` on
NeuroSLAM and the chosen self-motion (the ``wheel`` source of ``neuroslam drive --odometry wheel``, or the
camera's own), starting at the true start pose, and prints NeuroSLAM's loop closures, the localiser's
corrections and rejections, and per lap the median and largest horizontal error of the localiser's pose and
of the self-motion integrated alone, against the truth (m), with the localiser's final 1σ.
"""

from __future__ import annotations

import argparse

import numpy as np

import sim
from neuroslam import NeuroSLAM
from neuroslam.lab.frames import DriveStream, SelfMotionSource
from neuroslam.localisation import LocalisationConfig, Localiser


def measure(world: str, laps: int, odometry: str) -> None:
    slam = NeuroSLAM("sim")
    source = SelfMotionSource(odometry, slam)
    localiser: Localiser | None = None
    errors, dead_reckoning, lap_of, closures = [], [], [], 0
    alone = None
    with sim.ScriptedDrive(world, laps=laps) as drive:
        for frame in DriveStream(drive):
            truth = np.asarray(frame.truth.pose, dtype=float)
            if localiser is None:
                preset = LocalisationConfig.preset("wheel" if odometry == "wheel" else "visual")
                localiser = Localiser(slam, truth, preset)
                alone = truth.copy()
            where = localiser.step(frame.image, frame.time, odometry=source(frame))
            motion, dt = where.estimate.self_motion, (frame.time - lap_of[-1][1]) if lap_of else 0.0
            distance, turn = motion.forward_speed * dt, motion.yaw_rate * dt
            middle = alone[3] + turn / 2
            alone = alone + np.array([distance * np.cos(middle), distance * np.sin(middle), motion.climb_rate * dt,
                                      turn])
            closures += where.estimate.loop_closure
            errors.append(float(np.linalg.norm(where.pose[:2] - truth[:2])))
            dead_reckoning.append(float(np.linalg.norm(alone[:2] - truth[:2])))
            lap_of.append((drive.laps_completed, frame.time))
    laps_done = np.minimum([lap for lap, _ in lap_of], laps - 1)  # the last frame, after the last lap, is in it
    print(f"{world}: {len(errors)} frames, {closures} loop closures, {localiser.corrections} corrections, "
          f"{localiser.rejections} rejected; final 1σ {localiser.sigma[0]:.2f} m")
    for lap in np.unique(laps_done):
        mask = laps_done == lap
        e, d = np.array(errors)[mask], np.array(dead_reckoning)[mask]
        print(f"  lap {lap + 1}: localiser median / largest {np.median(e):.2f} / {e.max():.2f} m, "
              f"{odometry} alone {np.median(d):.2f} / {d.max():.2f} m")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("worlds", nargs="*", default=["carpark"])
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--odometry", choices=["wheel", "visual"], default="wheel")
    args = parser.parse_args()
    for world in args.worlds:
        measure(world, args.laps, args.odometry)


if __name__ == "__main__":
    main()
