"""Eq. M8: a place known across the path but not along it. A view seen along many metres (a blank corridor) is no
evidence for a loop closure, which must say where along the path the robot is; it still says where across the
path the robot is and which way it faces, and the map takes exactly that."""

import math

import numpy as np
import pytest

from neuroslam.config import ExperienceMapConfig
from neuroslam.errors import InvalidParameterError
from neuroslam.evaluation import false_along_path_mask
from neuroslam.experience_map import ExperienceMap
from neuroslam.loop_closure import confirm_place
from neuroslam.relaxation import solve_least_squares

SPACING = 0.5  # m between the first pass's experiences


def _corridor(count=60, y=0.0, z=0.0):
    """The first pass: experiences every 0.5 m along a straight corridor heading east (x from 0)."""
    x = SPACING * np.arange(count)
    return np.column_stack([x, np.full(count, y), np.full(count, z), np.zeros(count)])


def _window(frames=20, start=10.0, drift_yaw=0.4, drift=(5.0, -2.0, 0.0)):
    """The second pass along the same corridor, 1 m a frame from x = ``start``, in an odometry frame rotated by
    ``drift_yaw`` and shifted by ``drift`` (where the map's estimate has drifted to)."""
    x = start + np.arange(frames, dtype=float)
    c, s = math.cos(drift_yaw), math.sin(drift_yaw)
    return np.column_stack([c * x + drift[0], s * x + drift[1], np.full(frames, drift[2]), np.full(frames, drift_yaw)])


def _confirm(poses, experiences_of, window, robot, *, along_path):
    return confirm_place(window, np.zeros(len(window), dtype=int), 0.0, poses, experiences_of,
                         np.ones(len(poses), dtype=bool), robot, radius=20.0, tolerance=1.0, matches=16,
                         along_path=along_path)


def test_a_corridor_seen_as_one_view_confirms_a_place_across_the_path_only():
    """Every experience of a blank corridor holds the one view: the confirmation cannot say where along it the
    robot is and refuses; eq. M8's test confirms a place on the corridor, whose heading the window agrees with."""
    poses = _corridor()
    every = np.arange(len(poses))
    window = _window()
    robot = np.array([24.0, 1.5, 0.0, 0.3])  # the estimate, drifted
    assert _confirm(poses, lambda template: every, window, robot, along_path=False) == -1
    place = _confirm(poses, lambda template: every, window, robot, along_path=True)
    assert place >= 0 and abs(poses[place, 0] - robot[0]) <= 20.0


def test_two_corridors_side_by_side_that_look_alike_confirm_nothing_across():
    """The same view along two parallel corridors 4 m apart: the window fits both, so where across the path the
    robot is stays ambiguous, and eq. M8 confirms nothing."""
    poses = np.concatenate([_corridor(), _corridor(y=4.0)])
    every = np.arange(len(poses))
    robot = np.array([24.0, 2.0, 0.0, 0.0])
    assert _confirm(poses, lambda template: every, _window(), robot, along_path=True) == -1


def test_a_window_that_turned_does_not_fit_a_straight_corridor():
    """The robot turned 90 degrees halfway through the window: its frames cannot all lie along the corridor."""
    poses = _corridor()
    every = np.arange(len(poses))
    straight = _window(drift_yaw=0.0, drift=(0.0, 0.0, 0.0))
    turned = straight.copy()
    turned[:10, :2] = turned[10, :2] + np.column_stack([np.zeros(10), -np.arange(10, 0, -1.0)])  # came from the south
    robot = straight[-1]
    assert _confirm(poses, lambda template: every, straight, robot, along_path=True) >= 0
    assert _confirm(poses, lambda template: every, turned, robot, along_path=True) == -1


def test_a_distinct_view_still_confirms_the_place_itself():
    """Where the views do say where along the path the robot is, eq. M8's test finds the same place as the
    confirmation (the best fit of the hypotheses)."""
    poses = _corridor()
    own = [np.array([2 * k, 2 * k + 1]) for k in range(30)]  # each view belongs to two neighbouring experiences
    window = _window(start=10.0, drift_yaw=0.0, drift=(0.0, 0.0, 0.0))
    templates = (window[:, 0] / SPACING).astype(int) // 2
    robot = window[-1]
    common = {"radius": 20.0, "tolerance": 1.0, "matches": 16}
    placed = confirm_place(window, templates, 0.0, poses, lambda t: own[t], np.ones(60, bool), robot, **common)
    along = confirm_place(window, templates, 0.0, poses, lambda t: own[t], np.ones(60, bool), robot, along_path=True,
                          **common)
    assert placed >= 0 and along == placed


def test_the_map_is_held_across_the_places_heading_in_height_and_in_yaw_not_along_it():
    """Eq. M8's link (no length, along the place's heading, its length weight nothing): the least-squares map
    moves the linked experience onto the line through the place along its heading, to its height and facing
    its yaw plus the view's, and leaves where along the line it is to the other links."""
    poses = np.array([[0.0, 0.0, 0.0, 0.5], [3.0, 4.0, 0.4, 0.9]])
    relative_yaw = 0.1
    # a faint driven link (weight 1e-6) that agrees with the experience as it is, so that something holds it
    # along the line (in a map every experience has its driven links)
    offset = poses[1, :2] - poses[0, :2]
    driven = [math.hypot(*offset), math.atan2(offset[1], offset[0]) - 0.5, 0.4, 0.4]
    links = np.array([[0.0, 0.0, relative_yaw, 0.0], driven])
    solved, settled = solve_least_squares(poses, np.array([0, 0]), np.array([1, 1]), links, np.array([0.1, 1e-6]),
                                          length_weights=np.array([0.0, 1e-6]))
    assert settled
    heading = np.array([math.cos(0.5), math.sin(0.5)])
    across = np.array([-heading[1], heading[0]])
    assert poses[1, :2] @ across == pytest.approx(2.07, abs=0.01)  # 2.07 m off the line before
    assert solved[1, :2] @ across == pytest.approx(0.0, abs=1e-4)  # on the line
    assert solved[1, :2] @ heading == pytest.approx(poses[1, :2] @ heading, abs=1e-4)  # where along it, kept
    assert solved[1, 2] == pytest.approx(0.0, abs=1e-4)
    assert solved[1, 3] == pytest.approx(0.5 + relative_yaw, abs=1e-4)


def test_the_experience_map_links_a_new_experience_to_the_place_and_counts_no_loop_closure():
    themap = ExperienceMap(ExperienceMapConfig(threshold=1.0))
    themap.update(0, np.zeros(3), np.zeros(2), 0.0)
    for k in range(1, 5):  # the first pass, 2 m a step east
        themap.integrate(2.0, 0.0, 0.0)
        themap.update(k, np.array([2.0 * k, 0.0, 0.0]), np.zeros(2), float(k))
    themap.integrate(0.0, 0.3, 0.0)
    themap.integrate(1.0, 0.0, 0.0)  # the robot has drifted off the line: 0.3 rad, to the side
    update = themap.update(9, np.array([50.0, 0.0, 0.0]), np.zeros(2), 100.0, along_path=2, along_path_yaw=0.05)
    assert update.new_experience and not update.loop_closure
    assert themap.loop_closures == 0 and themap.along_path_closures == 1
    (source, target), link_pose = themap.links[-1], themap.link_poses[-1]
    assert (source, target) == (2, update.experience_id)
    assert tuple(link_pose) == pytest.approx((0.0, 0.0, 0.05, 0.0))
    assert themap.link_weights[-1] == themap.config.closure_weight
    assert math.isinf(themap.link_blind_times[-1]) and themap.length_weights()[-1] == 0.0
    # the link says nothing of how far along the path they lie: the robot may not step from one to the other
    # without a loop closure, also once the map is saved and loaded
    assert not themap.linked(2, update.experience_id) and themap.linked(4, update.experience_id)
    loaded = ExperienceMap(themap.config)
    loaded.load_state_dict(themap.state_dict())
    assert not loaded.linked(2, update.experience_id) and loaded.linked(4, update.experience_id)
    assert loaded.along_path_closures == 1 and loaded.loop_closures == 0
    # the solve moved the new experience toward the corridor's line and its heading toward the place's
    assert abs(themap.poses[update.experience_id, 1]) < math.sin(0.3) * 1.0
    assert abs(themap.poses[update.experience_id, 3] - 0.05) < 0.3


def test_the_setting_is_checked():
    with pytest.raises(InvalidParameterError, match="confirmation_along_path"):
        ExperienceMapConfig(confirmation_along_path=1).validate()


def test_a_link_is_false_where_its_experiences_lie_apart_across_the_path_or_on_another_floor():
    """Judged as a loop closure is (2 m, levels), but only across the place's true heading: the two experiences
    of a link may lie any distance apart along the path."""
    places = np.array([[0.0, 0.0, 0.0, 0.0]] * 5 + [[0.0, 0.0, 0.0, math.pi / 2]])
    positions = np.array([[15.0, 0.5, 0.0],    # 15 m along, 0.5 m across: right
                          [-8.0, -1.9, 0.0],   # behind, 1.9 m across: right
                          [3.0, 2.5, 0.0],     # 2.5 m across: false
                          [0.0, 0.0, 3.0],     # the floor above: false
                          [0.0, 1.5, 1.5],     # 1.5 m across and 1.5 m up (a ramp's middle): 2.1 m, false
                          [2.5, 9.0, 0.0]])    # facing north: 9 m along, 2.5 m across: false
    levels = np.array([0, 0, 0, 1, -1, 0])
    false = false_along_path_mask(places, positions, np.zeros(6, dtype=int), levels, floors=np.array([0.0, 3.0]))
    assert false.tolist() == [False, False, True, True, True, True]
