"""4-DoF pose algebra: the one copy.

A pose is ``(x, y, z, yaw)``: a position in metres and a heading in radians about +z (counter-clockwise,
zero along +x), the degrees of freedom NeuroSLAM estimates (the robot's roll and pitch are not part of a
pose). A relative pose is a pose expressed in another pose's frame: its ``x`` ahead of that pose, ``y``
to its left, ``z`` up, ``yaw`` the turn from it. The group operation is the planar rigid motion in
(x, y, yaw) with the heights added:

    compose(a, b) = (a_x + cos a_yaw · b_x − sin a_yaw · b_y,
                     a_y + sin a_yaw · b_x + cos a_yaw · b_y,
                     a_z + b_z,
                     wrap(a_yaw + b_yaw))

``inverse(b)`` undoes ``b`` (``compose(b, inverse(b))`` is the identity) and ``relative(a, c)`` is the
``b`` with ``compose(a, b) = c``. Every function takes one pose, shape (4,), or many, shape (..., 4), and
broadcasts; one pose in gives one pose out, computed with scalar arithmetic (the per-frame path calls
these a few times a frame).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["compose", "inverse", "quarter_wrap", "relative", "wrap"]

_TAU = 2 * np.pi


def wrap(angle: np.ndarray | float) -> np.ndarray | float:
    """``angle`` (rad) wrapped into [-pi, pi); a float for a float, an array for an array."""
    if isinstance(angle, float | int):
        return (angle + math.pi) % _TAU - math.pi
    return (np.asarray(angle, dtype=float) + np.pi) % _TAU - np.pi


def quarter_wrap(angle: np.ndarray | float) -> np.ndarray | float:
    """``angle`` (rad) wrapped into [-pi/4, pi/4): the same direction modulo 90 degrees (a grid of perpendicular
    lines looks the same turned by a quarter); a float for a float, an array for an array."""
    if isinstance(angle, float | int):
        return (angle + math.pi / 4) % (math.pi / 2) - math.pi / 4
    return (np.asarray(angle, dtype=float) + np.pi / 4) % (np.pi / 2) - np.pi / 4


def compose(pose: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """``relative`` (m, rad; in ``pose``'s frame) applied to ``pose`` (m, rad): where it puts the robot.

    Shapes (4,) or (..., 4), broadcast against each other; the yaw is wrapped into [-pi, pi)."""
    pose = np.asarray(pose, dtype=float)
    relative = np.asarray(relative, dtype=float)
    if pose.ndim == 1 and relative.ndim == 1:
        c, s = math.cos(pose[3]), math.sin(pose[3])
        return np.array([pose[0] + c * relative[0] - s * relative[1], pose[1] + s * relative[0] + c * relative[1],
                         pose[2] + relative[2], wrap(float(pose[3] + relative[3]))])
    c, s = np.cos(pose[..., 3]), np.sin(pose[..., 3])
    return np.stack(np.broadcast_arrays(
        pose[..., 0] + c * relative[..., 0] - s * relative[..., 1],
        pose[..., 1] + s * relative[..., 0] + c * relative[..., 1],
        pose[..., 2] + relative[..., 2], wrap(pose[..., 3] + relative[..., 3])), axis=-1)


def inverse(relative: np.ndarray) -> np.ndarray:
    """The relative pose (m, rad) that undoes ``relative``: shape (4,) or (..., 4).

    The yaw is negated, not wrapped (the inverse of a wrapped yaw stays within (-pi, pi])."""
    relative = np.asarray(relative, dtype=float)
    if relative.ndim == 1:
        x, y, z, yaw = relative
        c, s = math.cos(yaw), math.sin(yaw)
        return np.array([-(c * x + s * y), -(-s * x + c * y), -z, -yaw])
    c, s = np.cos(relative[..., 3]), np.sin(relative[..., 3])
    x, y = relative[..., 0], relative[..., 1]
    return np.stack([-(c * x + s * y), -(-s * x + c * y), -relative[..., 2], -relative[..., 3]], axis=-1)


def relative(origin: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose`` (m, rad) seen from ``origin`` (m, rad): the relative pose ``r`` with
    ``compose(origin, r) == pose``. Shapes (4,) or (..., 4), broadcast; the yaw is wrapped into [-pi, pi)."""
    origin = np.asarray(origin, dtype=float)
    pose = np.asarray(pose, dtype=float)
    if origin.ndim == 1 and pose.ndim == 1:
        c, s = math.cos(origin[3]), math.sin(origin[3])
        dx, dy = pose[0] - origin[0], pose[1] - origin[1]
        return np.array([c * dx + s * dy, -s * dx + c * dy, pose[2] - origin[2],
                         wrap(float(pose[3] - origin[3]))])
    c, s = np.cos(origin[..., 3]), np.sin(origin[..., 3])
    dx, dy = pose[..., 0] - origin[..., 0], pose[..., 1] - origin[..., 1]
    return np.stack(np.broadcast_arrays(c * dx + s * dy, -s * dx + c * dy, pose[..., 2] - origin[..., 2],
                                        wrap(pose[..., 3] - origin[..., 3])), axis=-1)
