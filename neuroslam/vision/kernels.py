"""Compiled inner loops of the visual odometry: one pass over the pixels per Gauss–Newton iteration.

The direct alignments of :mod:`.ground_motion` (eqs. G1–G4) and :mod:`.pitch` (eqs. R1–R2) spend their time in
per-pixel arithmetic on a few thousand pixels: project each through the motion, sample the previous image and
its gradients bilinearly, form the residual, the Jacobian and the Huber weight, and sum the normal equations.
Written with numpy arrays, each iteration is some forty passes over the pixels and as many temporary arrays
(about 0.3 ms at 160 × 120 on this project's machine, most of it in call overhead and fancy indexing); here it
is one loop, compiled by numba, whose cost is the arithmetic (about 10 µs). The equations are the modules'
own; the sums are accumulated in float64 (the numpy forms summed float32 arrays), so results agree with the
numpy forms to about 1e-6 relative, not bit for bit.

The functions are compiled on first use and cached on disk (numba's ``cache=True``: beside this file where
it is writable, else in the user's cache directory), so a new process pays the compilation (a few seconds)
once per machine.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["ground_align", "rotation_cost", "rotation_solve", "sample_bilinear"]

_JIT = {"cache": True, "nogil": True, "error_model": "numpy"}


@numba.njit(inline="always", **_JIT)
def _sample(stack, u, v):
    """Bilinear samples of the three channels of ``stack`` (3, rows, columns) at (u, v), clamped as
    :func:`sample_bilinear` clamps."""
    rows, columns = stack.shape[1], stack.shape[2]
    u = min(max(u, 0.0), columns - 1.001)
    v = min(max(v, 0.0), rows - 1.001)
    u0, v0 = int(u), int(v)
    fu, fv = u - u0, v - v0
    out0 = out1 = out2 = 0.0
    for channel in range(3):
        top_left, top_right = stack[channel, v0, u0], stack[channel, v0, u0 + 1]
        bottom_left, bottom_right = stack[channel, v0 + 1, u0], stack[channel, v0 + 1, u0 + 1]
        top = top_left + fu * (top_right - top_left)
        value = top + fv * (bottom_left + fu * (bottom_right - bottom_left) - top)
        if channel == 0:
            out0 = value
        elif channel == 1:
            out1 = value
        else:
            out2 = value
    return out0, out1, out2


@numba.njit(**_JIT)
def sample_bilinear(stack, u, v):
    """Bilinear samples of every channel of a (3, rows, columns) ``stack`` at pixel positions (u, v) (column,
    row), each clamped to [0, size − 1.001]; returns (3, N) float64."""
    out = np.empty((3, u.shape[0]))
    for k in range(u.shape[0]):
        out[0, k], out[1, k], out[2, k] = _sample(stack, u[k], v[k])
    return out


@numba.njit(**_JIT)
def ground_align(old, target, ground_x, ground_y, flow, focal, centre_u, centre_v, height, forward, distance, turn,
                 prior_distance, prior_turn, weight_distance, weight_turn, prior_weight, min_information, crosswise,
                 robust_scale, iterations, tolerance, near_only):
    """Gauss–Newton on eq. G3 (or, with ``near_only``, eq. G4's yaw alone) at one resolution.

    ``old``: the previous image's (3, rows, columns) stack (blurred image, horizontal and vertical gradient);
    ``target``: the current image's intensity at the floor pixels; ``ground_x``, ``ground_y``: their ground
    points q (m, eq. G1); ``flow``: |d pi / dd|² of eq. G6 (px² / m²); ``focal``, ``centre_u``, ``centre_v``:
    px; ``height``: the plane below (positive) or above (negative) the camera, m; ``forward``: the camera
    ahead of the turning axis, m; (``distance``, ``turn``): the start, m and rad; (``prior_distance``,
    ``prior_turn``): eq. G3's prior; ``weight_distance``, ``weight_turn``: its weights (robust_scale / s)²;
    ``prior_weight``: the distance's weight after eq. G3a; ``min_information``: in the prior's weights;
    ``crosswise``: sin²(aperture) of eq. G6 (0: every pixel counts); ``tolerance``: stop once an update is below
    tolerance × (0.1 mm, 0.01 mrad); ``near_only``: eq. G4.

    Returns (distance, turn, information on the distance (eq. G6's, in the prior's weights), information on the
    yaw (in its prior's weight), support (share of the pixels in view), the near floor's Σ w J_w², iterations).
    Each information and the support are the last linearisation's; −1 where no iteration set them.
    """
    rows, columns = old.shape[1], old.shape[2]
    limit_u, limit_v = columns - 1.001, rows - 1.001
    count = target.shape[0]
    information_distance = information_turn = support = near_information = -1.0
    done = 0
    for _ in range(iterations):
        done += 1
        c, s = math.cos(turn), math.sin(turn)
        ch, sh = math.cos(turn / 2), math.sin(turn / 2)
        a11 = a12 = a22 = seen = b_distance = b_turn = 0.0
        visible_count = 0
        for k in range(count):
            qx, qy = ground_x[k], ground_y[k]
            px = distance * ch + c * qx - s * qy  # eq. G2
            py = distance * sh + s * qx + c * qy
            ahead = px - forward
            visible = ahead > 0.2
            inverse = 1.0 / max(ahead, 0.2)
            u = centre_u - focal * py * inverse  # eq. G1
            v = centre_v + focal * height * inverse
            visible = visible and u >= 0 and u <= limit_u and v >= 0 and v <= limit_v
            if not visible:  # its Huber weight is 0: it adds nothing
                continue
            visible_count += 1
            intensity, gradient_u, gradient_v = _sample(old, u, v)
            residual = intensity - target[k]
            d_py = -focal * gradient_u * inverse
            d_px = -(d_py * py + focal * height * gradient_v * inverse) * inverse
            jacobian_turn = d_px * (-distance / 2 * sh - s * qx - c * qy) + d_py * (distance / 2 * ch + c * qx - s * qy)
            weight = robust_scale / max(abs(residual), robust_scale)
            wt = weight * jacobian_turn
            a22 += wt * jacobian_turn
            b_turn += wt * residual
            if near_only:
                continue
            jacobian_distance = d_px * ch + d_py * sh
            wd = weight * jacobian_distance
            squared = jacobian_distance * jacobian_distance
            a11 += wd * jacobian_distance
            a12 += wd * jacobian_turn
            b_distance += wd * residual
            if crosswise > 0:  # eq. G6: the pixels whose gradient runs across their image motion
                if squared >= crosswise * (gradient_u * gradient_u + gradient_v * gradient_v) * flow[k]:
                    seen += weight * squared
        if near_only:  # eq. G4: the yaw alone, the distance held
            near_information = a22
            delta_turn = -(b_turn + weight_turn * (turn - prior_turn)) / (a22 + weight_turn)
            turn += delta_turn
            if abs(delta_turn) < 1e-5 * tolerance:
                break
            continue
        if crosswise <= 0:
            seen = a11
        information_distance, information_turn = seen / weight_distance, a22 / weight_turn
        if seen < min_information * weight_distance:  # the floor does not see the distance: the prior's
            a11 = a12 = b_distance = 0.0
        b1 = b_distance + prior_weight * (distance - prior_distance)
        b2 = b_turn + weight_turn * (turn - prior_turn)
        n11, n22 = a11 + prior_weight, a22 + weight_turn
        determinant = n11 * n22 - a12 * a12  # positive: the prior keeps the 2 x 2 system regular
        delta_distance = -(n22 * b1 - a12 * b2) / determinant
        delta_turn = -(n11 * b2 - a12 * b1) / determinant
        distance += delta_distance
        turn += delta_turn
        support = visible_count / max(count, 1)
        if abs(delta_distance) < 1e-4 * tolerance and abs(delta_turn) < 1e-5 * tolerance:
            break
    return distance, turn, information_distance, information_turn, support, near_information, done


@numba.njit(inline="always", **_JIT)
def _rotation_pixel(previous, x, y, focal, cy, sy, cp, sp, expansion, centre_u, centre_v, limit_u, limit_v):
    """Eq. R1 at one pixel (x, y): (visible, intensity, gradient_u, gradient_v, rx, py, pz, inverse, scale)."""
    py, pz = cp * y - sp * focal, sp * y + cp * focal  # R_pitch r (x unchanged)
    rx, rz = cy * x - sy * pz, sy * x + cy * pz  # R_yaw (x, py, pz)
    inverse = 1.0 / rz
    scale = (1.0 - expansion) * focal
    u = scale * rx * inverse + centre_u
    v = scale * py * inverse + centre_v
    visible = u >= 0 and u <= limit_u and v >= 0 and v <= limit_v
    intensity, gradient_u, gradient_v = _sample(previous, u, v)
    return visible, intensity, gradient_u, gradient_v, rx, py, pz, inverse, scale


@numba.njit(**_JIT)
def rotation_normal(previous, target, x, y, labels, parameters, focal, robust_scale):
    """The Huber-weighted normal equations of eq. R2 at ``parameters`` = (yaw, pitch, e_0 … e_{K−1}), each pixel
    (x, y from the image centre, px) with its own expansion e_labels[k]: (normal (2+K, 2+K), gradient (2+K))."""
    size = parameters.shape[0]
    normal = np.zeros((size, size))
    gradient = np.zeros(size)
    rows, columns = previous.shape[1], previous.shape[2]
    centre_u, centre_v = columns / 2 - 0.5, rows / 2 - 0.5
    limit_u, limit_v = columns - 1.001, rows - 1.001
    yaw, pitch = parameters[0], parameters[1]
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    for k in range(target.shape[0]):
        label = 2 + labels[k]
        visible, intensity, gradient_u, gradient_v, rx, py, pz, inverse, scale = _rotation_pixel(
            previous, x[k], y[k], focal, cy, sy, cp, sp, parameters[label], centre_u, centre_v, limit_u, limit_v)
        if not visible:
            continue
        residual = intensity - target[k]
        weight = robust_scale / max(abs(residual), robust_scale)
        # derivatives of (rx, py, rz) and then of (u, v) = scale (rx, py) / rz
        d_rx, d_rz = -sy * x[k] - cy * pz, cy * x[k] - sy * pz
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (-py * inverse * d_rz) * inverse
        j_yaw = gradient_u * du + gradient_v * dv
        d_pitch_y, d_pitch_z = -sp * y[k] - cp * focal, cp * y[k] - sp * focal
        d_rx, d_rz = -sy * d_pitch_z, cy * d_pitch_z
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (d_pitch_y - py * inverse * d_rz) * inverse
        j_pitch = gradient_u * du + gradient_v * dv
        j_expansion = -(gradient_u * rx + gradient_v * py) * focal * inverse  # d/de of the pixel's own e
        w_yaw, w_pitch, w_expansion = weight * j_yaw, weight * j_pitch, weight * j_expansion
        normal[0, 0] += w_yaw * j_yaw
        normal[0, 1] += w_yaw * j_pitch
        normal[1, 1] += w_pitch * j_pitch
        normal[0, label] += w_yaw * j_expansion
        normal[1, label] += w_pitch * j_expansion
        normal[label, label] += w_expansion * j_expansion
        gradient[0] += w_yaw * residual
        gradient[1] += w_pitch * residual
        gradient[label] += w_expansion * residual
    for row in range(size):
        for column in range(row):
            normal[row, column] = normal[column, row]
    return normal, gradient


@numba.njit(**_JIT)
def rotation_cost(previous, target, x, y, labels, parameters, focal, robust_scale):
    """Eq. R2's mean Huber cost over the pixels that land inside the previous image, and their share:
    (cost, support)."""
    rows, columns = previous.shape[1], previous.shape[2]
    centre_u, centre_v = columns / 2 - 0.5, rows / 2 - 0.5
    limit_u, limit_v = columns - 1.001, rows - 1.001
    yaw, pitch = parameters[0], parameters[1]
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    total, visible_count = 0.0, 0
    for k in range(target.shape[0]):
        visible, intensity, _, _, _, _, _, _, _ = _rotation_pixel(
            previous, x[k], y[k], focal, cy, sy, cp, sp, parameters[2 + labels[k]], centre_u, centre_v,
            limit_u, limit_v)
        if not visible:
            continue
        visible_count += 1
        size = abs(intensity - target[k])
        total += 0.5 * size * size if size < robust_scale else robust_scale * (size - 0.5 * robust_scale)
    count = target.shape[0]
    return total / max(visible_count, 1), visible_count / max(count, 1)


@numba.njit(**_JIT)
def rotation_solve(previous, target, x, y, labels, start, focal, robust_scale, iterations, damping, tolerance):
    """Gauss–Newton on eq. R2 from ``start`` (yaw, pitch, e_0 … e_{K−1}), at most ``iterations`` times, until the
    yaw and pitch updates are below ``tolerance`` rad; the normal equations damped by ``damping`` × identity.
    Returns (parameters, the marginal information on each: 1 / diag(normal⁻¹) at the last linearisation,
    iterations done)."""
    parameters = start.copy()
    size = parameters.shape[0]
    information = np.zeros(size)
    done = 0
    for _ in range(iterations):
        done += 1
        normal, gradient = rotation_normal(previous, target, x, y, labels, parameters, focal, robust_scale)
        for k in range(size):
            normal[k, k] += damping
        update = -np.linalg.solve(normal, gradient)
        inverse = np.linalg.inv(normal)
        for k in range(size):
            information[k] = 1.0 / max(inverse[k, k], 1e-12)
        parameters += update
        if max(abs(update[0]), abs(update[1])) < tolerance:  # the expansions are nuisance parameters
            break
    return parameters, information, done
