"""Compiled loops of the attractor networks' frame (:mod:`.attractor`): the spectra's product, the global
inhibition and normalisation, and the packet's read-out.

Written with numpy, each of these is several passes over the network's cells (36,864 for the grid cells) and
as many temporary arrays; here each is one loop, compiled by numba (cached on disk like
:mod:`neuroslam.vision.kernels`). Networks of one to three axes are handled as three-axis arrays (a missing
axis has one cell). The arithmetic is the numpy forms' own, in the same order, except that the sums
(the total activity, the read-out's circular means) are accumulated in float64.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["circular_means", "inhibit_and_normalise", "multiply_spectrum"]

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(**_JIT)
def multiply_spectrum(spectrum, kernel, factor_0, factor_1, factor_2):
    """``spectrum`` (three axes, complex) times ``kernel`` (its shape) times the per-axis factors ``factor_a``
    (one value per index of axis a), in place: steps 1–3 of the frame (NeuroSLAM eqs. 2–9, 13–20)."""
    first, second, third = spectrum.shape
    for i in range(first):
        for j in range(second):
            for k in range(third):
                spectrum[i, j, k] = spectrum[i, j, k] * kernel[i, j, k] * factor_0[i] * factor_1[j] * factor_2[k]


@numba.njit(**_JIT)
def inhibit_and_normalise(activity, global_inhibition):
    """Step 4 and 6 of the frame (NeuroSLAM eqs. 4–5, 15–16) in place on ``activity`` (any shape, float):
    ``global_inhibition`` subtracted everywhere, negative activity clipped to 0, then the total scaled to 1.
    Returns the total before scaling; where it is 0 or less nothing is scaled (the caller keeps its previous
    activity)."""
    flat = activity.ravel()
    inhibition = flat.dtype.type(global_inhibition)
    total = 0.0
    for k in range(flat.shape[0]):
        value = max(flat[k] - inhibition, 0)
        flat[k] = value
        total += value
    if total > 0:
        scale = flat.dtype.type(total)
        for k in range(flat.shape[0]):
            flat[k] /= scale
    return total


@numba.njit(**_JIT)
def circular_means(activity, peak, radius, cosines, sines):
    """The packet's centre on each axis of a three-axis ``activity``: the circular mean of the activity in the
    window of ``radius[a]`` cells either side of the cell ``peak`` (a flat index: the most active cell; a radius
    of 0 for an axis of one cell), over each axis's cells at angles 2π i / n (``cosines[a, i]``,
    ``sines[a, i]``). Returns the centre in fractional cells, one per axis."""
    sizes = activity.shape
    centre_cell = (peak // (sizes[1] * sizes[2]), (peak // sizes[2]) % sizes[1], peak % sizes[2])
    sums_cos = np.zeros(3)
    sums_sin = np.zeros(3)
    for di in range(-radius[0], radius[0] + 1):
        i = (centre_cell[0] + di) % sizes[0]
        for dj in range(-radius[1], radius[1] + 1):
            j = (centre_cell[1] + dj) % sizes[1]
            for dk in range(-radius[2], radius[2] + 1):
                k = (centre_cell[2] + dk) % sizes[2]
                value = float(activity[i, j, k])
                sums_cos[0] += value * cosines[0, i]
                sums_sin[0] += value * sines[0, i]
                sums_cos[1] += value * cosines[1, j]
                sums_sin[1] += value * sines[1, j]
                sums_cos[2] += value * cosines[2, k]
                sums_sin[2] += value * sines[2, k]
    centre = np.empty(3)
    for axis in range(3):
        angle = math.atan2(sums_sin[axis], sums_cos[axis])
        centre[axis] = (angle * sizes[axis] / (2 * math.pi)) % sizes[axis]
    return centre
