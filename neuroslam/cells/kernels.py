"""Compiled loops of the attractor networks' frame (:mod:`.attractor`: the spectra's product, the global
inhibition and normalisation, and the packet's read-out) and of the grid network's (:mod:`.grid_network`:
the recurrent input from four quarter-size FFTs, the Euler step and the read-out's Gauss–Newton sums).

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

from ..compiled import JIT as _JIT
from ..compiled import enable_ordered_reductions

__all__ = ["circular_means", "euler_step", "inhibit_and_normalise", "multiply_spectrum", "phase_ramp",
           "polyphase_recurrence", "shift_normal_equations"]

enable_ordered_reductions()  # before the first compilation: loops ending in sums may use the vector units


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


@numba.njit(**_JIT)
def _four_products(kernel_pairs, spectrum_pairs, out_pairs, k, column, p, q, sign):
    """out[k, column] = Σ_d K_d[k, column] · S_d[p, q] (each S_d conjugated where ``sign`` is −1), on the arrays'
    float32 (real, imaginary) views, summed over d = 0 … 3 in order as complex arithmetic would."""
    k0_re, k0_im = kernel_pairs[0, k, 2 * column], kernel_pairs[0, k, 2 * column + 1]
    k1_re, k1_im = kernel_pairs[1, k, 2 * column], kernel_pairs[1, k, 2 * column + 1]
    k2_re, k2_im = kernel_pairs[2, k, 2 * column], kernel_pairs[2, k, 2 * column + 1]
    k3_re, k3_im = kernel_pairs[3, k, 2 * column], kernel_pairs[3, k, 2 * column + 1]
    s0_re, s0_im = spectrum_pairs[0, p, 2 * q], sign * spectrum_pairs[0, p, 2 * q + 1]
    s1_re, s1_im = spectrum_pairs[1, p, 2 * q], sign * spectrum_pairs[1, p, 2 * q + 1]
    s2_re, s2_im = spectrum_pairs[2, p, 2 * q], sign * spectrum_pairs[2, p, 2 * q + 1]
    s3_re, s3_im = spectrum_pairs[3, p, 2 * q], sign * spectrum_pairs[3, p, 2 * q + 1]
    re = (((k0_re * s0_re - k0_im * s0_im) + (k1_re * s1_re - k1_im * s1_im)) + (k2_re * s2_re - k2_im * s2_im)
          + (k3_re * s3_re - k3_im * s3_im))
    im = (((k0_re * s0_im + k0_im * s0_re) + (k1_re * s1_im + k1_im * s1_re)) + (k2_re * s2_im + k2_im * s2_re)
          + (k3_re * s3_im + k3_im * s3_re))
    out_pairs[k, 2 * column] = re
    out_pairs[k, 2 * column + 1] = im


@numba.njit(**_JIT)
def polyphase_recurrence(small_spectra, kernels):
    """The recurrent input's spectrum of the grid network (grid-network eqs. 1–2): Σ_d K_d · FFT(mask_d · s), from
    the real FFTs of the four sub-sheets s[r::2, c::2] (``small_spectra``: (4, m, m // 2 + 1), direction
    d = 2 r + c) instead of four FFTs of the whole masked sheet. With n = 2 m, the whole sheet's spectrum
    of the masked activity at (k, l) is e^{-2πi (k r + l c) / n} S_d[k mod m, l mod m] (the zeros between a
    sub-sheet's neurons make its spectrum repeat); that phase is folded into ``kernels`` ((4, n, n // 2 + 1):
    K_d times it), and S_d beyond m // 2 columns is the complex conjugate of its mirror (the sub-sheet is
    real). Returns the (n, n // 2 + 1) spectrum."""
    rows, columns = kernels.shape[1], kernels.shape[2]
    m = small_spectra.shape[1]
    half = m // 2
    # complex arithmetic written out on float32 (real, imaginary) pairs in complex multiplication's own order (the
    # same numbers bit for bit), the columns in three branch-free runs: half the time of a complex64 loop here
    kernel_pairs, spectrum_pairs = kernels.view(np.float32), small_spectra.view(np.float32)
    out = np.empty((rows, columns), dtype=kernels.dtype)
    out_pairs = out.view(np.float32)
    one = np.float32(1.0)
    for k in range(rows):
        p = k % m
        mirrored = (m - p) % m
        for column in range(half + 1):  # the sub-sheets' own columns
            _four_products(kernel_pairs, spectrum_pairs, out_pairs, k, column, p, column, one)
        for column in range(half + 1, m):  # beyond them: the complex conjugate of the mirror
            _four_products(kernel_pairs, spectrum_pairs, out_pairs, k, column, mirrored, m - column, -one)
        for column in range(m, columns):  # the whole sheet's last column: the spectrum repeats
            _four_products(kernel_pairs, spectrum_pairs, out_pairs, k, column, p, column - m, one)
    return out


@numba.njit(**_JIT)
def euler_step(activity, recurrent, drive, rate):
    """One Euler step of grid-network eq. 1, in place: s ← s + rate (max(Σ W s + B, 0) − s), with the
    recurrent input ``recurrent`` (Σ W s) and ``drive`` (B, grid-network eq. 4)."""
    rows, columns = activity.shape
    for i in range(rows):
        for j in range(columns):
            value = activity[i, j]
            activity[i, j] = value + rate * (max(recurrent[i, j] + drive[i, j], 0.0) - value)


@numba.njit(**_JIT)
def _shift_terms(moved, target, i, up, down, j, left, right, s00, s01, s11, r0, r1):
    """:func:`shift_normal_equations`' sums with the cell (i, j) added (its neighbours' indices given)."""
    g0 = (moved[down, j] - moved[up, j]) / 2
    g1 = (moved[i, right] - moved[i, left]) / 2
    residual = target[i, j] - moved[i, j]
    return s00 + g0 * g0, s01 + g0 * g1, s11 + g1 * g1, r0 + g0 * residual, r1 + g1 * residual


@numba.njit(**_JIT)
def shift_normal_equations(moved, target):
    """The read-out's Gauss–Newton system (grid-network paper, Table I, refined below a cell): with the central
    differences g_0, g_1 of ``moved`` along its two axes (wrapping around), the normal matrix
    [[Σ g_0², Σ g_0 g_1], [Σ g_0 g_1, Σ g_1²]] and the right-hand side −(Σ g_0 r, Σ g_1 r), r = target − moved."""
    rows, columns = moved.shape
    s00 = s01 = s11 = r0 = r1 = 0.0
    for i in range(rows):
        up, down = (i - 1) % rows, (i + 1) % rows
        # the columns in order, the wrapped neighbours of the first and last apart: the inner run without a modulo
        s00, s01, s11, r0, r1 = _shift_terms(moved, target, i, up, down, 0, columns - 1, 1 % columns,
                                             s00, s01, s11, r0, r1)
        for j in range(1, columns - 1):
            s00, s01, s11, r0, r1 = _shift_terms(moved, target, i, up, down, j, j - 1, j + 1, s00, s01, s11, r0, r1)
        if columns > 1:
            s00, s01, s11, r0, r1 = _shift_terms(moved, target, i, up, down, columns - 1, columns - 2, 0,
                                                 s00, s01, s11, r0, r1)
    return np.array([[s00, s01], [s01, s11]]), -np.array([r0, r1])


@numba.njit(**_JIT)
def phase_ramp(spectrum, rows, columns, shift_0, shift_1):
    """``spectrum`` (the real FFT of a ``rows`` × ``columns`` sheet) times the phase ramp of a circular shift by
    (``shift_0``, ``shift_1``) cells: e^{-2πi (k shift_0 / rows + l shift_1 / columns)}, as a new array (the
    Fourier shift theorem)."""
    count_rows, count_columns = spectrum.shape
    out = np.empty_like(spectrum)
    ramp_columns = np.empty(count_columns, dtype=spectrum.dtype)
    for column in range(count_columns):
        angle = -2 * math.pi * column / columns * shift_1
        ramp_columns[column] = complex(math.cos(angle), math.sin(angle))
    for k in range(count_rows):
        frequency = k if k < (rows + 1) // 2 else k - rows  # numpy's fftfreq order
        angle = -2 * math.pi * frequency / rows * shift_0
        ramp_row = complex(math.cos(angle), math.sin(angle))
        for column in range(count_columns):
            out[k, column] = spectrum[k, column] * ramp_row * ramp_columns[column]
    return out
