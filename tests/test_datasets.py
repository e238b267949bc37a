"""Recorded datasets: frames in natural order, TUM and CSV ground truth, clear errors; record → run."""

import json

import numpy as np
import pytest
from PIL import Image

from neuroslam.cli import main
from neuroslam.datasets import DatasetError, frame_times, list_frames, load_frame, read_groundtruth


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
    assert metrics["frames"] == 40 and metrics["ate_rmse_m"]["slam"] >= 0 and metrics["level_accuracy"] is None
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
