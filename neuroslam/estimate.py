"""What NeuroSLAM says after each frame."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .vision.odometry import SelfMotion

__all__ = ["Estimate"]


@dataclass(frozen=True)
class Estimate:
    """The SLAM state after one frame.

    Attributes:
        timestamp: the frame's time, s.
        pose: (x, y, z, yaw) in the map frame, m and rad.
        experience_id: the current experience. template_id: the active local view cell.
        loop_closure: an existing experience was re-entered this frame.
        new_experience, new_template: created this frame.
        self_motion: the self-motion used for this frame.
        grid_cell: decoded 3D grid-cell packet, fractional cells. head_direction_cell: (yaw, height) cells.
        merged: this frame merged the robot's map into another (a loaded map it recognised).
        floor_lines: the orientation of the floor's straight lines in the robot's frame this frame, rad,
            modulo 90° (eq. M2 of :mod:`neuroslam.vision.structure`); NaN where the floor showed none, or
            where the map does not read them (``experience_map.structure_weight`` 0, a panoramic camera).
    """

    timestamp: float
    pose: np.ndarray
    experience_id: int
    template_id: int
    loop_closure: bool
    new_experience: bool
    new_template: bool
    self_motion: SelfMotion
    grid_cell: np.ndarray
    head_direction_cell: np.ndarray
    merged: bool = False
    floor_lines: float = math.nan
