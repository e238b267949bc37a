"""Trajectory alignment recovers a known similarity transform; the ATE of a hand-computed case."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from neuroslam.evaluation import associate, ate_rmse, umeyama


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


def test_a_closure_on_a_ramp_is_judged_by_distance_and_one_between_floors_by_level():
    """Floors at 0 and 1.8 m. Closure 0: two places 0.24 m apart on a ramp, either side of its half-way height
    (labelled levels 0 and 1): the same place, true with the floors given, false by labels alone. Closure 1:
    one floor over the other, 1.8 m apart (within 2 m): false either way. Closure 2: a ramp place 1.41 m
    from a place on the upper floor (labelled levels 0 and 1): judged by distance, true. Closure 3: the ramp,
    2.1 m apart: false."""
    from neuroslam.evaluation import FLOOR_TOLERANCE, false_loop_closure_mask, false_loop_closures

    now = np.array([[0, 0, 0.85], [4, 0, 0.0], [6, 0, 0.8], [0, 0, 0.5]])
    then = np.array([[0.2, 0, 0.98], [4, 0, 1.8], [7.0, 0, 1.8], [2.0, 0, 1.14]])
    levels_now, levels_then = np.array([0, 0, 0, 0]), np.array([1, 1, 1, 0])
    floors = np.array([0.0, 1.8])
    assert false_loop_closure_mask(now, then, levels_now, levels_then, floors=floors).tolist() == [
        False, True, False, True]
    assert false_loop_closure_mask(now, then, levels_now, levels_then).tolist() == [True, True, True, True]
    assert false_loop_closures(now, then, levels_now, levels_then, floors=floors) == 2
    # within the tolerance of a floor a place is on it: the ramp's foot against the floor above is false
    foot = np.array([[4, 0, FLOOR_TOLERANCE]])
    assert false_loop_closures(foot, np.array([[4, 0, 1.8]]), np.array([0]), np.array([1]), floors=floors) == 1


def test_run_metrics_counts_true_closures_per_level():
    """Six frames on two levels; closures at frames 3 (back at frame 0's place: true, level 0), 4 (3 m from
    frame 1: false) and 5 (over frame 2 but one level up: false)."""
    from neuroslam.evaluation import run_metrics

    truth = np.array([[0, 0, 0, 0], [5, 0, 0, 0], [10, 0, 0, 0], [0.5, 0, 0, 0], [8, 0, 0, 0], [10, 0, 3, 0]], float)
    levels = np.array([0, 0, 0, 0, 0, 1])
    metrics = run_metrics(truth=truth, true_levels=levels, levels=np.array([0.0, 3.0]), estimate=truth,
                          odometry=truth, experience_positions=truth[:3, :3], experience_truth=truth[:3, :3],
                          experience_levels=levels[:3], closure_frames=np.array([3, 4, 5]),
                          closure_truth=truth[:3, :3], closure_levels=levels[:3])
    assert metrics["loop_closures"] == 3
    assert metrics["false_loop_closures"] == 2
    assert metrics["true_loop_closures_per_level"] == {"0": 1, "1": 0}
    assert metrics["level_accuracy"] == 1.0
    assert metrics["map_rmse_m"] == 0.0 and "merges" not in metrics
    # the same closure at frame 5, but frame 5 half-way up a ramp (1.5 m, labelled level 1) and 1.5 m from
    # frame 2's place: on no level, judged by distance, so true; it counts for its labelled level
    truth[5, 2] = 1.5
    metrics = run_metrics(truth=truth, true_levels=levels, levels=np.array([0.0, 3.0]), estimate=truth,
                          odometry=truth, experience_positions=truth[:3, :3], experience_truth=truth[:3, :3],
                          experience_levels=levels[:3], closure_frames=np.array([3, 4, 5]),
                          closure_truth=truth[:3, :3], closure_levels=levels[:3])
    assert metrics["false_loop_closures"] == 1
    assert metrics["true_loop_closures_per_level"] == {"0": 1, "1": 1}


def test_run_metrics_scores_merges_and_a_map_with_unknown_places():
    """Merges judged like loop closures (the place merged at against where the robot truly is); experiences
    of a loaded map saved without ground truth (NaN) stay out of the map error."""
    from neuroslam.evaluation import run_metrics

    truth = np.array([[0, 0, 0, 0], [5, 0, 0, 0], [10, 0, 0, 0], [0.5, 0, 0, 0], [8, 0, 0, 0], [10, 0, 3, 0]], float)
    levels = np.array([0, 0, 0, 0, 0, 1])
    places = np.array([[0, 0, 0], [5, 0, 0], [10, 0, 0], [np.nan] * 3])
    mapped = places.copy()
    mapped[:3] *= 2  # a map at twice the scale is exact after the Sim(3) alignment
    mapped[3] = [100, 100, 100]
    metrics = run_metrics(truth=truth, true_levels=levels, levels=np.array([0.0, 3.0]), estimate=truth,
                          odometry=truth, experience_positions=mapped, experience_truth=places,
                          closure_frames=np.zeros(0, int), closure_truth=np.zeros((0, 3)), closure_levels=np.zeros(0),
                          merge_frames=np.array([3, 5]), merge_truth=places[[0, 2]], merge_levels=np.array([0, 0]))
    assert metrics["map_rmse_m"] == pytest.approx(0.0, abs=1e-9)
    assert metrics["merges"] == 2 and metrics["merge_frames"] == [3, 5]
    assert metrics["false_merges"] == 1  # frame 5 is one level above the place it merged at


# --- against evo (github.com/MichaelGrupp/evo), the reference implementation of these metrics, where installed ---

STEP = 0.345  # m of true travel per frame: a 10 m segment is 29 frames (10.005 m), far from a tie (28 = 9.66 m)


def _drive_with_drift(frames: int = 400, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """A true (x, y, z, yaw) trajectory at a constant STEP per frame, with turns and a ramp up and down,
    and an estimate of it that drifts in scale (+4 %) and heading (0.1°/frame) with noise, then moved by a
    known 4-DoF similarity (scale 0.8, 40° about z, an offset); m and rad."""
    rng = np.random.default_rng(seed)
    k = np.arange(frames)
    yaw = 0.9 * np.sin(k / 35) + k / 60  # curving and circling
    pitch = np.where((k > 120) & (k < 180), 0.12, 0.0) - np.where((k > 260) & (k < 320), 0.12, 0.0)
    direction = np.column_stack([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    positions = np.vstack([[0.0, 0.0, 0.0], np.cumsum(STEP * direction[:-1], axis=0)])
    truth = np.column_stack([positions, yaw])
    estimated_yaw = yaw + np.radians(0.1) * k + rng.normal(0, 0.01, frames)
    heading = np.column_stack([np.cos(pitch) * np.cos(estimated_yaw), np.cos(pitch) * np.sin(estimated_yaw),
                               np.sin(pitch)])
    steps = 1.04 * STEP * heading[:-1] + rng.normal(0, 0.01, (frames - 1, 3))
    local = np.vstack([[0.0, 0.0, 0.0], np.cumsum(steps, axis=0)]) + rng.normal(0, 0.05, (frames, 3))
    turn = Rotation.from_euler("z", 40, degrees=True).as_matrix()
    estimate = np.column_stack([0.8 * local @ turn.T + [5.0, -3.0, 2.0], estimated_yaw + np.radians(40)])
    return truth, estimate


def _evo_trajectory(poses: np.ndarray, times: np.ndarray):
    """An evo trajectory of (x, y, z, yaw) poses: orientation a rotation about z only (NeuroSLAM is 4-DoF)."""
    from evo.core.trajectory import PoseTrajectory3D

    from neuroslam.tum import yaw_quaternion

    return PoseTrajectory3D(positions_xyz=poses[:, :3], orientations_quat_wxyz=yaw_quaternion(poses[:, 3]),
                            timestamps=times)


def _evo_ate(reference, estimate, *, with_scale: bool) -> tuple[float, tuple]:
    """evo's APE RMSE of the positions after its Umeyama alignment (Sim(3), or SE(3) without scale), m, and
    the alignment (rotation, translation, scale) it found."""
    import copy

    from evo.core.metrics import APE, PoseRelation, StatisticsType

    aligned = copy.deepcopy(estimate)  # align() moves the trajectory in place
    transform = aligned.align(reference, correct_scale=with_scale)
    ape = APE(PoseRelation.translation_part)
    ape.process_data((reference, aligned))
    return ape.get_statistic(StatisticsType.rmse), transform


def test_ate_and_alignment_match_evo():
    pytest.importorskip("evo")
    truth, estimate = _drive_with_drift()
    # a general 3-D rotation too (ATE uses positions only): the Umeyama fit must undo any Sim(3)
    tilt = Rotation.from_euler("zyx", [-25, 8, -4], degrees=True).as_matrix()
    estimate = np.column_stack([estimate[:, :3] @ tilt.T, estimate[:, 3]])
    times = 0.1 * np.arange(len(truth))
    reference, estimated = _evo_trajectory(truth, times), _evo_trajectory(estimate, times)
    for with_scale in (True, False):
        evo_ate, (evo_rotation, evo_translation, evo_scale) = _evo_ate(reference, estimated, with_scale=with_scale)
        scale, rotation, translation = umeyama(estimate[:, :3], truth[:, :3], with_scale=with_scale)
        np.testing.assert_allclose(rotation, evo_rotation, atol=1e-9)
        np.testing.assert_allclose(translation, evo_translation, rtol=1e-9, atol=1e-9)
        assert scale == pytest.approx(evo_scale, rel=1e-9)
        assert ate_rmse(estimate[:, :3], truth[:, :3], with_scale=with_scale) == pytest.approx(evo_ate, rel=1e-6)
        assert evo_ate > 0.1  # drift and noise that no alignment removes: the comparison is not 0 against 0
    assert scale == 1.0 and evo_scale == 1.0
    assert umeyama(estimate[:, :3], truth[:, :3])[0] == pytest.approx(1 / 0.8, rel=0.1)  # the known scale, roughly


def test_rpe_matches_evo_with_the_same_pairs():
    """Our RPE is evo's RPE of the translation part (the norm of the translation of
    (Q_i⁻¹ Q_j)⁻¹ (P_i⁻¹ P_j), which is |R(P_i)ᵀ Δp_est − R(Q_i)ᵀ Δp_true|) over pairs 10 m of true travel
    apart, taken from every frame.

    Differences in definition, and how the evo call is made to match ours:
    - pairs: ours takes for every frame i the *first* frame j at least 10 m further along the true path; evo's
      ``delta_unit=meters, all_pairs=True`` takes the frame *nearest* to 10 m and keeps it if it is within
      ``rel_delta_tol`` × 10 m (default 10 %, so it also keeps pairs near the end only 9 m apart). At a constant
      0.345 m per frame the first and the nearest frame are the same (29 frames, 10.005 m), and
      ``rel_delta_tol=0.01`` drops the short pairs at the end, so both use the same pairs;
      ``pairs_from_reference=True`` measures the travel on the true path, as ours does.
    - orientation: ours expresses each displacement in the heading frame of frame i (yaw only: NeuroSLAM
      is 4-DoF); evo uses the full orientation. Here both trajectories carry yaw-only orientations, so the
      frames are the same; on a true trajectory with pitch (ramps) evo's number differs slightly.
    """
    pytest.importorskip("evo")
    from evo.core.metrics import RPE, PoseRelation, StatisticsType, Unit

    from neuroslam.evaluation import rpe_rmse

    truth, estimate = _drive_with_drift()
    times = 0.1 * np.arange(len(truth))
    reference, estimated = _evo_trajectory(truth, times), _evo_trajectory(estimate, times)
    rpe = RPE(PoseRelation.translation_part, delta=10.0, delta_unit=Unit.meters, rel_delta_tol=0.01,
              all_pairs=True, pairs_from_reference=True)
    rpe.process_data((reference, estimated))
    assert len(rpe.error) == len(truth) - 29  # every frame with a partner 29 frames on, as ours
    ours = rpe_rmse(estimate, truth)
    assert ours == pytest.approx(rpe.get_statistic(StatisticsType.rmse), rel=1e-6)
    assert ours > 1.0  # the 0.8 scale alone costs 2 m per 10 m segment: not 0 against 0


def test_run_metrics_and_tum_files_of_a_drive_match_evo(tmp_path):
    """A short drive through the car park with the CLI: evo reads every TUM file it writes, and its ATE
    (Sim(3) and SE(3)) and RPE of slam.tum, slam_online.tum and odometry.tum against groundtruth.tum are the ones in
    metrics.json (to the 9 digits of the files)."""
    pytest.importorskip("evo")
    import json

    from evo.core.metrics import RPE
    from evo.tools import file_interface

    from neuroslam.lab.cli import main

    assert main(["drive", "carpark", "--max-frames", "200", "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "metrics.json").read_text())
    trajectories = {}
    for name in ("groundtruth", "slam", "slam_online", "odometry", "wheel_odometry", "experiences"):
        trajectory = file_interface.read_tum_trajectory_file(tmp_path / f"{name}.tum")
        valid, details = trajectory.check()  # unit quaternions, SE(3) poses, ascending unique timestamps
        assert valid, (name, details)
        trajectories[name] = trajectory
    truth = trajectories["groundtruth"]
    assert truth.num_poses == summary["frames"] == 200
    for name in ("slam", "slam_online", "odometry", "wheel_odometry"):
        np.testing.assert_array_equal(trajectories[name].timestamps, truth.timestamps)
    assert trajectories["experiences"].num_poses == summary["experiences"]

    # our RPE is 4-DoF: ground truth with its heading only (the file has the full orientation, pitched on ramps)
    w, x, y, z = truth.orientations_quat_wxyz.T
    true_yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    flat_truth = _evo_trajectory(np.column_stack([truth.positions_xyz, true_yaw]), truth.timestamps)
    positions = truth.positions_xyz
    travelled = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(positions, axis=0), axis=1))])
    partners = np.searchsorted(travelled, travelled + 10.0)  # our pairs (see the test above): speed varies here
    pairs = [(i, j) for i, j in enumerate(partners) if j < len(positions)]
    assert len(pairs) > 20
    for name in ("slam", "slam_online", "odometry"):
        estimate = trajectories[name]
        assert _evo_ate(truth, estimate, with_scale=True)[0] == pytest.approx(summary["ate_rmse_m"][name], rel=1e-6)
        assert _evo_ate(truth, estimate, with_scale=False)[0] == pytest.approx(summary["ate_se3_rmse_m"][name],
                                                                               rel=1e-6)
        # evo's relative error pose of each pair, translation part
        errors = [np.linalg.norm(RPE.rpe_base(flat_truth.poses_se3[i], flat_truth.poses_se3[j],
                                              estimate.poses_se3[i], estimate.poses_se3[j])[:3, 3])
                  for i, j in pairs]
        assert np.sqrt(np.mean(np.square(errors))) == pytest.approx(summary["rpe_rmse_m"][name], rel=1e-6)


def test_associate_pairs_each_estimate_with_the_nearest_truth_time():
    truth = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    estimate = np.array([0.004, 0.096, 0.15, 0.31, 0.305, 0.9])
    mine, theirs = associate(estimate, truth, max_difference=0.01)
    # 0.15 is 0.05 s from any truth time, 0.9 from all of them; 0.31 and 0.305 both want 0.3: the nearer wins
    assert mine.tolist() == [0, 1, 4] and theirs.tolist() == [0, 1, 3]
    # any order; 0.15 is nearest 0.1 (by float rounding), which 0.096 holds more nearly
    mine, theirs = associate(estimate[::-1], truth[::-1], max_difference=0.06)
    assert sorted(zip(estimate[::-1][mine], truth[::-1][theirs], strict=True)) == [(0.004, 0.0), (0.096, 0.1),
                                                                                   (0.305, 0.3)]
