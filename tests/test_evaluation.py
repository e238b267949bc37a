"""Trajectory alignment recovers a known similarity transform; the ATE of a hand-computed case."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from neuroslam.evaluation import ate_rmse, umeyama


def test_umeyama_recovers_a_known_similarity():
    rng = np.random.default_rng(0)
    truth = rng.normal(size=(50, 3)) * 10
    rotation = Rotation.from_euler("zyx", [40, -10, 5], degrees=True).as_matrix()
    estimate = (truth @ rotation.T) * 0.5 + [3.0, -2.0, 1.0]  # a rotated, halved, moved copy
    scale, found_rotation, _ = umeyama(estimate, truth)
    assert scale == pytest.approx(2.0)
    np.testing.assert_allclose(found_rotation, rotation.T, atol=1e-9)
    assert ate_rmse(estimate, truth) == pytest.approx(0.0, abs=1e-9)
    assert ate_rmse(estimate, truth, with_scale=False) > 1.0  # the scale is wrong without Sim(3)


def test_ate_of_a_constant_offset_that_alignment_cannot_remove():
    truth = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], dtype=float)
    estimate = truth + np.array([[0, 0.5, 0], [0, -0.5, 0], [0, 0.5, 0], [0, -0.5, 0]])
    # the best rigid fit cannot undo a zig-zag: the residual stays close to 0.5 m on every point
    assert 0.3 < ate_rmse(estimate, truth, with_scale=False) <= 0.5
    with pytest.raises(ValueError, match="N x 3"):
        ate_rmse(estimate[:2], truth[:2])


def test_rpe_ignores_a_rigid_offset_and_measures_scale_error():
    from neuroslam.evaluation import rpe_rmse

    t = np.linspace(0, 100, 501)  # a straight 100 m drive along x, 0.2 m per frame
    truth = np.column_stack([t, np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)])
    moved = truth + [5.0, -3.0, 1.0, 0.0]
    assert rpe_rmse(moved, truth) == pytest.approx(0.0, abs=1e-9)
    # rotate the whole estimate by 90 degrees, yaw included: still no relative error
    rotated = np.column_stack([-truth[:, 1], truth[:, 0], truth[:, 2], truth[:, 3] + np.pi / 2])
    assert rpe_rmse(rotated, truth) == pytest.approx(0.0, abs=1e-9)
    # 10 % too long: every 10 m segment is 1 m too long
    assert rpe_rmse(truth * [1.1, 1, 1, 1], truth) == pytest.approx(1.0, rel=0.03)
    assert rpe_rmse(truth[:10], truth[:10]) is None  # shorter than one segment


def test_level_accuracy_and_false_closures():
    from neuroslam.evaluation import false_loop_closures, level_accuracy

    assert level_accuracy(np.array([0.1, 2.8, 1.6, -0.4]), np.array([0, 1, 0, 0]), np.array([0.0, 3.0])) == 0.75
    now = np.array([[0, 0, 0], [10, 0, 0], [0, 0, 3]])
    then = np.array([[1, 1, 0], [13, 0, 0], [0, 0.5, 0]])
    assert false_loop_closures(now, then, np.array([0, 0, 1]), np.array([0, 0, 0])) == 2
