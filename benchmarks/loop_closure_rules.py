"""Loop-closure precision and recall of the two rules, on the testbed's worlds (camera only, 2 laps).

Run: ``python benchmarks/loop_closure_rules.py [--worlds carpark urban building gen1:1 gen1:2 gen1:3]``
(about 1.5 minutes a world and rule). Rules: ``code`` (the NeuroSLAM paper: re-entering any experience
whose conjunctive code matches closes a loop, eq. 22); ``paper`` (the grid-network paper's rule, more than
6 of the last 10 frames matched consistently, made geometric: ``neuroslam.loop_closure`` with
``confirmation_window = 10``, ``confirmation_matches = 7``, ``confirmation_spacing = 0``); ``confirmed`` (the
same rule as the ``sim`` preset sets it: 16 of the last 20 frames one metre apart).

Printed per world and rule:

- closures, and **closure precision**: the share of loop closures whose two places are within 2 m and on
  the same level in ground truth;
- **revisit recall**: of the frames on which the robot is truly back at a place it passed at least 30 s
  before (within 2 m, same level), the share on which its current experience is such an old one (made
  within 2 m of where the robot truly is, on its level): the map recognised the revisit, whether by a
  closure event on that frame or by following the links of an earlier one;
- **revisit precision**: of the frames on which the current experience is an old one (made at least 30 s
  before), the share on which it truly lies within 2 m on the robot's level;
- SLAM ATE (the final trajectory, Sim(3)) and ms per frame of SLAM.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
from scipy.spatial import cKDTree

from neuroslam import NeuroSLAM, presets
from neuroslam.evaluation import ate_rmse

REVISIT_AGE = 30.0  # s: a place passed at least this long ago counts as a revisit
NEAR = 2.0  # m


def drive(world: str, rule: str) -> dict:
    """One 2-lap drive of ``world``'s main route with the given loop-closure rule; the scores."""
    import sim
    from neuroslam.lab.frames import DriveStream
    from neuroslam.lab.runner import run

    config = presets.get("sim")
    changes = {"code": {"loop_closure": "code"}, "confirmed": {},
               "paper": {"confirmation_window": 10, "confirmation_matches": 7, "confirmation_spacing": 0.0}}[rule]
    config = config.replace(experience_map=dataclasses.replace(config.experience_map, **changes))
    result = run(DriveStream(sim.ScriptedDrive(world, laps=2, seed=0)), NeuroSLAM(config), progress=False)
    times, truth, levels = result.times, result.truth, result.true_levels
    current = result.active[:, 1]  # the experience at each frame
    closures = np.zeros(result.frames, dtype=bool)
    closures[[frame for frame, _, _ in result.closures]] = True
    slam = result.slam
    themap = slam.experience_map
    made = np.minimum(np.searchsorted(times, themap.creation_times), len(times) - 1)  # creation frames
    place, place_level = truth[made[current], :3], levels[made[current]]
    on_place = (np.linalg.norm(place - truth[:, :3], axis=1) <= NEAR) & (place_level == levels)
    old = themap.creation_times[current] < times - REVISIT_AGE
    # frames truly back at a place passed REVISIT_AGE before, on the same level
    revisit = np.zeros(len(times), dtype=bool)
    for level in np.unique(levels):
        frames_here = np.flatnonzero(levels == level)
        tree = cKDTree(truth[frames_here, :2])
        for index, neighbours in zip(frames_here, tree.query_ball_point(truth[frames_here, :2], NEAR), strict=True):
            revisit[index] = np.any(times[frames_here[neighbours]] < times[index] - REVISIT_AGE)
    true_closures = closures & on_place
    return {
        "closures": int(closures.sum()),
        "closure_precision": float(true_closures.sum() / max(closures.sum(), 1)),
        "revisit_recall": float((revisit & old & on_place).sum() / max(revisit.sum(), 1)),
        "revisit_precision": float((old & on_place).sum() / max(old.sum(), 1)),
        "ate": ate_rmse(result.estimate[:, :3], truth[:, :3]),
        "ms": 1000 * result.slam_seconds / result.frames,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", nargs="+", default=["carpark", "urban", "building", "gen1:1", "gen1:2", "gen1:3"])
    parser.add_argument("--rules", nargs="+", choices=["code", "paper", "confirmed"],
                        default=["code", "paper", "confirmed"])
    args = parser.parse_args()
    print(f"{'world':<10} {'rule':<10} {'closures':>8} {'precision':>9} {'revisit recall':>14} "
          f"{'revisit precision':>17} {'SLAM ATE m':>10} {'ms':>6}")
    for world in args.worlds:
        for rule in args.rules:
            r = drive(world, rule)
            print(f"{world:<10} {rule:<10} {r['closures']:>8} {r['closure_precision']:>9.3f} "
                  f"{r['revisit_recall']:>14.3f} {r['revisit_precision']:>17.3f} {r['ate']:>10.2f} {r['ms']:>6.2f}",
                  flush=True)


if __name__ == "__main__":
    main()
