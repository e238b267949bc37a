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
    experience_map = ExperienceMap(ExperienceMapConfig(threshold=0.5, relaxation_passes=0, idle_passes=0,
                                                       relaxation="passes"))
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


def _link_cost(poses, links, link_poses, weights=None):
    """Eq. 25's objective, written out independently: squared link errors (x, y, z in m, yaw in rad), each
    times its link's weight (all 1 when None)."""
    total = 0.0
    weights = np.ones(len(links)) if weights is None else weights
    for (source, target), (distance, heading, facing, height), weight in zip(links, link_poses, weights, strict=True):
        direction = poses[source, 3] + heading
        dx = poses[source, 0] + distance * math.cos(direction) - poses[target, 0]
        dy = poses[source, 1] + distance * math.sin(direction) - poses[target, 1]
        dz = poses[source, 2] + height - poses[target, 2]
        dyaw = (poses[source, 3] + facing - poses[target, 3] + math.pi) % (2 * math.pi) - math.pi
        total += weight * (dx * dx + dy * dy + dz * dz + dyaw * dyaw)
    return total


def _loop_with(relaxation, passes=0):
    """Eight experiences round a 4 × 4 m square with a climb, the closing side 1 m too long and 0.2 rad off."""
    config = ExperienceMapConfig(threshold=0.5, relaxation=relaxation, relaxation_passes=passes, idle_passes=0)
    experience_map = ExperienceMap(config, grid_size=(100, 100, 100))
    experience_map.update(0, np.zeros(3), np.zeros(2), 0.0)
    for k in range(1, 8):
        experience_map.integrate(2.0, 0.0, 0.25)
        experience_map.update(k, np.array([10.0 * k, 0.0, 0.0]), np.zeros(2), float(k))
        if k % 2 == 0:
            experience_map.integrate(0.0, math.pi / 2, 0.0)
    experience_map.integrate(3.0, 0.0, -1.75)
    experience_map.integrate(0.0, math.pi / 2 + 0.2, 0.0)
    update = experience_map.update(0, np.zeros(3), np.zeros(2), 8.0)
    assert update.loop_closure
    return experience_map


def test_least_squares_relaxation_reaches_the_minimum_of_eq_25s_link_errors():
    solved = _loop_with("least-squares")
    for _ in range(5):  # a frame runs at most 3 Gauss–Newton iterations; an unfinished solve goes on
        solved._relax(0)
    assert solved.settled
    poses, links, link_poses, weights = solved.poses.copy(), solved.links, solved.link_poses, solved.link_weights
    assert poses[0] == pytest.approx([0, 0, 0, 0], abs=1e-6)  # the first experience holds the map in place
    # the driven links weigh 1, the loop closure's (the last) closure_weight
    assert weights.tolist() == [1.0] * 7 + [solved.config.closure_weight]
    cost = _link_cost(poses, links, link_poses, weights)
    # a minimum: no small move of any other experience lowers the cost (central differences of the gradient)
    gradient = np.zeros_like(poses)
    for index in np.ndindex(*poses.shape):
        if index[0] == 0:
            continue
        step = np.zeros_like(poses)
        step[index] = 1e-6
        gradient[index] = (_link_cost(poses + step, links, link_poses, weights)
                           - _link_cost(poses - step, links, link_poses, weights)) / 2e-6
    assert np.abs(gradient).max() < 1e-4
    # the loop's error is spread over every link, not left on the closing one
    before = _link_cost(_loop_with("passes").poses, links, link_poses, weights)
    assert cost < 0.2 * before
    # eq. 25's own passes, run long enough, settle at a higher cost (they ignore the yaw coupling)
    passes = _loop_with("passes", passes=1000)
    assert cost <= _link_cost(passes.poses, links, link_poses, weights) + 1e-9


def test_a_map_saved_before_links_had_weights_loads_with_all_alike():
    """States written before ``link_weights`` existed load with every link weighing 1; a state with the
    weights keeps them."""
    built = _loop_with("least-squares")
    state = built.state_dict()
    assert state["link_weights"].tolist() == [1.0] * 7 + [built.config.closure_weight]
    old = {name: value for name, value in state.items() if name != "link_weights"}
    loaded = ExperienceMap(built.config, grid_size=(100, 100, 100))
    loaded.load_state_dict(old)
    assert loaded.link_weights.tolist() == [1.0] * 8
    loaded.load_state_dict(state)
    assert loaded.link_weights.tolist() == state["link_weights"].tolist()


def test_a_confirmed_place_is_the_one_re_entered_not_the_neighbour_whose_codes_lie_nearer():
    """View 7 seen along a corridor: experiences 0, 1, 2 at codes 0, 1.5 and 3 cells. Back in the corridor
    with codes 2.2 (drifted), eq. 22 alone re-enters experience 1 (0.7 cells away against 0.8); when a run of
    views confirmed experience 2 (``place``), the loop closes there."""
    def corridor():
        experience_map = ExperienceMap(ExperienceMapConfig(threshold=1.0, relaxation_passes=0, idle_passes=0))
        for k, code in enumerate([0.0, 1.5, 3.0]):
            experience_map.integrate(3.0 if k else 0.0, 0.0, 0.0)
            assert experience_map.update(7, np.array([code, 0.0, 0.0]), np.zeros(2), float(k)).new_experience
        experience_map.integrate(3.0, 0.0, 0.0)
        assert experience_map.update(8, np.array([10.0, 0.0, 0.0]), np.zeros(2), 3.0).experience_id == 3
        experience_map.integrate(3.0, 0.0, 0.0)
        assert experience_map.update(9, np.array([20.0, 0.0, 0.0]), np.zeros(2), 4.0).experience_id == 4
        experience_map.integrate(0.0, math.pi, 0.0)
        return experience_map

    by_codes = corridor().update(7, np.array([2.2, 0.0, 0.0]), np.zeros(2), 5.0)
    assert by_codes.loop_closure and by_codes.experience_id == 1
    confirmed = corridor().update(7, np.array([2.2, 0.0, 0.0]), np.zeros(2), 5.0, place=2)
    assert confirmed.loop_closure and confirmed.experience_id == 2
    # following the map is not a loop closure: at experience 2, eq. 22 re-enters its linked neighbour 1, and
    # that stands whatever place was confirmed
    following = ExperienceMap(ExperienceMapConfig(threshold=1.0, relaxation_passes=0, idle_passes=0))
    for k, code in enumerate([0.0, 1.5, 3.0]):
        following.integrate(3.0 if k else 0.0, 0.0, 0.0)
        following.update(7, np.array([code, 0.0, 0.0]), np.zeros(2), float(k))
    followed = following.update(7, np.array([2.2, 0.0, 0.0]), np.zeros(2), 3.0, place=0)
    assert not followed.loop_closure and followed.experience_id == 1


@pytest.mark.parametrize(("keeps_pose", "links_driven"), [(False, False), (True, False), (False, True)])
def test_following_the_map_puts_the_robot_where_its_codes_or_its_map_pose_say(keeps_pose, links_driven):
    """Experiences 0–3 every 3 m along +x (views 7–10, codes 0–9 cells of 1 m); a loop closes back at experience 0.
    The robot drives 3 m on (truly at x = 3), its grid code drifted to 3.6: eq. 22 re-enters experience 1, linked
    to 0 (the robot follows the map; no loop closure). By the codes (the default) the robot is 0.6 m past 1, at
    x = 3.6; with ``reentry_keeps_pose`` it stays where the map had it, x = 3. Driven 2 m on to a new view, the
    new experience is made where the robot is, and its link from experience 1 carries that place, or with
    ``reentry_links_driven`` the driven path (x = 3 + 2, 2 m past experience 1) wherever the codes put the robot."""
    experience_map = ExperienceMap(ExperienceMapConfig(threshold=1.0, relaxation="passes", relaxation_passes=0,
                                                       idle_passes=0, reentry_keeps_pose=keeps_pose,
                                                       reentry_links_driven=links_driven))
    for k in range(4):
        experience_map.integrate(3.0 if k else 0.0, 0.0, 0.0)
        assert experience_map.update(7 + k, np.array([3.0 * k, 0.0, 0.0]), np.zeros(2), float(k)).new_experience
    closed = experience_map.update(7, np.zeros(3), np.zeros(2), 4.0, place=0)
    assert closed.loop_closure and closed.experience_id == 0
    experience_map.integrate(3.0, 0.0, 0.0)
    followed = experience_map.update(8, np.array([3.6, 0.0, 0.0]), np.zeros(2), 5.0)
    assert not followed.loop_closure and not followed.new_experience and followed.experience_id == 1
    x = 3.0 if keeps_pose else 3.6
    assert experience_map.robot_pose() == pytest.approx([x, 0.0, 0.0, 0.0], abs=1e-9)
    experience_map.integrate(2.0, 0.0, 0.0)
    made = experience_map.update(11, np.array([20.0, 0.0, 0.0]), np.zeros(2), 6.0)
    assert made.new_experience
    assert experience_map.poses[made.experience_id] == pytest.approx([x + 2.0, 0.0, 0.0, 0.0], abs=1e-9)
    assert tuple(experience_map.links[-1]) == (1, made.experience_id)
    link_x = 3.0 if keeps_pose or links_driven else 3.6
    assert experience_map.link_poses[-1] == pytest.approx([link_x - 1.0, 0.0, 0.0, 0.0], abs=1e-9)


def _link_pose(source: np.ndarray, target: np.ndarray) -> tuple[float, float, float, float]:
    """Eq. 23's link (distance, heading, facing, height) that puts ``target`` exactly where it is from ``source``."""
    dx, dy = target[:2] - source[:2]
    c, s = math.cos(source[3]), math.sin(source[3])
    x, y = c * dx + s * dy, -s * dx + c * dy
    return math.hypot(x, y), math.atan2(y, x), target[3] - source[3], target[2] - source[2]


def test_fusing_duplicates_a_little_apart_keeps_the_map_s_shape():
    """A second pass along a straight lane made duplicates 0.2 m and 3 degrees off the first pass's
    experiences (as a merged session's do). Fusing them must not bend the lane: each moved link is
    re-expressed through its duplicate's offset, so the solved map stays exactly as it was; a link
    taken to join the kept experiences themselves would make every fused pair disagree by the offset."""
    kept = np.array([[float(k), 0.0, 0.0, 0.0] for k in range(6)])
    offsets = [np.array([0.2, 0.1, 0.0, math.radians(3)]), np.array([-0.15, -0.1, 0.0, math.radians(-2)]),
               np.array([0.1, -0.05, 0.0, math.radians(4)]), np.array([-0.2, 0.1, 0.0, math.radians(-3)])]
    duplicates = np.array([kept[1 + k] + offset for k, offset in enumerate(offsets)])
    poses = np.concatenate([kept, duplicates])
    links = [(k, k + 1) for k in range(5)] + [(6 + k, 7 + k) for k in range(3)] + [(5, 6)]
    state = {"poses": poses, "grid_codes": np.zeros((10, 3)), "direction_codes": np.zeros((10, 2)),
             "template_ids": np.array([0, 1, 2, 3, 4, 5, 1, 2, 3, 4]), "creation_times": np.arange(10.0),
             "links": np.array(links), "link_poses": np.array([_link_pose(poses[a], poses[b]) for a, b in links]),
             "link_times": np.ones(len(links)), "link_weights": np.ones(len(links)),
             "degree": np.bincount(np.array(links).ravel(), minlength=10), "components": np.zeros(10, dtype=int),
             "sessions": np.zeros(10, dtype=int), "settled": np.bool_(True), "current": np.int64(9),
             "relative": np.zeros(4), "loop_closures": np.int64(0), "component": np.int64(0), "session": np.int64(0)}
    experience_map = ExperienceMap(ExperienceMapConfig(relaxation="least-squares"))
    experience_map.load_state_dict(state)
    remap = experience_map.fuse({6: 1, 7: 2, 8: 3, 9: 4})
    assert experience_map.size == 6 and list(remap) == [0, 1, 2, 3, 4, 5, 1, 2, 3, 4]
    experience_map._relax(0)
    assert experience_map.poses == pytest.approx(kept, abs=1e-9)
    assert _residuals(experience_map) == pytest.approx(np.zeros(len(experience_map.links)), abs=1e-9)
    # the robot, which was at the last duplicate, is still where it was
    assert experience_map.robot_pose() == pytest.approx(duplicates[-1], abs=1e-9)
