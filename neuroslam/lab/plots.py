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
    headline: str = "",
    closure_frames: np.ndarray | None = None,
    true_levels: np.ndarray | None = None,
    path: str | Path | None = None,
):
    """The run at a glance: top and 3-D views of ground truth, odometry, the SLAM trajectory and the
    experience map (as the paper's Fig. 12), the active template and experience against time (Figs. 19–20)
    and the SLAM and odometry position errors along the path (after Sim(3) alignment).

    The loop closures are marked where they happened; the ground truth is coloured by floor level (or, without
    levels, the SLAM trajectory by its height); without ground truth the trajectories are drawn as estimated
    and the error panel says there is nothing to score; a flat route's heights are drawn on at least a metre
    of axis, not magnified millimetres.

    Args:
        truth: (N, ≥3) true positions per frame, or None. odometry, estimate: (N, ≥3) per frame.
        experiences: (M, ≥3) experience positions. experience_frames: (M,) frame each was made.
        links: (L, 2) experience ids.
        template_ids, experience_ids: (N,) per frame. times: (N,) seconds.
        title: the figure's title; headline: a line of headline numbers under it.
        closure_frames: (C,) the frames at which a loop closed, or None. true_levels: (N,) each frame's true
            floor level, or None.
        path: where to save the figure (PNG), or None.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from mpl_toolkits.mplot3d.art3d import Line3DCollection

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
    scored = truth is not None and len(truth) >= 3
    if scored:
        truth_points = truth[:, :3]
        odometry_points = align(odometry_points, truth_points)
        made = np.clip(np.asarray(experience_frames), 0, len(truth) - 1)
        map_points = align(map_points, truth_points[made]) if len(map_points) >= 3 else map_points
        estimate_points = align(estimate_points, truth_points)
    if truth is not None:
        levels = np.zeros(len(truth), dtype=int) if true_levels is None else np.asarray(true_levels)
        # not the odometry's orange, the map's blue, the SLAM's green or the closures' red
        colours = ("black", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan", "tab:gray")
        for number, level in enumerate(np.unique(levels)):
            on = np.where(levels == level, 1.0, np.nan)  # breaks the line where the robot is on another level
            label = "ground truth" if true_levels is None else f"ground truth, level {level}"
            colour = colours[number % len(colours)]
            top.plot(truth[:, 0] * on, truth[:, 1] * on, color=colour, linewidth=1.2, label=label)
            space.plot(truth[:, 0] * on, truth[:, 1] * on, truth[:, 2] * on, color=colour, linewidth=1.0)
            side.plot(truth[:, 0] * on, truth[:, 2] * on, color=colour, linewidth=1.0)
    top.plot(odometry_points[:, 0], odometry_points[:, 1], color="tab:orange", linewidth=0.8, label="odometry")
    top.plot(estimate_points[:, 0], estimate_points[:, 1], color="tab:green", linewidth=0.8, label="SLAM")
    side.plot(estimate_points[:, 0], estimate_points[:, 2], color="tab:green", linewidth=0.8)
    if truth is None and len(estimate_points):  # the SLAM's own heights tell the levels apart
        points = top.scatter(estimate_points[:, 0], estimate_points[:, 1], c=estimate_points[:, 2], s=3,
                             cmap="viridis", zorder=3)
        figure.colorbar(points, ax=top, label="estimated height (m)", shrink=0.7)
    # the map's links as one artist per view (thousands of single lines cost seconds to draw and to place the
    # legend around); none without links (an empty 3-D collection fails to draw)
    if len(links):
        segments = map_points[links]
        top.add_collection(LineCollection(segments[:, :, :2], colors="tab:blue", linewidths=0.6))
        space.add_collection3d(Line3DCollection(segments, colors="tab:blue", linewidths=0.6))
        # a collection widens the 3-D limits by itself only from matplotlib 3.10
        space.auto_scale_xyz(segments[:, :, 0], segments[:, :, 1], segments[:, :, 2], had_data=True)
    top.scatter(map_points[:, 0], map_points[:, 1], s=2, color="tab:blue", label="experience map")
    side.plot(odometry_points[:, 0], odometry_points[:, 2], color="tab:orange", linewidth=0.8)
    side.scatter(map_points[:, 0], map_points[:, 2], s=2, color="tab:blue")
    closures = np.zeros(0, dtype=int) if closure_frames is None else np.asarray(closure_frames, dtype=int)
    closures = closures[(closures >= 0) & (closures < len(estimate_points))]
    if len(closures):
        top.scatter(estimate_points[closures, 0], estimate_points[closures, 1], marker="x", s=18, color="tab:red",
                    linewidths=0.8, zorder=4, label=f"loop closure ({len(closures)})")
        side.scatter(estimate_points[closures, 0], estimate_points[closures, 2], marker="x", s=18,
                     color="tab:red", linewidths=0.8, zorder=4)
    top.set(title="top view", xlabel="x (m)", ylabel="y (m)", aspect="equal")
    side.set(title="side view", xlabel="x (m)", ylabel="z (m)")
    space.set(title="3-D", xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    heights = np.concatenate([estimate_points[:, 2], map_points[:, 2], [] if truth is None else truth[:, 2]])
    if len(heights):  # a flat route: at least a metre of height axis, not magnified millimetres
        middle, half = (heights.max() + heights.min()) / 2, max((heights.max() - heights.min()) / 2 * 1.1, 0.5)
        side.set_ylim(middle - half, middle + half)
        space.set_zlim(middle - half, middle + half)
    top.legend(loc="best", fontsize=7)
    ids.plot(times, template_ids, ".", markersize=1.5, label="local view cell (template)")
    ids.plot(times, experience_ids, ".", markersize=1.5, label="experience")
    ids.set(title="active cells", xlabel="time (s)", ylabel="id")
    ids.legend(loc="upper left", fontsize=8, markerscale=5)
    if scored:
        errors.plot(times, np.linalg.norm(estimate_points - truth[:, :3], axis=1), label="SLAM", color="tab:green")
        errors.plot(times, np.linalg.norm(odometry_points - truth[:, :3], axis=1), label="odometry",
                    color="tab:orange")
        for frame in closures:
            errors.axvline(times[frame], color="tab:red", linewidth=0.3, alpha=0.4)
        errors.legend(fontsize=8)
        errors.set(title="position error after Sim(3) alignment (red: loop closures)", xlabel="time (s)",
                   ylabel="error (m)")
    else:
        errors.set_axis_off()
        errors.text(0.5, 0.5, "no ground truth: nothing to score the trajectories against", ha="center",
                    va="center", transform=errors.transAxes, color="0.4")
    figure.suptitle(title + (f"\n{headline}" if headline else ""))
    figure.tight_layout()
    if path is not None:
        figure.savefig(path, dpi=90)
        plt.close(figure)
    return figure, (top, space, ids, errors, side)
