"""Map files: a saved and reloaded session continues exactly; bad files are refused and change nothing."""

import json
import math
import zipfile

import numpy as np
import pytest
from test_slam import image

import sim
from neuroslam import NeuroSLAM, SelfMotion
from neuroslam.config import Config, ExperienceMapConfig
from neuroslam.maps import FORMAT_VERSION, MapFileError, read_map

SQUARE_CONFIG = Config(experience_map=ExperienceMapConfig(
    loop_closure="confirmed", relaxation="least-squares", confirmation_age=2.0, confirmation_drift=0.2,
    confirmation_tolerance=1.0, confirmation_window=10, confirmation_matches=7, confirmation_spacing=0.0))


def _square_stream(laps=2):
    """Frames of a 40-view square driven ``laps`` times, with a 6 m odometry jump at the end of the first lap
    (so the second lap closes a loop whose least-squares solve takes several frames)."""
    views = [image(100 + k) for k in range(40)]
    t = 0.0
    for lap in range(laps):
        for k in range(40):
            t += 0.1
            turning = k % 10 == 9
            speed = 0.0 if turning else 10.0 + (60.0 if (lap, k) == (0, 38) else 0.0)
            yield views[k], t, SelfMotion(speed, (math.pi / 2) / 0.1 if turning else 0.0)


def _assert_same_state(a, b):
    state_a, state_b = a.state_dict(), b.state_dict()
    assert state_a.keys() == state_b.keys()
    for key in state_a:
        np.testing.assert_array_equal(state_a[key], state_b[key], err_msg=key)


def test_a_reloaded_session_continues_exactly_where_it_stopped(tmp_path):
    """Saved at every interesting moment (before the loop, the frame the loop closes, while the least-squares
    solve is still running): the reloaded SLAM gives bit-identical estimates to the one that never stopped."""
    frames = list(_square_stream())
    reference = NeuroSLAM(SQUARE_CONFIG)
    estimates, unsettled = [], []
    for index, (view, t, motion) in enumerate(frames):
        estimates.append(reference.step(view, t, odometry=motion))
        if not reference.experience_map.settled:
            unsettled.append(index)
    closures = [index for index, estimate in enumerate(estimates) if estimate.loop_closure]
    assert closures and unsettled  # the stream exercises a loop closure and a solve spread over frames
    for stop in (20, closures[0], unsettled[0]):
        first = NeuroSLAM(SQUARE_CONFIG)
        for view, t, motion in frames[: stop + 1]:
            first.step(view, t, odometry=motion)
        path = first.save(tmp_path / f"map{stop}.npz")
        second = NeuroSLAM.load(path)
        _assert_same_state(first, second)
        np.testing.assert_array_equal(second.last.pose, estimates[stop].pose)
        for index in range(stop + 1, len(frames)):
            view, t, motion = frames[index]
            continued = second.step(view, t, odometry=motion)
            np.testing.assert_array_equal(continued.pose, estimates[index].pose, err_msg=f"frame {index}")
            assert continued.experience_id == estimates[index].experience_id
        _assert_same_state(reference, second)
        np.testing.assert_array_equal(second.trajectory(), reference.trajectory())


def test_a_camera_drive_saved_mid_way_continues_with_the_same_visual_odometry(tmp_path):
    """The whole pipeline on the testbed's camera (floor alignment, profiles, pitch, templates): saving
    after frame 60 of a car-park drive and reloading gives the same estimates for the next 60 frames."""
    drive = sim.ScriptedDrive("carpark", laps=1, max_frames=120, seed=0)
    frames = [(frame.image, frame.time) for frame in drive]
    reference, first = NeuroSLAM("sim"), NeuroSLAM("sim")
    for frame_image, t in frames[:60]:
        reference.step(frame_image, t)
        first.step(frame_image, t)
    second = NeuroSLAM.load(first.save(tmp_path / "map.npz"))
    for frame_image, t in frames[60:]:
        expected = reference.step(frame_image, t)
        np.testing.assert_array_equal(second.step(frame_image, t).pose, expected.pose)
    _assert_same_state(reference, second)
    assert reference.local_view.count > 5 and reference.experience_map.size > 20


def test_extra_arrays_and_notes_travel_with_the_map_and_a_run_folder_loads(tmp_path):
    slam = NeuroSLAM("sim")
    for k in range(5):
        slam.step(image(k), 0.1 * (k + 1), odometry=SelfMotion(1.0, 0.1))
    truth = np.arange(slam.experience_map.size * 4, dtype=float).reshape(-1, 4)
    slam.save(tmp_path / "map.npz", extra={"experience_truth": truth}, metadata={"world": "carpark"})
    loaded = NeuroSLAM.load(tmp_path)  # a run's folder holding map.npz
    np.testing.assert_array_equal(loaded.map_extra["experience_truth"], truth)
    assert loaded.map_metadata == {"world": "carpark"}
    assert loaded.config == slam.config
    assert "extra.experience_truth" not in loaded.state_dict()


def test_an_empty_session_round_trips(tmp_path):
    fresh = NeuroSLAM("sim")
    loaded = NeuroSLAM.load(fresh.save(tmp_path / "map.npz"))
    _assert_same_state(fresh, loaded)
    assert loaded.last is None and loaded.frames == 0
    loaded.step(image(0), 0.0)  # and it runs


def _saved(tmp_path):
    slam = NeuroSLAM("sim")
    for k in range(5):
        slam.step(image(k), 0.1 * (k + 1), odometry=SelfMotion(1.0, 0.1))
    return slam.save(tmp_path / "map.npz")


def _rewrite_header(path, change):
    """A copy of the map at ``path`` with its header changed by ``change(header)``."""
    with zipfile.ZipFile(path) as archive:
        members = {name: archive.read(name) for name in archive.namelist()}
    header = json.loads(members["header.json"])
    change(header)
    members["header.json"] = json.dumps(header).encode()
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)


def _flip_byte_in_an_array(path):
    data = bytearray(path.read_bytes())
    with zipfile.ZipFile(path) as archive:
        info = archive.getinfo("grid_cells.activity.npy")
    # the member's data starts after its local header (30 bytes + name + extra); flip one byte well inside it
    position = info.header_offset + 30 + len(info.filename) + len(info.extra) + 1000
    data[position] ^= 0xFF
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("damage, message", [
    (lambda p: p.write_bytes(b""), "truncated or corrupted"),
    (lambda p: p.write_bytes(p.read_bytes()[: len(p.read_bytes()) // 2]), "truncated or corrupted"),
    (_flip_byte_in_an_array, "truncated or corrupted"),
    (lambda p: np.savez(p.with_suffix(""), a=np.zeros(3)), "not a neuroslam map"),
    (lambda p: p.write_text(json.dumps({"format": "neuroslam-map"})), "truncated or corrupted"),
    (lambda p: _rewrite_header(p, lambda h: h.update(version=FORMAT_VERSION + 1)), "newer than this neuroslam"),
    (lambda p: _rewrite_header(p, lambda h: h.update(format="other")), "not a neuroslam map"),
    (lambda p: _rewrite_header(p, lambda h: h["config"]["grid_cells"].update(size=[10, 10, 10])), "inconsistent"),
    (lambda p: _rewrite_header(p, lambda h: h["config"].update(colour=1)), "configuration is invalid"),
    (lambda p: _rewrite_header(p, lambda h: h["arrays"].pop("experience_map.poses")), "inconsistent state"),
])
def test_bad_map_files_are_refused_with_a_reason(tmp_path, damage, message):
    path = _saved(tmp_path)
    damage(path)
    with pytest.raises(MapFileError, match=message) as error:
        NeuroSLAM.load(path)
    assert str(path) in str(error.value) and "\n" not in str(error.value)


def test_missing_files_and_directories_are_refused(tmp_path):
    with pytest.raises(MapFileError, match="does not exist"):
        NeuroSLAM.load(tmp_path / "nothing.npz")
    with pytest.raises(MapFileError, match="is a directory"):
        NeuroSLAM.load(tmp_path)  # a folder without map.npz
    with pytest.raises(MapFileError, match="does not exist"):
        NeuroSLAM("sim").save(tmp_path / "no" / "such" / "map.npz")
    with pytest.raises(MapFileError, match="is a directory"):
        NeuroSLAM("sim").save(tmp_path)


def test_a_failed_save_keeps_the_previous_map(tmp_path, monkeypatch):
    path = _saved(tmp_path)
    before = path.read_bytes()
    calls = []

    def fail_on_the_third_array(file, array, **_):
        calls.append(1)
        if len(calls) == 3:
            raise OSError(28, "No space left on device")
        return original(file, array, allow_pickle=False)

    original = np.lib.format.write_array
    monkeypatch.setattr(np.lib.format, "write_array", fail_on_the_third_array)
    with pytest.raises(MapFileError, match="No space left"):
        NeuroSLAM("sim").save(path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.npz"]  # no temporary file left behind
    header, arrays = read_map(path)
    assert header["version"] == FORMAT_VERSION and "grid_cells.activity" in arrays


def test_a_session_with_the_grid_network_continues_exactly(tmp_path):
    config = SQUARE_CONFIG.replace(integrator="grid-network")
    frames = list(_square_stream())
    reference, first = NeuroSLAM(config), NeuroSLAM(config)
    for view, t, motion in frames[:30]:
        reference.step(view, t, odometry=motion)
        first.step(view, t, odometry=motion)
    second = NeuroSLAM.load(first.save(tmp_path / "map.npz"))
    for view, t, motion in frames[30:50]:
        np.testing.assert_array_equal(second.step(view, t, odometry=motion).pose,
                                      reference.step(view, t, odometry=motion).pose)
    _assert_same_state(reference, second)
