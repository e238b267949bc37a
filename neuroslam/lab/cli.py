"""The ``neuroslam`` command line.

Commands:
    drive   drive a route in a simulated world with NeuroSLAM in the loop; write trajectories and metrics
    run     run NeuroSLAM on a folder of recorded frames (with optional ground truth)
    record  save a simulated drive as such a folder
    calibrate  fit the visual-odometry gains to ground truth and write a config file
    worlds  list the built-in worlds with their levels and routes
    compare-maps  the RMSE between two experience maps after ICP registration
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
    parser.add_argument("--integrator", choices=["odometry", "grid-network"],
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


def _record_option(parser: argparse.ArgumentParser) -> None:
    """The ``--record`` option of the commands that run NeuroSLAM."""
    parser.add_argument("--record", action="store_true",
                        help="also write run.rrd into the output folder, a rerun recording of the run (camera, "
                        "trajectories, experience map, cell activity, ids and error over time); open it with "
                        "'rerun run.rrd'; needs: pip install \"neuroslam[record]\"")


def _recorder(args: argparse.Namespace, out: Path, name: str):
    """A :class:`~neuroslam.lab.recording.RunRecorder` writing ``out/run.rrd`` if ``--record`` was given, else None."""
    if not args.record:
        return None
    from .recording import RunRecorder

    return RunRecorder(out / "run.rrd", name=name)


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="neuroslam",
        description="NeuroSLAM, brain-inspired 4-DoF SLAM, and its multi-level MuJoCo testbed.",
    )
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
    drive.add_argument("--quality", choices=["fast", "high"], default="fast", help="visual profile (default: fast)")
    _slam_options(drive, sessions=True)
    drive.add_argument("--odometry", choices=["visual", "wheel", "visual-inertial"], default="visual",
                       help="self-motion from the camera (visual odometry), from the wheel encoders with the "
                       "camera's pitch for the height rate, or from the camera with the height rate from the IMU's "
                       "gravity direction (visual-inertial; not the paper's) (default: visual)")
    drive.add_argument("--out", type=Path, help="output folder (default: a new folder under runs/)")
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
    run.add_argument("--out", type=Path, help="output folder (default: a new folder under runs/)")
    _record_option(run)

    record = commands.add_parser(
        "record", help="save a simulated drive as a dataset of frames and ground truth",
        description="Drive a route and save frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum and "
        "dataset.json (world, route and floor heights), a dataset that neuroslam run (or any other SLAM system) "
        "can replay.")
    record.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    _drive_options(record, laps=1, camera=True)
    record.add_argument("--out", type=Path, required=True, help="dataset folder to write")

    calibrate = commands.add_parser(
        "calibrate", help="fit the visual-odometry gains to ground truth and write a config file",
        description="Drive a calibration route, compare the visual odometry's raw measurements with ground truth, "
        "fit its gains (speed and yaw scale by least squares; the height pipeline of eqs. 31-32 by the least height "
        "error, written only with height_model = profile: the default transitions height has no gains) and "
        "write them as a TOML config file usable with --config.")
    calibrate.add_argument("world", help="built-in world name, gen:SEED, or an MJCF file")
    _drive_options(calibrate, laps=1, camera=False)
    _slam_options(calibrate)
    calibrate.add_argument("--out", type=Path, required=True, help="TOML file to write")

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
    sweep.add_argument("--odometry", choices=["visual", "wheel", "visual-inertial"], default="visual",
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
    nav.add_argument("--out", type=Path, help="output folder (default: a new folder under runs/)")

    commands.add_parser("worlds", help="list the built-in worlds with their levels and routes",
                        description="List the built-in worlds with their floor levels and routes.")
    return parser


def _drive(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    import sim  # the simulator is only needed here; importing it selects headless rendering

    from ..evaluation import observation_shares, run_metrics
    from ..inertial import GravityPitch
    from ..tum import write_tum, yaw_quaternion
    from ..vision.odometry import Observed, SelfMotion
    from ..vision.preprocessing import grey

    slam, book = _slam_from(args)
    if args.load_map:
        slam.begin_session(start=args.start)
    gravity = GravityPitch()

    world, route_name = _world_and_route(args)
    camera = _camera(args, panoramic=args.panoramic)
    drive = sim.ScriptedDrive(world, route=route_name, laps=args.laps, speed=args.speed,
                              camera_rate=args.camera_rate, max_frames=args.max_frames, seed=args.seed,
                              camera=camera, quality=args.quality)
    out = args.out or Path("runs") / f"drive-{world.name.replace(':', '_')}-{time.strftime('%Y%m%d-%H%M%S')}"
    out.mkdir(parents=True, exist_ok=True)
    recorder = _recorder(args, out, f"{world.name}/{drive.route.name}")
    times, truths, odometry, estimates, self_motion, active, observed = [], [], [], [], [], [], []
    closures, merges = [], []  # (frame, true pose and level where the re-entered / merged-at experience was made)
    slam_seconds = 0.0
    previous_time = None
    started = time.perf_counter()
    with tqdm(total=int(drive.total_distance), unit="m", desc=f"{world.name}/{drive.route.name}") as bar:
        for frame in drive:
            slam_started = time.perf_counter()
            motion = None
            dt = 0.0 if previous_time is None else frame.time - previous_time
            if args.odometry == "visual-inertial":  # the camera for speed and turn; the IMU for the pitch
                visual = slam.visual_odometry.step(grey(frame.image), dt)
                pitch = gravity.step(frame.imu.accelerometer, dt)
                seen = None if visual.observed is None else Observed(visual.observed.distance, visual.observed.yaw)
                motion = SelfMotion(visual.forward_speed, visual.yaw_rate, visual.forward_speed * math.sin(pitch), seen)
            elif args.odometry == "wheel":  # encoders for speed and turn; the camera for the pitch
                visual = slam.visual_odometry.step(grey(frame.image), dt)
                seen = None if visual.observed is None else Observed(height=visual.observed.height)
                speed = frame.odometry.forward_speed
                motion = SelfMotion(speed, frame.odometry.yaw_rate, slam.visual_odometry.climb_rate_at(speed), seen)
            estimate = slam.step(frame.image, frame.time, odometry=motion)
            slam_seconds += time.perf_counter() - slam_started
            previous_time = frame.time
            times.append(frame.time)
            truths.append(frame.ground_truth)
            book.add_frame(frame.time, frame.ground_truth.pose, frame.ground_truth.level)
            odometry.append(frame.odometry)
            estimates.append(estimate.pose)
            active.append((estimate.template_id, estimate.experience_id))
            observed.append(estimate.self_motion.observed)
            _note_events(estimate, len(times) - 1, book, closures, merges)
            self_motion.append(slam.odometry_pose)
            if recorder is not None:
                recorder.log_frame(frame.time, frame.image, slam, estimate, frame.ground_truth.pose)
            bar.update(min(int(frame.progress), bar.total) - bar.n)
    if recorder is not None:
        recorder.close()
    elapsed = time.perf_counter() - started
    times = np.array(times)
    positions = np.array([t.position for t in truths])
    write_tum(out / "groundtruth.tum", times, positions, np.array([t.quaternion for t in truths]))
    write_tum(out / "wheel_odometry.tum", times, np.array([[o.x, o.y, 0.0] for o in odometry]),
              yaw_quaternion(np.array([o.yaw for o in odometry])))
    online, self_motion = np.array(estimates), np.array(self_motion)
    estimates = slam.trajectory()
    _write_slam(out, times, estimates, online, self_motion, slam)
    experience_map = slam.experience_map
    frames = len(times)
    true_levels = np.array([t.level for t in truths])
    scores = run_metrics(
        truth=np.array([t.pose for t in truths]), true_levels=true_levels, levels=np.array(world.levels),
        estimate=estimates, odometry=self_motion, online_estimate=online,
        **_event_arguments(slam, book, closures, merges if args.load_map else None))
    _save_map(slam, out, book, {"world": world.name, "route": drive.route.name})
    summary = {
        "world": world.name,
        "route": drive.route.name,
        "frames": frames,
        "laps": drive.laps_completed,
        **_path_summary(positions, true_levels, world.levels),
        "odometry": args.odometry,
        "templates": slam.local_view.count,
        "experiences": experience_map.size,
        "map_components": len(np.unique(experience_map.components)),
        **scores,
        **observation_shares(observed),
        "ms_per_frame": {
            "slam": 1000 * slam_seconds / frames,
            "physics": 1000 * drive.timings["physics"] / frames,
            "render": 1000 * drive.timings["render"] / frames,
            "total": 1000 * elapsed / frames,
        },
    }
    (out / "metrics.json").write_text(json.dumps(summary, indent=2) + "\n")
    _report(out / "report.png", f"{world.name} / {drive.route.name}: {args.odometry} odometry", times,
            np.array([t.pose for t in truths]), estimates, self_motion, slam, np.array(active))
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
    return 0


def _path_summary(positions: np.ndarray | None, true_levels: np.ndarray | None, levels) -> dict:
    """metrics.json's ``distance_m``, ``levels``, ``levels_visited`` and ``height_range_m`` of a run's true
    positions (N × 3, m; None when unknown, and then those keys are None but ``levels``)."""
    known = positions is not None
    return {"distance_m": float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1))) if known else None,
            "levels": None if levels is None else list(levels),
            "levels_visited": None if true_levels is None else sorted({int(level) for level in true_levels}),
            "height_range_m": [float(positions[:, 2].min()), float(positions[:, 2].max())] if known else None}


def _write_slam(out: Path, times: np.ndarray, estimates: np.ndarray, online: np.ndarray, self_motion: np.ndarray,
                slam) -> None:
    """slam.tum (every frame in the final map), slam_online.tum (the estimate as it was at each frame),
    odometry.tum and experiences.tum of a run."""
    from ..tum import write_tum, yaw_quaternion

    write_tum(out / "slam.tum", times, estimates[:, :3], yaw_quaternion(estimates[:, 3]))
    write_tum(out / "slam_online.tum", times, online[:, :3], yaw_quaternion(online[:, 3]))
    write_tum(out / "odometry.tum", times, self_motion[:, :3], yaw_quaternion(self_motion[:, 3]))
    experience_map = slam.experience_map
    write_tum(out / "experiences.tum", experience_map.creation_times, experience_map.poses[:, :3],
              yaw_quaternion(experience_map.poses[:, 3]))


def _note_events(estimate, frame: int, book: _Truths, closures: list, merges: list) -> None:
    """Keep a frame's loop closure or merge with the ground truth of the experience it joined (looked up now:
    a later merge may renumber the experiences)."""
    for happened, events in ((estimate.loop_closure, closures), (estimate.merged, merges)):
        if happened:
            poses, levels = book.of([estimate.experience_id])
            events.append((frame, poses[0, :3], levels[0]))


def _event_arguments(slam, book: _Truths, closures: list, merges: list | None) -> dict:
    """The map, loop-closure and merge arguments of :func:`~neuroslam.evaluation.run_metrics`. The map scored
    is the robot's (after merges, the merged map); loaded maps it never met are separate maps in frames of
    their own, so they are left out (``map_components`` in metrics.json counts them)."""
    themap = slam.experience_map
    mine = np.flatnonzero(themap.components == themap.component)
    experience_truth, experience_levels = book.of(mine)

    def columns(events: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return (np.array([frame for frame, _, _ in events], dtype=int),
                np.array([pose for _, pose, _ in events]).reshape(-1, 3),
                np.array([level for _, _, level in events], dtype=int))

    closure_frames, closure_truth, closure_levels = columns(closures)
    arguments = {"experience_positions": themap.poses[mine, :3], "experience_truth": experience_truth[:, :3],
                 "experience_levels": experience_levels, "closure_frames": closure_frames,
                 "closure_truth": closure_truth, "closure_levels": closure_levels}
    if merges is not None:
        arguments["merge_frames"], arguments["merge_truth"], arguments["merge_levels"] = columns(merges)
    return arguments


def _save_map(slam, out: Path, book: _Truths, metadata: dict) -> None:
    """out/map.npz, the final map, with each experience's true pose and level where it was made
    (``experience_truth``, ``experience_levels``; NaN and -1 where unknown), so that later sessions which
    load the map can score the merged map."""
    from ..slam import MAP_FILE

    poses, levels = book.of(np.arange(slam.experience_map.size))
    slam.save(out / MAP_FILE, extra={"experience_truth": poses, "experience_levels": levels}, metadata=metadata)


def _report(path: Path, title: str, times: np.ndarray, truth: np.ndarray | None, estimates: np.ndarray,
            self_motion: np.ndarray, slam, active: np.ndarray) -> None:
    """report.png of a run."""
    from .plots import plot_report

    experience_map = slam.experience_map
    plot_report(truth=truth, odometry=self_motion, estimate=estimates, experiences=experience_map.poses,
                experience_frames=np.searchsorted(times, experience_map.creation_times), links=experience_map.links,
                template_ids=active[:, 0], experience_ids=active[:, 1], times=times, title=title, path=path)


def _print_rows(rows: list[tuple[str, str]]) -> None:
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")


def _slam_from(args: argparse.Namespace):
    """The NeuroSLAM the options ask for: a preset and config file, or the maps of earlier sessions.

    Returns (slam, truths): the :class:`_Truths` book of every experience's ground truth."""
    from .. import presets
    from ..config import load_config
    from ..errors import InvalidParameterError
    from ..slam import NeuroSLAM

    maps = getattr(args, "load_map", [])
    if not maps:
        config = presets.get(args.preset or "sim")
        if args.config is not None:
            config = load_config(args.config, base=config)
        if args.integrator is not None:
            config = config.replace(integrator=args.integrator)
        slam = NeuroSLAM(config)
        return slam, _Truths(slam, np.zeros((0, 4)), np.zeros(0, dtype=int))
    if args.preset is not None or args.config is not None or args.integrator is not None:
        raise InvalidParameterError("--load-map", str(maps[0]), "keeps the configuration its map was built with; "
                                    "leave out --preset, --config and --integrator")
    slam, poses, levels = None, [], []
    for path in maps:
        loaded = NeuroSLAM.load(path)
        size = loaded.experience_map.size
        poses.append(loaded.map_extra.get("experience_truth", np.full((size, 4), np.nan)))
        levels.append(loaded.map_extra.get("experience_levels", np.full(size, -1)))
        if slam is None:
            slam = loaded
        else:
            slam.add_map(loaded)
    return slam, _Truths(slam, np.concatenate(poses), np.concatenate(levels))


class _Truths:
    """The ground truth of every experience, across sessions: this session's from its frames, the loaded
    maps' from the truth saved with them (``experience_truth`` and ``experience_levels`` in the map file;
    NaN and -1 when a map was saved without ground truth). An experience is identified by (session,
    creation time), which survives merges and fusions; ``loaded_poses``/``loaded_levels`` are in the order
    of the loaded experiences."""

    def __init__(self, slam, loaded_poses: np.ndarray, loaded_levels: np.ndarray):
        self.slam = slam
        themap = slam.experience_map
        self.loaded = {(int(session), float(time)): (np.asarray(pose, dtype=float), int(level))
                       for session, time, pose, level in zip(themap.sessions, themap.creation_times, loaded_poses,
                                                             loaded_levels, strict=True)}
        self.times: list[float] = []
        self.poses: list[np.ndarray] = []
        self.levels: list[int] = []

    def add_frame(self, time: float, pose: np.ndarray | None, level: int = -1) -> None:
        """This session's next frame: its time, true pose (None if unknown) and level."""
        self.times.append(time)
        self.poses.append(np.full(4, np.nan) if pose is None else np.asarray(pose, dtype=float))
        self.levels.append(level)

    def of(self, experiences) -> tuple[np.ndarray, np.ndarray]:
        """(K, 4) true poses and (K,) true levels where the given experiences were made."""
        themap = self.slam.experience_map
        poses, levels = [], []
        for experience in np.asarray(experiences, dtype=int).reshape(-1):
            session, time = int(themap.sessions[experience]), float(themap.creation_times[experience])
            if session == themap.session and self.times:
                frame = min(int(np.searchsorted(self.times, time)), len(self.times) - 1)
                pose, level = self.poses[frame], self.levels[frame]
            else:
                pose, level = self.loaded.get((session, time), (np.full(4, np.nan), -1))
            poses.append(pose)
            levels.append(level)
        return np.array(poses).reshape(-1, 4), np.array(levels, dtype=int)


def _run(args: argparse.Namespace) -> int:
    """NeuroSLAM on a folder of recorded frames."""
    from tqdm import tqdm

    from ..datasets import (
        DatasetError,
        check_frame_sizes,
        check_levels,
        frame_times,
        list_frames,
        load_frame,
        read_description,
        read_groundtruth,
    )
    from ..evaluation import nearest_level, observation_shares, run_metrics

    frames = list_frames(args.frames)
    description = read_description(args.frames)
    levels = check_levels(args.levels, "--levels") if args.levels is not None else description.levels
    groundtruth = read_groundtruth(args.groundtruth) if args.groundtruth is not None else None
    if groundtruth is not None and len(groundtruth.positions) != len(frames):
        raise DatasetError(f"ground truth {str(args.groundtruth)!r}: {len(groundtruth.positions)} rows for "
                           f"{len(frames)} frames (one row per frame)")
    if args.max_frames is not None:
        frames = frames[: args.max_frames]
    check_frame_sizes(frames)
    if groundtruth is not None:
        groundtruth = type(groundtruth)(groundtruth.positions[: len(frames)], groundtruth.yaw[: len(frames)],
                                        None if groundtruth.times is None else groundtruth.times[: len(frames)])
    times = frame_times(len(frames), groundtruth, args.rate)
    slam, book = _slam_from(args)
    if args.load_map:
        slam.begin_session(start=args.start)
    out = args.out or Path("runs") / f"run-{Path(args.frames).resolve().name}-{time.strftime('%Y%m%d-%H%M%S')}"
    out.mkdir(parents=True, exist_ok=True)
    recorder = _recorder(args, out, Path(args.frames).resolve().name)
    truth = None if groundtruth is None else groundtruth.poses
    # each frame's floor: the level nearest the true height, as the simulator gives it (sim.World.level_of)
    true_levels = None if truth is None or levels is None else nearest_level(truth[:, 2], levels)
    estimates, self_motion, closures, merges, active, observed = [], [], [], [], [], []
    started = time.perf_counter()
    slam_seconds = 0.0
    for index, path in enumerate(tqdm(frames, unit="frame", desc=Path(args.frames).name)):
        image = load_frame(path)
        slam_started = time.perf_counter()
        estimate = slam.step(image, float(times[index]))
        slam_seconds += time.perf_counter() - slam_started
        book.add_frame(float(times[index]), None if truth is None else truth[index],
                       -1 if true_levels is None else int(true_levels[index]))
        if recorder is not None:
            recorder.log_frame(float(times[index]), image, slam, estimate, None if truth is None else truth[index])
        estimates.append(estimate.pose)
        active.append((estimate.template_id, estimate.experience_id))
        observed.append(estimate.self_motion.observed)
        self_motion.append(slam.odometry_pose)
        _note_events(estimate, index, book, closures, merges)
    if recorder is not None:
        recorder.close()
    elapsed = time.perf_counter() - started
    online, self_motion = np.array(estimates), np.array(self_motion)
    estimates = slam.trajectory()
    _write_slam(out, times, estimates, online, self_motion, slam)
    _save_map(slam, out, book, {"frames": str(Path(args.frames).resolve())})
    experience_map = slam.experience_map
    positions = None if groundtruth is None else groundtruth.positions
    metrics = {"world": description.world or Path(args.frames).resolve().name, "route": description.route,
               "frames": len(frames),
               **_path_summary(positions, true_levels, levels),
               "odometry": "visual", "templates": slam.local_view.count, "experiences": experience_map.size,
               "map_components": len(np.unique(experience_map.components)),
               "loop_closures": experience_map.loop_closures}
    if args.load_map:
        metrics.update(merges=len(slam.merges), merge_frames=[frame for frame, _ in slam.merges])
    if groundtruth is not None:
        metrics.update(run_metrics(
            truth=groundtruth.poses, true_levels=true_levels, levels=None if levels is None else np.array(levels),
            estimate=estimates, odometry=self_motion, online_estimate=online,
            **_event_arguments(slam, book, closures, merges if args.load_map else None)))
    metrics.update(observation_shares(observed))
    # recorded frames: no physics and no rendering; "read" is decoding the image files
    metrics["ms_per_frame"] = {"slam": 1000 * slam_seconds / len(frames), "physics": None, "render": None,
                               "read": 1000 * (elapsed - slam_seconds) / len(frames),
                               "total": 1000 * elapsed / len(frames)}
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    _report(out / "report.png", Path(args.frames).name, times, None if groundtruth is None else groundtruth.poses,
            estimates, self_motion, slam, np.array(active))
    rows = [("frames", str(len(frames)))]
    if positions is not None:
        rows.append(("distance", f"{metrics['distance_m']:.1f} m"))
    if true_levels is not None:
        rows.append(("levels visited", f"{metrics['levels_visited']} of {list(range(len(levels)))}"))
    false = "" if groundtruth is None else f" ({metrics['false_loop_closures']} false)"
    rows.append(("map", f"{metrics['templates']} templates, {metrics['experiences']} experiences, "
                        f"{metrics['loop_closures']} loop closures{false}"))
    if groundtruth is not None:
        rows.append(("ATE (Sim(3))", f"SLAM {_metres(metrics['ate_rmse_m']['slam'])} "
                                     f"(online {_metres(metrics['ate_rmse_m']['slam_online'])}), "
                                     f"odometry {_metres(metrics['ate_rmse_m']['odometry'])}"))
        if metrics["level_accuracy"] is not None:
            rows.append(("level accuracy", f"{metrics['level_accuracy']:.2f}"))
    rows += [("ms per frame", "SLAM {slam:.2f}, reading images {read:.2f}, total {total:.2f}".format(
                 **metrics["ms_per_frame"])),
             ("output", str(out))]
    _print_rows(rows)
    return 0


def _record(args: argparse.Namespace) -> int:
    """Save a drive as a dataset: frames/NNNNNN.png, groundtruth.tum, wheel_odometry.tum."""
    from PIL import Image
    from tqdm import tqdm

    import sim

    from ..datasets import DatasetDescription, write_description
    from ..tum import write_tum, yaw_quaternion

    world, route = _world_and_route(args)
    drive = sim.ScriptedDrive(world, route=route, laps=args.laps, speed=args.speed, max_frames=args.max_frames,
                              seed=args.seed, camera=_camera(args))
    out = args.out
    (out / "frames").mkdir(parents=True, exist_ok=True)
    times, truths, odometry = [], [], []
    with tqdm(total=int(drive.total_distance), unit="m", desc=f"record {world.name}") as bar:
        for frame in drive:
            Image.fromarray(frame.image).save(out / "frames" / f"{frame.index:06d}.png")
            times.append(frame.time)
            truths.append(frame.ground_truth)
            odometry.append(frame.odometry)
            bar.update(min(int(frame.progress), bar.total) - bar.n)
    times = np.array(times)
    write_tum(out / "groundtruth.tum", times, np.array([t.position for t in truths]),
              np.array([t.quaternion for t in truths]))
    write_tum(out / "wheel_odometry.tum", times, np.array([[o.x, o.y, 0.0] for o in odometry]),
              yaw_quaternion(np.array([o.yaw for o in odometry])))
    write_description(out, DatasetDescription(world.name, drive.route.name, tuple(world.levels)))
    _print_rows([("world / route", f"{world.name} / {drive.route.name}"), ("frames", str(len(times))),
                 ("output", str(out))])
    return 0


def _calibrate(args: argparse.Namespace) -> int:
    """Fit the visual-odometry gains on a calibration drive and write them as a config file."""
    import dataclasses

    from tqdm import tqdm

    import sim

    from ..geometry import wrap
    from ..vision.calibration import fit_odometry_gains
    from ..vision.odometry import VisualOdometry
    from ..vision.preprocessing import grey

    base = _slam_from(args)[0].config
    # the raw row-shift pitch changes are eqs. 31-32's ("profile"), whose gains are fitted; the "transitions"
    # height (eqs. R1-R3) has none
    neutral = dataclasses.replace(base.odometry, speed_scale=1.0, yaw_scale=1.0, climb_scale=1.0,
                                  pitch_flow_bias=0.0, pitch_leak=0.0, max_speed=1e6, max_yaw_rate=1e6,
                                  max_climb_rate=1e6, height_model="profile")
    odometry = VisualOdometry(neutral, horizontal_fov=base.horizontal_fov, vertical_fov=base.vertical_fov,
                              panoramic=base.panoramic)
    world, route = _world_and_route(args)
    drive = sim.ScriptedDrive(world, route=route, laps=args.laps, speed=args.speed, max_frames=args.max_frames,
                              seed=args.seed)
    rows = []
    previous = None
    with tqdm(total=int(drive.total_distance), unit="m", desc=f"calibrate {world.name}") as bar:
        for frame in drive:
            dt = 0.0 if previous is None else frame.time - previous.time
            pitch_before = odometry.pitch
            motion = odometry.step(grey(frame.image), dt)
            truth = frame.ground_truth
            if previous is not None:
                turn = wrap(truth.yaw - previous.ground_truth.yaw)
                rows.append((dt, motion.forward_speed * dt, motion.yaw_rate, odometry.pitch - pitch_before,
                             float(np.hypot(*truth.velocity[:2])), turn / dt, truth.position[2]))
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
        ("height", ("" if profile_height else "not written (height_model = transitions has no gains); eqs. 31-32: ")
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
    out = args.out or Path("runs") / f"nav-{time.strftime('%Y%m%d-%H%M%S')}"
    out.mkdir(parents=True, exist_ok=True)
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
                "compare-maps": _compare_maps, "sweep": _sweep, "nav": _nav}
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
