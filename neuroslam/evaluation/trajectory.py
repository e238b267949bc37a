"""Trajectory alignment (Umeyama 1991) and absolute trajectory error, as in the SLAM-evaluation standard
(evo, Zhang and Scaramuzza 2018; the paper's NeuroSLAM eq. 33 is the RMSE over positions)."""

from __future__ import annotations

import numpy as np

__all__ = ["ate_rmse", "umeyama"]


def umeyama(source: np.ndarray, target: np.ndarray, *, with_scale: bool = True) -> tuple[float, np.ndarray, np.ndarray]:
    """The similarity (scale, rotation, translation) that best maps ``source`` onto ``target`` (N × 3) in
    the least-squares sense; without scale it is the rigid SE(3) alignment."""
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    if source.shape != target.shape or source.ndim != 2 or source.shape[1] != 3 or len(source) < 3:
        raise ValueError(f"positions: expected two N x 3 arrays with N >= 3, got {source.shape} and {target.shape}")
    mean_source, mean_target = source.mean(axis=0), target.mean(axis=0)
    centred_source, centred_target = source - mean_source, target - mean_target
    covariance = centred_target.T @ centred_source / len(source)
    u, singular, vt = np.linalg.svd(covariance)
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2, 2] = -1
    rotation = u @ sign @ vt
    variance = (centred_source**2).sum() / len(source)
    scale = float(np.trace(np.diag(singular) @ sign) / variance) if with_scale and variance > 0 else 1.0
    translation = mean_target - scale * rotation @ mean_source
    return scale, rotation, translation


def ate_rmse(estimate: np.ndarray, truth: np.ndarray, *, with_scale: bool = True) -> float:
    """Root-mean-square position error (m) after aligning ``estimate`` to ``truth`` (N × 3 each, matched
    by index): Sim(3) alignment by default, SE(3) with ``with_scale=False``."""
    scale, rotation, translation = umeyama(estimate, truth, with_scale=with_scale)
    aligned = scale * np.asarray(estimate, dtype=float) @ rotation.T + translation
    return float(np.sqrt(((aligned - np.asarray(truth, dtype=float)) ** 2).sum(axis=1).mean()))
