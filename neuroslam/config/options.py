"""The configuration's options: each a Literal type (what a field may hold) and the tuple of its values."""

from __future__ import annotations

from typing import Literal, get_args

__all__ = [
    "HEIGHT_MODELS", "INTEGRATORS", "LOOP_CLOSURES", "PLANAR_MOTIONS", "RELAXATIONS", "SHIFTS", "HeightModel",
    "Integrator", "LoopClosure", "PlanarMotion", "Relaxation", "Shift",
]

Relaxation = Literal["passes", "least-squares"]
Integrator = Literal["odometry", "grid-network"]
LoopClosure = Literal["code", "confirmed"]
PlanarMotion = Literal["profile", "ground"]
HeightModel = Literal["profile", "transitions"]
Shift = Literal["fourier", "linear"]
RELAXATIONS: tuple[str, ...] = get_args(Relaxation)
INTEGRATORS: tuple[str, ...] = get_args(Integrator)
LOOP_CLOSURES: tuple[str, ...] = get_args(LoopClosure)
PLANAR_MOTIONS: tuple[str, ...] = get_args(PlanarMotion)
HEIGHT_MODELS: tuple[str, ...] = get_args(HeightModel)
SHIFTS: tuple[str, ...] = get_args(Shift)
