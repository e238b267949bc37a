"""Self-motion: what one frame's odometry says, and what the camera observed of it."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InvalidInputError

__all__ = ["BLIND", "Observed", "SelfMotion"]

BLIND = ("held", "none")  # the sources of a degree of freedom that nothing observed


@dataclass(frozen=True)
class Observed:
    """Where one frame's self-motion came from, per degree of freedom: what the camera saw of it.

    Each of ``distance``, ``yaw`` and ``height`` is one of

    - ``floor``: the floor's motion under the ground-plane model (eqs. G1–G4), where the floor has marks;
    - ``ceiling`` (distance): the ceiling's motion under the same plane model, in the ceiling height the
      floor last gave it (eq. S1 of :meth:`VisualOdometry._observed_motion`);
    - ``image``: the whole image: its rotation for the yaw and pitch (eqs. R1–R2: walls, ceiling, anything
      far or near; with ``odometry.faint_yaw_contrast``, also where its information is low but its yaw
      stands out, eq. R11); for the distance, the expansion of the image above its centre in the scale the floor
      last gave it (eq. S1);
    - ``profile`` (yaw): the shift of the whole image's column profile (NeuroSLAM eqs. 27–29, the paper's own
      yaw), where the image's alignment (eq. R2) has too little information to see the yaw but the profile's best shift
      stands out from the others (:func:`profile_turn`): a blank floor under an open sky, whose only
      structure is a thin band of distant objects along the horizon;
    - ``held``: nothing observed it; the last observed speed, held for at most ``odometry.blind_hold``
      seconds (a ramp's foot or top, where the floor is not one plane, holds the speed too; for the yaw: the
      last second's observed turn rate, for at most ``odometry.yaw_hold`` seconds, eq. R10; for the height:
      the pitch holds, as it does between transitions);
    - ``none``: nothing observed it and nothing is held: zero;
    - ``external``: given by another sensor (wheels, an IMU).
    """

    distance: str = "external"
    yaw: str = "external"
    height: str = "external"

    @property
    def blind(self) -> tuple[bool, bool, bool]:
        """(distance, yaw, height): True where nothing observed that degree of freedom this frame."""
        return self.distance in BLIND, self.yaw in BLIND, self.height in BLIND


@dataclass(frozen=True)
class SelfMotion:
    """Self-motion over one frame, in the robot's frame.

    Attributes:
        forward_speed: m/s along the heading, horizontal (on a slope, the part of the speed along the surface
            that moves the robot over the ground plan). yaw_rate: rad/s, counter-clockwise positive.
        climb_rate: m/s, positive up.
        observed: what the camera observed of each (:class:`Observed`); None where the source does not
            say (the paper's profile odometry).
    """

    forward_speed: float
    yaw_rate: float
    climb_rate: float = 0.0
    observed: Observed | None = None

    def validate(self) -> None:
        """Raise :class:`~neuroslam.errors.InvalidInputError` (a ValueError) naming the first field that is not
        a finite number."""
        for name in ("forward_speed", "yaw_rate", "climb_rate"):
            value = getattr(self, name)
            if (not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool)
                    or not math.isfinite(value)):
                raise InvalidInputError(f"odometry.{name}", repr(value), "must be a finite number")
