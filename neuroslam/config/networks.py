"""The attractor networks' sections: 3D grid cells, multilayered head-direction cells, the grid-network."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .checks import cells, non_negative, number, positive, require, validate_network
from .options import Shift

__all__ = ["GridCellConfig", "GridNetworkConfig", "HeadDirectionConfig"]


@dataclass(frozen=True)
class GridCellConfig:
    """3D grid cells (NeuroSLAM eqs. 1–11).

    Attributes:
        size: cells along (x, y, z). cell_size: metres per cell along (x, y, z).
        excitation_width, excitation_variance: Gaussian excitatory kernel (NeuroSLAM eq. 1), cells and cells².
        inhibition_width, inhibition_variance: Gaussian inhibitory kernel (NeuroSLAM eq. 4).
        inhibition_scale: weight of the local inhibition (1 in the paper, which is unstable; see
            :mod:`neuroslam.cells.attractor`).
        global_inhibition: phi of NeuroSLAM eq. 4, subtracted from every cell each frame.
        view_injection: delta of NeuroSLAM eq. 11, strength of local view calibration.
        readout_radius: half-width of the window of the circular-mean read-out, cells.
        shift: path integration by an exact phase ramp (``fourier``) or the paper's blend (``linear``).
    """

    size: tuple[int, int, int] = (48, 48, 16)
    cell_size: tuple[float, float, float] = (2.0, 2.0, 1.0)
    excitation_width: int = 7
    excitation_variance: float = 1.5
    inhibition_width: int = 5
    inhibition_variance: float = 2.0
    inhibition_scale: float = 0.7
    global_inhibition: float = 0.0002
    view_injection: float = 0.005
    readout_radius: int = 4
    shift: Shift = "fourier"

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "grid_cells") -> None:
        cells(path, "size", self.size, 3)
        ok = isinstance(self.cell_size, tuple) and len(self.cell_size) == 3 and all(
            number(v) and v > 0 for v in self.cell_size)
        require(f"{path}.cell_size", self.cell_size, ok, "must be three positive lengths in metres")
        validate_network(path, self)


@dataclass(frozen=True)
class HeadDirectionConfig:
    """Multilayered head-direction cells (NeuroSLAM eqs. 12–20): yaw × height.

    Attributes:
        size: cells along (yaw, height). height_cell_size: metres per height cell.
        The yaw cell size is 2 pi / size[0] radians. Other fields as in :class:`GridCellConfig`.
        The paper's 8-cell excitatory width is even, which makes a resting packet drift; 9 is used,
        and the read-out window is ±6 cells (the paper's ±5 cuts the packet and biases the read-out).
    """

    size: tuple[int, int] = (36, 36)
    height_cell_size: float = 1.0
    excitation_width: int = 9
    excitation_variance: float = 1.9
    inhibition_width: int = 5
    inhibition_variance: float = 3.0
    inhibition_scale: float = 0.7
    global_inhibition: float = 0.0002
    view_injection: float = 0.005
    readout_radius: int = 6
    shift: Shift = "fourier"

    @property
    def yaw_cell_size(self) -> float:
        """Radians per yaw cell."""
        return 2 * math.pi / self.size[0]

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "head_direction") -> None:
        cells(path, "size", self.size, 2)
        positive(path, height_cell_size=self.height_cell_size)
        validate_network(path, self)


@dataclass(frozen=True)
class GridNetworkConfig:
    """The Burak–Fiete periodic grid-cell network (grid-network paper, grid-network eqs. 1–5, Tables I–II).

    Attributes:
        size: n, neurons along each side of the n × n sheet (a torus).
        time_constant: tau of grid-network eq. 1, ms. time_step: the Euler step of grid-network eq. 1, ms.
        excitation_scale: alpha of grid-network eq. 3. lattice_period: the lambda with beta = 3 / lambda² of
            grid-network eq. 3, neurons.
        surround_ratio: gamma / beta of grid-network eq. 3 (1.05).
        weight_shift: l of grid-network eq. 2, neurons: each neuron's outgoing weights shifted along its
            preferred direction.
        velocity_gain: eta of grid-network eq. 4.
        velocity_scale: the velocity input of grid-network eq. 4 per m/s of the robot's speed; the pattern flows
            linearly with its input (0.36 neurons per step per unit of eta × v) only while eta × this × speed stays
            below about 0.04 (measured: beyond it the lattice deforms), so the default keeps 2 m/s there.
        steps_per_frame: Euler steps of grid-network eq. 1 per camera frame (the accuracy/speed trade-off:
            ``benchmarks/grid_network.py``).
        search_radius: Delta of Table I, neurons: the read-out looks for the shift within ±Delta.
        settle_steps: steps at rest from a random start before use, so that the lattice forms.
        seed: of that random start.
        calibration_directions: headings at which the settled lattice's flow direction is measured once
            against its input, to correct the read-out (0: no correction).
    """

    size: int = 128
    time_constant: float = 5.0
    time_step: float = 0.5
    excitation_scale: float = 1.0
    lattice_period: float = 18.0
    surround_ratio: float = 1.05
    weight_shift: float = 2.0
    velocity_gain: float = 2.0
    velocity_scale: float = 0.01
    steps_per_frame: int = 10
    search_radius: int = 9
    settle_steps: int = 2000
    seed: int = 0
    calibration_directions: int = 24

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "grid_network") -> None:
        require(f"{path}.size", self.size, isinstance(self.size, int) and not isinstance(self.size, bool)
                 and 16 <= self.size <= 1024 and self.size % 2 == 0,
                 "must be an even integer from 16 to 1024 (neurons: each 2 x 2 block holds the four directions)")
        positive(path, time_constant=self.time_constant, time_step=self.time_step,
                  excitation_scale=self.excitation_scale, lattice_period=self.lattice_period,
                  surround_ratio=self.surround_ratio, velocity_scale=self.velocity_scale)
        non_negative(path, weight_shift=self.weight_shift, velocity_gain=self.velocity_gain)
        require(f"{path}.time_step", self.time_step, self.time_step <= self.time_constant,
                 "must not exceed time_constant (the Euler step of grid-network eq. 1 would overshoot)")
        for name, low in (("steps_per_frame", 1), ("search_radius", 1), ("settle_steps", 0),
                          ("calibration_directions", 0)):
            value = getattr(self, name)
            require(f"{path}.{name}", value, isinstance(value, int) and not isinstance(value, bool)
                     and low <= value <= 100_000, f"must be an integer from {low} to 100000")
        require(f"{path}.search_radius", self.search_radius, self.search_radius < self.size // 2,
                 "must be below half the sheet")
        require(f"{path}.seed", self.seed, isinstance(self.seed, int) and not isinstance(self.seed, bool),
                 "must be an integer")
