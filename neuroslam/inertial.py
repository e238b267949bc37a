"""The robot's pitch from an IMU's accelerometer, for the height rate (an alternative to the camera's).

A ground robot's accelerometer measures the specific force in its body frame (x forward, y left, z up):
gravity's reaction, ``g (sin pitch, ·, cos pitch)`` for a nose-up pitch, plus the robot's own
accelerations. The pitch is ``atan2(f_x, f_z)``, low-passed with a first-order filter (time constant
``time_constant``) so that speeding up and braking, which last a second or so and average out, do not
read as slopes. The climb rate is then the forward speed times the sine of the pitch (this project's rule, as
in the camera's ``transitions`` height; NeuroSLAM eq. 32 takes a gain times the height region's shift instead).

This is not in the NeuroSLAM paper, which measures the pitch from the images (NeuroSLAM eqs. 31–32); that
measurement carries a bias from forward motion that depends on the scene's depth, and the integrated
height drifts by metres per hundred metres on most of the testbed's worlds. The camera's default height
(:mod:`neuroslam.vision.pitch`, level floors joined by ramps) no longer drifts; the IMU also follows
slopes that change gradually. Up the testbed's car-park ramp (3 m) this filter gets the height within
0.16 m, with the wheels' speed (``tests/test_inertial.py``).
"""

from __future__ import annotations

import math

import numpy as np

from .errors import InvalidInputError, InvalidParameterError

__all__ = ["GravityPitch"]


class GravityPitch:
    """Pitch (rad, nose up positive) from the accelerometer's specific force, low-passed.

    Args:
        time_constant: s, of the first-order low-pass (0: no filtering).

    Example::

        pitch = GravityPitch()
        climb_rate = forward_speed * math.sin(pitch.step(imu.accelerometer, dt))
    """

    def __init__(self, time_constant: float = 0.5):
        if not isinstance(time_constant, (int, float)) or not math.isfinite(time_constant) or time_constant < 0:
            raise InvalidParameterError("time_constant", time_constant, "must be a number of seconds >= 0")
        self.time_constant = float(time_constant)
        self.pitch: float | None = None  # rad, the filtered pitch so far (None before the first reading)

    def step(self, accelerometer: np.ndarray, dt: float) -> float:
        """Add one reading: specific force (3,) in m/s² (body frame, x forward, z up) after ``dt`` seconds.

        Returns the filtered pitch, rad. Raises InvalidInputError (state unchanged) for a reading that is
        not three finite numbers, or one with no upward component (the robot is not on its wheels).
        """
        force = np.asarray(accelerometer, dtype=float) if _numeric(accelerometer) else None
        if force is None or force.shape != (3,) or not np.all(np.isfinite(force)):
            raise InvalidInputError("accelerometer", repr(accelerometer), "must be three finite numbers (m/s^2)")
        if force[2] <= 0:
            raise InvalidInputError("accelerometer", repr(accelerometer),
                                    "has no upward component: the robot is not on its wheels")
        if not isinstance(dt, (int, float)) or not math.isfinite(dt) or dt < 0:
            raise InvalidInputError("dt", repr(dt), "must be a number of seconds >= 0")
        measured = math.atan2(float(force[0]), float(force[2]))
        if self.pitch is None or self.time_constant == 0:
            self.pitch = measured
        else:
            weight = 1.0 - math.exp(-dt / self.time_constant)
            self.pitch += weight * (measured - self.pitch)
        return self.pitch


def _numeric(value: object) -> bool:
    try:
        return np.asarray(value).dtype.kind in "iuf"
    except (TypeError, ValueError):
        return False
