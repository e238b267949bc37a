"""Comparing two experience maps: 4-DoF ICP registration, then the RMSE between them.

Two maps of the same place built in different frames (a multisession map and a single-session one, say)
are compared as the multisession RatSLAM paper does, with the protocol stated here because the number
depends on it:

1. **Initial alignment.** Map A's centroid is put on map B's; then A is turned about the vertical axis
   through it by each of 36 headings (every 10 degrees) and the heading with the smallest median
   nearest-neighbour distance is kept. (The maps' frames start at unrelated headings, so no single initial
   guess is safe.)
2. **Correspondences**, from A to B: every experience of A is paired with its nearest experience of B
   (scipy's KD-tree, 3-D Euclidean distance). B may hold places A never visited; those stay unpaired.
3. **Outliers**: pairs farther apart than ``outlier_factor`` (3) times the median pair distance, and at
   least ``minimum_outlier_distance`` (0.5 m), are left out of the fit and of the RMSE.
4. **Fit**: the 4-DoF rigid transform (rotation about z, 3-D translation; no scale: both maps are in
   metres) that minimises the squared distances of the inlier pairs, in closed form (the 2-D Umeyama
   rotation of the horizontal parts, the mean of the height differences).
5. Steps 2–4 repeat until the transform changes by less than 1e-6 m and rad, at most ``iterations`` times.

The result: the RMSE over the inlier pairs (``rmse_m``), the RMSE over all pairs (``rmse_all_m``), the
share of A's experiences that are inliers, and the transform.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..geometry import compose, wrap

__all__ = ["MapComparison", "compare_maps", "fit_yaw_translation", "transform_points"]


@dataclass(frozen=True)
class MapComparison:
    """The outcome of :func:`compare_maps`.

    Attributes:
        rmse_m: RMSE over the inlier pairs after registration, m.
        rmse_all_m: RMSE over every pair (outliers included), m.
        inlier_fraction: share of map A's experiences whose pair is an inlier.
        yaw: rotation about z applied to A, rad. translation: (x, y, z) applied after it, m.
        iterations: ICP iterations run.
        pairs: number of A's experiences (one pair each).
    """

    rmse_m: float
    rmse_all_m: float
    inlier_fraction: float
    yaw: float
    translation: tuple[float, float, float]
    iterations: int
    pairs: int

    def as_dict(self) -> dict:
        """Plain data (for JSON)."""
        return {"rmse_m": self.rmse_m, "rmse_all_m": self.rmse_all_m, "inlier_fraction": self.inlier_fraction,
                "yaw_deg": math.degrees(self.yaw), "translation_m": list(self.translation),
                "iterations": self.iterations, "pairs": self.pairs}


def transform_points(points: np.ndarray, yaw: float, translation: np.ndarray) -> np.ndarray:
    """``points`` (N, 3; m) rotated by ``yaw`` (rad) about z through the origin, then shifted by ``translation``."""
    motion = np.array([*translation, yaw])
    return compose(motion, np.column_stack([points, np.zeros(len(points))]))[:, :3]


def fit_yaw_translation(source: np.ndarray, target: np.ndarray, weights: np.ndarray | None = None
                        ) -> tuple[float, np.ndarray]:
    """The rotation about z (rad) and translation (m) taking ``source`` onto ``target`` (paired (N, 3) rows,
    m), weighted least squares in closed form (``weights``: (N,), equal when None): the 2-D Umeyama rotation
    of the horizontal parts, and the (weighted) mean of the height differences."""
    if weights is None:
        source_centre, target_centre, w = source.mean(axis=0), target.mean(axis=0), 1.0
    else:
        w = np.asarray(weights, dtype=float) / float(np.sum(weights))
        source_centre, target_centre, w = w @ source, w @ target, w[:, None]
    a, b = source[:, :2] - source_centre[:2], target[:, :2] - target_centre[:2]
    # the 2-D rotation maximising sum w b · R a: angle of sum w (a x b, a · b)
    cross = (a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])[:, None]
    yaw = math.atan2(float(np.sum(w * cross)), float(np.sum(w * a * b)))
    translation = target_centre - transform_points(source_centre[None], yaw, np.zeros(3))[0]
    return yaw, translation


def _inliers(distances: np.ndarray, outlier_factor: float, minimum_outlier_distance: float) -> np.ndarray:
    return distances <= max(outlier_factor * float(np.median(distances)), minimum_outlier_distance)


def compare_maps(a: np.ndarray, b: np.ndarray, *, iterations: int = 100, outlier_factor: float = 3.0,
                 minimum_outlier_distance: float = 0.5) -> MapComparison:
    """Register experience map ``a`` onto ``b`` by 4-DoF ICP and report the RMSE between them.

    Args:
        a, b: (N, 3) and (M, 3) experience positions, m (at least 3 each).
        iterations: most ICP iterations. outlier_factor, minimum_outlier_distance: the outlier rule (m).

    The protocol (initial alignment, correspondence direction A → B, outlier rule) is the module's.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    for name, points in (("a", a), ("b", b)):
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 3 or not np.all(np.isfinite(points)):
            raise ValueError(f"{name}: expected at least 3 finite (x, y, z) positions, got shape {points.shape}")
    tree = cKDTree(b)
    shift = b.mean(axis=0) - a.mean(axis=0)
    centred = a - a.mean(axis=0)
    best = (math.inf, 0.0)
    for yaw in np.radians(np.arange(0, 360, 10)):
        distances, _ = tree.query(transform_points(centred, yaw, np.zeros(3)) + b.mean(axis=0))
        best = min(best, (float(np.median(distances)), float(yaw)))
    yaw = best[1]
    translation = a.mean(axis=0) + shift - transform_points(a.mean(axis=0)[None], yaw, np.zeros(3))[0]
    iteration = 0
    for iteration in range(1, iterations + 1):  # noqa: B007 (the count is reported)
        moved = transform_points(a, yaw, translation)
        distances, nearest = tree.query(moved)
        keep = _inliers(distances, outlier_factor, minimum_outlier_distance)
        step_yaw, step_translation = fit_yaw_translation(moved[keep], b[nearest[keep]])
        yaw = wrap(float(yaw + step_yaw))
        translation = transform_points(translation[None], step_yaw, step_translation)[0]
        if abs(step_yaw) < 1e-6 and np.abs(step_translation).max() < 1e-6:
            break
    distances, _ = tree.query(transform_points(a, yaw, translation))
    keep = _inliers(distances, outlier_factor, minimum_outlier_distance)
    return MapComparison(rmse_m=float(np.sqrt(np.mean(distances[keep] ** 2))),
                         rmse_all_m=float(np.sqrt(np.mean(distances**2))), inlier_fraction=float(keep.mean()),
                         yaw=yaw, translation=tuple(float(v) for v in translation), iterations=iteration,
                         pairs=len(a))
