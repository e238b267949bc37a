"""The other commands: eval, compare-maps, sweep, nav, worlds."""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from .options import metres, print_rows
from .runs import output_folder


def map_positions(path: Path) -> np.ndarray:
    """(N, 3) experience positions of a map.npz, a run's output folder (its map.npz, else experiences.tum),
    or an experiences.tum file."""
    from ...slam import MAP_FILE, NeuroSLAM
    from ...tum import read_tum

    if path.is_dir() and not (path / MAP_FILE).is_file() and (path / "experiences.tum").is_file():
        path = path / "experiences.tum"
    if path.suffix == ".tum":
        return read_tum(path)[1]
    return NeuroSLAM.load(path).experience_map.poses[:, :3].copy()


def evaluate_command(args: argparse.Namespace) -> int:
    """Score an estimated trajectory against ground truth (``neuroslam eval``)."""
    from ...datasets import DatasetError, read_groundtruth
    from ...evaluation import associate, trajectory_errors

    truth, estimate = read_groundtruth(args.groundtruth), read_groundtruth(args.estimate)
    for name, trajectory in (("groundtruth", truth), ("estimate", estimate)):
        if trajectory.times is None:
            raise DatasetError(f"{name} {str(getattr(args, name))!r}: needs times: a TUM file (t x y z qx qy qz qw)")
    mine, theirs = associate(estimate.times, truth.times, args.max_difference)
    if len(mine) < 3:
        raise DatasetError(f"only {len(mine)} poses of {str(args.estimate)!r} lie within {args.max_difference} s "
                           f"of a ground-truth pose; at least 3 are needed")
    scores = {"pairs": int(len(mine)), "estimate_poses": len(estimate.times),
              **trajectory_errors(estimate.poses[mine], truth.poses[theirs])}
    if args.json:
        print(json.dumps(scores, indent=2))
        return 0
    print_rows([("pairs", f"{scores['pairs']} of {scores['estimate_poses']} estimated poses "
                           f"(within {args.max_difference} s of the truth)"),
                 ("ATE (Sim(3))", metres(scores["ate_rmse_m"])), ("ATE (SE(3))", metres(scores["ate_se3_rmse_m"])),
                 ("RPE (10 m)", metres(scores["rpe_rmse_m"]))])
    return 0


def compare_maps_command(args: argparse.Namespace) -> int:
    """The RMSE between two experience maps after ICP (:mod:`neuroslam.evaluation.registration`)."""
    from ...errors import InvalidInputError
    from ...evaluation.registration import compare_maps

    a, b = map_positions(args.a), map_positions(args.b)
    for name, points in (("a", a), ("b", b)):
        if len(points) < 3:
            raise InvalidInputError(f"map {name}", f"with {len(points)} experiences", "needs at least 3")
    result = compare_maps(a, b)
    if args.json:
        print(json.dumps(result.as_dict(), indent=2))
        return 0
    print_rows([
        ("maps", f"A {args.a} ({len(a)} experiences) onto B {args.b} ({len(b)} experiences)"),
        ("RMSE", f"{result.rmse_m:.3f} m over inliers ({100 * result.inlier_fraction:.1f} % of A), "
                 f"{result.rmse_all_m:.3f} m over all pairs"),
        ("transform", "yaw {:.2f} deg, shift ({:.2f}, {:.2f}, {:.2f}) m".format(math.degrees(result.yaw),
                                                                               *result.translation)),
        ("iterations", str(result.iterations)),
    ])
    return 0


def sweep_command(args: argparse.Namespace) -> int:
    """Drives as Ray tasks (:mod:`neuroslam.lab.sweep`); exit code 1 if any drive failed."""
    from ..sweep import expand_worlds, parse_grid, run_sweep, summary

    worlds, grid = expand_worlds(args.worlds), parse_grid(args.grid)
    rows, failed = run_sweep(worlds, args.seeds, grid, args.out, laps=args.laps, max_frames=args.max_frames,
                             workers=args.workers, address=args.address, odometry=args.odometry)
    grid_fields = sorted({field for setting in grid for field, _ in setting})
    table = summary(rows, grid_fields)
    widths = [max(len(str(line[k])) for line in table) for k in range(len(table[0]))]
    for line in table:
        print("  ".join(str(cell).ljust(width) for cell, width in zip(line, widths, strict=True)))
    for row in rows:
        if row.get("status") == "failed":
            print(f"failed: {row['world']} seed {row['seed']}: {row['error']}")
    print(f"results: {args.out / 'results.csv'}")
    return 1 if failed else 0


def nav_command(args: argparse.Namespace) -> int:
    """Navigation episodes (:mod:`neuroslam.lab.nav`)."""
    from tqdm import tqdm

    import sim
    from sim.navigation import DrivableGraph

    from ...errors import InvalidParameterError
    from ..nav import load_agent, run_episode, run_episodes_vector, write_episodes, write_summary

    load_agent(args.agent)  # an unknown agent fails before any episode
    if args.load_map is not None and not args.pose.startswith("slam"):
        raise InvalidParameterError("--load-map", str(args.load_map), "is used with --pose slam or slam-camera only")
    if args.patrol is not None and (args.patrol < 2 or args.sequential < 2):
        raise InvalidParameterError("--patrol", args.patrol, "needs at least 2 places and --sequential N with N >= 2")
    worlds = {name: sim.load_world(name) for name in args.worlds}  # bad worlds and maps fail before any episode
    if args.load_map is not None:
        from ...slam import NeuroSLAM

        NeuroSLAM.load(args.load_map)
    out = output_folder(args, Path("runs") / f"nav-{time.strftime('%Y%m%d-%H%M%S')}")
    results = []
    with tqdm(total=len(args.worlds) * args.episodes, unit="episode", desc="nav") as bar:
        for name in args.worlds:
            world = worlds[name]
            graph = DrivableGraph.of(world)
            seeds = [args.seed + k for k in range(args.episodes)]
            settings = {"graph": graph, "goal_sensor": args.goal_sensor, "load_map": args.load_map,
                        "max_steps": args.max_steps, "goals": args.sequential,
                        "patrol": args.patrol}
            if args.num_envs > 1:
                results += run_episodes_vector(name, seeds, args.agent, args.pose, world=world,
                                               num_envs=args.num_envs, progress=bar, **settings)
                continue
            for seed in seeds:
                results += run_episode(name, seed, args.agent, args.pose, **settings)
                bar.update()
    write_episodes(out / "episodes.csv", results)
    summary = write_summary(out / "summary.json", results)
    for setting in summary["settings"]:
        trend, error = setting.get("localisation_error_trend"), setting["median_localisation_error_m"]
        print(f"{setting['world']:<10} {setting['agent']:<8} {setting['pose']:<12} {setting['goals']:>4} goals: "
              f"success {setting['success_rate']:.2f}, SPL {setting['spl']:.2f}, localisation error "
              + ("-" if error is None else f"{error:.2f} m")
              + ("" if trend is None else f" (trend {trend:+.2f} m per 100 m)")
              + ("" if setting["pose"] in ("odometry", "groundtruth") or setting["not_worse_than_wheels"] is None
                 else f"; not worse than the wheels on the same frames on {setting['not_worse_than_wheels']:.2f}"
                      " of goals"))
    print(f"output: {out}")
    return 0


def worlds_command(_: argparse.Namespace) -> int:
    import sim

    for name in sim.builtin_worlds():
        world = sim.load_world(name)
        levels = ", ".join(f"{h:g}" for h in world.levels)
        routes = ", ".join(f"{r.name} ({r.length:.0f} m)" for r in world.routes.values())
        print(f"{name:<10} levels at {levels} m; routes: {routes}")
    from sim.arenas import GENERATOR_VERSION

    print(f"gen:SEED   a generated world for any integer SEED (generator version {GENERATOR_VERSION}: 2-4 levels, "
          "5-12 degree ramps, blank to well-marked floors, open decks, corridors; genN:SEED for version N)")
    return 0
