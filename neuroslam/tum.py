"""TUM trajectory files: one pose per line, ``timestamp x y z qx qy qz qw`` (metres, seconds).

Quaternions are w-x-y-z inside neuroslam and x-y-z-w in the file, as the format prescribes.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .datasets import DatasetError
from .files import publish

__all__ = ["read_tum", "write_tum", "yaw_quaternion"]


def yaw_quaternion(yaw: np.ndarray) -> np.ndarray:
    """Quaternions (w, x, y, z) of rotations by ``yaw`` (rad) about +z; shape (..., 4)."""
    yaw = np.asarray(yaw, dtype=float)
    zeros = np.zeros_like(yaw)
    return np.stack([np.cos(yaw / 2), zeros, zeros, np.sin(yaw / 2)], axis=-1)


def write_tum(path: str | Path, timestamps: np.ndarray, positions: np.ndarray, quaternions: np.ndarray) -> None:
    """Write a TUM file atomically.

    Args:
        timestamps: (N,) seconds. positions: (N, 3) metres. quaternions: (N, 4) w-x-y-z.
    """
    timestamps = np.asarray(timestamps, dtype=float).reshape(-1)
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    quaternions = np.asarray(quaternions, dtype=float).reshape(-1, 4)
    if not len(timestamps) == len(positions) == len(quaternions):
        raise ValueError(
            f"lengths differ: {len(timestamps)} timestamps, {len(positions)} positions, {len(quaternions)} quaternions"
        )
    rows = np.column_stack([timestamps, positions, quaternions[:, 1:], quaternions[:, :1]])
    path = Path(path)
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "w") as file:
            file.write("# timestamp x y z qx qy qz qw\n")
            # each number as Python's shortest repr that reads back to the same float64 (exact round trip;
            # 9 significant digits would put Unix-time stamps up to 10 s off)
            file.write("".join(" ".join(map(repr, row)) + "\n" for row in rows.tolist()))
        publish(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Read a TUM file; returns (timestamps (N,), positions (N, 3), quaternions (N, 4) w-x-y-z).

    Raises :class:`~neuroslam.datasets.DatasetError` (a ValueError) for a missing or malformed file."""
    try:
        rows = np.loadtxt(path, comments="#", ndmin=2)
    except (OSError, ValueError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        raise DatasetError(f"TUM file {str(path)!r}: cannot read it ({reason})") from None
    if rows.shape[1] != 8:
        raise DatasetError(f"TUM file {str(path)!r}: expected 8 columns (t x y z qx qy qz qw), found {rows.shape[1]}")
    return rows[:, 0], rows[:, 1:4], np.column_stack([rows[:, 7], rows[:, 4:7]])
