"""TUM trajectory files round-trip exactly and are written atomically."""

import numpy as np
import pytest

from neuroslam.tum import read_tum, write_tum, yaw_quaternion


def test_round_trip(tmp_path):
    rng = np.random.default_rng(0)
    times = np.arange(5) * 0.1
    positions = rng.normal(size=(5, 3))
    quaternions = rng.normal(size=(5, 4))
    quaternions /= np.linalg.norm(quaternions, axis=1, keepdims=True)
    write_tum(tmp_path / "t.tum", times, positions, quaternions)
    t, p, q = read_tum(tmp_path / "t.tum")
    np.testing.assert_allclose(t, times)
    np.testing.assert_allclose(p, positions, rtol=1e-8)
    np.testing.assert_allclose(q, quaternions, rtol=1e-8, atol=1e-9)
    assert not list(tmp_path.glob(".*tmp"))  # no temporary file left behind


def test_yaw_quaternion_is_w_first():
    np.testing.assert_allclose(yaw_quaternion(np.pi / 2), [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])


def test_mismatched_lengths_are_refused(tmp_path):
    with pytest.raises(ValueError, match="lengths differ"):
        write_tum(tmp_path / "t.tum", [0, 1], np.zeros((3, 3)), np.zeros((2, 4)))
    assert not (tmp_path / "t.tum").exists()


def test_written_files_are_readable_by_others(tmp_path):
    """Trajectories and maps get the permissions any new file gets (0644 under umask 022), not mkstemp's
    0600: a run's outputs are meant to be shared."""
    import os
    import stat

    from neuroslam import NeuroSLAM

    previous = os.umask(0o022)
    try:
        write_tum(tmp_path / "a.tum", np.zeros(2), np.zeros((2, 3)), np.tile([1.0, 0, 0, 0], (2, 1)))
        NeuroSLAM("sim").save(tmp_path / "map.npz")
    finally:
        os.umask(previous)
    for name in ("a.tum", "map.npz"):
        assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644, name
