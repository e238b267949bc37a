"""The paper's intensity-profile odometry (NeuroSLAM eqs. 27–32): profiles compared at every shift.

A profile is an image region's column (or row) means. NeuroSLAM eq. 27 is the mean absolute difference of two
consecutive frames' profiles at a shift, eq. 28 the shift where it is least (the yaw, eq. 29, and the
speed, eq. 30, follow from it), eqs. 31–32 the same over the rows (the height). :func:`profile_turn` also
says whether the best shift stands out from the others: where it does not, the profile sees no turn.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from ..errors import InvalidParameterError

__all__ = ["best_shift", "profile_turn", "vertical_shift"]

# NeuroSLAM eq. 28's best shift stands out where the profiles' mean absolute difference over the searched shifts (their
# median) is at least this many times the difference at the best one. Sensor noise alone, alike at every
# shift, gives 1.13 (median) and at most 1.31 (measured over 1,500 pairs of uniform images with 1–20 grey
# levels of noise); 1.5 stays clear of it. Near walls, whose parallax no single shift fits, give 1.8–1.9 while
# turning; a thin band of distant structure along an open horizon, 20 (the testbed's frames, medians).
_PROFILE_CONTRAST = 1.5
# and by at least this much (intensity in [0, 1]): a tenth of a grey level of structure in the column means.
# A rendered uniform image's profiles agree exactly, where the ratio above says nothing.
_PROFILE_FLOOR = 0.1 / 255



def best_shift(previous: np.ndarray, current: np.ndarray, max_shift: int, *, circular: bool = False
               ) -> tuple[float, float]:
    """The shift of ``current`` against ``previous`` (1-D profiles) minimising the mean absolute difference.

    NeuroSLAM eq. 27: for a shift s the difference is the mean of |current[n + s] - previous[n]| over the overlap
    (circularly for panoramic profiles). Returns (shift refined by a parabola, difference at the best
    whole shift).
    """
    shifts, differences = _differences(previous, current, max_shift, circular)
    best = int(np.argmin(differences))
    return _refine(shifts, differences, best), float(differences[best])


def profile_turn(previous: np.ndarray, current: np.ndarray, max_shift: int, *, circular: bool = False,
                 bearings: np.ndarray | None = None, max_expansion: float = 0.0) -> tuple[float, bool]:
    """NeuroSLAM eq. 28's best shift of ``current`` against ``previous`` (1-D profiles, samples), and whether it
    stands out: the median of the differences over all searched shifts is at least ``_PROFILE_CONTRAST``
    (1.5) times the difference at the best, and at least ``_PROFILE_FLOOR`` above it. A uniform image's
    profiles differ by sensor noise alone, alike at every shift (the ratio 1.13, at most 1.31); a thin band
    of distant structure along the horizon makes one shift fit and the others not, however small its share
    of the image.

    With ``bearings`` (each sample's angle from the optical axis, rad, increasing) and ``max_expansion`` > 0,
    the shift is found together with the image's expansion (eq. R9): driving forward, what lay at bearing
    θ lies at θ' with tan θ' = e tan θ (e = Z / (Z - d), the travel d toward depth Z), so the previous
    profile is compared at each expansion e in [1 / (1 + E), 1 + E] (E = ``max_expansion``), in steps
    that move the outermost sample by one sample, and at every shift; the best pair's shift is the turn.
    Without it a robot driving toward a wall with more structure on one side reads a turn: the structure
    moves outward, one way."""
    if not (math.isfinite(max_expansion) and max_expansion >= 0):
        raise InvalidParameterError("max_expansion", max_expansion, "must be a finite number >= 0")
    if bearings is not None and len(bearings) != len(current):
        raise InvalidParameterError("bearings", len(bearings), f"must hold one bearing per sample ({len(current)})")
    shifts, differences = _differences(previous, current, max_shift, circular)
    if bearings is not None and max_expansion > 0 and not circular:
        differences = _expanded_differences(previous, current, max_shift, bearings, max_expansion, differences)
    best = int(np.argmin(differences))
    lowest, typical = float(differences[best]), float(np.median(differences))
    stands_out = typical >= _PROFILE_CONTRAST * lowest and typical - lowest >= _PROFILE_FLOOR
    return _refine(shifts, differences, best), stands_out


def _expanded_differences(previous: np.ndarray, current: np.ndarray, max_shift: int, bearings: np.ndarray,
                          max_expansion: float, unexpanded: np.ndarray) -> np.ndarray:
    """Eq. R9: NeuroSLAM eq. 27's differences at every shift for the expansion that fits best, e = 1 (no
    expansion) among them; over the middle samples, which every shift and expansion keep inside the profile
    (``unexpanded`` where there are too few of them or no expansion step fits within ``max_expansion``)."""
    length = len(current)
    outer = float(np.max(np.abs(bearings)))
    step_angle = float(bearings[-1] - bearings[0]) / max(length - 1, 1)
    # tan θ' = e tan θ moves the outermost bearing by sin θ cos θ (e - 1) for a small e - 1: one sample a step
    step = step_angle / max(math.sin(outer) * math.cos(outer), 1e-6)
    count = int(math.ceil(max_expansion / step))
    middle = slice(max_shift, length - max_shift)
    if count < 1 or length - 2 * max_shift < length // 4:
        return unexpanded
    growth = 1.0 + step * np.arange(1, count + 1)
    expansions = np.concatenate([1.0 / growth[::-1], [1.0], growth])
    # what the current frame sees at bearing θ lay at atan(tan θ / e) in the previous one
    source = np.arctan(np.tan(bearings[middle])[None, :] / expansions[:, None])  # (expansions, samples)
    expanded = np.interp(source, bearings, previous).astype(np.float32)
    _, positions, _ = _shift_table(length, max_shift, False)
    shifted = current[positions[:, middle]]  # (shifts, samples), all inside
    table = shifted[None, :, :] - expanded[:, None, :]  # (expansions, shifts, samples)
    np.abs(table, out=table)
    table = table.sum(axis=2) / table.shape[2]  # the mean absolute difference, (expansions, shifts)
    return table[int(np.argmin(table.min(axis=1)))]


def _differences(previous: np.ndarray, current: np.ndarray, max_shift: int, circular: bool
                 ) -> tuple[np.ndarray, np.ndarray]:
    """NeuroSLAM eq. 27 at every shift: (shifts, mean absolute differences over each shift's overlap)."""
    shifts, positions, valid = _shift_table(len(current), max_shift, circular)
    # all shifts at once: |current[n + s] - previous[n]| where n + s falls inside the profile
    differences = (np.abs(current[positions] - previous[None, :]) * valid).sum(axis=1) / valid.sum(axis=1)
    return shifts, differences


@lru_cache(maxsize=32)
def _shift_table(length: int, max_shift: int, circular: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Shifts, the index n + s of every comparison (clipped or wrapped) and whether it is inside."""
    shifts = np.arange(-max_shift, max_shift + 1)
    positions = np.arange(length)[None, :] + shifts[:, None]
    if circular:
        return shifts, positions % length, np.ones(positions.shape, dtype=np.float32)
    valid = ((positions >= 0) & (positions < length)).astype(np.float32)
    return shifts, np.clip(positions, 0, length - 1), valid


def _refine(shifts: np.ndarray, differences: np.ndarray, best: int) -> float:
    """The best shift refined by a parabola through its difference and its neighbours'."""
    shift = float(shifts[best])
    if 0 < best < len(shifts) - 1:
        left, centre, right = (float(v) for v in differences[best - 1: best + 2])
        curvature = left - 2 * centre + right
        if curvature > 0:
            shift += 0.5 * (left - right) / curvature
    return shift


def vertical_shift(previous: np.ndarray, current: np.ndarray, max_shift: int) -> float:
    """Rows ``current`` (2-D) is shifted down against ``previous``, minimising the mean absolute
    difference over the overlap (NeuroSLAM eq. 31), refined by a parabola through the three best shifts."""
    shifts, positions, valid = _shift_table(previous.shape[0], max_shift, False)
    row_differences = np.abs(current[positions] - previous[None]).mean(axis=2)  # (shifts, rows)
    differences = (row_differences * valid).sum(axis=1) / valid.sum(axis=1)
    return _refine(shifts, differences, int(np.argmin(differences)))
