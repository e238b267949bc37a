"""Closed loop against ground truth: two laps of a world's main route, camera only, default settings.

These are issue 4's accuracy properties, asserted on every world of the README's accuracy table: the drive
the README's main command runs (the car park), urban, the building and three generated worlds of generator
version 1 (gen1:1–gen1:3, then called gen:1–gen:3, on which the `sim` preset was developed; 1–2 minutes
each here). In the three runs of `benchmarks/sensitivity.py --seeds 2` (the recorded frames and two noisy
copies) the car park, urban, gen:1 and gen:2 met them every time (gen:2's ratio the closest call, 0.48);
the building and gen:3 met them on the recorded frames, which this test drives, but not on every noisy copy
(the building 2.03–2.04 m, gen:3's ratio 0.67–0.70): their margins are thin, and this test is where a change
that costs them shows. Urban's is thinner than those runs said: which loop closures its map makes changes with
millimetres of odometry, and a change that moved its odometry ATE by 5 mm moved its SLAM ATE 0.64 → 1.06 m
(``docs/generalization.md``, tenth step).

Two hard worlds of the generalization benchmark's generator-1 range (`benchmarks/generalization.py
--generator 1`) join them, where the floor helps least (issue 23's targets): ``gen1:108``, whose ground floor
is one flat colour without marks (the yaw from the whole image, the distance from the ceiling or the upper
image in the scale the floor last gave it; SLAM ATE 9.68 m before the odometry said what it observed), and
``gen1:127``, with sparsely marked floors and ramp (single frames read 3–13° of turn while driving straight
until a floor solution the whole image contradicts was refused; 7.92 m before). On the benchmark they meet
every target with some margin (0.81 m and 0.91 m, ratios 0.26 and 0.36).

Two more from the benchmark's current range (generator version 3, ``benchmarks/generalization.py``), chosen
by what the generator drew: the shortest of its worlds (seeds 100–139) with a blank ground floor and the
shortest with an open top under the sky, among those not largely blind on the benchmark's run (blind in
distance and yaw on less than a quarter of their frames, its ``BLIND_LIMIT``; the largely blind ones do not
meet the targets yet, docs/generalization.md, so they cannot be asserted here). ``gen3:134`` (551 m): a blank
ground floor and a large-tiled upper one, lane markings; ``gen3:114`` (497 m): a large-tiled ground floor
(thin lines 2.5–4 m apart) and a low-contrast open top with a second deck over part of it, the land and the
horizon in view, lane markings. On the benchmark and here, today's defaults: SLAM ATE 0.75 m (ratio 0.21) and
0.73 m (ratio 0.32), 44–67 s a drive.
"""

import json

import pytest

from neuroslam.lab.cli import main

DEVELOPMENT_WORLDS = ["carpark", "urban", "building", "gen1:1", "gen1:2", "gen1:3"]
HARD_WORLDS = ["gen1:108", "gen1:127",  # a blank floor; sparse marks (generator version 1)
               "gen3:134", "gen3:114"]  # a blank floor; an open deck over sparse lines (version 3)
WORLDS = DEVELOPMENT_WORLDS + HARD_WORLDS


# one drive per world, its tests together on one pytest-xdist worker (pyproject.toml's addopts: --dist loadgroup)
@pytest.fixture(scope="module", params=[pytest.param(world, marks=pytest.mark.xdist_group(world)) for world in WORLDS])
def metrics(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(request.param.replace(":", "_"))
    assert main(["drive", request.param, "--out", str(out)]) == 0
    return json.loads((out / "metrics.json").read_text())


@pytest.mark.slow
def test_slam_halves_the_visual_odometry_error_and_stays_within_two_metres(metrics):
    ate = metrics["ate_rmse_m"]
    assert metrics["laps"] == 2
    assert ate["slam"] <= 0.5 * ate["odometry"]
    assert ate["slam"] <= 2.0
    assert metrics["map_rmse_m"] <= 2.0


@pytest.mark.slow
def test_no_false_loop_closure_and_a_true_one_on_every_level(metrics):
    assert metrics["false_loop_closures"] == 0
    per_level = metrics["true_loop_closures_per_level"]
    assert metrics["levels_visited"] == list(range(len(metrics["levels"])))  # every main route visits every floor
    assert all(per_level[str(level)] >= 1 for level in metrics["levels_visited"])


@pytest.mark.slow
def test_the_estimate_stays_on_the_true_floor(metrics):
    assert metrics["level_accuracy"] >= 0.95


@pytest.mark.slow
def test_the_blind_shares_are_reported(metrics):
    """The benchmark counts a world the camera cannot observe separately; every drive says how blind it was."""
    blind = metrics["blind_share"]
    assert set(blind) == {"distance", "yaw", "height"}
    assert all(0.0 <= share < 0.5 for share in blind.values())
