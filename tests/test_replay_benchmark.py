"""benchmarks/replay.py scores a recorded drive as the generalization benchmark scores the drive (issue 23)."""

import csv
import math
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import replay


def _scored(folder: Path) -> dict:
    with (folder / "results.csv").open(newline="") as file:
        (row,) = list(csv.DictReader(file))
    return row


@pytest.mark.slow
def test_a_replayed_recording_scores_as_the_drive_did(tmp_path, capsys):
    """The scripted drive does not depend on the SLAM, so its recording replayed gives the drive's metrics (the
    benchmark drives through ``neuroslam sweep``'s worker): camera only to the last digit (the frames are
    lossless PNG); with the wheels to within a centimetre, since a recording keeps the wheels' pose, whose
    speed is the chord over a frame (within 0.1 % of the arc the encoders rolled)."""
    from neuroslam.lab.sweep import _run_drive, flatten

    data = tmp_path / "data"
    assert replay.main(["record", "--data", str(data), "--worlds", "carpark", "--max-frames", "120",
                        "--workers", "1"]) == 0
    for odometry in ("visual", "wheel"):
        out = tmp_path / f"run-{odometry}"
        assert replay.main(["score", str(data), "--out", str(out), "--odometry", odometry, "--workers", "1"]) == 0
        drive = _run_drive("carpark", 0, (), 2, 120, str(tmp_path / f"drive-{odometry}"), odometry=odometry)
        assert drive["status"] == "ok"
        expected, replayed = flatten(drive["metrics"]), _scored(out)
        for key in ("loop_closures", "experiences", "templates"):
            assert int(float(replayed[key])) == int(expected[key]), (odometry, key)
        for key in ("ate_rmse_m.slam", "ate_rmse_m.odometry"):
            if odometry == "visual":
                assert math.isclose(float(replayed[key]), float(expected[key]), rel_tol=1e-9), key
            else:
                assert abs(float(replayed[key]) - float(expected[key])) < 0.01, key
    printed = capsys.readouterr().out
    assert "1 worlds" in printed and "every target" in printed
    # a second score into the same folder is refused, not overwritten
    assert replay.main(["score", str(data), "--out", str(tmp_path / "run-wheel"), "--workers", "1"]) == 2


def test_scoring_a_folder_without_recordings_says_so(tmp_path, capsys):
    assert replay.main(["score", str(tmp_path), "--out", str(tmp_path / "run")]) == 2
    assert "no recorded drives" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()


def test_a_world_names_its_recording_folder():
    assert replay.dataset_name("gen3:115") == "gen3_115"
    assert replay.dataset_name("/somewhere/angled_carpark.xml") == "angled_carpark"
    assert replay.dataset_name("carpark") == "carpark"
