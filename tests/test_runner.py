"""The runner (neuroslam.lab.runner.run) over a frame stream: its history, metrics.json, the files it writes,
Ctrl-C, and the self-motion of each odometry mode (neuroslam.lab.frames.SelfMotionSource)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scenes import Scene, arc_path

from neuroslam import InvalidParameterError, NeuroSLAM
from neuroslam.evaluation import align
from neuroslam.lab.frames import Frame, FrameStream, SelfMotionSource, Truth, Wheels
from neuroslam.lab.runner import run
from neuroslam.tum import read_tum, yaw_quaternion

RATE = 10.0  # frames a second
SCENE = Scene()  # a textured floor between textured walls, under a ceiling


class ListStream:
    """Frames rendered along known poses (a ``FrameStream``), optionally with exact wheels, optionally
    interrupted (Ctrl-C) before frame ``interrupt_at``."""

    unit = "frame"
    name = "synthetic"
    levels = (0.0,)

    def __init__(self, poses: np.ndarray, *, wheels: bool = False, interrupt_at: int | None = None):
        self.poses, self.with_wheels, self.interrupt_at = poses, wheels, interrupt_at
        self.total = float(len(poses))

    def __iter__(self):
        for index, (x, y, yaw) in enumerate(self.poses):
            if index == self.interrupt_at:
                raise KeyboardInterrupt
            wheels = None
            if self.with_wheels:
                before = self.poses[max(index - 1, 0)]
                step = math.hypot(x - before[0], y - before[1])
                wheels = Wheels(step * RATE, (yaw - before[2]) * RATE, x, y, yaw)
            yield Frame(SCENE.render(x, y, yaw), index / RATE, index,
                        Truth(np.array([x, y, 0.0, yaw]), yaw_quaternion(yaw), 0), wheels, None, index + 1)

    def describe(self):
        return {"world": "synthetic", "route": None}

    def summary(self):
        return {}

    def timings(self):
        return {"physics": None, "render": None}

    def map_metadata(self):
        return {"world": "synthetic"}


POSES = arc_path([(4.0, 0.0), (3.0, math.pi / 2)], rate=RATE)  # 4 m straight, then a quarter turn over 3 m


def test_a_list_of_frames_is_a_frame_stream():
    assert isinstance(ListStream(POSES), FrameStream)


def test_the_history_holds_every_frame_and_metrics_score_it():
    result = run(ListStream(POSES), NeuroSLAM("sim"), progress=False)
    frames = len(POSES)
    assert result.frames == frames and not result.interrupted
    np.testing.assert_allclose(result.times, np.arange(frames) / RATE)
    assert result.online.shape == result.self_motion.shape == result.estimate.shape == (frames, 4)
    assert result.active.shape == (frames, 2) and len(result.observed) == frames
    np.testing.assert_allclose(result.truth[:, [0, 1, 3]], POSES)
    metrics = result.metrics()
    assert list(metrics)[:4] == ["world", "route", "frames", "distance_m"]
    assert metrics["frames"] == frames and metrics["odometry"] == "visual"
    true_distance = np.sum(np.hypot(*np.diff(POSES[:, :2], axis=0).T))
    assert metrics["distance_m"] == pytest.approx(true_distance, rel=1e-12)
    assert metrics["levels_visited"] == [0] and metrics["level_accuracy"] == 1.0
    # the scores are of the history: the odometry's path after a Sim(3) alignment to the truth, the SLAM's
    # final trajectory
    truth = result.truth[:, :3]
    for name, path in (("odometry", result.self_motion), ("slam", result.estimate)):
        error = np.sqrt(np.mean(np.sum((align(path[:, :3], truth) - truth) ** 2, axis=1)))
        assert metrics["ate_rmse_m"][name] == pytest.approx(error, rel=1e-12)
    np.testing.assert_array_equal(result.estimate, result.slam.trajectory())
    assert metrics["ms_per_frame"]["render"] is None and metrics["ms_per_frame"]["slam"] > 0
    assert "interrupted" not in metrics


def test_write_leaves_every_output_file(tmp_path):
    result = run(ListStream(POSES[:30], wheels=True), NeuroSLAM("sim"), progress=False)
    written = result.write(tmp_path / "out")
    names = {path.name for path in written}
    assert names == {"groundtruth.tum", "wheel_odometry.tum", "slam.tum", "slam_online.tum", "odometry.tum",
                     "experiences.tum", "map.npz", "metrics.json", "report.png"}
    assert all(path.is_file() for path in written)
    times, positions, _ = read_tum(tmp_path / "out" / "groundtruth.tum")
    np.testing.assert_array_equal(times, result.times)
    np.testing.assert_array_equal(positions, result.truth[:, :3])
    saved = json.loads((tmp_path / "out" / "metrics.json").read_text())
    fresh = result.metrics()
    assert {key: value for key, value in saved.items() if key != "ms_per_frame"} == json.loads(json.dumps(
        {key: value for key, value in fresh.items() if key != "ms_per_frame"}))
    assert NeuroSLAM.load(tmp_path / "out" / "map.npz").experience_map.size == result.slam.experience_map.size


def test_ctrl_c_keeps_the_frames_done(tmp_path):
    result = run(ListStream(POSES, interrupt_at=25), NeuroSLAM("sim"), progress=False)
    assert result.interrupted and result.frames == 25
    assert result.estimate.shape == (25, 4)
    result.write(tmp_path)
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["interrupted"] is True and metrics["frames"] == 25
    assert len(read_tum(tmp_path / "slam.tum")[0]) == 25


def test_wheel_self_motion_is_the_encoders_speed_and_turn():
    poses = POSES[:40]
    result = run(ListStream(poses, wheels=True), NeuroSLAM("sim"), odometry="wheel", progress=False)
    # exact wheels: the odometry's path is the true path (the arc midpoint rule of both integrations agrees)
    np.testing.assert_allclose(result.self_motion[:, :2], poses[:, :2] - poses[0, :2], atol=2e-3)
    assert result.metrics()["odometry"] == "wheel"


def test_self_motion_sources_refuse_what_they_cannot_use():
    slam = NeuroSLAM("sim")
    with pytest.raises(InvalidParameterError, match="odometry"):
        SelfMotionSource("lidar", slam)
    frame = Frame(SCENE.render(0.0, 0.0, 0.0), 0.0, 0)
    assert SelfMotionSource("visual", slam)(frame) is None
    with pytest.raises(InvalidParameterError, match="no wheel odometry"):
        SelfMotionSource("wheel", slam)(frame)
    with pytest.raises(InvalidParameterError, match="no IMU"):
        SelfMotionSource("visual-inertial", slam)(frame)


def test_a_run_continues_a_loaded_map_and_reports_its_merges(tmp_path):
    first = run(ListStream(POSES[:30]), NeuroSLAM("sim"), progress=False)
    first.slam.save(tmp_path / "map.npz")
    slam = NeuroSLAM.load(tmp_path / "map.npz")
    slam.begin_session()
    second = run(ListStream(POSES[:30]), slam, progress=False)  # no truth saved with the map: unknown, not an error
    metrics = second.metrics()
    assert metrics["frames"] == 30 and "merges" in metrics and "false_merges" in metrics
    size = first.slam.experience_map.size
    assert second.book.of(np.arange(size))[1].tolist() == [-1] * size


def test_on_frame_sees_every_frame_after_its_step():
    seen = []

    def keep(frame, estimate, slam):
        seen.append((frame.index, estimate.timestamp, slam.frames))

    result = run(ListStream(POSES[:12]), NeuroSLAM("sim"), progress=False, on_frame=keep)
    assert seen == [(index, index / RATE, index + 1) for index in range(12)]
    np.testing.assert_array_equal(result.times, np.arange(12) / RATE)


def test_the_closures_a_merge_found_before_it_are_scored_at_their_own_frames():
    """On a merging frame the runner keeps each loop closure the merge found among earlier frames with the
    truth of the experience it joined, at the earlier frame (where a false one is judged)."""
    from types import SimpleNamespace

    from neuroslam.lab.runner import _note_events

    truths = {7: [1.0, 2.0, 0.0], 9: [3.0, 4.0, 3.0]}
    book = SimpleNamespace(of=lambda ids: (np.array([[*truths[int(i)], 0.0] for i in ids]),
                                           np.array([int(truths[int(i)][2] > 1) for i in ids])))
    history = SimpleNamespace(book=book, closures=[], merges=[],
                              slam=SimpleNamespace(closures_before_merge=[(3, 7), (5, 9)]))
    _note_events(history, SimpleNamespace(loop_closure=False, merged=False, experience_id=7), 40)
    assert history.closures == [] and history.merges == []
    _note_events(history, SimpleNamespace(loop_closure=False, merged=True, experience_id=9), 41)
    assert [frame for frame, _, _ in history.merges] == [41]
    assert [(frame, list(pose), level) for frame, pose, level in history.closures] == [
        (3, [1.0, 2.0, 0.0], 0), (5, [3.0, 4.0, 3.0], 1)]
