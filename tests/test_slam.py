"""The pipeline: bad input is refused without changing anything; a revisited route closes loops."""

import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam import InvalidInputError, NeuroSLAM, SelfMotion


def image(seed, shape=(120, 160, 3)):
    rng = np.random.default_rng(seed)
    return (ndimage.gaussian_filter(rng.random(shape[:2]), 2) * 255).astype(np.uint8)[:, :, None].repeat(3, axis=2)


def state(slam):
    return (slam.frames, slam.local_view.count, slam.experience_map.size, slam.grid_cells.activity.copy(),
            slam.head_direction.activity.copy(), slam.odometry_pose)


@pytest.mark.parametrize("bad, args, field", [
    (np.zeros((120, 160, 4), np.uint8), (), "image"),
    (np.zeros((0, 160), np.uint8), (), "image"),
    (np.array([["a"] * 20] * 20), (), "image"),
    (np.zeros((120, 160), np.uint16), (), "image"),
    (np.full((120, 160), np.nan), (), "image"),
    (np.zeros((100, 160, 3), np.uint8), (), "image"),
    (None, (float("nan"),), "timestamp"),
    (None, (0.05,), "timestamp"),
    (None, (0.3, SelfMotion(float("inf"), 0.0)), "odometry"),
])
def test_bad_input_is_refused_and_changes_nothing(bad, args, field):
    slam = NeuroSLAM()
    slam.step(image(0), 0.1)
    before = state(slam)
    frame = image(1) if bad is None else bad
    timestamp, *rest = args or (0.2,)
    with pytest.raises(InvalidInputError) as error:
        slam.step(frame, timestamp, *rest)
    assert error.value.field == field
    after = state(slam)
    assert before[:3] == after[:3]
    for a, b in zip(before[3:], after[3:], strict=True):
        np.testing.assert_array_equal(a, b)


def test_a_revisited_route_reuses_its_views_and_closes_loops():
    """A square route of 40 distinct views driven twice with exact odometry: the second lap re-enters the
    first lap's experiences instead of making new ones."""
    slam = NeuroSLAM()
    views = [image(100 + k) for k in range(40)]
    t = 0.0
    closures = 0
    for lap in range(2):
        for k in range(40):
            t += 0.1
            turning = k % 10 == 9
            motion = SelfMotion(0.0 if turning else 10.0, (math.pi / 2) / 0.1 if turning else 0.0)
            estimate = slam.step(views[k], t, odometry=motion)
            closures += estimate.loop_closure
        if lap == 0:
            after_first = (slam.local_view.count, slam.experience_map.size)
    assert slam.local_view.count == after_first[0] == 40
    assert slam.experience_map.size == after_first[1] == 40  # the second lap made no new experience
    assert closures == 1  # entering the first experience again; the rest of the lap follows its links
    # exact odometry: the square's corners, and the estimate ends where the odometry does (re-entering an
    # experience places the robot by the difference of the packets' read-outs, good to about a centimetre)
    np.testing.assert_allclose(slam.experience_map.poses[20], [7, 9, 0, math.pi], atol=0.02)
    np.testing.assert_allclose(slam.last.pose, [-1, 0, 0, 0], atol=0.02)


def test_estimate_carries_the_state():
    slam = NeuroSLAM("sim")
    estimate = slam.step(image(0), 0.0)
    assert estimate.pose.shape == (4,) and estimate.new_template and estimate.new_experience
    assert estimate.grid_cell.shape == (3,) and estimate.head_direction_cell.shape == (2,)
