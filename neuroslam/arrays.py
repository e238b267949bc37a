"""Arrays that grow a row at a time: the map's and the trajectory's storage."""

from __future__ import annotations

import numpy as np

__all__ = ["GrowingArray"]


class GrowingArray:
    """A contiguous array that doubles its capacity as rows are appended (amortised O(1) a row).

    ``columns`` 0 makes a 1-D array; :attr:`view` is the filled part (a view, not a copy)."""

    def __init__(self, columns: int, dtype: type):
        self.data = np.zeros((64, columns) if columns else 64, dtype=dtype)
        self.count = 0

    def append(self, row) -> None:
        if self.count == len(self.data):
            self.data = np.concatenate([self.data, np.zeros_like(self.data)])
        self.data[self.count] = row
        self.count += 1

    def extend(self, rows: np.ndarray) -> None:
        """Append several rows at once."""
        rows = np.asarray(rows, dtype=self.data.dtype)
        while self.count + len(rows) > len(self.data):
            self.data = np.concatenate([self.data, np.zeros_like(self.data)])
        self.data[self.count: self.count + len(rows)] = rows
        self.count += len(rows)

    @property
    def view(self) -> np.ndarray:
        return self.data[: self.count]

    @classmethod
    def of(cls, rows: np.ndarray, columns: int, dtype: type) -> GrowingArray:
        """A growing array holding a copy of ``rows`` (capacity at least 64)."""
        rows = np.asarray(rows, dtype=dtype)
        expected = (len(rows), columns) if columns else (len(rows),)
        if rows.shape != expected:
            raise ValueError(f"shape {rows.shape}, expected {expected}")
        grown = cls(columns, dtype)
        if len(rows) > len(grown.data):
            grown.data = np.zeros((len(rows), *grown.data.shape[1:]), dtype=dtype)
        grown.data[: len(rows)] = rows
        grown.count = len(rows)
        return grown
