"""Recorded datasets: frames in natural order, TUM and CSV ground truth, clear errors; record → run."""

import json

import numpy as np
import pytest
from PIL import Image

from neuroslam.datasets import (
    DatasetDescription,
    DatasetError,
    frame_times,
    list_frames,
    load_frame,
    read_description,
    read_groundtruth,
)
from neuroslam.lab.cli import main


def test_frames_in_natural_order(tmp_path):
    for name in ("frame10.png", "frame2.png", "frame1.jpg", "notes.txt"):
        if name.endswith("txt"):
            (tmp_path / name).write_text("x")
        else:
            Image.fromarray(np.zeros((12, 16, 3), np.uint8)).save(tmp_path / name)
    assert [p.name for p in list_frames(tmp_path)] == ["frame1.jpg", "frame2.png", "frame10.png"]
    assert load_frame(tmp_path / "frame2.png").shape == (12, 16, 3)


def test_groundtruth_formats(tmp_path):
    (tmp_path / "g.tum").write_text("# t x y z qx qy qz qw\n0 1 2 3 0 0 0.7071068 0.7071068\n0.1 1 2 3 0 0 0 1\n")
    truth = read_groundtruth(tmp_path / "g.tum")
    np.testing.assert_allclose(truth.times, [0, 0.1])
    np.testing.assert_allclose(truth.yaw, [np.pi / 2, 0], atol=1e-6)
    (tmp_path / "g.csv").write_text("0,1,2,3,0,0,1.5\n1,2,2,3,0,0,1.6\n")
    truth = read_groundtruth(tmp_path / "g.csv")
    assert truth.times is None and truth.poses.shape == (2, 4) and truth.yaw[1] == pytest.approx(1.6)
    np.testing.assert_allclose(frame_times(2, truth, 10.0), [0, 0.1])


@pytest.mark.parametrize("content, text", [
    ("1 2 3\n", "3 columns"),
    ("0 1 2 3 0 0 0 1\n0 1 2\n", "different numbers of columns"),
    ("a b c d e f g h\n", "numbers"),
    ("", "no rows"),
])
def test_bad_groundtruth(tmp_path, content, text):
    (tmp_path / "g.tum").write_text(content)
    with pytest.raises(DatasetError, match=text):
        read_groundtruth(tmp_path / "g.tum")


def test_bad_folders(tmp_path):
    with pytest.raises(DatasetError, match="not a readable folder"):
        list_frames(tmp_path / "missing")
    with pytest.raises(DatasetError, match="no PNG or JPEG"):
        list_frames(tmp_path)
    (tmp_path / "broken.png").write_text("not an image")
    with pytest.raises(DatasetError, match="not a readable image"):
        load_frame(tmp_path / "broken.png")


def test_record_then_run_with_ground_truth(tmp_path, capsys):
    dataset, run = tmp_path / "dataset", tmp_path / "run"
    assert main(["record", "gen:5", "--max-frames", "40", "--out", str(dataset)]) == 0
    assert len(list((dataset / "frames").glob("*.png"))) == 40
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"), "--out", str(run)]) == 0
    metrics = json.loads((run / "metrics.json").read_text())
    assert metrics["frames"] == 40 and metrics["ate_rmse_m"]["slam"] >= 0
    assert metrics["levels_visited"] == [0] and metrics["level_accuracy"] == 1.0  # floors from dataset.json
    for name in ("slam.tum", "slam_online.tum", "odometry.tum", "experiences.tum", "report.png", "map.npz"):
        assert (run / name).is_file()
    # a second session over the same frames, holding the first one's map
    again = tmp_path / "again"
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"), "--load-map", str(run),
                 "--start", "known", "--out", str(again)]) == 0
    metrics = json.loads((again / "metrics.json").read_text())
    assert metrics["merges"] == 0 and metrics["map_components"] == 1  # a known start continues in the map
    # a folder of frames without ground truth runs too, timed by --rate
    assert main(["run", str(dataset / "frames"), "--rate", "5", "--out", str(tmp_path / "bare")]) == 0
    assert "ate_rmse_m" not in json.loads((tmp_path / "bare" / "metrics.json").read_text())


def test_a_recorded_drive_replayed_scores_as_the_drive_did(tmp_path):
    """`record` then `run` on its folder gives the metrics `drive` gives on the same frames: the dataset's
    description carries the world, route and floor heights, so floors, level accuracy and closures judged by
    floor are scored on a replay too (ground truth read back from TUM: equal to its printed precision)."""
    dataset = tmp_path / "dataset"
    assert main(["record", "gen1:2", "--max-frames", "120", "--out", str(dataset)]) == 0
    assert json.loads((dataset / "dataset.json").read_text()) == {"world": "gen1:2", "route": "main",
                                                                   "levels": [0.0, 3.02]}
    assert main(["drive", "gen1:2", "--max-frames", "120", "--out", str(tmp_path / "drive")]) == 0
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"),
                 "--out", str(tmp_path / "run")]) == 0
    drive = json.loads((tmp_path / "drive" / "metrics.json").read_text())
    replay = json.loads((tmp_path / "run" / "metrics.json").read_text())
    for key in ("world", "route", "frames", "levels", "levels_visited", "odometry", "templates", "experiences",
                "loop_closures", "false_loop_closures", "true_loop_closures_per_level"):
        assert replay[key] == drive[key], key
    assert replay["levels_visited"] == [0] and replay["level_accuracy"] == drive["level_accuracy"] == 1.0
    for key in ("distance_m", "map_rmse_m"):
        assert replay[key] == pytest.approx(drive[key], abs=1e-5), key
    for key in ("ate_rmse_m", "ate_se3_rmse_m", "rpe_rmse_m"):
        assert replay[key] == pytest.approx(drive[key], abs=1e-5), key
    assert replay["ms_per_frame"]["render"] is None and replay["ms_per_frame"]["slam"] > 0
    # floor heights given on the command line take the description's place
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"), "--levels", "-3", "0",
                 "--out", str(tmp_path / "levels")]) == 0
    assert json.loads((tmp_path / "levels" / "metrics.json").read_text())["levels_visited"] == [1]


def test_a_recorded_drive_replays_its_wheel_odometry(tmp_path, capsys):
    """`run --odometry wheel` on a recorded folder takes the wheels from its wheel_odometry.tum and scores as
    `drive --odometry wheel` on the same frames: the speeds are the recorded positions' chords over the frame
    times (the drive's are the arcs rolled): at the routes' turn rates, up to 1 rad/s, a 0.1 s chord is
    shorter than its arc by up to 4e-4 of it, a few millimetres over these 12 m."""
    dataset = tmp_path / "dataset"
    assert main(["record", "gen1:2", "--max-frames", "120", "--out", str(dataset)]) == 0
    assert main(["drive", "gen1:2", "--max-frames", "120", "--odometry", "wheel",
                 "--out", str(tmp_path / "drive")]) == 0
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"), "--odometry", "wheel",
                 "--out", str(tmp_path / "run")]) == 0
    drive = json.loads((tmp_path / "drive" / "metrics.json").read_text())
    replay = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert replay["odometry"] == drive["odometry"] == "wheel"
    for key in ("frames", "templates", "experiences", "loop_closures", "false_loop_closures", "level_accuracy"):
        assert replay[key] == drive[key], key
    for key in ("ate_rmse_m", "rpe_rmse_m"):
        assert replay[key] == pytest.approx(drive[key], abs=1e-3), key
    # a folder without wheel odometry: one line, exit code 2
    (dataset / "wheel_odometry.tum").unlink()
    capsys.readouterr()
    assert main(["run", str(dataset), "--odometry", "wheel", "--out", str(tmp_path / "none")]) == 2
    error = capsys.readouterr().err.strip()
    assert "wheel_odometry.tum" in error and "\n" not in error


@pytest.mark.parametrize("content, text", [
    ("[1, 2]", "must be a JSON object"),
    ('{"levels": [3, 0]}', "strictly increasing"),
    ('{"levels": "0 3"}', "must be a list of heights"),
    ('{"world": 7}', "world=7 must be a name"),
    ("{levels", "not readable JSON"),
])
def test_a_bad_dataset_description_is_named(tmp_path, content, text):
    (tmp_path / "dataset.json").write_text(content)
    with pytest.raises(DatasetError, match=text):
        read_description(tmp_path)
    assert read_description(tmp_path / "elsewhere") == DatasetDescription()  # none: an empty description


def test_run_says_which_camera_it_assumes_and_takes_yours(tmp_path, capsys):
    """`run` on your own frames: without camera options it says it assumes the testbed's camera; with them the
    SLAM uses yours (the vertical field of view from the frames' aspect ratio, square pixels)."""
    import math

    from PIL import Image

    from neuroslam import NeuroSLAM

    frames = tmp_path / "frames"
    frames.mkdir()
    rng = np.random.default_rng(0)
    for index in range(3):
        Image.fromarray(rng.integers(0, 255, (90, 160, 3), dtype=np.uint8)).save(frames / f"{index}.png")
    assert main(["run", str(frames), "--out", str(tmp_path / "assumed")]) == 0
    captured = capsys.readouterr()
    assert "camera: assuming the testbed's: 0.50 m above the floor" in captured.err
    assert main(["run", str(frames), "--camera-height", "1.2", "--camera-forward", "0", "--fov", "90",
                 "--out", str(tmp_path / "mine")]) == 0
    assert "assuming" not in capsys.readouterr().err
    config = NeuroSLAM.load(tmp_path / "mine" / "map.npz").config
    assert config.odometry.camera_height == 1.2 and config.odometry.camera_forward == 0.0
    assert config.horizontal_fov == pytest.approx(math.pi / 2)
    assert config.vertical_fov == pytest.approx(2 * math.atan(90 / 160))  # tan(45°) × 90 / 160
    assert main(["run", str(frames), "--fov", "400", "--out", str(tmp_path / "bad")]) == 2
    assert "--fov=[400.0]" in capsys.readouterr().err
