"""Evaluation against ground truth: trajectory alignment and errors, loop-closure and level scores
(pure math, no I/O)."""

from .metrics import (
    FLOOR_TOLERANCE,
    align,
    associate,
    false_along_path_mask,
    false_loop_closure_mask,
    false_loop_closures,
    level_accuracy,
    nearest_level,
    observation_shares,
    rpe_rmse,
    run_metrics,
    trajectory_errors,
)
from .trajectory import ate_rmse, umeyama

__all__ = ["FLOOR_TOLERANCE", "align", "associate", "ate_rmse", "false_along_path_mask", "false_loop_closure_mask",
           "false_loop_closures", "level_accuracy", "nearest_level", "observation_shares", "rpe_rmse", "run_metrics",
           "trajectory_errors", "umeyama"]
