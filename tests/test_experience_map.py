"""The experience map: links point the right way, loops close, relaxation spreads the error and converges."""

import math

import numpy as np
import pytest

from neuroslam.config import ExperienceMapConfig
from neuroslam.experience_map import ExperienceMap


def test_new_experience_link_points_the_way_the_robot_went():
    experience_map = ExperienceMap(ExperienceMapConfig(threshold=1.0))
    experience_map.integrate(0.0, math.pi / 2, 0.0)  # face +y
    experience_map.update(0, np.zeros(3), np.zeros(2), 0.0)
    assert experience_map.poses[0] == pytest.approx([0, 0, 0, math.pi / 2])
    experience_map.integrate(2.0, 0.0, 0.5)  # 2 m ahead, 0.5 m up
    update = experience_map.update(1, np.array([0.0, 2.0, 0.5]), np.zeros(2), 1.0)
    assert update.new_experience and update.experience_id == 1
    assert experience_map.poses[1] == pytest.approx([0, 2, 0.5, math.pi / 2], abs=1e-9)
    distance, heading, facing, height = experience_map.link_poses[0]
    assert (distance, heading, facing, height) == pytest.approx((2.0, 0.0, 0.0, 0.5))
    # relaxing a consistent map changes nothing: the link agrees with the poses
    experience_map._relax(50)
    assert experience_map.poses[1] == pytest.approx([0, 2, 0.5, math.pi / 2], abs=1e-9)


def _square_loop(error_scale):
    """A 4 × 4 m square driven counter-clockwise with the last side measured ``error_scale`` too long."""
    experience_map = ExperienceMap(ExperienceMapConfig(threshold=0.5, relaxation_passes=0, idle_passes=0))
    codes = [np.array([x, y, 0.0]) for x, y in [(0, 0), (4, 0), (4, 4), (0, 4)]]
    experience_map.update(0, codes[0], np.zeros(2), 0.0)
    for k in range(1, 4):
        experience_map.integrate(4.0, 0.0, 0.0)
        experience_map.update(k, codes[k], np.array([9.0 * k, 0.0]), float(k))
        experience_map.integrate(0.0, math.pi / 2, 0.0)
    experience_map.integrate(4.0 * error_scale, 0.0, 0.0)
    experience_map.integrate(0.0, math.pi / 2, 0.0)  # facing the way the first experience faced
    update = experience_map.update(0, codes[0], np.zeros(2), 4.0)  # back at the first place: loop closure
    assert update.loop_closure and update.experience_id == 0
    return experience_map


def _residuals(experience_map):
    poses = experience_map.poses
    out = []
    for (source, target), (distance, heading, _facing, _height) in zip(experience_map.links, experience_map.link_poses,
                                                                     strict=True):
        direction = poses[source, 3] + heading
        expected = poses[source, :2] + distance * np.array([math.cos(direction), math.sin(direction)])
        out.append(np.linalg.norm(expected - poses[target, :2]))
    return np.array(out)


def test_relaxation_spreads_a_loop_error_and_converges():
    experience_map = _square_loop(1.25)  # the closing side is 1 m too long
    before = _residuals(experience_map)
    assert before.max() == pytest.approx(1.0, abs=1e-9) and np.count_nonzero(before > 1e-9) == 1
    totals = []
    for _ in range(8):
        experience_map._relax(25)
        totals.append(_residuals(experience_map).sum())
    after = _residuals(experience_map)
    assert after.max() < 0.5 * before.max()                  # no single link keeps the whole error
    assert np.count_nonzero(after > 0.05) >= 3               # it is shared around the loop
    assert abs(totals[-1] - totals[-2]) < 1e-6               # converged
    assert experience_map.loop_closures == 1


def test_matching_prefers_the_same_view_at_the_same_place():
    experience_map = ExperienceMap(ExperienceMapConfig())
    experience_map.update(5, np.array([1.0, 1.0, 0.0]), np.array([0.0, 0.0]), 0.0)
    scores = experience_map.scores(5, np.array([1.5, 1.0, 0.0]), np.array([0.0, 0.0]))
    assert scores[0] == pytest.approx(0.5)
    assert experience_map.scores(6, np.array([1.0, 1.0, 0.0]), np.zeros(2))[0] == pytest.approx(10.0)
    # distances wrap around the networks
    assert experience_map.scores(5, np.array([35.5, 1.0, 0.0]), np.zeros(2))[0] == pytest.approx(1.5)
