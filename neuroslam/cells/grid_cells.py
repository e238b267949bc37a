"""3D grid cells (NeuroSLAM eqs. 1–11): position (x, y, z) as a packet of activity on a 3-D torus of cells."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..config import GridCellConfig
from .attractor import AttractorNetwork, wrapped_distance

__all__ = ["GridCells"]


class GridCells:
    """The 3D grid-cell network.

    Metres are converted to cells once, here, with ``config.cell_size``; the network wraps around, so
    the decoded cell is the position modulo the network's extent (36 m with the defaults).

    Args:
        config: network parameters (Table 5).
    """

    def __init__(self, config: GridCellConfig = GridCellConfig()):
        config.validate("grid_cells")
        self.config = config
        self.cell_size = np.asarray(config.cell_size, dtype=float)
        self.network = AttractorNetwork.from_config(config)

    @property
    def activity(self) -> np.ndarray:
        """Activity of every cell, shape ``config.size``, total 1."""
        return self.network.activity

    def step(self, translation: Sequence[float]) -> None:
        """Attractor dynamics and path integration by a translation (dx, dy, dz) in metres (NeuroSLAM eqs. 1–9)."""
        self.network.step(np.asarray(translation, dtype=float) / self.cell_size)

    def inject(self, cell: Sequence[float], energy: float) -> None:
        """Local view calibration: add ``energy`` at a recalled (fractional) cell (NeuroSLAM eq. 11)."""
        self.network.inject(cell, energy)

    def normalise(self) -> None:
        """Total activity back to 1 (NeuroSLAM eq. 5), after injections."""
        self.network.normalise()

    def decode(self) -> np.ndarray:
        """Centre of the activity packet, fractional cells (x, y, z)."""
        return self.network.decode()

    def distance(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Wrapped Euclidean distance between cells ``a`` (..., 3) and ``b`` (..., 3), in cells."""
        return wrapped_distance(a, b, self.config.size)
