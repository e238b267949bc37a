"""Multilayered head-direction cells (NeuroSLAM eqs. 12–20): yaw × height as a packet on a 2-D torus of cells."""

from __future__ import annotations

import numpy as np

from ..config import HeadDirectionConfig
from ..geometry import wrap
from .attractor import AttractorNetwork, wrapped_distance

__all__ = ["HeadDirectionCells"]


class HeadDirectionCells:
    """The multilayered head-direction network: one ring of yaw cells per height layer.

    Args:
        config: network parameters (Table 6).
    """

    def __init__(self, config: HeadDirectionConfig = HeadDirectionConfig()):
        config.validate("head_direction")
        self.config = config
        self.yaw_cell_size = config.yaw_cell_size
        self.network = AttractorNetwork.from_config(config)

    @property
    def activity(self) -> np.ndarray:
        """Activity of every cell, shape ``config.size`` (yaw, height), total 1."""
        return self.network.activity

    def step(self, yaw_change: float, height_change: float) -> None:
        """Attractor dynamics and path integration by a yaw change (rad) and height change (m)
        (NeuroSLAM eqs. 12–20)."""
        self.network.step((yaw_change / self.yaw_cell_size, height_change / self.config.height_cell_size))

    def inject(self, cell: np.ndarray, energy: float) -> None:
        """Local view calibration: add ``energy`` at a recalled (fractional) cell (yaw, height) (NeuroSLAM eq. 11)."""
        self.network.inject(cell, energy)

    def normalise(self) -> None:
        """Total activity back to 1 (NeuroSLAM eq. 16), after injections."""
        self.network.normalise()

    def decode(self) -> np.ndarray:
        """Centre of the activity packet, fractional cells (yaw, height)."""
        return self.network.decode()

    def yaw(self) -> float:
        """Decoded yaw, rad in [-pi, pi)."""
        return wrap(float(self.decode()[0] * self.yaw_cell_size))

    def distance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Wrapped Euclidean distance between cells ``a`` (..., 2) and ``b`` (..., 2), in cells."""
        return wrapped_distance(a, b, self.config.size)
