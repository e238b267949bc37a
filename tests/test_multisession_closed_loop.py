"""Multisession mapping in the closed loop (camera only, default settings), against ground truth:

- the car park's `west` loop, then its `ground` loop (which starts where `west` never went and shares about
  60 of its 106 m) loading the first map: exactly one merge, on the shared part, and the merged map within
  1.25x of the map error of one session driving both (`west-then-ground`);
- a chain: the `south-block` loop, then the `north-block` loop loading it (they never overlap: no merge),
  then the main route loading that map of two separate parts: both merge into one connected map.

About 5 minutes here.
"""

import json

import numpy as np
import pytest
from scipy.spatial import cKDTree

from neuroslam import NeuroSLAM
from neuroslam.lab.cli import main

# the drives are one module fixture: its tests together on one pytest-xdist worker (--dist loadgroup)
pytestmark = pytest.mark.xdist_group("multisession_closed_loop")


def _drive(out, *args):
    assert main(["drive", "carpark", *args, "--out", str(out)]) == 0
    return json.loads((out / "metrics.json").read_text())


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("sessions")
    west = _drive(folder / "west", "--route", "west")
    ground = _drive(folder / "ground", "--route", "ground", "--load-map", str(folder / "west"))
    single = _drive(folder / "single", "--route", "west-then-ground")
    return folder, west, ground, single


def _remade(slam, after_time, session, *, earlier_sessions_only=False, horizon=30.0):
    """Experiences of ``session`` made after ``after_time`` within 1 m and 30 degrees (ground truth) of an
    experience of an earlier session, or (unless ``earlier_sessions_only``) of one of its own made at least
    ``horizon`` s before (on an earlier pass)."""
    themap, truth = slam.experience_map, slam.map_extra["experience_truth"]
    count = 0
    for experience in np.flatnonzero((themap.sessions == session) & (themap.creation_times > after_time)):
        earlier = themap.sessions < session
        if not earlier_sessions_only:
            earlier |= (themap.sessions == session) & (
                themap.creation_times < themap.creation_times[experience] - horizon)
        gaps = np.linalg.norm(truth[earlier, :2] - truth[experience, :2], axis=1)
        turns = np.abs(np.angle(np.exp(1j * (truth[earlier, 3] - truth[experience, 3]))))
        count += bool(np.any((gaps < 1.0) & (turns < np.radians(30))))
    return count


@pytest.mark.slow
def test_an_unknown_start_merges_once_where_the_routes_overlap(runs):
    folder, west, ground, _ = runs
    assert west["false_loop_closures"] == 0 and ground["false_loop_closures"] == 0
    assert ground["merges"] == 1 and ground["false_merges"] == 0
    assert ground["map_components"] == 1
    # on the shared part: the robot's true position at the merge lies on the first session's path
    first_path = np.loadtxt(folder / "west" / "groundtruth.tum")[:, 1:4]
    at_merge = np.loadtxt(folder / "ground" / "groundtruth.tum")[ground["merge_frames"][0], 1:4]
    assert cKDTree(first_path).query(at_merge)[0] < 1.0
    # the merged map keeps the loaded one: the first session's experiences all survive in it
    merged = NeuroSLAM.load(folder / "ground")
    assert np.sum(merged.experience_map.sessions == 0) == west["experiences"]


@pytest.mark.slow
def test_the_merged_map_is_as_good_as_one_session_driving_both_routes(runs):
    _, _, ground, single = runs
    assert ground["map_rmse_m"] <= 1.25 * single["map_rmse_m"]


@pytest.mark.slow
def test_the_shared_part_is_not_mapped_again_after_the_merge(runs):
    """After the merge the robot moves through the loaded experiences. It still makes a few new ones beside
    them where a view does not match (in the turns), as any session does on its own second lap; per metre
    driven over the shared part after the merge, it makes fewer such duplicates than the single session
    does per metre of its second lap."""
    folder, _, ground, single = runs
    merged, alone = NeuroSLAM.load(folder / "ground"), NeuroSLAM.load(folder / "single")
    truth = np.loadtxt(folder / "ground" / "groundtruth.tum")
    merge_frame = ground["merge_frames"][0]
    duplicates = _remade(merged, truth[merge_frame, 0], session=1, earlier_sessions_only=True)
    first_path = cKDTree(np.loadtxt(folder / "west" / "groundtruth.tum")[:, 1:3])
    after = truth[merge_frame:, 1:3]
    on_shared = first_path.query(after)[0] < 1.0
    shared_metres = np.sum(np.linalg.norm(np.diff(after, axis=0), axis=1)[on_shared[1:]])
    assert shared_metres > 50
    second_lap_rate = _remade(alone, -1.0, session=0) / (single["distance_m"] / 2)
    assert duplicates / shared_metres <= second_lap_rate


@pytest.mark.slow
def test_a_chain_of_three_sessions_ends_in_one_connected_map(runs):
    folder = runs[0]
    _drive(folder / "south", "--route", "south-block")
    north = _drive(folder / "north", "--route", "north-block", "--load-map", str(folder / "south"))
    assert north["merges"] == 0 and north["map_components"] == 2  # the two blocks never meet
    joined = _drive(folder / "joined", "--load-map", str(folder / "north"))
    assert joined["merges"] == 2 and joined["false_merges"] == 0
    assert joined["map_components"] == 1 and joined["false_loop_closures"] == 0
    themap = NeuroSLAM.load(folder / "joined").experience_map
    assert set(np.unique(themap.sessions)) == {0, 1, 2} and len(set(themap.components)) == 1
