"""The compiled alignment loops (neuroslam.vision.kernels) against the equations written out with numpy.

Each reference below is eq. G1–G3 or eq. R1–R2 term by term over whole arrays, in float64; the compiled
loops must give the same numbers to their rounding: they compute each pixel in float32 and sum a few thousand
terms in float32 (in the loop's order), so their sums carry a relative error of about
sqrt(N) × 6e-8 ≈ 3e-6 of the sum of the terms' magnitudes (1e-5 is allowed: cancelling terms make the sum
smaller than that magnitude).
"""

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy import ndimage

from neuroslam.vision.ground_motion import blurred_with_gradients
from neuroslam.vision.kernels import ground_align, rotation_cost, rotation_normal, rotation_solve, sample_bilinear

FOCAL = 80 / math.tan(math.radians(40))


def _stack(seed: int, shape=(120, 160)) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return blurred_with_gradients(ndimage.gaussian_filter(rng.random(shape), 2.0).astype(np.float32), 1.0)


def _bilinear(stack, u, v):
    """Bilinear sampling as scipy's map_coordinates (order 1) does it, after the kernels' clamp."""
    rows, columns = stack.shape[1:]
    u, v = np.clip(u, 0, columns - 1.001), np.clip(v, 0, rows - 1.001)
    return np.stack([ndimage.map_coordinates(channel.astype(np.float64), [v, u], order=1) for channel in stack])


def test_bilinear_samples_match_scipy():
    stack = _stack(0)
    rng = np.random.default_rng(1)
    u, v = rng.uniform(-5, 165, 2000), rng.uniform(-5, 125, 2000)  # some outside: clamped
    np.testing.assert_allclose(sample_bilinear(stack, u, v), _bilinear(stack, u, v), rtol=0, atol=2e-6)


def _ground_normal(old, target, qx, qy, focal, cu, cv, height, forward, distance, turn, robust_scale):
    """Eqs. G1–G3's data term at (distance, turn), with numpy: (a11, a12, a22, b1, b2, support)."""
    c, s, ch, sh = math.cos(turn), math.sin(turn), math.cos(turn / 2), math.sin(turn / 2)
    px, py = distance * ch + c * qx - s * qy, distance * sh + s * qx + c * qy  # eq. G2
    ahead = px - forward
    inverse = 1 / np.maximum(ahead, 0.2)
    u, v = cu - focal * py * inverse, cv + focal * height * inverse  # eq. G1
    rows, columns = old.shape[1:]
    visible = (ahead > 0.2) & (u >= 0) & (u <= columns - 1.001) & (v >= 0) & (v <= rows - 1.001)
    intensity, gu, gv = _bilinear(old, u, v)
    residual = intensity - target
    d_py = -focal * gu * inverse
    d_px = -(d_py * py + focal * height * gv * inverse) * inverse
    j_turn = d_px * (-distance / 2 * sh - s * qx - c * qy) + d_py * (distance / 2 * ch + c * qx - s * qy)
    j_distance = d_px * ch + d_py * sh
    weight = robust_scale / np.maximum(np.abs(residual), robust_scale) * visible
    return (np.sum(weight * j_distance**2), np.sum(weight * j_distance * j_turn), np.sum(weight * j_turn**2),
            np.sum(weight * j_distance * residual), np.sum(weight * j_turn * residual), visible.mean())


@pytest.mark.parametrize(("distance", "turn"), [(0.0, 0.0), (0.08, 0.03), (-0.05, -0.06)])
def test_one_floor_iteration_is_the_gauss_newton_step_of_eq_g3(distance, turn):
    old, new = _stack(2), _stack(3)
    v, u = np.mgrid[70:119, 1:159:2]
    u, v = u.ravel().astype(float), v.ravel().astype(float)
    cu, cv, height, forward = 79.5, 59.5, 0.5, 0.1
    depth = height * FOCAL / (v - cv)
    qx, qy = (depth + forward).astype(np.float32), (-(u - cu) * depth / FOCAL).astype(np.float32)
    target = new[0][v.astype(int), u.astype(int)]
    weight_distance, weight_turn, robust_scale = 6.25, 1.0, 0.05
    prior = (0.02, -0.01)
    result = ground_align(old, target, target, target, qx, qy, np.ones_like(qx), FOCAL, cu, cv, height, forward,
                          distance, turn, prior[0], prior[1], weight_distance, weight_turn, weight_distance, 0.0, 0.0,
                          robust_scale, 1, 1.0, False, False, 1.0, 1.0)
    a11, a12, a22, b1, b2, support = _ground_normal(old, target, qx.astype(float), qy.astype(float), FOCAL, cu, cv,
                                                    height, forward, distance, turn, robust_scale)
    normal = np.array([[a11 + weight_distance, a12], [a12, a22 + weight_turn]])
    gradient = np.array([b1 + weight_distance * (distance - prior[0]), b2 + weight_turn * (turn - prior[1])])
    expected = np.array([distance, turn]) - np.linalg.solve(normal, gradient)
    np.testing.assert_allclose(result[:2], expected, rtol=1e-5, atol=1e-8)  # 1e-8 m, 1e-8 rad
    np.testing.assert_allclose(result[2:5], [a11 / weight_distance, a22 / weight_turn, support], rtol=1e-5)
    assert result[6] == 1


def _rotation_residual(previous, target, x, y, parameters, labels):
    """Eq. R1–R2's residuals and visibility with numpy."""
    yaw, pitch = parameters[:2]
    expansion = parameters[2:][labels]
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    py, pz = cp * y - sp * FOCAL, sp * y + cp * FOCAL
    rx, rz = cy * x - sy * pz, sy * x + cy * pz
    u = (1 - expansion) * FOCAL * rx / rz + 79.5
    v = (1 - expansion) * FOCAL * py / rz + 59.5
    visible = (u >= 0) & (u <= 158.999) & (v >= 0) & (v <= 118.999)
    return _bilinear(previous, u, v)[0] - target, visible


def _rotation_jacobian(previous, x, y, parameters, labels):
    """Eq. R2's Jacobian on (yaw, pitch, e_0 … e_{K−1}): d (u, v) / d parameter of eq. R1 by the chain rule, times
    the previous image's gradients sampled at (u, v)."""
    yaw, pitch = parameters[:2]
    expansion = parameters[2:][labels]
    cy, sy, cp, sp = math.cos(yaw), math.sin(yaw), math.cos(pitch), math.sin(pitch)
    py, pz = cp * y - sp * FOCAL, sp * y + cp * FOCAL
    rx, rz = cy * x - sy * pz, sy * x + cy * pz
    scale = (1 - expansion) * FOCAL
    _, gu, gv = _bilinear(previous, scale * rx / rz + 79.5, scale * py / rz + 59.5)
    rows = []
    d_pitch_z = cp * y - sp * FOCAL
    for d_rx, d_py, d_rz in ((-sy * x - cy * pz, 0 * x, cy * x - sy * pz),
                             (-sy * d_pitch_z, -sp * y - cp * FOCAL, cy * d_pitch_z)):
        rows.append(gu * scale * (d_rx * rz - rx * d_rz) / rz**2 + gv * scale * (d_py * rz - py * d_rz) / rz**2)
    j_expansion = -(gu * rx + gv * py) * FOCAL / rz
    for k in range(len(parameters) - 2):
        rows.append(np.where(labels == k, j_expansion, 0.0))
    return np.array(rows)


@pytest.mark.parametrize("count", [1, 4, 16])
def test_rotation_normal_equations_match_finite_differences(count):
    """The Jacobian of eq. R2 in the kernel's normal equations against central differences of the residual: one
    expansion, one per quadrant, one per column block (eq. R5, the general pass)."""
    previous, current = _stack(4), _stack(5)
    v, u = np.mgrid[24:96:2, 16:144:2]
    x, y = u.ravel() - 79.5, v.ravel() - 59.5
    labels = {1: np.zeros(len(x), dtype=np.intp), 4: (2 * (y >= 0) + (x >= 0)).astype(np.intp),
              16: (u.ravel() * 16 // 160).astype(np.intp)}[count]
    target = current[0][v.ravel(), u.ravel()]
    parameters = np.array([0.02, -0.01] + [0.01] * count)
    normal, gradient = rotation_normal(previous, target, x, y, labels, parameters, FOCAL, 0.05)
    residual, visible = _rotation_residual(previous, target, x, y, parameters, labels)
    step = 1e-6
    columns = []
    for k in range(len(parameters)):
        plus, minus = parameters.copy(), parameters.copy()
        plus[k] += step
        minus[k] -= step
        columns.append((_rotation_residual(previous, target, x, y, plus, labels)[0]
                        - _rotation_residual(previous, target, x, y, minus, labels)[0]) / (2 * step))
    jacobian = np.array(columns)
    weight = 0.05 / np.maximum(np.abs(residual), 0.05) * visible
    # the numerical Jacobian differentiates the bilinear surface, the kernel uses the sampled gradient images:
    # they agree to the images' second differences (a few per cent on this texture)
    np.testing.assert_allclose(normal, (jacobian * weight) @ jacobian.T, rtol=0.05,
                               atol=0.05 * np.abs(normal).max())
    # the residual's gradient is a sum over uncorrelated images with cancellations: against the same chain rule
    # in numpy (d (u, v) / d parameter times the sampled image gradients), to rounding
    analytic = _rotation_jacobian(previous, x, y, parameters, labels)
    np.testing.assert_allclose(normal, (analytic * weight) @ analytic.T, rtol=1e-5, atol=1e-5 * np.abs(normal).max())
    np.testing.assert_allclose(gradient, (analytic * weight) @ residual, rtol=1e-5,
                               atol=1e-5 * np.abs(analytic * weight * residual).sum(axis=1).max())
    cost, support = rotation_cost(previous, target, x, y, labels, parameters, FOCAL, 0.05)
    size = np.abs(residual[visible])
    assert cost == pytest.approx(np.mean(np.where(size < 0.05, 0.5 * size**2, 0.05 * (size - 0.025))), rel=1e-5)
    assert support == pytest.approx(visible.mean())


def test_the_one_expansion_pass_is_the_general_pass_with_every_pixel_in_one_block():
    """The rotation pass compiled for one expansion (every call but eq. R5's) and the general pass (any number of
    expansions, float64 sums) with every pixel in block 0 and its expansion in all four: the same normal
    equations and cost, to the one-expansion pass's float32 sums over 2,304 terms (1e-5 relative), and nothing
    in the empty blocks."""
    previous, current = _stack(4), _stack(5)
    v, u = np.mgrid[24:96:2, 16:144:2]
    x, y = (u.ravel() - 79.5).astype(np.float32), (v.ravel() - 59.5).astype(np.float32)
    labels = np.zeros(len(x), dtype=np.intp)
    target = current[0][v.ravel(), u.ravel()]
    single = np.array([0.02, -0.01, 0.01])
    blocks = np.array([0.02, -0.01, 0.01, 0.01, 0.01, 0.01])
    normal, gradient = rotation_normal(previous, target, x, y, labels, single, FOCAL, 0.05)
    normal4, gradient4 = rotation_normal(previous, target, x, y, labels, blocks, FOCAL, 0.05)
    np.testing.assert_allclose(normal, normal4[:3, :3], rtol=1e-5, atol=1e-5 * np.abs(normal).max())
    np.testing.assert_allclose(gradient, gradient4[:3], rtol=1e-5, atol=1e-5 * np.abs(gradient).max())
    assert not normal4[3:].any() and not gradient4[3:].any()  # blocks 1-3 hold no pixel
    cost, support = rotation_cost(previous, target, x, y, labels, single, FOCAL, 0.05)
    cost4, support4 = rotation_cost(previous, target, x, y, labels, blocks, FOCAL, 0.05)
    assert cost4 == pytest.approx(cost, rel=1e-5) and support4 == support


def test_rotation_solve_recovers_a_pure_rotation():
    """A frame rendered from the previous one by a known yaw and pitch (eq. R1 with e = 0) is aligned back to
    them within 1e-4 rad, and the iterations stop at the cap."""
    previous = _stack(6, (240, 320))[:, 60:180, 80:240].copy()
    rows, columns = previous.shape[1:]
    v, u = np.mgrid[0:rows, 0:columns]
    x, y = (u - 79.5).ravel().astype(float), (v - 59.5).ravel().astype(float)
    truth = np.array([0.03, -0.02, 0.0])
    residual, _ = _rotation_residual(previous, np.zeros(len(x)), x, y, truth, np.zeros(len(x), dtype=np.intp))
    current = blurred_with_gradients(residual.reshape(rows, columns).astype(np.float32), 0.0)
    region = (np.abs(x) < 60) & (np.abs(y) < 36)
    target = current[0].ravel()[region]
    labels = np.zeros(int(region.sum()), dtype=np.intp)
    parameters, information, _ = rotation_solve(previous, target, x[region], y[region], labels, np.zeros(3),
                                                   FOCAL, 0.05, 20, 1e-2, 1e-6)
    np.testing.assert_allclose(parameters[:2], truth[:2], atol=1e-4)
    assert np.all(information > 0)
    _, _, capped = rotation_solve(previous, target, x[region], y[region], labels, np.zeros(3), FOCAL, 0.05, 2, 1e-2,
                                  0.0)
    assert capped == 2


def _fingerprint() -> str:
    """Every number of a few floor and rotation alignments (several iterations each, on random smooth images)
    and of the grid network's compiled loops, as exact hexadecimal floats: equal strings mean bit-for-bit
    equal results."""
    old, new = _stack(2), _stack(3)
    v, u = np.mgrid[70:119, 1:159:2]
    u, v = u.ravel().astype(float), v.ravel().astype(float)
    depth = 0.5 * FOCAL / (v - 59.5)
    qx, qy = (depth + 0.1).astype(np.float32), (-(u - 79.5) * depth / FOCAL).astype(np.float32)
    target = new[0][v.astype(int), u.astype(int)]
    numbers = []
    for distance, turn, crosswise in ((0.0, 0.0, 0.0), (0.08, 0.03, 0.25), (-0.05, -0.06, 0.25)):
        for shared in (False, True):  # eq. G8 (the current image's gradients) or not
            numbers += ground_align(old, target, new[1][v.astype(int), u.astype(int)],
                                    new[2][v.astype(int), u.astype(int)], qx, qy, np.ones_like(qx), FOCAL, 79.5, 59.5,
                                    0.5, 0.1, distance, turn, 0.02, -0.01, 6.25, 1.0, 6.25, 0.3, crosswise, 0.05, 10,
                                    1.0, False, shared, 3.14, 1.0)
    previous, current = _stack(4)[:, 20:100, 20:140].copy(), _stack(5)[:, 20:100, 20:140].copy()
    y, x = (np.mgrid[0:80, 0:120] - np.array([39.5, 59.5])[:, None, None]).reshape(2, -1).astype(np.float32)
    labels = (2 * (y >= 0) + (x >= 0)).astype(np.intp)
    for start in (np.zeros(3), np.array([0.02, -0.01, 0.0, 0.0, 0.0, 0.0])):
        parameters, information, done = rotation_solve(previous, current[0].ravel(), x, y,
                                                       labels if len(start) == 6 else labels * 0, start, FOCAL,
                                                       0.05, 8, 1e-2, 0.0)
        numbers += [*parameters, *information, done]
    # the grid network's loops (neuroslam.cells.kernels): a random sheet's recurrent spectrum and read-out sums
    from scipy import fft

    from neuroslam.cells.kernels import polyphase_recurrence, shift_normal_equations
    rng = np.random.default_rng(7)
    sheet, target = rng.random((2, 16, 16), dtype=np.float32)
    sub_sheets = sheet.reshape(8, 2, 8, 2).transpose(1, 3, 0, 2).reshape(4, 8, 8)
    kernels = (rng.standard_normal((4, 16, 9)) + 1j * rng.standard_normal((4, 16, 9))).astype(np.complex64)
    spectrum = polyphase_recurrence(fft.rfft2(sub_sheets), kernels)
    normal, right = shift_normal_equations(sheet, target)
    numbers += [*spectrum.real.ravel(), *spectrum.imag.ravel(), *normal.ravel(), *right]
    return " ".join(float(number).hex() for number in numbers)


def test_the_vectorised_loops_give_the_scalar_loops_numbers_bit_for_bit(tmp_path):
    """With LLVM's ordered reductions (:mod:`neuroslam.compiled`) the per-pixel loops run on the vector units and
    keep each sum's order: their numbers equal, bit for bit, those of the same loops compiled without it (in a
    process of its own, with an empty numba cache so nothing compiled here is loaded there)."""
    scalar_script = ("import llvmlite.binding; llvmlite.binding.set_option = lambda *args: None; "  # left unset
                     "import sys; sys.path.insert(0, sys.argv[1]); import test_kernels; "
                     "from neuroslam.compiled import vectorised; print(vectorised(), test_kernels._fingerprint())")
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    scalar = subprocess.run([sys.executable, "-c", scalar_script, str(Path(__file__).parent)], env=environment,
                            capture_output=True, text=True, check=True, timeout=300).stdout.split()
    assert scalar[0] == "False"  # compiled there, without the option: scalar
    assert " ".join(scalar[1:]) == _fingerprint()


def test_the_grid_networks_recurrent_input_from_quarter_sheets_is_the_masked_sheets():
    """grid-network eqs. 1–2: Σ_d K_d · FFT(mask_d · s) from the four sub-sheets' FFTs equals it from the four masked
    whole sheets (float32 spectra: 1e-5 of the largest term)."""
    from scipy import fft

    from neuroslam.cells.grid_network import GridNetwork
    from neuroslam.cells.kernels import polyphase_recurrence
    from neuroslam.config import GridNetworkConfig

    network = GridNetwork(GridNetworkConfig(size=32, settle_steps=0, calibration_directions=0))
    rng = np.random.default_rng(7)
    activity = rng.random((32, 32)).astype(np.float32)
    masks = np.stack([network.direction_index == d for d in range(4)])
    # the kernels without the folded-in phase: divide it out again
    rows = np.fft.fftfreq(32, 1 / 32)[:, None]
    columns = np.arange(17)[None, :]
    phases = np.stack([np.exp(-2j * math.pi * (rows * (d // 2) + columns * (d % 2)) / 32) for d in range(4)])
    kernels = network._kernels / phases
    expected = np.einsum("dij,dij->ij", kernels, fft.rfft2(masks * activity))
    sub_sheets = activity.reshape(16, 2, 16, 2).transpose(1, 3, 0, 2).reshape(4, 16, 16)
    result = polyphase_recurrence(fft.rfft2(sub_sheets), network._kernels)
    np.testing.assert_allclose(result, expected, rtol=0, atol=1e-5 * np.abs(expected).max())


def test_phase_ramp_is_the_fourier_shift():
    from scipy import fft

    from neuroslam.cells.kernels import phase_ramp

    sheet = np.random.default_rng(8).random((24, 30))
    spectrum = fft.rfft2(sheet)
    shifted = fft.irfft2(phase_ramp(spectrum, 24, 30, 3.0, -5.0), s=sheet.shape)
    np.testing.assert_allclose(shifted, np.roll(sheet, (3, -5), axis=(0, 1)), atol=1e-12)
