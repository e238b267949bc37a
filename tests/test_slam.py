"""The pipeline: bad input is refused without changing anything; a revisited route closes loops."""

import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam import NeuroSLAM, SelfMotion
from neuroslam.vision.motion import Observed


def image(seed, shape=(120, 160, 3)):
    rng = np.random.default_rng(seed)
    return (ndimage.gaussian_filter(rng.random(shape[:2]), 2) * 255).astype(np.uint8)[:, :, None].repeat(3, axis=2)


# bad input to step: tests/test_bad_input.py


def test_a_revisited_route_reuses_its_views_and_closes_loops():
    """A square route of 40 distinct views driven twice with exact odometry: the second lap re-enters the
    first lap's experiences instead of making new ones (the paper's experience map: eq. 22 and eq. 25)."""
    from neuroslam.config import Config, ExperienceMapConfig

    slam = NeuroSLAM(Config(experience_map=ExperienceMapConfig(loop_closure="code", relaxation="passes")))
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


def _square_laps(config, jump, second_lap_observed=None):
    """Two laps of the 40-view square; at the end of the first the odometry over-reads one frame by ``jump`` m.
    ``second_lap_observed``: what the self-motion says it observed on the second lap (None: not said)."""
    slam = NeuroSLAM(config)
    views = [image(100 + k) for k in range(40)]
    t, closures = 0.0, 0
    for lap in range(2):
        for k in range(40):
            t += 0.1
            turning = k % 10 == 9
            speed = 0.0 if turning else 10.0 + (10 * jump if (lap, k) == (0, 38) else 0.0)
            motion = SelfMotion(speed, (math.pi / 2) / 0.1 if turning else 0.0, 0.0,
                                second_lap_observed if lap == 1 else None)
            estimate = slam.step(views[k], t, odometry=motion)
            closures += estimate.loop_closure
    return slam, closures


def test_confirmed_loop_closure_corrects_drift_that_the_codes_cannot():
    """A 6 m odometry error before the second lap (three grid cells: eq. 22's codes no longer match): the
    paper's rule makes new experiences on a parallel track (with the default view calibration, 0.005, it
    closes one loop near the lap's end, too late to bring the lap back: 38 of its 40 frames make new
    experiences); the confirmed rule (the grid-network paper's more than 6 of the last 10 frames) recognises
    the run of views, moves the packets back, closes the loop, and the least-squares map puts the frames back
    on the square."""
    from neuroslam.config import Config, ExperienceMapConfig

    code, code_closures = _square_laps(
        Config(experience_map=ExperienceMapConfig(loop_closure="code", relaxation="passes")), jump=6.0)
    assert code_closures == 1 and code.experience_map.size == 78
    confirmed_config = Config(experience_map=ExperienceMapConfig(
        loop_closure="confirmed", relaxation="least-squares", confirmation_age=2.0, confirmation_drift=0.2,
        confirmation_tolerance=1.0, confirmation_window=10, confirmation_matches=7, confirmation_spacing=0.0))
    confirmed, closures = _square_laps(confirmed_config, jump=6.0)
    assert closures >= 1 and confirmed.experience_map.size < 50
    # the second lap's frames in the final map lie on the first lap's, 6 m off without the rule; the
    # least-squares map spreads the jump over the loop's ~40 links (all weighted alike), so up to ~1 m
    def lap_gaps(slam):
        trajectory = slam.trajectory()
        return np.linalg.norm(trajectory[40:78, :2] - trajectory[:38, :2], axis=1)  # frames 38-39 jumped

    assert np.median(lap_gaps(code)) > 5.0
    assert np.median(lap_gaps(confirmed)) < 1.0


@pytest.mark.parametrize(("distance", "confirmation_blind", "closes"), [
    ("floor", False, True), ("held", False, False), ("none", False, False), ("held", True, True)])
def test_a_loop_is_not_confirmed_where_nothing_observed_the_distance(distance, confirmation_blind, closes):
    """The drifted square of the test above, its second lap's self-motion saying how it saw the distance. Seen
    (``floor``), the run of views confirms the place as without that word; where nothing observed the distance
    (``held``, ``none``), a view places the robot along its path only to within metres
    (``confirmation_blind``), so no loop is confirmed and the lap makes new experiences 6 m off, unless
    ``confirmation_blind`` allows it."""
    from neuroslam.config import Config, ExperienceMapConfig

    config = Config(experience_map=ExperienceMapConfig(
        loop_closure="confirmed", relaxation="least-squares", confirmation_age=2.0, confirmation_drift=0.2,
        confirmation_tolerance=1.0, confirmation_window=10, confirmation_matches=7, confirmation_spacing=0.0,
        confirmation_blind=confirmation_blind))
    slam, closures = _square_laps(config, jump=6.0, second_lap_observed=Observed(distance, "floor", "floor"))
    if closes:
        assert closures >= 1 and slam.experience_map.size < 50
    else:
        assert closures == 0 and slam.experience_map.size >= 75


def test_trajectory_moves_frames_with_their_experiences():
    slam = NeuroSLAM()
    estimates = []
    for k in range(30):
        estimates.append(slam.step(image(k % 7), 0.1 * (k + 1), odometry=SelfMotion(5.0, 0.3)).pose)
    trajectory = slam.trajectory()
    assert trajectory.shape == (30, 4)
    np.testing.assert_allclose(trajectory, np.array(estimates), atol=1e-9)  # nothing relaxed: the online poses
    experience = slam.last.experience_id
    slam.experience_map._poses.data[experience] += [1.0, -2.0, 0.5, 0.0]
    moved = slam.trajectory() - trajectory
    at = slam._frame_experiences.view == experience
    np.testing.assert_allclose(moved[at], np.tile([1.0, -2.0, 0.5, 0.0], (at.sum(), 1)), atol=1e-9)
    assert np.abs(moved[~at]).max() == 0


def test_confirmation_blind_must_be_true_or_false():
    from neuroslam.config import ExperienceMapConfig
    from neuroslam.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="confirmation_blind"):
        ExperienceMapConfig(confirmation_blind=1)
