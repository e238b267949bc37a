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

import sys

from .parser import build_parser
from .runs import calibrate_command, drive_command, record_command, run_command
from .tools import compare_maps_command, evaluate_command, nav_command, sweep_command, worlds_command

__all__ = ["main"]


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``neuroslam`` console script; returns the exit code."""
    args = build_parser().parse_args(argv)
    handlers = {"drive": drive_command, "run": run_command, "record": record_command, "calibrate": calibrate_command,
                "worlds": worlds_command, "compare-maps": compare_maps_command, "eval": evaluate_command,
                "sweep": sweep_command, "nav": nav_command}
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
    from ...errors import NeuroSLAMError

    simulator = sys.modules.get("sim")
    return isinstance(error, (OSError, NeuroSLAMError)) or (
        simulator is not None and isinstance(error, simulator.SimError))
