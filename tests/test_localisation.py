"""The localiser follows its self-motion, corrects only on confirmed recognitions (by inverse-variance
weights, inside the gate), and aligns a loaded map's frame from several recognitions, not one snap.

NeuroSLAM is replaced here by a scripted stand-in that returns chosen estimates, so each rule is checked
against an exact expectation; the closed loop with the real SLAM runs in tests/test_nav.py."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from neuroslam import SelfMotion
from neuroslam.errors import InvalidInputError, InvalidParameterError
from neuroslam.estimate import Estimate
from neuroslam.geometry import compose, quarter_wrap, wrap
from neuroslam.localisation import LocalisationConfig, Localiser, align


class ScriptedSLAM:
    """Returns the estimate the test sets for the next frame (``pose`` in the SLAM's frame)."""

    def __init__(self):
        self.experience_map = SimpleNamespace(component=0)
        self.sessions = []
        self.next = {}
        self.experience = 0
        self.floor_lines = math.nan  # the floor's lines in the robot's frame, every frame unless set per frame

    def begin_session(self, start="unknown"):
        self.sessions.append(start)
        self.experience_map.component = 1

    def step(self, image, timestamp, odometry=None):
        plan = {"pose": np.zeros(4), "loop_closure": False, "merged": False, "experience": None,
                "floor_lines": self.floor_lines, **self.next}
        self.next = {}
        if plan["merged"]:
            self.experience_map.component = 0
        new = plan["experience"] is None
        if new:
            self.experience += 1
        experience = self.experience if new else plan["experience"]
        return Estimate(float(timestamp), np.asarray(plan["pose"], dtype=float), experience, 0, plan["loop_closure"],
                        new, False, odometry, np.zeros(3), np.zeros(2), plan["merged"], plan["floor_lines"])


IMAGE = np.zeros((8, 8), dtype=np.uint8)
STRAIGHT = SelfMotion(1.0, 0.0, 0.0)  # 1 m/s ahead
STOPPED = SelfMotion(0.0, 0.0, 0.0)


def drive(localiser, frames, start_time=0.0, motion=STRAIGHT):
    for k in range(frames):
        where = localiser.step(IMAGE, start_time + 0.1 * k, odometry=motion)
    return where


def test_without_recognitions_the_pose_is_the_self_motion_and_its_uncertainty_grows_linearly():
    config = LocalisationConfig(distance_drift=0.02, turn_drift=0.0, heading_drift=0.0, height_drift=0.01)
    start = np.array([3.0, -2.0, 1.0, math.pi / 2])
    localiser = Localiser(ScriptedSLAM(), start, config)
    where = drive(localiser, 101)  # 100 steps of 0.1 s at 1 m/s after the first frame: 10 m north
    np.testing.assert_allclose(where.pose, [3.0, 8.0, 1.0, math.pi / 2], atol=1e-9)
    assert where.position_error == pytest.approx(0.2) and where.height_error == pytest.approx(0.1)
    assert not where.corrected and where.aligned


BACK = SelfMotion(-1.0, 0.0, 0.0)  # 1 m/s reversing


def test_a_recognition_pulls_the_pose_by_the_inverse_variance_weight():
    """Experience 1 is laid at the start with no uncertainty; 50 m east and 49 m back the prediction is 1 m
    east of it (1σ 1.98 m). Recognising it measures the pose the localiser had when it laid it, whatever the
    experience map now says (here 30 m off), and the pose moves by the inverse-variance gain."""
    config = LocalisationConfig(distance_drift=0.02, turn_drift=0.0, heading_drift=0.0, recognition_error=0.3)
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    drive(localiser, 1)  # the first frame: experience 1, laid at the start with no uncertainty
    drive(localiser, 500, start_time=0.1)  # 50 m east
    where = drive(localiser, 490, start_time=50.1, motion=BACK)  # 49 m back: 1 m east of the start
    sigma = where.position_error
    assert sigma == pytest.approx(1.98) and where.pose[0] == pytest.approx(1.0)
    slam.next = {"pose": np.array([30.0, 0.0, 0.0, 0.0]), "loop_closure": True, "experience": 1}
    before = where.pose.copy()
    where = localiser.step(IMAGE, 99.1, odometry=STOPPED)
    gain = sigma**2 / (sigma**2 + 0.3**2)
    assert where.corrected and where.pose[0] - before[0] == pytest.approx(gain * -1.0)
    assert where.pose[1] == pytest.approx(0.0)
    fused = math.sqrt(sigma**2 * 0.09 / (sigma**2 + 0.09))
    assert where.position_error == pytest.approx(max(fused, 0.3 / math.sqrt(2)))


def test_a_recognition_beyond_the_gate_is_rejected():
    """Back at 4 m east of experience 1 with a 1σ of 0.96 m: the gate is 3 * hypot(0.96, 0.3) = 3.0 m."""
    config = LocalisationConfig(distance_drift=0.01, turn_drift=0.0, heading_drift=0.0, recognition_error=0.3, gate=3.0)
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    drive(localiser, 501)  # experience 1 at the start; 50 m east
    where = drive(localiser, 460, start_time=50.1, motion=BACK)  # 46 m back
    slam.next = {"pose": where.pose, "loop_closure": True, "experience": 1}
    after = localiser.step(IMAGE, 96.1, odometry=STOPPED)
    assert after.rejected and localiser.rejections == 1
    np.testing.assert_allclose(after.pose, where.pose)  # its height agreed (taken), its plane did not


def test_recognitions_that_agree_again_and_again_outside_the_gate_are_taken():
    """Three in a row, each 4 m west of the prediction (wheels that slipped): the third moves the pose."""
    config = LocalisationConfig(distance_drift=0.01, turn_drift=0.0, heading_drift=0.0, recognition_error=0.3,
                                persistence=3)
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    drive(localiser, 501)
    where = drive(localiser, 460, start_time=50.1, motion=BACK)
    for k in range(3):
        slam.next = {"pose": where.pose, "loop_closure": True, "experience": 1}
        after = localiser.step(IMAGE, 96.1 + 0.1 * k, odometry=STOPPED)
        assert after.rejected == (k < 2)
    np.testing.assert_allclose(after.pose, np.zeros(4), atol=1e-9)
    assert after.position_error == pytest.approx(0.3)


def test_a_loaded_map_is_aligned_from_several_recognitions_not_snapped_to_the_first():
    """The map's frame is the task's turned by 90° and shifted. The merge and the next three recognitions
    correct nothing; the fifth, once they span 5 m, aligns the frame, and from then on they correct."""
    map_from_task = np.array([10.0, -4.0, 2.0, math.pi / 2])  # a task pose p is compose(map_from_task, p) in the map
    MAPPED = 10_000  # an experience of the loaded map (this session never laid it)
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), LocalisationConfig(), loaded_map=True)
    assert slam.sessions == ["unknown"] and not localiser.aligned
    drive(localiser, 1)
    assert localiser.aligned  # its own session's frame starts at the task's start
    slam.next = {"merged": True, "pose": compose(map_from_task, localiser.pose), "experience": MAPPED}
    where = localiser.step(IMAGE, 0.1, odometry=STOPPED)
    assert not localiser.aligned and not where.corrected
    time = 0.2
    for k in range(4):
        drive(localiser, 19, start_time=time)  # 1.9 m on
        time += 1.9
        slam.next = {"loop_closure": True, "pose": compose(map_from_task, localiser.pose), "experience": MAPPED}
        where = localiser.step(IMAGE, time, odometry=STOPPED)
        time += 0.1
        assert localiser.aligned == (k == 3)  # the merge's pair and four more
        assert not where.corrected or k == 3
    # now a recognition that says the robot is 0.5 m south of its prediction moves it there by the weights
    drive(localiser, 100, start_time=time)
    truth = localiser.pose + np.array([0.0, -0.5, 0.0, 0.0])
    slam.next = {"loop_closure": True, "pose": compose(map_from_task, truth), "experience": MAPPED}
    before, sigma = localiser.pose.copy(), float(localiser.sigma[0])
    where = localiser.step(IMAGE, time + 10.0, odometry=STOPPED)
    noise = math.hypot(0.5, 0.3)  # a loaded map's place: map_error and recognition_error (an exact alignment)
    assert where.corrected and where.pose[1] - before[1] == pytest.approx(-0.5 * sigma**2 / (sigma**2 + noise**2))
    assert abs(where.pose[0] - before[0]) < 1e-6  # an exact alignment moves nothing sideways


def test_align_recovers_a_rigid_transform_despite_an_outlier():
    rng = np.random.default_rng(3)
    transform = np.array([4.0, -7.0, 3.0, 2.5])
    mapped = np.column_stack([rng.uniform(-20, 20, (12, 2)), rng.uniform(0, 3, 12), rng.uniform(-3, 3, 12)])
    task = compose(transform, mapped) + np.column_stack([rng.normal(0, 0.05, (12, 3)), np.zeros(12)])
    task[5, :2] += [6.0, -4.0]  # a false recognition
    found, residual = align([(task[k], mapped[k], 1.0) for k in range(12)])
    np.testing.assert_allclose(found[:3], transform[:3], atol=0.1)
    assert abs(found[3] - transform[3]) < 0.01 and residual < 0.15


@pytest.mark.parametrize("field, value", [("distance_drift", -0.1), ("gate", 0.0), ("alignment_pairs", 1),
                                          ("map_error", math.nan)])
def test_bad_settings_are_refused_by_name(field, value):
    with pytest.raises(InvalidParameterError, match=f"localisation.{field}"):
        LocalisationConfig(**{field: value})


def test_a_bad_start_and_an_unknown_preset_are_refused():
    with pytest.raises(InvalidInputError, match="start"):
        Localiser(ScriptedSLAM(), np.array([0.0, 0.0, math.nan, 0.0]))
    with pytest.raises(InvalidInputError, match="odometry"):
        LocalisationConfig.preset("lidar")


# the floor's lines -------------------------------------------------------------------------------------------
AXIS = math.radians(10.0)  # the world's lines' direction, modulo 90°
CURVING = SelfMotion(1.0, math.radians(0.5), 0.0)  # the wheels read a turn of 0.05° a frame; the robot drives straight


def _lines_localiser(lines_error, orientation_noise=0.0, seed=0):
    """A robot driving straight east (heading 0) whose wheels read a steady left turn; the floor's lines at
    AXIS in the world, seen in its true frame with ``orientation_noise`` (rad) per frame."""
    # the heading's uncertainty grows 1 mrad a metre: a localiser sure of its heading would take nothing
    config = LocalisationConfig(turn_drift=0.0, heading_drift=0.001, lines_error=lines_error)
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    rng = np.random.default_rng(seed)
    for k in range(600):  # 60 s, 60 m
        slam.floor_lines = float(quarter_wrap(AXIS - 0.0 + rng.normal(0.0, orientation_noise)))
        where = localiser.step(IMAGE, 0.1 * k, odometry=CURVING)
    return localiser, where


def test_the_floor_lines_hold_a_drifting_heading():
    # the wheels turn the heading 0.05° a frame (30° over 60 m); the lines, 1° of scatter a frame, fix their
    # direction over the first 30 frames (1.5° of drift by then, so the direction is that far off) and hold the
    # heading to it: within the reference's offset plus the lag of a metre's median
    localiser, where = _lines_localiser(math.radians(1.0), orientation_noise=math.radians(1.0))
    assert localiser.lines_axis == pytest.approx(AXIS, abs=math.radians(2.0))
    assert abs(wrap(where.pose[3])) < math.radians(3.0)
    assert localiser.lines_corrections > 50
    assert where.heading_error >= math.radians(1.0) / math.sqrt(2) - 1e-12  # never surer than the lines allow
    _, drifting = _lines_localiser(0.0)  # off (the default): the wheels' heading alone
    assert wrap(drifting.pose[3]) == pytest.approx(math.radians(0.05) * 599, abs=1e-9)


def test_lines_that_disagree_fix_no_direction_and_turn_nothing():
    # orientations scattered over every direction: their median deviation exceeds lines_error, so no direction
    # is fixed and the pose is the wheels' alone
    config = LocalisationConfig(turn_drift=0.0, heading_drift=0.0, lines_error=math.radians(1.0))
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    rng = np.random.default_rng(1)
    for k in range(300):
        slam.floor_lines = float(rng.uniform(-math.pi / 4, math.pi / 4))
        where = localiser.step(IMAGE, 0.1 * k, odometry=CURVING)
    assert localiser.lines_axis is None and localiser.lines_corrections == 0
    assert wrap(where.pose[3]) == pytest.approx(math.radians(0.05) * 299, abs=1e-9)


def test_a_misread_metre_beyond_the_gate_turns_nothing():
    # once the direction is fixed, a metre of lines 20° off (a wall read as floor) is outside the gate
    config = LocalisationConfig(turn_drift=0.0, heading_drift=0.001, lines_error=math.radians(1.0))
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    slam.floor_lines = AXIS
    drive(localiser, 40)  # straight, no drift: the direction is fixed at AXIS
    assert localiser.lines_axis == pytest.approx(AXIS)
    slam.floor_lines = AXIS + math.radians(20.0)
    where = drive(localiser, 12, start_time=4.0)
    assert where.pose[3] == pytest.approx(0.0, abs=1e-12)


def test_lines_seen_late_stop_the_drift_from_there():
    # 30 m without lines (the wheels' turn reads 15° by then), then lines: their direction is fixed where the
    # heading then is, as unsure as the heading was, and the heading holds there instead of drifting 15° more
    config = LocalisationConfig(turn_drift=0.0, heading_drift=0.001, lines_error=math.radians(1.0))
    slam = ScriptedSLAM()
    localiser = Localiser(slam, np.zeros(4), config)
    drive(localiser, 300, motion=CURVING)
    sigma_then = localiser.last.heading_error
    slam.floor_lines = AXIS
    where = drive(localiser, 300, start_time=30.0, motion=CURVING)
    # fixed on the 30th frame with lines, 3 m later: the heading's 1σ grew 1 mrad a metre meanwhile
    assert localiser.lines_axis_error == pytest.approx(sigma_then + 0.001 * 3.0, abs=1e-9)
    assert abs(wrap(where.pose[3]) - math.radians(0.05) * 330) < math.radians(2.0)  # 16.5° then, held
    assert where.heading_error >= sigma_then * 0.95
