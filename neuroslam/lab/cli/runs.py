"""The commands that run NeuroSLAM or drive the testbed: drive, run, record, calibrate."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

from .options import make_recorder, metres, print_rows, simulated_camera


def drive_command(args: argparse.Namespace) -> int:
    import sim  # the simulator is only needed here; importing it selects headless rendering

    from ..frames import DriveStream

    slam, book = slam_from(args)
    if args.load_map:
        slam.begin_session(start=args.start)
    world, route_name = world_and_route(args)
    camera = simulated_camera(args, panoramic=args.panoramic)
    drive = sim.ScriptedDrive(world, route=route_name, laps=args.laps, speed=args.speed,
                              camera_rate=args.camera_rate, max_frames=args.max_frames, seed=args.seed,
                              camera=camera, quality=args.quality)
    out = output_folder(args, Path("runs") / f"drive-{world.name.replace(':', '_')}-{time.strftime('%Y%m%d-%H%M%S')}")
    result = run_stream(DriveStream(drive), slam, book, args, out)
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
            slam=metres(summary["ate_rmse_m"]["slam"]), online=metres(summary["ate_rmse_m"]["slam_online"]),
            odometry=args.odometry, odometry_ate=metres(summary["ate_rmse_m"]["odometry"]))),
        ("map error", f"{metres(summary['map_rmse_m'])} (experiences, Sim(3)); level accuracy "
                      + ("n/a" if summary["level_accuracy"] is None else f"{summary['level_accuracy']:.2f}")),
        ("ms per frame", "SLAM {slam:.2f}, physics {physics:.2f}, render {render:.2f}, total {total:.2f}".format(
            **summary["ms_per_frame"])),
        ("output", str(out)),
    ]
    if args.load_map:
        rows.insert(-3, ("sessions", f"{summary['merges']} merges at frames {summary['merge_frames']} "
                                     f"({summary['false_merges']} false); {summary['map_components']} separate maps"))
    print_rows(rows)
    return 130 if result.interrupted else 0


# files that mark a folder as an earlier neuroslam run, recording, dataset or navigation experiment
OUTPUT_MARKERS = ("metrics.json", "map.npz", "dataset.json", "frames", "groundtruth.tum", "run.rrd", "episodes.csv")


def output_folder(args: argparse.Namespace, default: Path) -> Path:
    """The folder ``--out`` names (or ``default``), made ready to write into: a new or empty folder is used
    as it is; one that holds an earlier run or dataset is refused unless ``--overwrite``, which clears it;
    a file, or a folder of other files, is refused."""
    import shutil

    from ...errors import InvalidParameterError

    out = args.out or default
    if out.exists() and not out.is_dir():
        raise InvalidParameterError("--out", str(out), "is a file; name a folder")
    if out.is_dir() and any(out.iterdir()):
        if not any((out / name).exists() for name in OUTPUT_MARKERS):
            raise InvalidParameterError("--out", str(out), "holds files neuroslam did not write; name another folder")
        if not args.overwrite:
            raise InvalidParameterError("--out", str(out), "holds an earlier run or dataset; add --overwrite to "
                                        "replace it, or name another folder")
        shutil.rmtree(out)
    out.mkdir(parents=True, exist_ok=True)
    return out


def run_stream(stream, slam, book, args: argparse.Namespace, out: Path):
    """The runner over ``stream`` with the options' odometry and recording; its outputs written into ``out``.
    Returns the :class:`~neuroslam.lab.runner.Run`, or None when Ctrl-C came before the first frame (then
    ``out`` is removed if it is empty)."""
    from ..runner import run

    recorder = make_recorder(args, out, stream.name)
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


def camera_summary(config, image_size: tuple[int, int]) -> str:
    """The camera a configuration assumes, in words."""
    return (f"{config.odometry.camera_height:.2f} m above the floor, {config.odometry.camera_forward:.2f} m ahead of "
            f"the turning axis, {math.degrees(config.horizontal_fov):.0f} x {math.degrees(config.vertical_fov):.0f} "
            f"degree field of view, {image_size[0]}x{image_size[1]} pixels")


def camera_config(config, args: argparse.Namespace, image_size: tuple[int, int]):
    """``config`` with the camera the options describe (``--camera-height``, ``--camera-forward``, ``--fov``)."""
    import dataclasses

    from ...errors import InvalidParameterError

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


def slam_from(args: argparse.Namespace, camera_for: tuple[int, int] | None = None):
    """The NeuroSLAM the options ask for: a preset and config file, or the maps of earlier sessions; with
    ``camera_for`` (the frames' width and height, pixels) the camera options of ``run`` apply.

    Returns (slam, book): the :class:`~neuroslam.lab.runner.ExperienceTruth` of every loaded experience."""
    from ... import presets
    from ...config import load_config
    from ...errors import InvalidParameterError
    from ...slam import NeuroSLAM
    from ..runner import ExperienceTruth, load_sessions

    maps = getattr(args, "load_map", [])
    if not maps:
        config = presets.get(args.preset or "sim")
        if args.config is not None:
            config = load_config(args.config, base=config)
        if args.integrator is not None:
            config = config.replace(integrator=args.integrator)
        if camera_for is not None:
            config = camera_config(config, args, camera_for)
        slam = NeuroSLAM(config)
        return slam, ExperienceTruth(slam)
    camera = camera_for is not None and (args.camera_height is not None or args.camera_forward is not None
                                         or args.fov)
    if args.preset is not None or args.config is not None or args.integrator is not None or camera:
        raise InvalidParameterError("--load-map", str(maps[0]), "keeps the configuration its map was built with; "
                                    "leave out --preset, --config, --integrator and the camera options")
    return load_sessions(maps)


def run_command(args: argparse.Namespace) -> int:
    """NeuroSLAM on a folder of recorded frames."""
    from ..frames import FolderStream

    wheel_odometry = None
    if args.odometry != "visual":
        wheel_odometry = Path(args.frames) / "wheel_odometry.tum"
        if not wheel_odometry.is_file():
            from ...errors import InvalidParameterError

            raise InvalidParameterError("--odometry", args.odometry, f"needs {wheel_odometry}, which is missing")
    stream = FolderStream(args.frames, groundtruth=args.groundtruth, wheel_odometry=wheel_odometry,
                          levels=args.levels, rate=args.rate, max_frames=args.max_frames)
    slam, book = slam_from(args, camera_for=stream.image_size)
    camera = camera_summary(slam.config, stream.image_size)
    if not (args.camera_height or args.camera_forward is not None or args.fov or args.config or args.load_map):
        print(f"camera: assuming the testbed's: {camera} (--camera-height, --camera-forward and --fov "
              "describe yours)", file=sys.stderr)
    if args.load_map:
        slam.begin_session(start=args.start)
    name = Path(args.frames).resolve().name
    out = output_folder(args, Path("runs") / f"run-{name}-{time.strftime('%Y%m%d-%H%M%S')}")
    result = run_stream(stream, slam, book, args, out)
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
        rows.append(("ATE (Sim(3))", f"SLAM {metres(metrics['ate_rmse_m']['slam'])} "
                                     f"(online {metres(metrics['ate_rmse_m']['slam_online'])}), "
                                     f"{args.odometry} odometry {metres(metrics['ate_rmse_m']['odometry'])}"))
        if metrics["level_accuracy"] is not None:
            rows.append(("level accuracy", f"{metrics['level_accuracy']:.2f}"))
    rows += [("ms per frame", "SLAM {slam:.2f}, reading images {read:.2f}, total {total:.2f}".format(
                 **metrics["ms_per_frame"])),
             ("output", str(out))]
    print_rows(rows)
    return 130 if result.interrupted else 0


def record_command(args: argparse.Namespace) -> int:
    """Save a drive as a dataset: frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum."""
    from PIL import Image
    from tqdm import tqdm

    import sim

    from ...datasets import DatasetDescription, write_description
    from ...tum import write_tum, yaw_quaternion
    from ..frames import DriveStream

    world, route = world_and_route(args)
    stream = DriveStream(sim.ScriptedDrive(world, route=route, laps=args.laps, speed=args.speed,
                                           max_frames=args.max_frames, seed=args.seed, camera=simulated_camera(args)))
    out = output_folder(args, args.out)
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
    print_rows([("world / route", f"{world.name} / {stream.drive.route.name}"), ("frames", str(len(times))),
                 ("output", str(out))])
    return 0


def calibrate_command(args: argparse.Namespace) -> int:
    """Fit the visual-odometry gains on a calibration drive and write them as a config file."""
    import dataclasses

    from tqdm import tqdm

    import sim

    from ...errors import InvalidParameterError
    from ...geometry import wrap
    from ...vision.calibration import fit_odometry_gains
    from ...vision.odometry import VisualOdometry
    from ...vision.preprocessing import grey
    from ..frames import DriveStream

    if args.out.is_dir() or (args.out.exists() and not args.overwrite):
        raise InvalidParameterError("--out", str(args.out), "is a folder; name a file" if args.out.is_dir()
                                    else "exists; add --overwrite to replace it, or name another file")
    base = slam_from(args)[0].config
    # the raw row-shift pitch changes are NeuroSLAM eqs. 31-32's ("profile"), whose gains are fitted; the "transitions"
    # height (eqs. R1-R3) has none
    neutral = dataclasses.replace(base.odometry, speed_scale=1.0, yaw_scale=1.0, climb_scale=1.0,
                                  pitch_flow_bias=0.0, pitch_leak=0.0, max_speed=1e6, max_yaw_rate=1e6,
                                  max_climb_rate=1e6, height_model="profile")
    odometry = VisualOdometry(neutral, horizontal_fov=base.horizontal_fov, vertical_fov=base.vertical_fov,
                              panoramic=base.panoramic)
    world, route = world_and_route(args)
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
    print_rows([
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


def world_and_route(args: argparse.Namespace):
    """The world and route name a command names (``--route`` may be a routes JSON file)."""
    import sim

    route, routes_file = args.route, None
    if route and route.endswith(".json"):
        route, routes_file = None, route
    return sim.load_world(args.world, routes=routes_file), route
