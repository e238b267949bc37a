"""Where a navigating robot could recognise a place, and whether NeuroSLAM's views do.

Run: ``python benchmarks/revisits.py WORLD [WORLD ...] [--sequential 12] [--patrol K] [--episodes 1]
[--seed 0] [--pose slam]``. A measurement, not a test: it asserts nothing and is not part of the pytest run.
About half a minute an episode of 12 goals here.

It drives the planner on ``NeuroSLAM/SequentialPointNav-v0`` as ``neuroslam nav --sequential`` does
(:func:`neuroslam.lab.nav.run_episode` with a per-step recorder), with NeuroSLAM (wheels + camera) as its
pose source, and records each frame's true pose, its view (the local view cells' thumbnail) and the
template NeuroSLAM took. A frame *revisits* a place where the robot was at
least ``confirmation_age`` (30 s) earlier within 1 m horizontally, 0.5 m vertically and 20° of heading
(the view cells' column shifts reach ±20° with the ``sim`` preset: 4 of 16 columns of an 81.5° view). Per
world it prints

- the share of frames that revisit, over the first 100 m and 200 m driven and over the whole episode: the
  frames on which a view-based recognition of the route driven could correct the pose at all;
- of the revisit frames, the share on which NeuroSLAM's view was a template of the earlier visit
  (recognised), and the share on which it made a new template instead;
- the view difference (the local view cells' shifted mean absolute difference) of a revisit frame to the
  earlier visit's templates, and of every tenth frame after the first 30 s to the nearest-looking template
  laid more than 3 m away (how alike distinct places look), against ``local_view.threshold``;
- the turn the robot made while its bumper was closed (what wheels that slip against a wall do not read),
  and the pose's final heading error.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.spatial import cKDTree

import sim
from neuroslam.geometry import wrap
from neuroslam.lab.nav import run_episode
from neuroslam.vision.preprocessing import grey
from sim.navigation import DrivableGraph

AGE = 30.0  # s: the experience map's confirmation_age
RADIUS, HEIGHT, HEADING = 1.0, 0.5, math.radians(20.0)


def drive(world_name: str, seed: int, goals: int, patrol: int | None, pose: str) -> dict:
    """One episode; per frame: time, true pose, pose, template id, whether new, thumbnail, bumper."""
    frames = {"time": [], "truth": [], "template": [], "new": [], "thumbnail": [], "bumped": [], "pose": []}
    held = {}

    def record(runner, observation, info) -> None:
        estimate = runner.localiser.last.estimate
        held["local_view"] = local_view = runner.localiser.slam.local_view
        frames["time"].append(float(info["time"]))
        frames["truth"].append(np.array(info["pose"], dtype=float))
        frames["pose"].append(np.array(runner.pose, dtype=float))
        frames["template"].append(estimate.template_id)
        frames["new"].append(estimate.new_template)
        frames["thumbnail"].append(local_view.thumbnail(grey(observation["image"])))
        frames["bumped"].append(bool(np.asarray(observation["bumper"]).ravel()[0]))

    graph = DrivableGraph.of(sim.load_world(world_name))
    rows = run_episode(world_name, seed, "planner", pose, graph=graph, goals=goals, patrol=patrol, on_step=record)
    out = {key: np.array(value) for key, value in frames.items()}
    out["local_view"] = held["local_view"]
    out["success"] = sum(row.success for row in rows)
    out["goals"] = len(rows)
    return out


def analyse(name: str, episode: dict) -> None:
    truth, time, template = episode["truth"], episode["time"], episode["template"]
    local_view, threshold = episode["local_view"], episode["local_view"].config.threshold
    moved = np.r_[0.0, np.linalg.norm(np.diff(truth[:, :2], axis=0), axis=1)]
    driven = np.cumsum(moved)
    born: dict[int, int] = {}
    for index, identity in enumerate(template):
        born.setdefault(int(identity), index)
    tree = cKDTree(truth[:, :2])
    revisit = np.zeros(len(truth), dtype=bool)
    recognised = np.zeros(len(truth), dtype=bool)
    same_place: list[float] = []
    for index in range(len(truth)):
        earlier = [j for j in tree.query_ball_point(truth[index, :2], RADIUS)
                   if time[j] < time[index] - AGE and abs(truth[j, 2] - truth[index, 2]) < HEIGHT
                   and abs(wrap(float(truth[j, 3] - truth[index, 3]))) < HEADING]
        if not earlier:
            continue
        revisit[index] = True
        visits = np.unique(template[earlier])
        recognised[index] = template[index] in set(visits.tolist())
        differences, _ = local_view.compare(episode["thumbnail"][index], visits)
        same_place.append(float(differences.min()))
    distinct: list[float] = []
    for index in range(0, len(truth), 10):
        old = np.array([identity for identity, first in born.items() if time[first] < time[index] - AGE
                        and np.linalg.norm(truth[first, :2] - truth[index, :2]) > 3.0])
        if len(old):
            distinct.append(float(local_view.compare(episode["thumbnail"][index], old)[0].min()))
    same, other = np.array(same_place), np.array(distinct)

    def share(mask: np.ndarray, limit: float) -> str:
        inside = driven <= limit
        return f"{mask[inside].mean():.2f}" if inside.any() else "-"

    bumped = episode["bumped"]
    true_turn = np.r_[0.0, [wrap(float(b - a)) for a, b in zip(truth[:-1, 3], truth[1:, 3], strict=True)]]
    final = episode["pose"][-1]
    print(f"{name}: {episode['success']} of {episode['goals']} goals, {driven[-1]:.0f} m, {len(truth)} frames")
    print(f"  revisit share: first 100 m {share(revisit, 100)}, first 200 m {share(revisit, 200)}, "
          f"all {revisit.mean():.2f}")
    if revisit.any():
        new = episode["new"][revisit]
        print(f"  revisit frames {revisit.sum()}: recognised {recognised[revisit].mean():.2f}, new template "
              f"{new.mean():.2f}; view difference to the earlier visit median {np.median(same):.3f} "
              f"(<= threshold {threshold}: {np.mean(same <= threshold):.2f})")
    if len(other):
        print(f"  nearest-looking template > 3 m away: median {np.median(other):.3f}, 10th percentile "
              f"{np.percentile(other, 10):.3f} (<= threshold: {np.mean(other <= threshold):.2f})")
    contact_turn = np.degrees(np.abs(true_turn[bumped]).sum())
    print(f"  bumper closed on {bumped.mean():.1%} of frames, turning {contact_turn:.0f}° in all; "
          f"final pose error {np.linalg.norm(final[:2] - truth[-1, :2]):.2f} m, "
          f"heading {np.degrees(wrap(float(final[3] - truth[-1, 3]))):+.1f}°")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("worlds", nargs="+", metavar="WORLD")
    parser.add_argument("--sequential", type=int, default=12, help="goals in a row (default 12)")
    parser.add_argument("--patrol", type=int, default=None, help="places of a patrol (default: random goals)")
    parser.add_argument("--episodes", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pose", default="slam", choices=("slam", "slam-camera"))
    args = parser.parse_args()
    for world in args.worlds:
        for seed in range(args.seed, args.seed + args.episodes):
            analyse(f"{world} seed {seed}", drive(world, seed, args.sequential, args.patrol, args.pose))


if __name__ == "__main__":
    main()
