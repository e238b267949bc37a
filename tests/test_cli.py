"""The command line: help, listing worlds, a short drive with its outputs, one-line errors."""

import json
import subprocess
import sys

import numpy as np
import pytest

from neuroslam import NeuroSLAM
from neuroslam.lab.cli import main
from neuroslam.tum import read_tum, write_tum


def run(*args):
    return subprocess.run([sys.executable, "-m", "neuroslam.lab.cli", *args], capture_output=True, text=True,
                          timeout=300)


def test_help_explains_every_command():
    result = run("--help")
    assert result.returncode == 0
    assert "drive" in result.stdout and "worlds" in result.stdout
    drive_help = run("drive", "--help").stdout
    for option in ("--route", "--laps", "--seed", "--quality", "--max-frames", "--out", "--panoramic"):
        assert option in drive_help


def test_record_drives_as_many_laps_as_drive_by_default():
    """A recording made with the defaults replays the drive `neuroslam drive` makes with them."""
    from neuroslam.lab.cli.parser import build_parser

    parser = build_parser()
    drive = parser.parse_args(["drive", "gen:1"])
    record = parser.parse_args(["record", "gen:1", "--out", "somewhere"])
    assert record.laps == drive.laps == 2


def test_worlds_lists_levels_and_routes(capsys):
    assert main(["worlds"]) == 0
    out = capsys.readouterr().out
    assert "carpark" in out and "levels at 0, 3 m" in out and "main (" in out and "gen:SEED" in out


@pytest.mark.parametrize("odometry", ["visual", "wheel", "visual-inertial"])
def test_short_drive_with_slam_writes_trajectories_and_summary(tmp_path, capsys, odometry):
    assert main(["drive", "gen:2", "--max-frames", "30", "--out", str(tmp_path), "--seed", "1",
                 "--odometry", odometry]) == 0
    times, _positions, quaternions = read_tum(tmp_path / "groundtruth.tum")
    assert len(times) == 30 and times[1] == pytest.approx(0.1)
    np.testing.assert_allclose(np.linalg.norm(quaternions, axis=1), 1.0, atol=1e-6)
    for name in ("odometry.tum", "wheel_odometry.tum", "slam.tum", "slam_online.tum"):
        other_times, other_positions, _ = read_tum(tmp_path / name)
        np.testing.assert_array_equal(other_times, times)
        assert np.all(np.isfinite(other_positions))
    experience_times, _, _ = read_tum(tmp_path / "experiences.tum")
    assert (tmp_path / "report.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = json.loads((tmp_path / "metrics.json").read_text())
    assert summary["frames"] == 30 and summary["world"] == "gen:2" and summary["odometry"] == odometry
    assert summary["distance_m"] > 0.5
    assert summary["experiences"] == len(experience_times) >= 1 and summary["templates"] >= 1
    for key in ("world", "route", "frames", "distance_m", "levels_visited", "ate_rmse_m", "ate_se3_rmse_m",
                "rpe_rmse_m", "map_rmse_m", "loop_closures", "false_loop_closures", "level_accuracy", "templates",
                "experiences", "ms_per_frame"):
        assert key in summary, key
    assert set(summary["ate_rmse_m"]) == {"slam", "slam_online", "odometry"} and summary["ate_rmse_m"]["slam"] >= 0
    assert 0 <= summary["level_accuracy"] <= 1 and summary["false_loop_closures"] <= summary["loop_closures"]
    assert set(summary["ms_per_frame"]) == {"slam", "physics", "render", "total"}
    assert "levels visited" in capsys.readouterr().out
    saved = NeuroSLAM.load(tmp_path / "map.npz")  # the final map, with each experience's true pose
    assert saved.experience_map.size == summary["experiences"] and saved.frames == 30
    truth = saved.map_extra["experience_truth"]
    assert truth.shape == (summary["experiences"], 4)
    np.testing.assert_allclose(truth[0, :3], read_tum(tmp_path / "groundtruth.tum")[1][0])


@pytest.mark.parametrize("args, text", [
    (["drive", "atlantis"], "not a built-in world"),
    (["drive", "gen:x"], "integer seed"),
    (["drive", "carpark", "--route", "nope"], "route='nope'"),
    (["drive", "carpark", "--laps", "0"], "must be at least 1"),
    (["drive", "carpark", "--preset", "nope"], "unknown preset"),
    (["drive", "carpark", "--laps", "x"], "argument --laps: 'x' is not an integer"),
    (["drive", "--odometry", "lidar"], "argument --odometry: invalid choice"),
    (["fly"], "argument COMMAND: invalid choice"),
])
def test_bad_input_gives_one_line_and_exit_code_2(args, text):
    result = run(*args)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert "Traceback" not in result.stderr
    assert len(lines) == 1 and text in lines[0], result.stderr


def test_eval_scores_two_trajectories_as_metrics_json_does(tmp_path, capsys):
    assert main(["drive", "gen:2", "--max-frames", "40", "--out", str(tmp_path / "drive")]) == 0
    summary = json.loads((tmp_path / "drive" / "metrics.json").read_text())
    capsys.readouterr()
    for name in ("slam", "odometry"):
        assert main(["eval", str(tmp_path / "drive" / "groundtruth.tum"), str(tmp_path / "drive" / f"{name}.tum"),
                     "--json"]) == 0
        scores = json.loads(capsys.readouterr().out)
        assert scores["pairs"] == scores["estimate_poses"] == 40
        for key in ("ate_rmse_m", "ate_se3_rmse_m"):  # the files hold every float exactly
            assert scores[key] == pytest.approx(summary[key][name], rel=1e-9), key
    # a trajectory of other times pairs with nothing: one line, exit code 2
    times, positions, quaternions = read_tum(tmp_path / "drive" / "slam.tum")
    write_tum(tmp_path / "late.tum", times + 100.0, positions, quaternions)
    assert main(["eval", str(tmp_path / "drive" / "groundtruth.tum"), str(tmp_path / "late.tum")]) == 2
    assert "only 0 poses" in capsys.readouterr().err


def test_version():
    from neuroslam import __version__

    result = run("--version")
    assert result.returncode == 0 and result.stdout.strip() == f"neuroslam {__version__}"


def test_an_earlier_run_is_replaced_only_with_overwrite(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["drive", "gen:1", "--max-frames", "5", "--out", str(out)]) == 0
    (out / "run.rrd").write_text("a stale recording")
    first = (out / "metrics.json").read_text()
    capsys.readouterr()
    assert main(["drive", "gen:1", "--max-frames", "6", "--out", str(out)]) == 2
    assert "holds an earlier run or dataset; add --overwrite" in capsys.readouterr().err
    assert (out / "metrics.json").read_text() == first  # nothing touched
    assert main(["drive", "gen:1", "--max-frames", "6", "--out", str(out), "--overwrite"]) == 0
    assert json.loads((out / "metrics.json").read_text())["frames"] == 6
    assert not (out / "run.rrd").exists()  # cleared: no stale file from the earlier run
    # a dataset is refused alike, a file or a folder of other files even with --overwrite
    assert main(["record", "gen:1", "--max-frames", "3", "--out", str(out)]) == 2
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "mine.txt").write_text("keep")
    (tmp_path / "file").write_text("keep")
    capsys.readouterr()
    for target, text in (("notes", "holds files neuroslam did not write"), ("file", "is a file")):
        assert main(["drive", "gen:1", "--max-frames", "3", "--out", str(tmp_path / target), "--overwrite"]) == 2
        assert text in capsys.readouterr().err
    assert (tmp_path / "notes" / "mine.txt").read_text() == (tmp_path / "file").read_text() == "keep"
    # calibrate refuses to replace its config file before it drives
    assert main(["calibrate", "gen:1", "--max-frames", "3", "--out", str(tmp_path / "file")]) == 2
    assert "exists; add --overwrite" in capsys.readouterr().err


def test_bad_files_give_one_line_and_exit_code_2(tmp_path):
    """An unreadable frames folder, frames of different sizes, an invalid config value: one line, exit 2."""
    from PIL import Image

    mixed = tmp_path / "mixed"
    mixed.mkdir()
    Image.fromarray(np.zeros((120, 160, 3), np.uint8)).save(mixed / "000000.png")
    Image.fromarray(np.zeros((60, 80, 3), np.uint8)).save(mixed / "000001.png")
    config = tmp_path / "bad.toml"
    config.write_text("[grid_cells]\nsize = [0, 48, 16]\n")
    cases = [
        (["run", str(tmp_path / "missing")], "missing"),
        (["run", str(mixed)], "000001.png': 80x60 pixels, but the first frame"),
        (["run", str(mixed), "--levels", "3", "0"], "--levels=[3.0, 0.0]: must be one or more finite heights"),
        (["drive", "carpark", "--max-frames", "2", "--config", str(config)], "grid_cells.size"),
        (["drive", "carpark", "--max-frames", "2", "--load-map", str(tmp_path / "none.npz")], "does not exist"),
        (["drive", "carpark", "--max-frames", "2", "--load-map", str(config)], "truncated or corrupted"),
        (["drive", "carpark", "--max-frames", "2", "--load-map", str(mixed)], "is a directory"),
    ]
    for args, text in cases:
        result = run(*args, "--out", str(tmp_path / "out"))
        assert result.returncode == 2, (args, result.stderr)
        assert "Traceback" not in result.stderr
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and text in lines[0], (args, result.stderr)


def test_calibrate_writes_a_config_that_loads(tmp_path, capsys):
    from neuroslam import load_config

    out = tmp_path / "gains.toml"
    assert main(["calibrate", "gen:2", "--max-frames", "60", "--out", str(out)]) == 0
    config = load_config(out)
    assert config.odometry.speed_scale > 0 and config.odometry.yaw_scale > 0
    assert "height error" in capsys.readouterr().out
    # the default height (transitions) has no gains: eqs. 31-32's are reported, not written
    assert "climb_scale" not in out.read_text() and config.odometry.height_model == "transitions"


def test_fit_odometry_gains_recovers_known_scales():
    from neuroslam.vision.calibration import fit_odometry_gains

    rng = np.random.default_rng(0)
    n = 200
    dt = np.full(n, 0.1)
    speed = 1.0 + 0.2 * rng.random(n)
    yaw_rate = rng.normal(0, 0.3, n)
    fit = fit_odometry_gains(dt=dt, raw_difference=speed * dt / 8.0, raw_yaw_rate=yaw_rate / 0.8,
                             raw_pitch_change=np.zeros(n), true_speed=speed, true_yaw_rate=yaw_rate,
                             true_height=np.zeros(n))
    assert fit.speed_scale == pytest.approx(8.0) and fit.yaw_scale == pytest.approx(0.8)
    assert fit.height_rmse == pytest.approx(0.0)


def test_a_second_session_loads_the_first_map_and_scores_merges(tmp_path):
    """drive --load-map: the loaded map's experiences keep their ground truth in the new map.npz; metrics.json
    adds merges, merge_frames and false_merges. A session in another world never merges into it."""
    first, second, other = tmp_path / "first", tmp_path / "second", tmp_path / "other"
    assert main(["drive", "gen:2", "--max-frames", "150", "--out", str(first)]) == 0
    assert main(["drive", "gen:2", "--max-frames", "60", "--load-map", str(first), "--out", str(second)]) == 0
    summary = json.loads((second / "metrics.json").read_text())
    assert {"merges", "merge_frames", "false_merges"} <= set(summary)
    assert summary["merges"] == len(summary["merge_frames"]) and summary["false_merges"] in (0, None)
    before, after = NeuroSLAM.load(first), NeuroSLAM.load(second)
    assert after.experience_map.size >= before.experience_map.size
    truth = after.map_extra["experience_truth"]
    assert truth.shape == (after.experience_map.size, 4) and np.all(np.isfinite(truth))
    # another world: its views never line up with the loaded map's, so nothing merges
    assert main(["drive", "gen:3", "--max-frames", "150", "--load-map", str(first / "map.npz"),
                 "--out", str(other)]) == 0
    assert json.loads((other / "metrics.json").read_text())["merges"] == 0
    assert len(set(NeuroSLAM.load(other).experience_map.components)) == 2


def test_compare_maps_reports_the_rmse_after_registration(tmp_path, capsys):
    from neuroslam.tum import write_tum, yaw_quaternion

    rng = np.random.default_rng(0)
    t = np.linspace(0, 1, 200)
    b = np.column_stack([20 * np.cos(2 * np.pi * t) + 4 * np.sin(6 * np.pi * t), 12 * np.sin(2 * np.pi * t),
                         3.0 * (t > 0.5)])
    yaw = np.radians(75)
    a = np.column_stack([np.cos(yaw) * b[:, 0] - np.sin(yaw) * b[:, 1], np.sin(yaw) * b[:, 0] + np.cos(yaw) * b[:, 1],
                         b[:, 2]]) + [4.0, -2.0, 1.0] + rng.normal(0, 0.05, b.shape)
    for name, points in (("a.tum", a), ("b.tum", b)):
        write_tum(tmp_path / name, t, points, yaw_quaternion(np.zeros(len(t))))
    assert main(["compare-maps", str(tmp_path / "a.tum"), str(tmp_path / "b.tum"), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["rmse_m"] < 0.15 and result["inlier_fraction"] > 0.95
    assert result["yaw_deg"] == pytest.approx(-75, abs=0.5)
    assert main(["compare-maps", str(tmp_path / "a.tum"), str(tmp_path / "b.tum")]) == 0
    assert "RMSE" in capsys.readouterr().out


def test_drive_with_the_grid_network_integrator(tmp_path):
    assert main(["drive", "gen:2", "--max-frames", "30", "--integrator", "grid-network", "--out", str(tmp_path)]) == 0
    saved = NeuroSLAM.load(tmp_path)
    assert saved.config.integrator == "grid-network" and saved.grid_network is not None
    assert json.loads((tmp_path / "metrics.json").read_text())["frames"] == 30


def test_ctrl_c_keeps_what_was_done_or_leaves_nothing(tmp_path, monkeypatch, capsys):
    """Ctrl-C during a drive: the frames done are written (metrics.json says so) and the exit code is 130;
    before the first frame, nothing is left behind."""
    from neuroslam.lab.frames import DriveStream

    iterate = DriveStream.__iter__

    def interrupted_after(frames):
        def frames_then_ctrl_c(self):
            for count, frame in enumerate(iterate(self)):
                if count == frames:
                    raise KeyboardInterrupt
                yield frame
        return frames_then_ctrl_c

    monkeypatch.setattr(DriveStream, "__iter__", interrupted_after(12))
    assert main(["drive", "gen:1", "--max-frames", "30", "--out", str(tmp_path / "some")]) == 130
    assert "interrupted after 12 frames" in capsys.readouterr().err
    metrics = json.loads((tmp_path / "some" / "metrics.json").read_text())
    assert metrics["interrupted"] is True and metrics["frames"] == 12
    assert len(read_tum(tmp_path / "some" / "slam.tum")[0]) == 12
    monkeypatch.setattr(DriveStream, "__iter__", interrupted_after(0))
    assert main(["drive", "gen:1", "--max-frames", "30", "--out", str(tmp_path / "none")]) == 130
    assert not (tmp_path / "none").exists()
