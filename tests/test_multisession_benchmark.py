"""benchmarks/multisession.py splits the merged map's error by where its experiences came from (issue 23)."""

import sys
from pathlib import Path

import numpy as np
import pytest
from test_multisession import APPROACH, APPROACH_IN_FIRST_FRAME, drive, first_session, square

from neuroslam import NeuroSLAM
from neuroslam.tum import write_tum, yaw_quaternion

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import multisession


def test_the_experiences_made_before_the_merge_are_scored_apart(tmp_path):
    """The unknown start of tests/test_multisession.py merges after its 20-frame approach; with exact odometry
    every experience lies where it was made. The truth saved with the map puts the approach's experiences
    1 m off to one side: they, and only they, are the part made before the merge, and the map without them
    is exact."""
    slam = NeuroSLAM.load(first_session(tmp_path))
    slam.begin_session()
    estimates, _ = drive(slam, [*APPROACH, (0, 1.0, 0.0), *square(range(1, 40))])
    merge_frame = next(index for index, estimate in enumerate(estimates) if estimate.merged)
    themap = slam.experience_map
    truth = themap.poses.copy()
    approach = np.flatnonzero(themap.sessions == 1)
    np.testing.assert_allclose(truth[approach, :2], APPROACH_IN_FIRST_FRAME, atol=0.05)
    truth[approach, 1] += 1.0
    second = tmp_path / "second"
    second.mkdir()
    slam.save(second / "map.npz", extra={"experience_truth": truth})
    times = np.array([estimate.timestamp for estimate in estimates])
    poses = np.array([estimate.pose for estimate in estimates])
    write_tum(second / "slam.tum", times, poses[:, :3], yaw_quaternion(poses[:, 3]))
    parts = multisession.merged_map_parts(second, [merge_frame])
    assert parts["before_merge"] == len(approach) == 20
    assert parts["map_without_them_rmse_m"] < 1e-6
    assert 0.3 < parts["before_merge_rmse_m"] < 1.0  # 1 m off, less what the whole map's alignment takes up
    assert multisession.merged_map_parts(second, []) == {"before_merge": 0, "before_merge_rmse_m": None,
                                                         "map_without_them_rmse_m": None}


def test_the_config_reaches_the_first_and_the_single_session(tmp_path, monkeypatch):
    """``--config FILE`` goes to the first and the single session as ``neuroslam drive --config FILE``; the second
    loads the first's map, which keeps its configuration (``--load-map`` refuses ``--config``). A file that does
    not exist is refused before any drive."""
    calls = []

    def fake_drive(out, world, *arguments):
        calls.append(arguments)
        return {"merges": 1, "false_merges": 0, "map_components": 1, "map_rmse_m": 1.0, "merge_frames": [],
                "ate_rmse_m": {"slam": 1.0}}

    monkeypatch.setattr(multisession, "_drive", fake_drive)
    monkeypatch.setattr(multisession, "merged_map_parts", lambda second, frames: {})
    config = tmp_path / "settings.json"
    config.write_text('{"experience_map": {"confirmation_pinned_yaw": false}}')
    multisession.measure("gen:100", tmp_path / "gen_100", 1, None, config)
    assert len(calls) == 3
    first, second, single = calls
    assert first[-2:] == single[-2:] == ("--config", str(config))
    assert "--config" not in second and "--load-map" in second
    with pytest.raises(SystemExit) as stopped:
        multisession.main(["--out", str(tmp_path / "out"), "--config", str(tmp_path / "missing.json")])
    assert stopped.value.code == 2
    assert len(calls) == 3
