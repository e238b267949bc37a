"""The rerun recording (``--record``): run.rrd of a drive and of a run, verified by rerun's own CLI."""

import dataclasses
import re
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from neuroslam.lab.cli import main
from neuroslam.lab.recording import RecordingUnavailableError, RunRecorder
from neuroslam.slam import NeuroSLAM

EVERY_RUN = {"camera", "world/slam", "world", "map", "map/robot", "map/experiences", "cells/grid", "cells/grid/extent",
             "cells/head_direction", "plots/template_id", "plots/experience_id"}
WITH_TRUTH = {"world/truth", "plots/position_error"}


@pytest.fixture
def strict_rerun():
    """rerun in strict mode: bad data raises instead of warning."""
    rr = pytest.importorskip("rerun")
    before = rr.strict_mode()
    rr.set_strict_mode(True)
    yield rr
    rr.set_strict_mode(before)


def rerun_cli(*args):
    """The rerun CLI that comes with rerun-sdk (``rerun ...``)."""
    return subprocess.run([sys.executable, "-m", "rerun_cli", *args], capture_output=True, text=True, timeout=120)


def verified_entities(path):
    """The entity paths in an .rrd file with their data columns, after ``rerun rrd verify`` has passed on it."""
    assert path.is_file() and path.stat().st_size > 0
    verify = rerun_cli("rrd", "verify", str(path))
    assert verify.returncode == 0, verify.stdout + verify.stderr
    listing = rerun_cli("rrd", "print", str(path))
    assert listing.returncode == 0, listing.stderr
    entities = {}
    for entity, columns in re.findall(r" - /(\S+) - data columns: \[([^\]]*)\]", listing.stdout):
        entities.setdefault(entity, set()).update(columns.split())
    return entities


def test_drive_with_record_writes_a_recording_rerun_can_load(tmp_path, strict_rerun):
    assert main(["drive", "gen:2", "--max-frames", "40", "--record", "--out", str(tmp_path)]) == 0
    entities = verified_entities(tmp_path / "run.rrd")
    assert EVERY_RUN | WITH_TRUTH <= entities.keys(), EVERY_RUN | WITH_TRUTH - entities.keys()
    assert "Scalars:scalars" in entities["plots/position_error"] and "EncodedImage:blob" in entities["camera"]
    assert (tmp_path / "metrics.json").is_file()  # the usual outputs are still written


def test_run_with_record_over_a_recorded_folder(tmp_path, strict_rerun):
    dataset, out = tmp_path / "dataset", tmp_path / "run"
    assert main(["record", "gen:5", "--max-frames", "20", "--out", str(dataset)]) == 0
    assert main(["run", str(dataset), "--groundtruth", str(dataset / "groundtruth.tum"), "--record",
                 "--out", str(out)]) == 0
    entities = verified_entities(out / "run.rrd")
    assert EVERY_RUN | WITH_TRUTH <= entities.keys(), EVERY_RUN | WITH_TRUTH - entities.keys()
    assert "Scalars:scalars" in entities["plots/position_error"] and "EncodedImage:blob" in entities["camera"]


def test_recorder_without_ground_truth_and_with_grey_float_images(tmp_path, strict_rerun):
    slam = NeuroSLAM("sim")
    rng = np.random.default_rng(0)
    scene = rng.random((60, 80))
    path = tmp_path / "frames.rrd"
    with RunRecorder(path, name="synthetic", every=4, strict=True) as recorder:
        for index in range(9):  # the last frame is not a heavy one: close() logs the final map
            image = np.roll(scene, 2 * index, axis=1)
            estimate = slam.step(image, 0.1 * index)
            if index == 5:  # a loop closure (none happen this soon): an event and a marker
                estimate = dataclasses.replace(estimate, loop_closure=True)
            recorder.log_frame(0.1 * index, image, slam, estimate)
    assert recorder.frames == 9
    entities = verified_entities(path)
    assert EVERY_RUN | {"events", "world/loop_closures"} <= entities.keys()
    assert "Scalars:scalars" not in entities["plots/position_error"]  # only its style: no ground truth, no error
    assert "LineStrips3D:strips" in entities["world/slam"] and "LineStrips3D:strips" not in entities["world/truth"]


def test_help_lists_record():
    for command in ("drive", "run"):
        result = subprocess.run([sys.executable, "-m", "neuroslam.lab.cli", command, "--help"], capture_output=True,
                                text=True, timeout=60)
        assert "--record" in result.stdout and "run.rrd" in result.stdout


def test_missing_rerun_gives_a_clear_error(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun now raises ImportError
    with pytest.raises(RecordingUnavailableError, match=re.escape('pip install "rerun-sdk>=0.41,<0.42"')):
        RunRecorder(tmp_path / "x.rrd")
    frames = tmp_path / "frames"
    frames.mkdir()
    for index in range(3):
        Image.fromarray(np.full((24, 32, 3), 40 * index, np.uint8)).save(frames / f"{index}.png")
    assert main(["run", str(frames), "--record", "--out", str(tmp_path / "out")]) == 2
    assert 'pip install "rerun-sdk>=0.41,<0.42"' in capsys.readouterr().err
