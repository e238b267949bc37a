"""The vision module: preprocessing, visual odometry ("aidvo") and local view cells."""

from .local_view import LocalViewCells, ViewMatch
from .odometry import SelfMotion, VisualOdometry
from .preprocessing import crop, grey, noise_deviation, patch_normalise, resize

__all__ = [
    "LocalViewCells", "SelfMotion", "ViewMatch", "VisualOdometry", "crop", "grey", "noise_deviation", "patch_normalise",
    "resize",
]
