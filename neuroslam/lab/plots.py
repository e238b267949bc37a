"""Figures of a run (glue: imports matplotlib, headless). Every ``plot_*`` returns ``(figure, axes)``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_report"]


def plot_report(
    *,
    truth: np.ndarray | None,
    odometry: np.ndarray,
    estimate: np.ndarray,
    experiences: np.ndarray,
    experience_frames: np.ndarray,
    links: np.ndarray,
    template_ids: np.ndarray,
    experience_ids: np.ndarray,
    times: np.ndarray,
    title: str = "",
    path: str | Path | None = None,
):
    """The run at a glance: top and 3-D views of ground truth, odometry and the experience map (as the
    paper's Fig. 12), the active template and experience against time (Figs. 19–20) and the SLAM and
    odometry position errors along the path (after Sim(3) alignment).

    Args:
        truth: (N, ≥3) true positions per frame, or None. odometry, estimate: (N, ≥3) per frame.
        experiences: (M, ≥3) experience positions. experience_frames: (M,) frame each was made.
        links: (L, 2) experience ids.
        template_ids, experience_ids: (N,) per frame. times: (N,) seconds.
        path: where to save the figure (PNG), or None.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..evaluation import align

    figure = plt.figure(figsize=(15, 9))
    grid = figure.add_gridspec(2, 3)
    top = figure.add_subplot(grid[0, 0])
    space = figure.add_subplot(grid[0, 1], projection="3d")
    ids = figure.add_subplot(grid[0, 2])
    errors = figure.add_subplot(grid[1, :2])
    side = figure.add_subplot(grid[1, 2])
    map_points = experiences[:, :3]
    odometry_points, estimate_points = odometry[:, :3], estimate[:, :3]
    if truth is not None and len(truth) >= 3:
        truth_points = truth[:, :3]
        odometry_points = align(odometry_points, truth_points)
        made = np.clip(np.asarray(experience_frames), 0, len(truth) - 1)
        map_points = align(map_points, truth_points[made]) if len(map_points) >= 3 else map_points
        estimate_points = align(estimate_points, truth_points)
    for axes in (top, space, side):
        if truth is not None:
            view = (truth[:, 0], truth[:, 1]) if axes is top else (
                (truth[:, 0], truth[:, 2]) if axes is side else (truth[:, 0], truth[:, 1], truth[:, 2]))
            axes.plot(*view, color="black", linewidth=1.0, label="ground truth")
    top.plot(odometry_points[:, 0], odometry_points[:, 1], color="tab:orange", linewidth=0.8, label="odometry")
    segments = map_points[links] if len(links) else np.zeros((0, 2, 3))
    for segment in segments:
        top.plot(segment[:, 0], segment[:, 1], color="tab:blue", linewidth=0.6)
        space.plot(segment[:, 0], segment[:, 1], segment[:, 2], color="tab:blue", linewidth=0.6)
    top.scatter(map_points[:, 0], map_points[:, 1], s=2, color="tab:blue", label="experience map")
    side.plot(odometry_points[:, 0], odometry_points[:, 2], color="tab:orange", linewidth=0.8)
    side.scatter(map_points[:, 0], map_points[:, 2], s=2, color="tab:blue")
    top.set(title="top view", xlabel="x (m)", ylabel="y (m)", aspect="equal")
    side.set(title="side view", xlabel="x (m)", ylabel="z (m)")
    space.set(title="3-D", xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    top.legend(loc="best", fontsize=8)
    ids.plot(times, template_ids, ".", markersize=1.5, label="local view cell (template)")
    ids.plot(times, experience_ids, ".", markersize=1.5, label="experience")
    ids.set(title="active cells", xlabel="time (s)", ylabel="id")
    ids.legend(loc="upper left", fontsize=8, markerscale=5)
    if truth is not None and len(truth) >= 3:
        errors.plot(times, np.linalg.norm(estimate_points - truth[:, :3], axis=1), label="SLAM")
        errors.plot(times, np.linalg.norm(odometry_points - truth[:, :3], axis=1), label="odometry")
        errors.legend(fontsize=8)
    errors.set(title="position error after Sim(3) alignment", xlabel="time (s)", ylabel="error (m)")
    figure.suptitle(title)
    figure.tight_layout()
    if path is not None:
        figure.savefig(path, dpi=90)
        plt.close(figure)
    return figure, (top, space, ids, errors, side)
