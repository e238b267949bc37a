"""The ``neuroslam`` command line.

Commands:
    drive   drive a route in a simulated world with NeuroSLAM in the loop; write trajectories and metrics
    run     run NeuroSLAM on a folder of recorded frames (with optional ground truth)
    record  save a simulated drive as such a folder
    calibrate  fit the visual-odometry gains to ground truth and write a config file
    worlds  list the built-in worlds with their levels and routes
    compare-maps  the RMSE between two experience maps after ICP registration
    eval    score a trajectory against ground truth (two TUM files), as metrics.json scores a run
    sweep   many drives (worlds x seeds x parameter settings) as Ray tasks
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

from ..config import INTEGRATORS
from .frames import ODOMETRY_MODES

__all__ = ["main"]


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a number >= 0")
    return value


def _camera(args: argparse.Namespace, *, panoramic: bool = False):
    """The simulated camera the options ask for (:class:`sim.CameraConfig`)."""
    import sim

    return sim.CameraConfig(width=args.width, height=args.height, panoramic=panoramic, read_noise=args.read_noise,
                            shot_noise=args.shot_noise, exposure=args.exposure)


def _positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number")
    return value


def _drive_options(parser: argparse.ArgumentParser, *, laps: int, camera: bool) -> None:
    """Options of every command that drives a route."""
    parser.add_argument("--route", help="route name, or a routes JSON file for an MJCF world (default: the first)")
    parser.add_argument("--laps", type=_positive_int, default=laps, help=f"laps to drive (default: {laps})")
    parser.add_argument("--speed", type=_positive_float, default=1.0, help="cruise speed in m/s (default: 1.0)")
    if camera:
        parser.add_argument("--width", type=_positive_int, default=160, help="image width in pixels (default: 160)")
        parser.add_argument("--height", type=_positive_int, default=120, help="image height in pixels (default: 120)")
        parser.add_argument("--read-noise", type=_non_negative_float, default=0.0, metavar="GREY_LEVELS",
                            help="camera read noise: standard deviation in grey levels of 255 (default: 0)")
        parser.add_argument("--shot-noise", type=_non_negative_float, default=0.0, metavar="GREY_LEVELS",
                            help="camera photon noise: its standard deviation at full white (default: 0)")
        parser.add_argument("--exposure", type=_non_negative_float, default=0.0, metavar="SECONDS",
                            help="shutter time for motion blur, up to 0.5 s (default: 0, none)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensor noise (default: 0)")
    parser.add_argument("--max-frames", type=_positive_int, help="stop after this many frames")


def _slam_options(parser: argparse.ArgumentParser, *, sessions: bool = False) -> None:
    """Options choosing the NeuroSLAM parameters (and, for drive and run, maps of earlier sessions)."""
    parser.add_argument("--preset", help="NeuroSLAM parameter preset (default: sim)")
    parser.add_argument("--config", type=Path, help="TOML or JSON file of NeuroSLAM settings over the preset")
    parser.add_argument("--integrator", choices=INTEGRATORS,
                        help="how the displacement that links experiences is integrated: the self-motion directly "
                        "(odometry, the paper) or through the Burak-Fiete grid-cell network (grid-network) "
                        "(default: the preset's, odometry)")
    if sessions:
        parser.add_argument("--load-map", type=Path, action="append", default=[], metavar="MAP",
                            help="a map of an earlier session (a map.npz, or a run's output folder); repeat for "
                            "several. The session starts a map of its own and merges into a loaded one once it "
                            "recognises a place of it over several frames; the loaded map's configuration is used")
        parser.add_argument("--start", choices=["unknown", "known"], default="unknown",
                            help="with --load-map: 'known' if the robot starts inside the loaded map (the first "
                            "view places it there), 'unknown' if it may start anywhere (default: unknown)")


def _output_options(parser: argparse.ArgumentParser, text: str, *, required: bool = False) -> None:
    """``--out`` (an output folder) and ``--overwrite`` of the commands that write a run or a dataset."""
    parser.add_argument("--out", type=Path, required=required, help=text)
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an earlier run or dataset in --out (its files are deleted first)")


def _record_option(parser: argparse.ArgumentParser) -> None:
    """The ``--record`` option of the commands that run NeuroSLAM."""
    parser.add_argument("--record", action="store_true",
                        help="also write run.rrd into the output folder, a rerun recording of the run (camera, "
                        "trajectories, experience map, cell activity, ids and error over time); open it with "
                        "'rerun run.rrd'")


def _recorder(args: argparse.Namespace, out: Path, name: str):
    """A :class:`~neuroslam.lab.recording.RunRecorder` writing ``out/run.rrd`` if ``--record`` was given, else None."""
    if not args.record:
        return None
    from .recording import RunRecorder

    return RunRecorder(out / "run.rrd", name=name)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block) and exit with code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = _Parser(
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
    _drive_options(drive, laps=2, camera=True)
    drive.add_argument("--camera-rate", type=_positive_float, default=10.0, help="frames per second (default: 10)")
    drive.add_argument("--panoramic", action="store_true", help="stitch four cameras into a 360-degree strip")
    drive.add_argument("--quality", choices=["fast", "high"], default="fast",
                       help="visual profile (default: fast); high renders shadows and reflections at about 0.2 s a "
                       "frame on a CPU (at 320x240; fast: 3-4 ms), so two laps take 20 minutes or more")
    _slam_options(drive, sessions=True)
    drive.add_argument("--odometry", choices=ODOMETRY_MODES, default="visual",
                       help="self-motion from the camera (visual odometry), from the wheel encoders with the "
                       "camera's pitch for the height rate, or from the camera with the height rate from the IMU's "
                       "gravity direction (visual-inertial; not the paper's) (default: visual)")
    _output_options(drive, "output folder (default: a new folder under runs/)")
    _record_option(drive)

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
    run.add_argument("--rate", type=_positive_float, default=10.0,
                     help="frames per second when the ground truth gives no times (default: 10)")
    run.add_argument("--max-frames", type=_positive_int, help="use only the first N frames")
    _slam_options(run, sessions=True)
    run.add_argument("--camera-height", type=_positive_float, metavar="METRES",
                     help="the camera's height above the floor (default: the testbed's, 0.5)")
    run.add_argument("--camera-forward", type=float, metavar="METRES",
                     help="the camera's distance ahead of the robot's turning axis (default: the testbed's, 0.1)")
    run.add_argument("--fov", type=_positive_float, nargs="+", metavar="DEGREES",
                     help="the camera's horizontal field of view, and optionally its vertical one (default: the "
                     "testbed's 80; the vertical from the frames' aspect ratio for square pixels)")
    run.add_argument("--odometry", choices=["visual", "wheel"], default="visual",
                     help="self-motion from the camera (visual odometry), or from the wheel odometry the folder "
                     "holds (wheel_odometry.tum, as neuroslam record writes it) with the camera's pitch for the "
                     "height rate (default: visual)")
    _output_options(run, "output folder (default: a new folder under runs/)")
    _record_option(run)

    record = commands.add_parser(
        "record", help="save a simulated drive as a dataset of frames and ground truth",
        description="Drive a route and save frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum and "
        "dataset.json (world, route and floor heights), a dataset that neuroslam run (or any other SLAM system) "
        "can replay.")
    record.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    _drive_options(record, laps=1, camera=True)
    _output_options(record, "dataset folder to write", required=True)

    calibrate = commands.add_parser(
        "calibrate", help="fit the visual-odometry gains to ground truth and write a config file",
        description="Drive a calibration route, compare the visual odometry's raw measurements with ground truth, "
        "fit its gains (speed and yaw scale by least squares; the height pipeline of NeuroSLAM eqs. 31-32 by the "
        "least height error, written only with height_model = profile: the default transitions height has no "
        "gains) and write them as a TOML config file usable with --config.")
    calibrate.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    _drive_options(calibrate, laps=1, camera=False)
    _slam_options(calibrate)
    calibrate.add_argument("--out", type=Path, required=True, help="TOML file to write")
    calibrate.add_argument("--overwrite", action="store_true", help="replace the file --out names")

    evaluate = commands.add_parser(
        "eval", help="score a trajectory against ground truth (two TUM files), as metrics.json does",
        description="Pair the estimate's poses with the ground truth's by time (each with the nearest truth time "
        "within --max-difference) and print the errors metrics.json reports for a run: ATE after a Sim(3) and "
        "after an SE(3) alignment, and the relative error over 10 m of true travel.")
    evaluate.add_argument("groundtruth", type=Path, help="ground-truth TUM file (t x y z qx qy qz qw)")
    evaluate.add_argument("estimate", type=Path, help="estimated trajectory, TUM file")
    evaluate.add_argument("--max-difference", type=_positive_float, default=0.01, metavar="SECONDS",
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
    sweep.add_argument("--seeds", type=_positive_int, default=1, help="sensor-noise seeds 0..N-1 (default: 1)")
    sweep.add_argument("--laps", type=_positive_int, default=2, help="laps per drive (default: 2)")
    sweep.add_argument("--max-frames", type=_positive_int, help="stop each drive after this many frames")
    sweep.add_argument("--grid", nargs="+", default=[], metavar="FIELD=V1,V2",
                       help="configuration fields to vary over the sim preset, every combination "
                       "(e.g. local_view.threshold=0.05,0.07 experience_map.loop_closure=code,confirmed)")
    sweep.add_argument("--odometry", choices=ODOMETRY_MODES, default="visual",
                       help="each drive's self-motion, as for drive (default: visual)")
    sweep.add_argument("--workers", type=_positive_int, help="CPUs of the local Ray instance (default: all)")
    sweep.add_argument("--address", help="address of a running Ray cluster (default: start one locally)")
    sweep.add_argument("--out", type=Path, required=True, help="output folder (results.csv, drives/)")

    nav = commands.add_parser(
        "nav", help="point-goal navigation episodes with an agent and a pose source",
        description="Evaluate navigation on NeuroSLAM/PointNav-v0: N seeded episodes per world (the same start "
        "and goal pairs for every setting), an agent (random; planner: a ramp-aware shortest path on the "
        "drivable graph derived from the world's geometry, followed with the scripted drives' controller; or "
        "module:Class, see neuroslam.lab.nav) localising itself with a pose source (groundtruth, odometry: the "
        "wheel encoders, slam: NeuroSLAM on the wheels and the camera, with --load-map a map of an earlier "
        "drive of the same world). Writes OUT/episodes.csv (world, seed, agent, pose, success, spl, "
        "path_length_m, geodesic_m, steps, collisions, final_localisation_error_m) and OUT/summary.json.")
    nav.add_argument("worlds", nargs="+", metavar="WORLD", help="built-in names, gen:SEED or MJCF paths")
    nav.add_argument("--agent", default="planner", help="random, planner or module:Class (default: planner)")
    nav.add_argument("--pose", choices=["groundtruth", "odometry", "slam"], default="groundtruth",
                     help="how the agent localises itself (default: groundtruth)")
    nav.add_argument("--load-map", type=Path, help="with --pose slam: a map (or run folder) of an earlier drive")
    nav.add_argument("--goal-sensor", choices=["gps", "start"], default="gps",
                     help="the goal relative to the robot every step (gps) or only at reset (start)")
    nav.add_argument("--episodes", type=_positive_int, default=20, help="episodes per world (default: 20)")
    nav.add_argument("--seed", type=int, default=0, help="first episode's seed (default: 0)")
    nav.add_argument("--max-steps", type=_positive_int, default=1500, help="steps per episode (default: 1500)")
    nav.add_argument("--num-envs", type=_positive_int, default=1,
                     help="run episodes in a gymnasium async vector env of this many copies (spawned processes)")
    _output_options(nav, "output folder (default: a new folder under runs/)")

    commands.add_parser("worlds", help="list the built-in worlds with their levels and routes",
                        description="List the built-in worlds with their floor levels and routes.")
    return parser


def _drive(args: argparse.Namespace) -> int:
    import sim  # the simulator is only needed here; importing it selects headless rendering

    from .frames import DriveStream

    slam, book = _slam_from(args)
    if args.load_map:
        slam.begin_session(start=args.start)
    world, route_name = _world_and_route(args)
    camera = _camera(args, panoramic=args.panoramic)
    drive = sim.ScriptedDrive(world, route=route_name, laps=args.laps, speed=args.speed,
                              camera_rate=args.camera_rate, max_frames=args.max_frames, seed=args.seed,
                              camera=camera, quality=args.quality)
    out = _output_folder(args, Path("runs") / f"drive-{world.name.replace(':', '_')}-{time.strftime('%Y%m%d-%H%M%S')}")
    result = _run_stream(DriveStream(drive), slam, book, args, out)
    if result is None:
        return 130
    summary = result.metrics()
    frames, times = result.frames, result.times
    rows = [
        ("world / route", f"{world.name} / {drive.route.name}"),
        ("frames", f"{frames} ({times[-1]:.1f} s simulated)"),
        ("laps", str(summary["laps"])),
        ("distance", f"{summary['distance_m']:.1f} m"),
        ("levels visited", f"{summary['levels_visited']} of {list(range(len(world.levels)))}"),
        ("height range", f"{summary['height_range_m'][0]:.2f} .. {summary['height_range_m'][1]:.2f} m"),
        ("map", f"{summary['templates']} templates, {summary['experiences']} experiences, "
                f"{summary['loop_closures']} loop closures ({summary['false_loop_closures']} false)"),
        ("ATE (Sim(3))", "SLAM {slam} (online {online}), {odometry} odometry {odometry_ate}".format(
            slam=_metres(summary["ate_rmse_m"]["slam"]), online=_metres(summary["ate_rmse_m"]["slam_online"]),
            odometry=args.odometry, odometry_ate=_metres(summary["ate_rmse_m"]["odometry"]))),
        ("map error", f"{_metres(summary['map_rmse_m'])} (experiences, Sim(3)); level accuracy "
                      + ("n/a" if summary["level_accuracy"] is None else f"{summary['level_accuracy']:.2f}")),
        ("ms per frame", "SLAM {slam:.2f}, physics {physics:.2f}, render {render:.2f}, total {total:.2f}".format(
            **summary["ms_per_frame"])),
        ("output", str(out)),
    ]
    if args.load_map:
        rows.insert(-3, ("sessions", f"{summary['merges']} merges at frames {summary['merge_frames']} "
                                     f"({summary['false_merges']} false); {summary['map_components']} separate maps"))
    _print_rows(rows)
    return 130 if result.interrupted else 0


# files that mark a folder as an earlier neuroslam run, recording, dataset or navigation experiment
_OUTPUT_MARKERS = ("metrics.json", "map.npz", "dataset.json", "frames", "groundtruth.tum", "run.rrd", "episodes.csv")


def _output_folder(args: argparse.Namespace, default: Path) -> Path:
    """The folder ``--out`` names (or ``default``), made ready to write into: a new or empty folder is used
    as it is; one that holds an earlier run or dataset is refused unless ``--overwrite``, which clears it;
    a file, or a folder of other files, is refused."""
    import shutil

    from ..errors import InvalidParameterError

    out = args.out or default
    if out.exists() and not out.is_dir():
        raise InvalidParameterError("--out", str(out), "is a file; name a folder")
    if out.is_dir() and any(out.iterdir()):
        if not any((out / name).exists() for name in _OUTPUT_MARKERS):
            raise InvalidParameterError("--out", str(out), "holds files neuroslam did not write; name another folder")
        if not args.overwrite:
            raise InvalidParameterError("--out", str(out), "holds an earlier run or dataset; add --overwrite to "
                                        "replace it, or name another folder")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def _run_stream(stream, slam, book, args: argparse.Namespace, out: Path):
    """The runner over ``stream`` with the options' odometry and recording; its outputs written into ``out``.
    Returns the :class:`~neuroslam.lab.runner.Run`, or None when Ctrl-C came before the first frame (then
    ``out`` is removed if it is empty)."""
    from .runner import run

    recorder = _recorder(args, out, stream.name)
    result = run(stream, slam, odometry=getattr(args, "odometry", "visual"), book=book, recorder=recorder)
    if result.frames == 0 and result.interrupted:
        if not any(out.iterdir()):
            out.rmdir()
        print("interrupted before the first frame: nothing written", file=sys.stderr)
        return None
    result.write(out)
    if result.interrupted:
        print(f"interrupted after {result.frames} frames: wrote what was done into {out}", file=sys.stderr)
    return result


def _print_rows(rows: list[tuple[str, str]]) -> None:
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")


def _camera_summary(config, image_size: tuple[int, int]) -> str:
    """The camera a configuration assumes, in words."""
    return (f"{config.odometry.camera_height:.2f} m above the floor, {config.odometry.camera_forward:.2f} m ahead of "
            f"the turning axis, {math.degrees(config.horizontal_fov):.0f} x {math.degrees(config.vertical_fov):.0f} "
            f"degree field of view, {image_size[0]}x{image_size[1]} pixels")


def _camera_config(config, args: argparse.Namespace, image_size: tuple[int, int]):
    """``config`` with the camera the options describe (``--camera-height``, ``--camera-forward``, ``--fov``)."""
    import dataclasses

    from ..errors import InvalidParameterError

    odometry = config.odometry
    if args.camera_height is not None:
        odometry = dataclasses.replace(odometry, camera_height=args.camera_height)
    if args.camera_forward is not None:
        odometry = dataclasses.replace(odometry, camera_forward=args.camera_forward)
    changes = {"odometry": odometry}
    if args.fov:
        if len(args.fov) > 2 or args.fov[0] > 360 or (len(args.fov) == 2 and args.fov[1] >= 180):
            raise InvalidParameterError("--fov", args.fov, "must be a horizontal field of view of at most 360 "
                                        "degrees and optionally a vertical one under 180")
        horizontal = math.radians(args.fov[0])
        width, height = image_size
        vertical = (math.radians(args.fov[1]) if len(args.fov) == 2
                    else 2 * math.atan(math.tan(horizontal / 2) * height / width) if horizontal < math.pi
                    else config.vertical_fov)
        changes.update(horizontal_fov=horizontal, vertical_fov=vertical)
    return config.replace(**changes)


def _slam_from(args: argparse.Namespace, camera_for: tuple[int, int] | None = None):
    """The NeuroSLAM the options ask for: a preset and config file, or the maps of earlier sessions; with
    ``camera_for`` (the frames' width and height, pixels) the camera options of ``run`` apply.

    Returns (slam, book): the :class:`~neuroslam.lab.runner.ExperienceTruth` of every loaded experience."""
    from .. import presets
    from ..config import load_config
    from ..errors import InvalidParameterError
    from ..slam import NeuroSLAM
    from .runner import ExperienceTruth, load_sessions

    maps = getattr(args, "load_map", [])
    if not maps:
        config = presets.get(args.preset or "sim")
        if args.config is not None:
            config = load_config(args.config, base=config)
        if args.integrator is not None:
            config = config.replace(integrator=args.integrator)
        if camera_for is not None:
            config = _camera_config(config, args, camera_for)
        slam = NeuroSLAM(config)
        return slam, ExperienceTruth(slam)
    camera = camera_for is not None and (args.camera_height is not None or args.camera_forward is not None
                                         or args.fov)
    if args.preset is not None or args.config is not None or args.integrator is not None or camera:
        raise InvalidParameterError("--load-map", str(maps[0]), "keeps the configuration its map was built with; "
                                    "leave out --preset, --config, --integrator and the camera options")
    return load_sessions(maps)


def _run(args: argparse.Namespace) -> int:
    """NeuroSLAM on a folder of recorded frames."""
    from .frames import FolderStream

    wheel_odometry = None
    if args.odometry != "visual":
        wheel_odometry = Path(args.frames) / "wheel_odometry.tum"
        if not wheel_odometry.is_file():
            from ..errors import InvalidParameterError

            raise InvalidParameterError("--odometry", args.odometry, f"needs {wheel_odometry}, which is missing")
    stream = FolderStream(args.frames, groundtruth=args.groundtruth, wheel_odometry=wheel_odometry,
                          levels=args.levels, rate=args.rate, max_frames=args.max_frames)
    slam, book = _slam_from(args, camera_for=stream.image_size)
    camera = _camera_summary(slam.config, stream.image_size)
    if not (args.camera_height or args.camera_forward is not None or args.fov or args.config or args.load_map):
        print(f"camera: assuming the testbed's: {camera} (--camera-height, --camera-forward and --fov "
              "describe yours)", file=sys.stderr)
    if args.load_map:
        slam.begin_session(start=args.start)
    name = Path(args.frames).resolve().name
    out = _output_folder(args, Path("runs") / f"run-{name}-{time.strftime('%Y%m%d-%H%M%S')}")
    result = _run_stream(stream, slam, book, args, out)
    if result is None:
        return 130
    metrics = result.metrics()
    truth, levels = result.truth, stream.levels
    rows = [("frames", str(result.frames)), ("camera", camera)]
    if truth is not None:
        rows.append(("distance", f"{metrics['distance_m']:.1f} m"))
    if result.true_levels is not None:
        rows.append(("levels visited", f"{metrics['levels_visited']} of {list(range(len(levels)))}"))
    false = "" if truth is None else f" ({metrics['false_loop_closures']} false)"
    rows.append(("map", f"{metrics['templates']} templates, {metrics['experiences']} experiences, "
                        f"{metrics['loop_closures']} loop closures{false}"))
    if truth is not None:
        rows.append(("ATE (Sim(3))", f"SLAM {_metres(metrics['ate_rmse_m']['slam'])} "
                                     f"(online {_metres(metrics['ate_rmse_m']['slam_online'])}), "
                                     f"{args.odometry} odometry {_metres(metrics['ate_rmse_m']['odometry'])}"))
        if metrics["level_accuracy"] is not None:
            rows.append(("level accuracy", f"{metrics['level_accuracy']:.2f}"))
    rows += [("ms per frame", "SLAM {slam:.2f}, reading images {read:.2f}, total {total:.2f}".format(
                 **metrics["ms_per_frame"])),
             ("output", str(out))]
    _print_rows(rows)
    return 130 if result.interrupted else 0


def _record(args: argparse.Namespace) -> int:
    """Save a drive as a dataset: frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum."""
    from PIL import Image
    from tqdm import tqdm

    import sim

    from ..datasets import DatasetDescription, write_description
    from ..tum import write_tum, yaw_quaternion
    from .frames import DriveStream

    world, route = _world_and_route(args)
    stream = DriveStream(sim.ScriptedDrive(world, route=route, laps=args.laps, speed=args.speed,
                                           max_frames=args.max_frames, seed=args.seed, camera=_camera(args)))
    out = _output_folder(args, args.out)
    (out / "frames").mkdir()
    times, truths, wheels = [], [], []
    with tqdm(total=int(stream.total), unit=stream.unit, desc=f"record {world.name}") as bar:
        for frame in stream:
            Image.fromarray(frame.image).save(out / "frames" / f"{frame.index:06d}.png")
            times.append(frame.time)
            truths.append(frame.truth)
            wheels.append(frame.wheels)
            bar.update(min(int(frame.progress), bar.total) - bar.n)
    times = np.array(times)
    write_tum(out / "groundtruth.tum", times, np.array([t.pose[:3] for t in truths]),
              np.array([t.quaternion for t in truths]))
    write_tum(out / "wheel_odometry.tum", times, np.array([[w.x, w.y, 0.0] for w in wheels]),
              yaw_quaternion(np.array([w.yaw for w in wheels])))
    write_description(out, DatasetDescription(world.name, stream.drive.route.name, tuple(world.levels)))
    _print_rows([("world / route", f"{world.name} / {stream.drive.route.name}"), ("frames", str(len(times))),
                 ("output", str(out))])
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    """Fit the visual-odometry gains on a calibration drive and write them as a config file."""
    import dataclasses

    from tqdm import tqdm

    import sim

    from ..errors import InvalidParameterError
    from ..geometry import wrap
    from ..vision.calibration import fit_odometry_gains
    from ..vision.odometry import VisualOdometry
    from ..vision.preprocessing import grey
    from .frames import DriveStream

    if args.out.is_dir() or (args.out.exists() and not args.overwrite):
        raise InvalidParameterError("--out", str(args.out), "is a folder; name a file" if args.out.is_dir()
                                    else "exists; add --overwrite to replace it, or name another file")
    base = _slam_from(args)[0].config
    # the raw row-shift pitch changes are NeuroSLAM eqs. 31-32's ("profile"), whose gains are fitted; the "transitions"
    # height (eqs. R1-R3) has none
    neutral = dataclasses.replace(base.odometry, speed_scale=1.0, yaw_scale=1.0, climb_scale=1.0,
                                  pitch_flow_bias=0.0, pitch_leak=0.0, max_speed=1e6, max_yaw_rate=1e6,
                                  max_climb_rate=1e6, height_model="profile")
    odometry = VisualOdometry(neutral, horizontal_fov=base.horizontal_fov, vertical_fov=base.vertical_fov,
                              panoramic=base.panoramic)
    world, route = _world_and_route(args)
    stream = DriveStream(sim.ScriptedDrive(world, route=route, laps=args.laps, speed=args.speed,
                                           max_frames=args.max_frames, seed=args.seed))
    rows = []
    previous = None
    with tqdm(total=int(stream.total), unit=stream.unit, desc=f"calibrate {world.name}") as bar:
        for frame in stream:
            dt = 0.0 if previous is None else frame.time - previous.time
            pitch_before = odometry.pitch
            motion = odometry.step(grey(frame.image), dt)
            truth = frame.truth
            if previous is not None:
                turn = wrap(float(truth.pose[3] - previous.truth.pose[3]))
                rows.append((dt, motion.forward_speed * dt, motion.yaw_rate, odometry.pitch - pitch_before,
                             float(np.hypot(*truth.velocity[:2])), turn / dt, truth.pose[2]))
            previous = frame
            bar.update(min(int(frame.progress), bar.total) - bar.n)
    table = np.array(rows)
    fit = fit_odometry_gains(dt=table[:, 0], raw_difference=table[:, 1], raw_yaw_rate=table[:, 2],
                             raw_pitch_change=table[:, 3], true_speed=table[:, 4], true_yaw_rate=table[:, 5],
                             true_height=table[:, 6])
    settings = fit.settings()["odometry"]
    profile_height = base.odometry.height_model == "profile"
    if not profile_height:
        settings = {key: settings[key] for key in ("speed_scale", "yaw_scale")}
    lines = [f"# visual-odometry gains fitted by neuroslam calibrate on {world.name} ({len(table)} frames)",
             "[odometry]"] + [f"{key} = {value!r}" for key, value in settings.items()]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    _print_rows([
        ("frames", str(len(table))),
        ("speed", f"scale {fit.speed_scale:.3f}, correlation {fit.speed_correlation:.2f}"),
        ("yaw", f"scale {fit.yaw_scale:.3f}, correlation {fit.yaw_correlation:.2f}"),
        ("height", ("" if profile_height
                    else "not written (height_model = transitions has no gains); NeuroSLAM eqs. 31-32: ")
         + f"climb gain {fit.climb_scale:.2f}, pitch bias {fit.pitch_flow_bias:.4f} rad/m, "
         f"leak {fit.pitch_leak:.2f}/s, height error {fit.height_rmse:.2f} m"),
        ("config", f"{args.out} (use with --config)"),
    ])
    return 0


def _world_and_route(args: argparse.Namespace):
    """The world and route name a command names (``--route`` may be a routes JSON file)."""
    import sim

    route, routes_file = args.route, None
    if route and route.endswith(".json"):
        route, routes_file = None, route
    return sim.load_world(args.world, routes=routes_file), route


def _metres(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f} m"


def _map_positions(path: Path) -> np.ndarray:
    """(N, 3) experience positions of a map.npz, a run's output folder (its map.npz, else experiences.tum),
    or an experiences.tum file."""
    from ..slam import MAP_FILE, NeuroSLAM
    from ..tum import read_tum

    if path.is_dir() and not (path / MAP_FILE).is_file() and (path / "experiences.tum").is_file():
        path = path / "experiences.tum"
    if path.suffix == ".tum":
        return read_tum(path)[1]
    return NeuroSLAM.load(path).experience_map.poses[:, :3].copy()


def _evaluate(args: argparse.Namespace) -> int:
    """Score an estimated trajectory against ground truth (``neuroslam eval``)."""
    from ..datasets import DatasetError, read_groundtruth
    from ..evaluation import associate, trajectory_errors

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
    _print_rows([("pairs", f"{scores['pairs']} of {scores['estimate_poses']} estimated poses "
                           f"(within {args.max_difference} s of the truth)"),
                 ("ATE (Sim(3))", _metres(scores["ate_rmse_m"])), ("ATE (SE(3))", _metres(scores["ate_se3_rmse_m"])),
                 ("RPE (10 m)", _metres(scores["rpe_rmse_m"]))])
    return 0


def _compare_maps(args: argparse.Namespace) -> int:
    """The RMSE between two experience maps after ICP (:mod:`neuroslam.evaluation.registration`)."""
    from ..errors import InvalidInputError
    from ..evaluation.registration import compare_maps

    a, b = _map_positions(args.a), _map_positions(args.b)
    for name, points in (("a", a), ("b", b)):
        if len(points) < 3:
            raise InvalidInputError(f"map {name}", f"with {len(points)} experiences", "needs at least 3")
    result = compare_maps(a, b)
    if args.json:
        print(json.dumps(result.as_dict(), indent=2))
        return 0
    _print_rows([
        ("maps", f"A {args.a} ({len(a)} experiences) onto B {args.b} ({len(b)} experiences)"),
        ("RMSE", f"{result.rmse_m:.3f} m over inliers ({100 * result.inlier_fraction:.1f} % of A), "
                 f"{result.rmse_all_m:.3f} m over all pairs"),
        ("transform", "yaw {:.2f} deg, shift ({:.2f}, {:.2f}, {:.2f}) m".format(math.degrees(result.yaw),
                                                                               *result.translation)),
        ("iterations", str(result.iterations)),
    ])
    return 0


def _sweep(args: argparse.Namespace) -> int:
    """Drives as Ray tasks (:mod:`neuroslam.lab.sweep`); exit code 1 if any drive failed."""
    from .sweep import expand_worlds, parse_grid, run_sweep, summary

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


def _nav(args: argparse.Namespace) -> int:
    """Navigation episodes (:mod:`neuroslam.lab.nav`)."""
    from tqdm import tqdm

    import sim
    from sim.navigation import DrivableGraph

    from ..errors import InvalidParameterError
    from .nav import load_agent, run_episode, run_episodes_vector, write_episodes, write_summary

    load_agent(args.agent)  # an unknown agent fails before any episode
    if args.load_map is not None and args.pose != "slam":
        raise InvalidParameterError("--load-map", str(args.load_map), "is used with --pose slam only")
    worlds = {name: sim.load_world(name) for name in args.worlds}  # bad worlds and maps fail before any episode
    if args.load_map is not None:
        from ..slam import NeuroSLAM

        NeuroSLAM.load(args.load_map)
    out = _output_folder(args, Path("runs") / f"nav-{time.strftime('%Y%m%d-%H%M%S')}")
    episodes = []
    with tqdm(total=len(args.worlds) * args.episodes, unit="episode", desc="nav") as bar:
        for name in args.worlds:
            world = worlds[name]
            graph = DrivableGraph(world)
            seeds = [args.seed + k for k in range(args.episodes)]
            if args.num_envs > 1:
                episodes += run_episodes_vector(name, seeds, args.agent, args.pose, graph=graph, world=world,
                                                num_envs=args.num_envs, goal_sensor=args.goal_sensor,
                                                load_map=args.load_map, max_steps=args.max_steps, progress=bar)
                continue
            for seed in seeds:
                episodes.append(run_episode(name, seed, args.agent, args.pose, graph=graph,
                                            goal_sensor=args.goal_sensor, load_map=args.load_map,
                                            max_steps=args.max_steps))
                bar.update()
    write_episodes(out / "episodes.csv", episodes)
    summary = write_summary(out / "summary.json", episodes)
    for setting in summary["settings"]:
        print(f"{setting['world']:<10} {setting['agent']:<8} {setting['pose']:<12} {setting['episodes']:>3} episodes: "
              f"success {setting['success_rate']:.2f}, SPL {setting['spl']:.2f}")
    print(f"output: {out}")
    return 0


def _worlds(_: argparse.Namespace) -> int:
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


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``neuroslam`` console script; returns the exit code."""
    args = _parser().parse_args(argv)
    handlers = {"drive": _drive, "run": _run, "record": _record, "calibrate": _calibrate, "worlds": _worlds,
                "compare-maps": _compare_maps, "eval": _evaluate, "sweep": _sweep, "nav": _nav}
    try:
        return handlers[args.command](args)
    except KeyboardInterrupt:
        print("neuroslam: interrupted", file=sys.stderr)
        return 130
    except Exception as error:
        if not _is_user_error(error):
            raise
        print(f"neuroslam {args.command}: error: {error}", file=sys.stderr)
        return 2


def _is_user_error(error: Exception) -> bool:
    """True for errors caused by the user's input (typed library errors, unreadable files), not bugs."""
    from ..errors import NeuroSLAMError

    simulator = sys.modules.get("sim")
    return isinstance(error, (OSError, NeuroSLAMError)) or (
        simulator is not None and isinstance(error, simulator.SimError))


if __name__ == "__main__":
    sys.exit(main())
