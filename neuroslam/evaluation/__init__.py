"""Evaluation against ground truth: trajectory alignment and errors (pure math, no I/O)."""

from .trajectory import ate_rmse, umeyama

__all__ = ["ate_rmse", "umeyama"]
