"""The neural networks of NeuroSLAM: 3D grid cells and multilayered head-direction cells, built on one
continuous-attractor machinery."""

from .attractor import AttractorNetwork, gaussian_kernel
from .grid_cells import GridCells
from .head_direction import HeadDirectionCells

__all__ = ["AttractorNetwork", "GridCells", "HeadDirectionCells", "gaussian_kernel"]
