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
