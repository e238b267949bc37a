"""Compiled inner loops of the visual odometry: one pass over the pixels per Gauss–Newton iteration.

The direct alignments of :mod:`.ground_motion` (eqs. G1–G4) and :mod:`.pitch` (eqs. R1–R2) spend their time in
per-pixel arithmetic on a few thousand pixels: project each through the motion, sample the previous image and
its gradients bilinearly, form the residual, the Jacobian and the Huber weight, and sum the normal equations.
Written with numpy arrays, each iteration is some forty passes over the pixels and as many temporary arrays
(about 0.3 ms at 160 × 120 on this project's machine, most of it in call overhead and fancy indexing); here it
is one loop, compiled by numba. The loop over the pixels is written without branches, in float32 (the images'
own precision, and the numpy forms' arrays), its sums in IEEE order, and runs on the vector units with its sums
as ordered reductions (:mod:`neuroslam.compiled`; about 8 ns a pixel against about 21 scalar on this
project's machine, the same results bit for bit). The equations are the modules' own;
the sums' rounding differs from the numpy forms' (both float32 sums over a few thousand terms, about 1e-5
relative), so results agree with them to that, not bit for bit. The iterations' bookkeeping (the 2 × 2, 3 × 3 or
18 × 18 solves, the prior, the stopping tests) is in float64.

The functions are compiled on first use and cached on disk (numba's ``cache=True``: beside this file where
it is writable, else in the user's cache directory), so a new process pays the compilation (a few seconds)
once per machine.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..compiled import JIT as _JIT
from ..compiled import enable_ordered_reductions

__all__ = ["ground_align", "rotation_cost", "rotation_solve", "sample_bilinear"]

enable_ordered_reductions()  # before the first compilation: the per-pixel loops run on the vector units


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


# not numba's inline="always": inlined by numba the loops calling it were not vectorised (LLVM saw a call);
# compiled as a function of its own, LLVM inlines it and vectorises the loops
@numba.njit(**_JIT)
def _sample32(flat_image, flat_u, flat_v, columns, u, v, limit_u, limit_v):
    """Bilinear samples (float32) of a flattened image and its two gradient images at (u, v), each clamped to
    [0, limit]: the per-pixel passes' form of :func:`sample_bilinear`, without branches."""
    f32 = np.float32
    u, v = min(max(u, f32(0.0)), limit_u), min(max(v, f32(0.0)), limit_v)
    u0, v0 = np.int32(u), np.int32(v)
    fu, fv = u - f32(u0), v - f32(v0)
    i = v0 * columns + u0
    j = i + columns
    top = flat_image[i] + fu * (flat_image[i + 1] - flat_image[i])
    intensity = top + fv * (flat_image[j] + fu * (flat_image[j + 1] - flat_image[j]) - top)
    top = flat_u[i] + fu * (flat_u[i + 1] - flat_u[i])
    gradient_u = top + fv * (flat_u[j] + fu * (flat_u[j + 1] - flat_u[j]) - top)
    top = flat_v[i] + fu * (flat_v[i + 1] - flat_v[i])
    gradient_v = top + fv * (flat_v[j] + fu * (flat_v[j + 1] - flat_v[j]) - top)
    return intensity, gradient_u, gradient_v


@numba.njit(inline="always", **_JIT)
def _floor_sums(old, target, target_u, target_v, ground_x, ground_y, flow, focal, centre_u, centre_v, height,
                forward, distance, turn, robust_scale, crosswise):
    """One pass of eqs. G1–G3 over the floor pixels at (``distance``, ``turn``): the Huber-weighted normal
    equations' entries (a11, a12, a22: on (d, w)), their right-hand sides (Σ w J_d r, Σ w J_w r), eq. G6's
    information on the distance (its pixels alone, where ``crosswise`` > 0), the pixels in view, and eq. G8's
    information on the distance (Σ w J_d J'_d over the same pixels, J'_d from the current image's gradients
    ``target_u``, ``target_v`` at the floor pixels; and over every pixel), and the sums of its terms' squares
    (the same two)."""
    rows, columns = old.shape[1], old.shape[2]
    flat_image, flat_u, flat_v = old[0].ravel(), old[1].ravel(), old[2].ravel()
    f32 = np.float32
    limit_u, limit_v = f32(columns - 1.001), f32(rows - 1.001)
    c, s = f32(math.cos(turn)), f32(math.sin(turn))
    ch, sh = f32(math.cos(turn / 2)), f32(math.sin(turn / 2))
    d, f, h, a = f32(distance), f32(focal), f32(height), f32(forward)
    cu, cv, scale, across_share = f32(centre_u), f32(centre_v), f32(robust_scale), f32(crosswise)
    zero, near = f32(0.0), f32(0.2)
    a11 = a12 = a22 = b_distance = b_turn = seen = visible_count = zero
    shared = shared_across = squares = squares_across = residual_squares = zero
    for k in range(target.shape[0]):
        qx, qy = ground_x[k], ground_y[k]
        px = d * ch + c * qx - s * qy  # eq. G2
        py = d * sh + s * qx + c * qy
        ahead = px - a
        inverse = f32(1.0) / max(ahead, near)
        u = cu - f * py * inverse  # eq. G1
        v = cv + f * h * inverse
        visible = (ahead > near) & (u >= zero) & (u <= limit_u) & (v >= zero) & (v <= limit_v)
        # bilinear samples of the image and its gradients, clamped (an unseen pixel's weight is 0 below)
        intensity, gradient_u, gradient_v = _sample32(flat_image, flat_u, flat_v, columns, u, v, limit_u, limit_v)
        residual = intensity - target[k]
        d_py = -f * gradient_u * inverse  # the chain rule through eqs. G1 and G2
        d_px = -(d_py * py + f * h * gradient_v * inverse) * inverse
        jacobian_turn = d_px * (-d / 2 * sh - s * qx - c * qy) + d_py * (d / 2 * ch + c * qx - s * qy)
        jacobian_distance = d_px * ch + d_py * sh
        weight = scale / max(abs(residual), scale)  # Huber: 1 inside, scale / |r| outside
        weight = weight if visible else zero
        visible_count += f32(1.0) if visible else zero
        wd, wt = weight * jacobian_distance, weight * jacobian_turn
        squared = jacobian_distance * jacobian_distance
        a11 += wd * jacobian_distance
        a12 += wd * jacobian_turn
        a22 += wt * jacobian_turn
        b_distance += wd * residual
        b_turn += wt * residual
        # eq. G6: the pixels whose gradient runs across their image motion
        across = squared >= across_share * (gradient_u * gradient_u + gradient_v * gradient_v) * flow[k]
        seen += weight * squared if across else zero
        # eq. G8: the current image's own derivative along the same motion, at its pixel (eqs. G1, G2 at rest)
        inverse_now = f32(1.0) / max(qx - a, near)
        d_py_now = -f * target_u[k] * inverse_now
        d_px_now = -(d_py_now * qy + f * h * target_v[k] * inverse_now) * inverse_now
        jacobian_now = d_px_now * ch + d_py_now * sh
        product = wd * jacobian_now
        shared += product
        shared_across += product if across else zero
        # eq. G8's variance under image noise, per unit of the gradients' noise variance
        spread = weight * weight * flow[k] * (squared + jacobian_now * jacobian_now)
        squares += spread
        squares_across += spread if across else zero
        residual_squares += residual * residual if visible else zero
    return (float(a11), float(a12), float(a22), float(b_distance), float(b_turn), float(seen),
            int(visible_count), float(shared), float(shared_across), float(squares), float(squares_across),
            float(residual_squares))


@numba.njit(**_JIT)
def ground_align(old, target, target_u, target_v, ground_x, ground_y, flow, focal, centre_u, centre_v, height,
                 forward, distance, turn, prior_distance, prior_turn, weight_distance, weight_turn, prior_weight,
                 min_information, crosswise, robust_scale, iterations, tolerance, near_only, shared, noise_area,
                 smoothing):
    """Gauss–Newton on eq. G3 (or, with ``near_only``, eq. G4's yaw alone) at one resolution.

    ``old``: the previous image's (3, rows, columns) stack (blurred image, horizontal and vertical gradient);
    ``target``: the current image's intensity at the floor pixels, ``target_u``, ``target_v`` its gradients there
    (read only with ``shared``); ``ground_x``, ``ground_y``: their ground
    points q (m, eq. G1); ``flow``: |d pi / dd|² of eq. G6 (px² / m²); ``focal``, ``centre_u``, ``centre_v``:
    px; ``height``: the plane below (positive) or above (negative) the camera, m; ``forward``: the camera
    ahead of the turning axis, m; (``distance``, ``turn``): the start, m and rad; (``prior_distance``,
    ``prior_turn``): eq. G3's prior; ``weight_distance``, ``weight_turn``: its weights (robust_scale / s)²;
    ``prior_weight``: the distance's weight after eq. G3a; ``min_information``: in the prior's weights;
    ``crosswise``: sin²(aperture) of eq. G6 (0: every pixel counts); ``tolerance``: stop once an update is below
    tolerance × (0.1 mm, 0.01 mrad); ``near_only``: eq. G4; ``shared``: the information on the distance is eq.
    G8's (the part both images share, where it stands out of its own noise), not eq. G3's (the previous image's
    alone); ``noise_area``: how many floor pixels one pixel's noise reaches (the blur's), for eq. G8's test.

    Returns (distance, turn, information on the distance (eq. G6's, or with ``shared`` eq. G8's where it stands
    out and 0 where not, in the prior's weights), information on the yaw (in its prior's weight), support (share
    of the pixels in view), the near floor's Σ w J_w², iterations, eq. G8's standing z (0 without ``shared``)).
    Each information and the support are the last linearisation's; −1 where no iteration set them.
    """
    count = target.shape[0]
    information_distance = information_turn = support = near_information = -1.0
    standing = 0.0
    done = 0
    start_distance, start_turn = distance, turn
    held = False  # eq. G8 refused what eq. G3 saw: solved again with the distance the prior's
    for _attempt in range(2):
        common_across = squares_across = residual_squares = visible_count = 0.0
        for _ in range(iterations):
            done += 1
            (a11, a12, a22, b_distance, b_turn, seen, visible_count, common, common_across, squares, squares_across,
             residual_squares) = _floor_sums(
                old, target, target_u, target_v, ground_x, ground_y, flow, focal, centre_u, centre_v, height,
                forward, distance, turn, robust_scale, crosswise)
            if near_only:  # eq. G4: the yaw alone, the distance held
                near_information = a22
                delta_turn = -(b_turn + weight_turn * (turn - prior_turn)) / (a22 + weight_turn)
                turn += delta_turn
                if abs(delta_turn) < 1e-5 * tolerance:
                    break
                continue
            if crosswise <= 0:  # every pixel counts
                seen, common_across, squares_across = a11, common, squares
            information_distance, information_turn = seen / weight_distance, a22 / weight_turn
            if held or seen < min_information * weight_distance:  # the floor does not see the distance: the prior's
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
        if not shared or near_only or held or done == 0:
            break
        # eq. G8 at the solution (the last linearisation): the information both images share, where it stands
        # out of its own noise by three standard errors. The gradients' noise variance comes from the residuals':
        # two images under noise sigma_n, blurred by s, differ by 2 sigma_n² / (4 pi s²); the gradient of one
        # has sigma_n² / (8 pi s⁴) per axis, a quarter s² of that difference
        gradient_noise = residual_squares / max(visible_count, 1.0) / (4.0 * smoothing * smoothing)
        standing = common_across / max(math.sqrt(squares_across * noise_area * gradient_noise), 1e-30)
        shared_information = common_across / weight_distance if standing > 3.0 else 0.0
        if information_distance < min_information or shared_information >= min_information:
            information_distance = shared_information
            break
        held, distance, turn = True, start_distance, start_turn
    if held:
        information_distance = 0.0
    return distance, turn, information_distance, information_turn, support, near_information, done, standing


@numba.njit(inline="always", **_JIT)
def _rotation_sums(previous, target, x, y, yaw, pitch, expansion, focal, robust_scale):
    """One pass of eqs. R1–R2 over the region's pixels (x, y from the image centre, px, float32), every one with
    the one ``expansion``. Returns the Huber-weighted normal equations' entries on (yaw, pitch, e), the Huber
    cost's sum over the pixels in view, and their count, as one float64 array: [yaw·yaw, yaw·pitch,
    pitch·pitch, yaw·r, pitch·r, yaw·e, pitch·e, e·e, e·r, the cost's sum, the count]. Written without branches
    and compiled to a loop on the vector units (:func:`_rotation_blocks` takes any number of expansions)."""
    rows, columns = previous.shape[1], previous.shape[2]
    flat_image, flat_u, flat_v = previous[0].ravel(), previous[1].ravel(), previous[2].ravel()
    f32 = np.float32
    f, scale_huber = f32(focal), f32(robust_scale)
    centre_u, centre_v = f32(columns / 2 - 0.5), f32(rows / 2 - 0.5)
    limit_u, limit_v = f32(columns - 1.001), f32(rows - 1.001)
    cy, sy, cp, sp = f32(math.cos(yaw)), f32(math.sin(yaw)), f32(math.cos(pitch)), f32(math.sin(pitch))
    e0 = f32(expansion)
    zero, one = f32(0.0), f32(1.0)
    yy = yp = pp = yr = pr = cost = visible_count = zero
    ye0 = pe0 = ee0 = er0 = zero
    for k in range(target.shape[0]):
        xk, yk = x[k], y[k]
        py, pz = cp * yk - sp * f, sp * yk + cp * f  # R_pitch r (x unchanged)
        rx, rz = cy * xk - sy * pz, sy * xk + cy * pz  # R_yaw (x, py, pz)
        # a ray turned more than about 84 degrees off the axis (rz below f / 10) lands more than ten focal
        # lengths off the centre, or behind the camera: never in view; its projection would divide by
        # zero at 90 degrees and poison the sums (and the sample's index) with inf and NaN
        ahead = rz > f32(0.1) * f
        inverse = one / rz if ahead else zero
        scale = (one - e0) * f
        u = scale * rx * inverse + centre_u  # eq. R1
        v = scale * py * inverse + centre_v
        visible = ahead & (u >= zero) & (u <= limit_u) & (v >= zero) & (v <= limit_v)
        intensity, gradient_u, gradient_v = _sample32(flat_image, flat_u, flat_v, columns, u, v, limit_u, limit_v)
        residual = intensity - target[k]
        size = abs(residual)
        weight = scale_huber / max(size, scale_huber)
        weight = weight if visible else zero
        huber = f32(0.5) * size * size if size < scale_huber else scale_huber * (size - f32(0.5) * scale_huber)
        cost += huber if visible else zero
        visible_count += one if visible else zero
        # derivatives of (rx, py, rz) and then of (u, v) = scale (rx, py) / rz
        d_rx, d_rz = -sy * xk - cy * pz, cy * xk - sy * pz
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (-py * inverse * d_rz) * inverse
        j_yaw = gradient_u * du + gradient_v * dv
        d_pitch_y, d_pitch_z = -sp * yk - cp * f, cp * yk - sp * f
        d_rx, d_rz = -sy * d_pitch_z, cy * d_pitch_z
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (d_pitch_y - py * inverse * d_rz) * inverse
        j_pitch = gradient_u * du + gradient_v * dv
        j_expansion = -(gradient_u * rx + gradient_v * py) * f * inverse  # d/de
        w_yaw, w_pitch, w_expansion = weight * j_yaw, weight * j_pitch, weight * j_expansion
        yy += w_yaw * j_yaw
        yp += w_yaw * j_pitch
        pp += w_pitch * j_pitch
        yr += w_yaw * residual
        pr += w_pitch * residual
        ye0 += w_yaw * j_expansion
        pe0 += w_pitch * j_expansion
        ee0 += w_expansion * j_expansion
        er0 += w_expansion * residual
    return np.array([yy, yp, pp, yr, pr, ye0, pe0, ee0, er0, cost, visible_count], dtype=np.float64)


@numba.njit(**_JIT)
def _rotation_blocks(previous, target, x, y, labels, parameters, focal, robust_scale):
    """One pass of eqs. R1–R2 with any number K of expansions (the column blocks of eq. R5,
    :meth:`~.pitch.RotationAlignment.column_yaw`), each pixel with ``parameters[2 + labels[k]]``: the
    Huber-weighted normal equations (2+K, 2+K) and gradient (2+K), float64, and the cost's sum and the count of
    pixels in view. The per-pixel arithmetic is :func:`_rotation_sums`' (float32); the sums are float64 arrays,
    indexed by the label, which the vector units do not take: 60 µs a pass over 2,304 pixels with 16 blocks
    against 34 with 4 (the quadrant form this replaced) and 25 for the one-expansion form (this project's
    machine, beside another job)."""
    size = parameters.shape[0]
    rows, columns = previous.shape[1], previous.shape[2]
    flat_image, flat_u, flat_v = previous[0].ravel(), previous[1].ravel(), previous[2].ravel()
    f32 = np.float32
    f, scale_huber = f32(focal), f32(robust_scale)
    centre_u, centre_v = f32(columns / 2 - 0.5), f32(rows / 2 - 0.5)
    limit_u, limit_v = f32(columns - 1.001), f32(rows - 1.001)
    yaw, pitch = parameters[0], parameters[1]
    cy, sy, cp, sp = f32(math.cos(yaw)), f32(math.sin(yaw)), f32(math.cos(pitch)), f32(math.sin(pitch))
    zero, one = f32(0.0), f32(1.0)
    normal = np.zeros((size, size))
    gradient = np.zeros(size)
    cost = 0.0
    visible_count = 0.0
    for k in range(target.shape[0]):
        block = 2 + labels[k]
        xk, yk = x[k], y[k]
        py, pz = cp * yk - sp * f, sp * yk + cp * f  # R_pitch r (x unchanged)
        rx, rz = cy * xk - sy * pz, sy * xk + cy * pz  # R_yaw (x, py, pz)
        if not rz > f32(0.1) * f:  # never in view (see _rotation_sums)
            continue
        inverse = one / rz
        scale = (one - f32(parameters[block])) * f
        u = scale * rx * inverse + centre_u  # eq. R1
        v = scale * py * inverse + centre_v
        if not ((u >= zero) & (u <= limit_u) & (v >= zero) & (v <= limit_v)):
            continue
        intensity, gradient_u, gradient_v = _sample32(flat_image, flat_u, flat_v, columns, u, v, limit_u, limit_v)
        residual = intensity - target[k]
        size_k = abs(residual)
        weight = scale_huber / max(size_k, scale_huber)
        cost += f32(0.5) * size_k * size_k if size_k < scale_huber else scale_huber * (size_k - f32(0.5) * scale_huber)
        visible_count += 1.0
        d_rx, d_rz = -sy * xk - cy * pz, cy * xk - sy * pz
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (-py * inverse * d_rz) * inverse
        j_yaw = float(gradient_u * du + gradient_v * dv)
        d_pitch_y, d_pitch_z = -sp * yk - cp * f, cp * yk - sp * f
        d_rx, d_rz = -sy * d_pitch_z, cy * d_pitch_z
        du = scale * (d_rx - rx * inverse * d_rz) * inverse
        dv = scale * (d_pitch_y - py * inverse * d_rz) * inverse
        j_pitch = float(gradient_u * du + gradient_v * dv)
        j_expansion = float(-(gradient_u * rx + gradient_v * py) * f * inverse)  # d/de of the pixel's own e
        w, r = float(weight), float(residual)
        normal[0, 0] += w * j_yaw * j_yaw
        normal[0, 1] += w * j_yaw * j_pitch
        normal[1, 1] += w * j_pitch * j_pitch
        normal[0, block] += w * j_yaw * j_expansion
        normal[1, block] += w * j_pitch * j_expansion
        normal[block, block] += w * j_expansion * j_expansion
        gradient[0] += w * j_yaw * r
        gradient[1] += w * j_pitch * r
        gradient[block] += w * j_expansion * r
    for row in range(size):
        for column in range(row):
            normal[row, column] = normal[column, row]
    return normal, gradient, cost, visible_count


@numba.njit(**_JIT)
def rotation_normal(previous, target, x, y, labels, parameters, focal, robust_scale):
    """The Huber-weighted normal equations of eq. R2 at ``parameters`` = (yaw, pitch, e_0 … e_{K−1}), each pixel
    (x, y from the image centre, px) with its own expansion e_labels[k] (the labels unread for K = 1):
    (normal (2+K, 2+K), gradient (2+K))."""
    if parameters.shape[0] > 3:
        normal, gradient, _, _ = _rotation_blocks(previous, target, x, y, labels, parameters, focal, robust_scale)
        return normal, gradient
    sums = _rotation_sums(previous, target, x, y, parameters[0], parameters[1], parameters[2], focal, robust_scale)
    normal = np.array([[sums[0], sums[1], sums[5]], [sums[1], sums[2], sums[6]], [sums[5], sums[6], sums[7]]])
    return normal, np.array([sums[3], sums[4], sums[8]])


@numba.njit(**_JIT)
def rotation_cost(previous, target, x, y, labels, parameters, focal, robust_scale):
    """Eq. R2's mean Huber cost over the pixels that land inside the previous image, and their share:
    (cost, support)."""
    count = target.shape[0]
    if parameters.shape[0] > 3:
        _, _, cost, visible = _rotation_blocks(previous, target, x, y, labels, parameters, focal, robust_scale)
        return cost / max(visible, 1.0), visible / max(count, 1)
    sums = _rotation_sums(previous, target, x, y, parameters[0], parameters[1], parameters[2], focal, robust_scale)
    return sums[9] / max(sums[10], 1.0), sums[10] / max(count, 1)


@numba.njit(**_JIT)
def rotation_solve(previous, target, x, y, labels, start, focal, robust_scale, iterations, damping, tolerance):
    """Gauss–Newton on eq. R2 from ``start`` (yaw, pitch, e_0 … e_{K−1}), at most ``iterations`` times, until the
    yaw and pitch updates are below ``tolerance`` rad; the normal equations damped by ``damping`` × identity.
    Returns (parameters, the marginal information on each: 1 / diag(normal⁻¹) at the last linearisation,
    iterations done); parameters all NaN where the iteration diverged to non-finite normal equations."""
    parameters = start.copy()
    size = parameters.shape[0]
    information = np.zeros(size)
    done = 0
    for _ in range(iterations):
        done += 1
        normal, gradient = rotation_normal(previous, target, x, y, labels, parameters, focal, robust_scale)
        if not (np.all(np.isfinite(normal)) and np.all(np.isfinite(gradient))):  # diverged (an expansion's
            parameters[:] = np.nan  # exponent overflowed): no solution, which the caller turns into no reading
            information[:] = 0.0
            break
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
