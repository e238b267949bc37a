"""Eq. M5: a link whose distance nobody observed yields its length to a loop closure, not its direction."""

import math

import numpy as np
import pytest

from neuroslam import NeuroSLAM, SelfMotion
from neuroslam.config import ExperienceMapConfig
from neuroslam.errors import InvalidParameterError
from neuroslam.experience_map import ExperienceMap
from neuroslam.geometry import quarter_wrap
from neuroslam.relaxation import solve_least_squares
from neuroslam.vision.motion import Observed

SIDE = 10  # m, and 1 m links: a 10 x 10 m square
BLIND_READING = 0.3  # of the truth: the blind side reads 3 m (the "held, then none" of a blank floor)


def _square(blind_side: int = 2):
    """A 10 x 10 m square driven counter-clockwise in 1 m links, turning 90° at each corner, its side
    ``blind_side`` read 0.3 m a link; the last link closes the loop at the first experience (the truth:
    no offset). Returns poses dead-reckoned from the links, sources, targets, link poses, and which links
    were blind."""
    link_poses, blind = [], []
    for side in range(4):
        for step in range(SIDE):
            turn = math.pi / 2 if step == SIDE - 1 else 0.0  # the corner's turn at the side's end
            seen = side != blind_side
            link_poses.append((1.0 if seen else BLIND_READING, 0.0, turn, 0.0))
            blind.append(not seen)
    count = len(link_poses)
    poses = np.zeros((count, 4))
    for k in range(1, count):
        distance, heading, facing, _ = link_poses[k - 1]
        x, y, z, yaw = poses[k - 1]
        poses[k] = (x + distance * math.cos(yaw + heading), y + distance * math.sin(yaw + heading), z,
                    yaw + facing)
    sources = np.arange(count)
    targets = np.append(np.arange(1, count), 0)  # the last link closes the loop
    return poses, sources, targets, np.array(link_poses), np.array(blind)


def _solve(poses, sources, targets, link_poses, weights, length_weights=None):
    for _ in range(20):
        poses, settled = solve_least_squares(poses, sources, targets, link_poses, weights,
                                             length_weights=length_weights)
        if settled:
            break
    assert settled
    return poses


def _side_length(poses, side):
    return float(np.linalg.norm(poses[(side * SIDE + SIDE) % len(poses), :2] - poses[side * SIDE, :2]))


def test_a_blind_side_takes_the_loop_error_and_the_measured_sides_keep_their_length():
    """The square's third side reads 3 m of its 10 m, so the loop ends 7 m short. Weighed alike, the
    least-squares map (which trades 1 rad² of yaw against 1 m² of position) puts the 7 m into bending the
    headings (by up to 35°) and leaves the side at 3.07 m. With eq. M5, each blind link 1 s blind (its length
    weighing 1 / (1 + (0.6 × 1 / 0.03)²) = 1/401: the default ``blind_speed_error`` and ``link_length_error``),
    the blind side stretches to 8.96 m, the measured sides keep their 10 m within 2 cm, and the headings bend
    by at most 5° (eq. M4's lines, not used here, hold them further)."""
    poses, sources, targets, link_poses, blind = _square()
    weights = np.ones(len(sources))
    solved = _solve(poses, sources, targets, link_poses, weights, np.where(blind, 1 / 401, 1.0))
    alike = _solve(poses, sources, targets, link_poses, weights)
    assert _side_length(solved, 2) == pytest.approx(8.96, abs=0.05)
    for side in (0, 1, 3):
        assert _side_length(solved, side) == pytest.approx(SIDE, abs=0.03)
    assert np.degrees(np.abs(quarter_wrap(solved[:, 3]))).max() < 5.5
    assert _side_length(alike, 2) == pytest.approx(3.07, abs=0.05)
    assert np.degrees(np.abs(quarter_wrap(alike[:, 3]))).max() > 30


def test_length_weights_equal_to_the_weights_change_nothing():
    poses, sources, targets, link_poses, _ = _square()
    weights = np.ones(len(sources))
    once = solve_least_squares(poses, sources, targets, link_poses, weights)[0]
    same = solve_least_squares(poses, sources, targets, link_poses, weights, length_weights=weights.copy())[0]
    assert np.array_equal(once, same)


def _driven_map(blind_speed_error: float) -> ExperienceMap:
    """The square driven through an ExperienceMap, 5 frames a link, the third side's frames blind in
    distance (each reads 0.06 m of the true 0.2 m), then the loop closed at the first experience."""
    config = ExperienceMapConfig(threshold=0.5, blind_speed_error=blind_speed_error, structure_weight=0.0)
    experience_map = ExperienceMap(config, grid_size=(200, 200, 200))
    experience_map.update(0, np.zeros(3), np.zeros(2), 0.0)
    x = y = yaw = 0.0
    time = 0.0
    for side in range(4):
        for step in range(SIDE):
            blind = side == 2
            for _frame in range(5):
                reading = 0.2 * (BLIND_READING if blind else 1.0)
                experience_map.integrate(reading, 0.0, 0.0, blind_time=0.1 if blind else 0.0)
                x, y = x + reading * math.cos(yaw), y + reading * math.sin(yaw)
                time += 0.1
            if step == SIDE - 1:
                experience_map.integrate(0.0, math.pi / 2, 0.0)
                yaw += math.pi / 2
            if side == 3 and step == SIDE - 1:  # back at the start: re-enter experience 0
                update = experience_map.update(0, np.zeros(3), np.zeros(2), time)
                assert update.loop_closure
            else:  # a new view every metre: a new experience (a different view costs more than the threshold)
                experience_map.update(side * SIDE + step + 1, np.zeros(3), np.zeros(2), time)
    for _ in range(20):
        if experience_map.settled:
            break
        experience_map._solve()
    return experience_map


def test_the_map_counts_each_links_blind_seconds_and_weighs_its_length_by_them():
    driven = _driven_map(0.6)
    blind_times = driven.link_blind_times
    assert len(blind_times) == len(driven.links) == 4 * SIDE
    # the third side's links: five frames of 0.1 s each, all blind (the corner's turn was not)
    assert blind_times[2 * SIDE: 3 * SIDE] == pytest.approx([0.5] * SIDE)
    assert np.all(blind_times[: 2 * SIDE] == 0) and np.all(blind_times[3 * SIDE:] == 0)
    assert driven.length_weights()[2 * SIDE: 3 * SIDE] == pytest.approx([1 / (1 + (0.6 * 0.5 / 0.03) ** 2)] * SIDE)
    assert driven.settled
    poses = driven.poses
    alike = _driven_map(0.0).poses
    # 6.83 m against 3.06 m: the blind links weigh 1/101 here (0.5 s each), the closure's link 0.1
    assert _side_length(poses, 2) == pytest.approx(6.83, abs=0.05)
    assert _side_length(alike, 2) == pytest.approx(3.06, abs=0.05)
    # saved and loaded, the blind seconds travel with the map; a map saved before them loads every length seen
    state = driven.state_dict()
    loaded = ExperienceMap(driven.config, grid_size=(200, 200, 200))
    loaded.load_state_dict(state)
    assert loaded.link_blind_times.tolist() == blind_times.tolist()
    old = {name: value for name, value in state.items() if name != "link_blind_times"}
    loaded.load_state_dict(old)
    assert loaded.link_blind_times.tolist() == [0.0] * len(blind_times)


@pytest.mark.parametrize(("name", "value"), [("blind_speed_error", -0.1), ("blind_speed_error", math.inf),
                                             ("blind_speed_error", math.nan), ("blind_speed_error", True),
                                             ("link_length_error", 0.0), ("link_length_error", -1.0)])
def test_bad_blind_parameters_are_refused(name, value):
    with pytest.raises(InvalidParameterError, match=name):
        ExperienceMapConfig(**{name: value})


@pytest.mark.parametrize(("observed", "blind_seconds"), [(Observed(distance="held"), 0.1),
                                                         (Observed(distance="none"), 0.1),
                                                         (Observed(distance="floor"), 0.0), (None, 0.0)])
def test_neuroslam_counts_the_seconds_its_self_motion_did_not_see_the_distance(observed, blind_seconds):
    """Each frame a new view (random images) at 1 m/s, 0.1 s apart: a new experience every frame, each link
    one frame long, blind for that frame when the self-motion says nothing observed its distance."""
    rng = np.random.default_rng(0)
    slam = NeuroSLAM("sim")
    for frame in range(12):
        # a new scene every frame: random 8 × 8 pixel blocks (per-pixel random values would be read as the
        # sensor's noise, eq. V2, and every such frame as one blank view)
        image = np.kron(rng.integers(0, 256, (15, 20)), np.ones((8, 8))).astype(np.uint8)
        slam.step(image, 0.1 * frame, SelfMotion(1.0, 0.0, 0.0, observed))
    experience_map = slam.experience_map
    assert len(experience_map.links) >= 8
    assert experience_map.link_blind_times == pytest.approx([blind_seconds] * len(experience_map.links))
