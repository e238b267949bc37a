"""Fitting the visual-odometry gains to ground truth (``neuroslam calibrate``).

The visual odometry's raw measurements (profile difference, column shift, row shift) become speed, yaw
rate and climb rate through gains that depend on the camera and the scenery (NeuroSLAM eqs. 29, 30, 32). Given a
calibration drive with ground truth, the speed gain makes the total distance right, the yaw gain is a
least-squares fit through the origin, and the height pipeline (pitch bias per metre, leak, climb gain)
is the grid point with the least height error when integrated over the whole drive, as the SLAM does.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OdometryCalibration", "fit_odometry_gains"]


@dataclass(frozen=True)
class OdometryCalibration:
    """Fitted gains and how well they fit.

    Attributes:
        speed_scale: metres per frame per unit profile difference (NeuroSLAM eq. 30's mu).
        yaw_scale: true over geometric yaw rate.
        climb_scale, pitch_flow_bias, pitch_leak: the height pipeline.
        speed_correlation, yaw_correlation: of the fitted against the true per-frame values.
        height_rmse: m, of the integrated height against the truth.
    """

    speed_scale: float
    yaw_scale: float
    climb_scale: float
    pitch_flow_bias: float
    pitch_leak: float
    speed_correlation: float
    yaw_correlation: float
    height_rmse: float

    def settings(self) -> dict:
        """The fitted values as an ``[odometry]`` table for a config file."""
        return {"odometry": {"speed_scale": self.speed_scale, "yaw_scale": self.yaw_scale,
                             "climb_scale": self.climb_scale, "pitch_flow_bias": self.pitch_flow_bias,
                             "pitch_leak": self.pitch_leak}}


def _through_origin(measured: np.ndarray, truth: np.ndarray) -> float:
    denominator = float(measured @ measured)
    return float(measured @ truth / denominator) if denominator > 0 else 1.0


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    if a.std() == 0 or b.std() == 0:
        return 0.0
    return float(np.corrcoef(a, b)[0, 1])


def fit_odometry_gains(
    *,
    dt: np.ndarray,
    raw_difference: np.ndarray,
    raw_yaw_rate: np.ndarray,
    raw_pitch_change: np.ndarray,
    true_speed: np.ndarray,
    true_yaw_rate: np.ndarray,
    true_height: np.ndarray,
) -> OdometryCalibration:
    """Fit the gains from per-frame raw measurements and ground truth.

    Args:
        dt: seconds between each frame and the previous one (N,).
        raw_difference: NeuroSLAM eq. 30's profile difference per frame (speed_scale 1).
        raw_yaw_rate: geometric yaw rate per frame, rad/s (yaw_scale 1).
        raw_pitch_change: pitch change per frame from the row shift, rad (no bias, no leak).
        true_speed: m/s. true_yaw_rate: rad/s. true_height: m, at each frame (N,).
    """
    arrays = [np.asarray(a, dtype=float) for a in (dt, raw_difference, raw_yaw_rate, raw_pitch_change, true_speed,
                                                   true_yaw_rate, true_height)]
    if len({len(a) for a in arrays}) != 1 or len(arrays[0]) < 10:
        raise ValueError("calibration: every series needs the same length, at least 10 frames")
    dt, difference, yaw_rate, pitch_change, speed, true_yaw, height = arrays
    distance_true = speed * dt
    # the ratio of totals keeps the distance driven right; a least-squares slope on this noisy regressor
    # (correlation about 0.25 per frame on the testbed) would shrink it by regression dilution
    speed_scale = float(distance_true.sum() / difference.sum()) if difference.sum() > 0 else 1.0
    yaw_scale = _through_origin(yaw_rate, true_yaw)
    distance = speed_scale * difference
    best = (math.inf, 0.0, 0.0, 1.0)
    for bias, leak, gain in itertools.product(np.linspace(0.0, 0.03, 16), (0.01, 0.02, 0.05, 0.1, 0.2),
                                              np.linspace(0.3, 1.5, 13)):
        pitch, z = 0.0, height[0]
        error = 0.0
        for k in range(1, len(height)):
            pitch = (pitch + pitch_change[k] - bias * distance[k]) * math.exp(-leak * dt[k])
            z += gain * distance[k] * math.sin(pitch)
            error += (z - height[k]) ** 2
        rmse = math.sqrt(error / (len(height) - 1))
        if rmse < best[0]:
            best = (rmse, float(bias), float(leak), float(gain))
    return OdometryCalibration(
        speed_scale=speed_scale, yaw_scale=yaw_scale, climb_scale=best[3], pitch_flow_bias=best[1],
        pitch_leak=best[2], speed_correlation=_correlation(distance, distance_true),
        yaw_correlation=_correlation(yaw_scale * yaw_rate, true_yaw), height_rmse=best[0],
    )
