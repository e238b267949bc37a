"""Argument types and the option groups the commands share."""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ...config import INTEGRATORS


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} must be at least 1")
    return value


def non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value < 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a number >= 0")
    return value


def simulated_camera(args: argparse.Namespace, *, panoramic: bool = False):
    """The simulated camera the options ask for (:class:`sim.CameraConfig`)."""
    import sim

    return sim.CameraConfig(width=args.width, height=args.height, panoramic=panoramic, read_noise=args.read_noise,
                            shot_noise=args.shot_noise, exposure=args.exposure)


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} must be a positive number")
    return value


def drive_options(parser: argparse.ArgumentParser, *, laps: int, camera: bool) -> None:
    """Options of every command that drives a route."""
    parser.add_argument("--route", help="route name, or a routes JSON file for an MJCF world (default: the first)")
    parser.add_argument("--laps", type=positive_int, default=laps, help=f"laps to drive (default: {laps})")
    parser.add_argument("--speed", type=positive_float, default=1.0, help="cruise speed in m/s (default: 1.0)")
    if camera:
        parser.add_argument("--width", type=positive_int, default=160, help="image width in pixels (default: 160)")
        parser.add_argument("--height", type=positive_int, default=120, help="image height in pixels (default: 120)")
        parser.add_argument("--read-noise", type=non_negative_float, default=0.0, metavar="GREY_LEVELS",
                            help="camera read noise: standard deviation in grey levels of 255 (default: 0)")
        parser.add_argument("--shot-noise", type=non_negative_float, default=0.0, metavar="GREY_LEVELS",
                            help="camera photon noise: its standard deviation at full white (default: 0)")
        parser.add_argument("--exposure", type=non_negative_float, default=0.0, metavar="SECONDS",
                            help="shutter time for motion blur, up to 0.5 s (default: 0, none)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sensor noise (default: 0)")
    parser.add_argument("--max-frames", type=positive_int, help="stop after this many frames")


def slam_options(parser: argparse.ArgumentParser, *, sessions: bool = False) -> None:
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


def output_options(parser: argparse.ArgumentParser, text: str, *, required: bool = False) -> None:
    """``--out`` (an output folder) and ``--overwrite`` of the commands that write a run or a dataset."""
    parser.add_argument("--out", type=Path, required=required, help=text)
    parser.add_argument("--overwrite", action="store_true",
                        help="replace an earlier run or dataset in --out (its files are deleted first)")


def record_option(parser: argparse.ArgumentParser) -> None:
    """The ``--record`` option of the commands that run NeuroSLAM."""
    parser.add_argument("--record", action="store_true",
                        help="also write run.rrd into the output folder, a rerun recording of the run (camera, "
                        "trajectories, experience map, cell activity, ids and error over time); open it with "
                        "'rerun run.rrd'")


def make_recorder(args: argparse.Namespace, out: Path, name: str):
    """A :class:`~neuroslam.lab.recording.RunRecorder` writing ``out/run.rrd`` if ``--record`` was given, else None."""
    if not args.record:
        return None
    from ..recording import RunRecorder

    return RunRecorder(out / "run.rrd", name=name)


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block) and exit with code 2."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def metres(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.2f} m"


def print_rows(rows: list[tuple[str, str]]) -> None:
    width = max(len(name) for name, _ in rows)
    for name, value in rows:
        print(f"{name:<{width}}  {value}")
