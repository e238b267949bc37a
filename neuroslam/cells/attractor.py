"""The machinery shared by the grid-cell and head-direction networks: a continuous attractor network on
a torus of any dimension, updated as one circular convolution per frame.

One frame (NeuroSLAM eqs. 1–9 for the grid cells, 12–20 for the head-direction cells):

1. local excitation (NeuroSLAM eqs. 1–3, 12–14): the activity is convolved with a Gaussian excitatory kernel;
2. local inhibition (NeuroSLAM eqs. 4, 15): the excited activity minus ``inhibition_scale`` times its convolution
   with an inhibitory kernel;
3. path integration (NeuroSLAM eqs. 6–9, 17–20): a shift by any displacement, in whole and fractional cells;
4. global inhibition (NeuroSLAM eqs. 4, 15): ``phi`` subtracted everywhere, negative activity clipped to zero;
5. local view calibration (NeuroSLAM eq. 11): learned activity injected at the recalled cells;
6. normalisation (NeuroSLAM eqs. 5, 16): total activity 1.

Steps 1–3 are linear and circular, so they are applied together as one product of spectra between one
real FFT and its inverse; the shift is applied in the same product, before the clipping of step 4
rather than after it (a reordering against the paper that cannot be told apart in the read-out).
Both kernels have odd widths and sum to 1, so a resting packet neither drifts nor changes shape.

Two measured departures from the paper, both about keeping the packet where the motion puts it:

- With both kernels summing to 1, excitation followed by equally strong local inhibition is a band-pass
  filter that favours a periodic pattern: a resting 36³ packet wandered 0.34 cells in 500 frames.
  Scaling the inhibition by 0.7 keeps it still (< 0.001 cells) with a compact packet.
- The paper's shift blends the two cells around the fractional residue (NeuroSLAM eqs. 6–9), which blurs the
  packet every frame; with the clipping of step 4 slow packets then stick to the lattice (−0.15 cells
  after 40 frames of 1/7 cell). The default ``fourier`` shift multiplies by the exact phase ramp of the
  displacement (a roll for whole cells, band-limited interpolation for the residue): errors stay below
  0.01 cells. ``linear`` selects the paper's blend.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import fft

from .kernels import circular_means, inhibit_and_normalise, multiply_spectrum

__all__ = ["AttractorNetwork", "gaussian_kernel", "wrapped_distance"]


def wrapped_distance(a: np.ndarray, b: np.ndarray, size: Sequence[int]) -> np.ndarray:
    """Euclidean distance between cells ``a`` (..., d) and ``b`` (..., d) on a torus of ``size``, in cells."""
    extent = np.asarray(size, dtype=float)
    difference = np.abs(np.asarray(a, dtype=float) - np.asarray(b, dtype=float)) % extent
    difference = np.minimum(difference, extent - difference)
    return np.sqrt((difference**2).sum(axis=-1))


def gaussian_kernel(dimensions: int, width: int, variance: float) -> np.ndarray:
    """Separable Gaussian weights over a ``width``-cell cube of ``dimensions`` axes, summing to 1
    (NeuroSLAM eqs. 1, 12).

    ``variance`` is the paper's "variance constant" delta, used as the standard deviation in cells.
    """
    offsets = np.arange(width) - width // 2
    profile = np.exp(-(offsets**2) / (2 * variance**2))
    kernel = profile
    for _ in range(dimensions - 1):
        kernel = np.multiply.outer(kernel, profile)
    return kernel / kernel.sum()


def _embedded_spectrum(kernel: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """Real-FFT spectrum of ``kernel`` centred on cell 0 of a torus of ``shape`` (wrap-around, NeuroSLAM eqs. 3, 14)."""
    torus = np.zeros(shape)
    width = kernel.shape[0]
    index = np.ix_(*[(np.arange(width) - width // 2) % n for n in shape])
    torus[index] = kernel
    return fft.rfftn(torus)


class AttractorNetwork:
    """A wrap-around continuous attractor network with one activity packet.

    Args:
        shape: cells along each axis.
        excitation_width, excitation_variance: excitatory Gaussian (cells, cells).
        inhibition_width, inhibition_variance: inhibitory Gaussian (cells, cells).
        global_inhibition: phi, subtracted from every cell each frame.
        readout_radius: half-width of the read-out window, cells.
        inhibition_scale: weight of the local inhibition relative to the excitation.
        shift: ``fourier`` (exact phase ramp) or ``linear`` (the paper's two-cell blend per axis).
        start: cell of the initial packet.
        dtype: floating type of the activity (float32 is fast and accurate enough).
    """

    def __init__(
        self,
        shape: Sequence[int],
        *,
        excitation_width: int,
        excitation_variance: float,
        inhibition_width: int,
        inhibition_variance: float,
        global_inhibition: float,
        readout_radius: int,
        inhibition_scale: float = 0.7,
        shift: str = "fourier",
        start: Sequence[float] | None = None,
        dtype: type = np.float32,
    ):
        if shift not in ("fourier", "linear"):
            raise ValueError(f"shift={shift!r}: expected 'fourier' or 'linear'")
        self.shift = shift
        self.shape = tuple(int(n) for n in shape)
        self.dimensions = len(self.shape)
        self.global_inhibition = float(global_inhibition)
        self.readout_radius = int(readout_radius)
        self.dtype = dtype
        excitation = _embedded_spectrum(gaussian_kernel(self.dimensions, excitation_width, excitation_variance),
                                        self.shape)
        inhibition = _embedded_spectrum(gaussian_kernel(self.dimensions, inhibition_width, inhibition_variance),
                                        self.shape)
        # excitation (NeuroSLAM eqs. 2, 13), then the excited activity inhibits itself locally (NeuroSLAM eqs. 4, 15)
        complex_type = np.complex64 if dtype == np.float32 else np.complex128
        self.kernel_spectrum = (excitation * (1.0 - inhibition_scale * inhibition)).astype(complex_type)
        spectrum_shape = self.kernel_spectrum.shape
        self._wavenumbers = []
        for axis, n in enumerate(self.shape):
            k = 2 * math.pi * (np.fft.rfftfreq(n) if axis == self.dimensions - 1 else np.fft.fftfreq(n))
            view = [1] * self.dimensions
            view[axis] = spectrum_shape[axis]
            self._wavenumbers.append(k.reshape(view))
        # the read-out's tables (:func:`~.kernels.circular_means`): each axis's cells on the unit circle, three axes
        # (a missing one has one cell, read out over a window of none)
        padded = self.shape + (1,) * (3 - self.dimensions)
        self._cosines = np.zeros((3, max(padded)))
        self._sines = np.zeros((3, max(padded)))
        for axis, n in enumerate(padded):
            self._cosines[axis, :n] = np.cos(2 * math.pi * np.arange(n) / n)
            self._sines[axis, :n] = np.sin(2 * math.pi * np.arange(n) / n)
        self._radius = np.array([self.readout_radius if axis < self.dimensions else 0 for axis in range(3)])
        self._padded = padded
        self._corners = np.array(list(np.ndindex(*(2,) * self.dimensions)))  # inject's 2^d neighbours
        self._no_shift = [np.ones(n, dtype=self.kernel_spectrum.dtype) for n in self.kernel_spectrum.shape]
        self.activity = np.zeros(self.shape, dtype=dtype)
        self.reset(start if start is not None else [0.0] * self.dimensions)

    def state_dict(self) -> dict[str, np.ndarray]:
        """The network's state (its activity), for saving; :meth:`load_state_dict` restores it exactly."""
        return {"activity": self.activity.copy()}

    def load_state_dict(self, state: dict[str, np.ndarray]) -> None:
        """Restore :meth:`state_dict`'s output. Raises ValueError when it does not fit this network."""
        activity = np.asarray(state["activity"])
        if activity.shape != self.shape or activity.dtype != self.dtype:
            raise ValueError(f"activity is {activity.dtype} {activity.shape}, the network is "
                             f"{np.dtype(self.dtype)} {self.shape}")
        self.activity = activity.copy()

    @classmethod
    def from_config(cls, config) -> AttractorNetwork:
        """A network from a :class:`~neuroslam.config.GridCellConfig` or
        :class:`~neuroslam.config.HeadDirectionConfig` (they share the network's fields)."""
        return cls(
            config.size, excitation_width=config.excitation_width, excitation_variance=config.excitation_variance,
            inhibition_width=config.inhibition_width, inhibition_variance=config.inhibition_variance,
            inhibition_scale=config.inhibition_scale, global_inhibition=config.global_inhibition,
            readout_radius=config.readout_radius, shift=config.shift,
        )

    def reset(self, cell: Sequence[float], *, settle: int = 30) -> None:
        """Put a single packet at ``cell`` (fractional cells) and let it settle to its resting shape."""
        self.activity[...] = 0
        self.inject(cell, 1.0)
        self.activity /= self.activity.sum()
        for _ in range(settle):
            self.step()

    def shift_factors(self, displacement: Sequence[float]) -> list[np.ndarray]:
        """Per-axis spectra of a shift by ``displacement`` cells (NeuroSLAM eqs. 6–9, 17–20), broadcastable to
        the spectrum:
        a roll by the whole cells times the residue's exact phase ramp (``fourier``) or its two-cell
        linear blend (``linear``). Their product is the shift's spectrum."""
        factors = []
        for k, d in zip(self._wavenumbers, displacement, strict=True):
            whole = math.floor(d)
            residue = d - whole
            if self.shift == "fourier":
                factor = np.exp(-1j * k * d)
            else:
                factor = np.exp(-1j * k * whole) * ((1 - residue) + residue * np.exp(-1j * k))
            factors.append(factor.astype(self.kernel_spectrum.dtype))
        return factors

    def step(self, displacement: Sequence[float] | None = None) -> None:
        """One frame of attractor dynamics with path integration by ``displacement`` cells (any size)."""
        spectrum = fft.rfftn(self.activity)
        if displacement is not None and any(d != 0 for d in displacement):
            factors = [factor.ravel() for factor in self.shift_factors(displacement)]
        else:
            factors = list(self._no_shift)
        factors += [np.ones(1, dtype=spectrum.dtype)] * (3 - self.dimensions)
        shape3 = spectrum.shape + (1,) * (3 - self.dimensions)
        multiply_spectrum(spectrum.reshape(shape3), self.kernel_spectrum.reshape(shape3), *factors)
        activity = fft.irfftn(spectrum, s=self.shape).astype(self.dtype, copy=False)
        # NeuroSLAM eqs. 4, 15 (global inhibition), then 5, 16 (normalisation); where the inhibition removed
        # everything, the previous packet is kept rather than lost
        if inhibit_and_normalise(activity, self.global_inhibition) > 0:
            self.activity = activity

    def inject(self, cell: Sequence[float], energy: float) -> None:
        """Add ``energy`` at a fractional ``cell``, split linearly over its 2^d neighbours (NeuroSLAM eq. 11)."""
        whole = np.floor(np.asarray(cell, dtype=float)).astype(int)
        residue = np.asarray(cell, dtype=float) - whole
        corners = self._corners
        weights = np.prod(np.where(corners == 1, residue, 1 - residue), axis=1)
        indices = (whole + corners) % self.shape
        # one corner after another, as a loop over them would (two corners may be one cell on a small axis)
        np.add.at(self.activity, tuple(indices.T), (energy * weights).astype(self.dtype))

    def normalise(self) -> None:
        """Scale the activity to a total of 1 (NeuroSLAM eqs. 5, 16)."""
        self.activity /= self.activity.sum()

    def peak(self) -> tuple[int, ...]:
        """Index of the most active cell."""
        return tuple(int(i) for i in np.unravel_index(int(np.argmax(self.activity)), self.shape))

    def decode(self) -> np.ndarray:
        """Packet centre in fractional cells: circular mean of the activity in a window around the peak."""
        activity = self.activity.reshape(self._padded)
        centre = circular_means(activity, int(np.argmax(activity)), self._radius, self._cosines, self._sines)
        return centre[: self.dimensions]
