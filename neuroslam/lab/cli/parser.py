"""The ``neuroslam`` command's argument parser: every command and option, with its help."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..frames import ODOMETRY_MODES
from .options import (
    Parser,
    drive_options,
    output_options,
    positive_float,
    positive_int,
    record_option,
    slam_options,
)


def build_parser() -> argparse.ArgumentParser:
    from ... import __version__

    parser = Parser(
        prog="neuroslam",
        description="NeuroSLAM, brain-inspired 4-DoF SLAM, and its multi-level MuJoCo testbed.",
    )
    parser.add_argument("--version", action="version", version=f"neuroslam {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    drive = commands.add_parser(
        "drive", help="drive a route in a simulated world with NeuroSLAM in the loop",
        description="Drive the robot along a route under MuJoCo physics, run NeuroSLAM on its camera frames, and "
        "write into the output folder: groundtruth.tum, slam.tum (every frame in the final map), slam_online.tum "
        "(the estimate as it was at each frame), odometry.tum "
        "(the self-motion integrated without the map), wheel_odometry.tum, experiences.tum (the final map), "
        "map.npz (the whole SLAM state, to continue from) and metrics.json (map size, loop closures and how many "
        "were false, trajectory and map errors after "
        "Sim(3) and SE(3) alignment, relative errors over 10 m, floor-level accuracy, timings).",
    )
    drive.add_argument("world", nargs="?", default="carpark",
                       help="built-in world name, gen:SEED for a generated world, or an MJCF file (default: carpark)")
    drive_options(drive, laps=2, camera=True)
    drive.add_argument("--camera-rate", type=positive_float, default=10.0, help="frames per second (default: 10)")
    drive.add_argument("--panoramic", action="store_true", help="stitch four cameras into a 360-degree strip")
    drive.add_argument("--quality", choices=["fast", "high"], default="fast",
                       help="visual profile (default: fast); high renders shadows and multisampling at about 25 ms "
                       "a frame on a CPU (35 ms at 320x240; fast: 3-4 ms): two laps of the car park take 2-3 "
                       "minutes longer")
    slam_options(drive, sessions=True)
    drive.add_argument("--odometry", choices=ODOMETRY_MODES, default="visual",
                       help="self-motion from the camera (visual odometry), from the wheel encoders with the "
                       "camera's pitch for the height rate, or from the camera with the height rate from the IMU's "
                       "gravity direction (visual-inertial; not the paper's) (default: visual)")
    output_options(drive, "output folder (default: a new folder under runs/)")
    record_option(drive)

    run = commands.add_parser(
        "run", help="run NeuroSLAM on a folder of recorded frames",
        description="Run NeuroSLAM on a folder of PNG/JPEG frames (natural order; a frames/ subfolder is used if "
        "present) and write slam.tum, slam_online.tum, odometry.tum, experiences.tum, map.npz and metrics.json; with "
        "--groundtruth (TUM, whose times become the frames' times, or the NeuroSLAM CSV frame,x,y,z,rx,ry,rz) "
        "metrics.json adds the distance driven and the trajectory and map errors, and with the floor heights "
        "(--levels, or the levels of the folder's dataset.json, which neuroslam record writes) the floors "
        "visited, the level accuracy and loop closures judged by floor, as neuroslam drive scores them.")
    run.add_argument("frames", type=Path, help="folder of frames (for example one written by neuroslam record)")
    run.add_argument("--groundtruth", type=Path, help="ground truth: TUM or NeuroSLAM CSV, one row per frame")
    run.add_argument("--levels", type=float, nargs="+", metavar="HEIGHT",
                     help="floor heights in metres, increasing (default: those of the folder's dataset.json, if any)")
    run.add_argument("--rate", type=positive_float, default=10.0,
                     help="frames per second when the ground truth gives no times (default: 10)")
    run.add_argument("--max-frames", type=positive_int, help="use only the first N frames")
    slam_options(run, sessions=True)
    run.add_argument("--camera-height", type=positive_float, metavar="METRES",
                     help="the camera's height above the floor (default: the testbed's, 0.5)")
    run.add_argument("--camera-forward", type=float, metavar="METRES",
                     help="the camera's distance ahead of the robot's turning axis (default: the testbed's, 0.1)")
    run.add_argument("--fov", type=positive_float, nargs="+", metavar="DEGREES",
                     help="the camera's horizontal field of view, and optionally its vertical one (default: the "
                     "testbed's 80; the vertical from the frames' aspect ratio for square pixels)")
    run.add_argument("--odometry", choices=["visual", "wheel"], default="visual",
                     help="self-motion from the camera (visual odometry), or from the wheel odometry the folder "
                     "holds (wheel_odometry.tum, as neuroslam record writes it) with the camera's pitch for the "
                     "height rate (default: visual)")
    output_options(run, "output folder (default: a new folder under runs/)")
    record_option(run)

    record = commands.add_parser(
        "record", help="save a simulated drive as a dataset of frames and ground truth",
        description="Drive a route and save frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum and "
        "dataset.json (world, route and floor heights), a dataset that neuroslam run (or any other SLAM system) "
        "can replay; two laps by default, as neuroslam drive, so that a replay scores as the drive did.")
    record.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    drive_options(record, laps=2, camera=True)
    output_options(record, "dataset folder to write", required=True)

    calibrate = commands.add_parser(
        "calibrate", help="fit the visual-odometry gains to ground truth and write a config file",
        description="Drive a calibration route, compare the visual odometry's raw measurements with ground truth, "
        "fit its gains (speed and yaw scale by least squares; the height pipeline of NeuroSLAM eqs. 31-32 by the "
        "least height error, written only with height_model = profile: the default transitions height has no "
        "gains) and write them as a TOML config file usable with --config.")
    calibrate.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    drive_options(calibrate, laps=1, camera=False)
    slam_options(calibrate)
    calibrate.add_argument("--out", type=Path, required=True, help="TOML file to write")
    calibrate.add_argument("--overwrite", action="store_true", help="replace the file --out names")

    evaluate = commands.add_parser(
        "eval", help="score a trajectory against ground truth (two TUM files), as metrics.json does",
        description="Pair the estimate's poses with the ground truth's by time (each with the nearest truth time "
        "within --max-difference) and print the errors metrics.json reports for a run: ATE after a Sim(3) and "
        "after an SE(3) alignment, and the relative error over 10 m of true travel.")
    evaluate.add_argument("groundtruth", type=Path, help="ground-truth TUM file (t x y z qx qy qz qw)")
    evaluate.add_argument("estimate", type=Path, help="estimated trajectory, TUM file")
    evaluate.add_argument("--max-difference", type=positive_float, default=0.01, metavar="SECONDS",
                          help="largest time difference of a pair (default: 0.01)")
    evaluate.add_argument("--json", action="store_true", help="print the numbers as JSON")

    compare = commands.add_parser(
        "compare-maps", help="the RMSE between two experience maps after 4-DoF ICP registration",
        description="Register experience map A onto map B and report the RMSE between them. Protocol: A's centroid "
        "on B's and the best of 36 headings (by median nearest-neighbour distance) as the initial alignment; "
        "correspondences from every experience of A to its nearest of B (KD-tree); pairs farther than 3x the "
        "median pair distance (and at least 0.5 m) are outliers, left out of the fit and the RMSE; the 4-DoF "
        "transform (yaw, x, y, z; no scale) refitted until it settles. Each map: a map.npz, a run's output "
        "folder, or an experiences.tum file.")
    compare.add_argument("a", type=Path, help="map A (registered onto B)")
    compare.add_argument("b", type=Path, help="map B (the reference)")
    compare.add_argument("--json", action="store_true", help="print the result as JSON")

    sweep = commands.add_parser(
        "sweep", help="many drives (worlds x seeds x parameter settings) as Ray tasks",
        description="Run every (world, seed, parameter setting) drive as a Ray task, on a local Ray instance "
        "started for the run, or on an existing cluster with --address, and write OUT/results.csv (one row per "
        "drive: world, seed, status ok/failed, error, the grid values, and every number of its metrics.json "
        "flattened with dots), each drive's outputs under OUT/drives/, and print a summary per world and "
        "setting. Running the same sweep into the same folder again skips the drives already ok. Needs Ray: "
        "pip install \"neuroslam[scale]\".")
    sweep.add_argument("--worlds", nargs="+", required=True, metavar="WORLD",
                       help="built-in names, gen:SEED, gen:A-B ranges, MJCF paths (spaces or commas)")
    sweep.add_argument("--seeds", type=positive_int, default=1, help="sensor-noise seeds 0..N-1 (default: 1)")
    sweep.add_argument("--laps", type=positive_int, default=2, help="laps per drive (default: 2)")
    sweep.add_argument("--max-frames", type=positive_int, help="stop each drive after this many frames")
    sweep.add_argument("--grid", nargs="+", default=[], metavar="FIELD=V1,V2",
                       help="configuration fields to vary over the sim preset, every combination "
                       "(e.g. local_view.threshold=0.05,0.07 experience_map.loop_closure=code,confirmed)")
    sweep.add_argument("--odometry", choices=ODOMETRY_MODES, default="visual",
                       help="each drive's self-motion, as for drive (default: visual)")
    sweep.add_argument("--workers", type=positive_int, help="CPUs of the local Ray instance (default: all)")
    sweep.add_argument("--address", help="address of a running Ray cluster (default: start one locally)")
    sweep.add_argument("--out", type=Path, required=True, help="output folder (results.csv, drives/)")

    nav = commands.add_parser(
        "nav", help="point-goal navigation episodes with an agent and a pose source",
        description="Evaluate navigation on NeuroSLAM/PointNav-v1, or with --sequential N on "
        "NeuroSLAM/SequentialPointNav-v0 (N goals in a row, nothing reset between them): seeded episodes per "
        "world (the same starts and goals for every setting), an agent (random; planner: a ramp-aware "
        "shortest path on the drivable graph derived from the world's geometry, followed with the scripted "
        "drives' controller; or module:Class, see neuroslam.lab.nav) localising itself with a pose source "
        "(groundtruth; odometry: the wheel encoders; slam: the wheels corrected where NeuroSLAM recognises a "
        "place, with --load-map a map of an earlier drive of the same world; slam-camera: the same on the "
        "camera alone). Writes OUT/episodes.csv (a row per goal: outcome, success, spl, path length, "
        "geodesic, steps, collisions, localisation error, the pose source's uncertainty and corrections, "
        "distance driven) and OUT/summary.json (success, SPL and their 95 %% intervals, localisation error "
        "and its trend).")
    nav.add_argument("worlds", nargs="+", metavar="WORLD", help="built-in names, gen:SEED or MJCF paths")
    nav.add_argument("--agent", default="planner", help="random, planner or module:Class (default: planner)")
    nav.add_argument("--pose", choices=["groundtruth", "odometry", "slam", "slam-camera"], default="groundtruth",
                     help="how the agent localises itself (default: groundtruth)")
    nav.add_argument("--load-map", type=Path,
                     help="with --pose slam or slam-camera: a map (or run folder) of an earlier drive")
    nav.add_argument("--goal-sensor", choices=["gps", "start"], default="gps",
                     help="the goal relative to the robot every step (gps) or only when it is given (start)")
    nav.add_argument("--episodes", type=positive_int, default=20, help="episodes per world (default: 20)")
    nav.add_argument("--sequential", type=positive_int, default=1, metavar="N",
                     help="goals per episode, driven in a row from wherever the last ended (default: 1)")
    nav.add_argument("--patrol", type=positive_int, metavar="K",
                     help="with --sequential N: the goals are K places visited in order, round after round "
                     "(a patrol re-drives its routes; default: every goal drawn afresh)")
    nav.add_argument("--seed", type=int, default=0, help="first episode's seed (default: 0)")
    nav.add_argument("--max-steps", type=positive_int, default=1500,
                     help="steps per goal before it times out (default: 1500 = 150 s)")
    nav.add_argument("--num-envs", type=positive_int, default=1,
                     help="run episodes in a gymnasium async vector env of this many copies (spawned processes)")
    output_options(nav, "output folder (default: a new folder under runs/)")

    commands.add_parser("worlds", help="list the built-in worlds with their levels and routes",
                        description="List the built-in worlds with their floor levels and routes.")
    return parser
