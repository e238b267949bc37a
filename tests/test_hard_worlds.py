"""Hard worlds from the generalization benchmark: issue 23's accuracy targets where the floor helps least.

Two worlds of the benchmark's generator-1 range (`benchmarks/generalization.py --generator 1`), two laps of
the main route, camera only, the default preset, as the benchmark drives them:

- ``gen1:108``: its ground floor is one flat colour without marks (a blank floor): the yaw comes from the
  whole image and the distance from the ceiling or the upper image in the scale the floor last gave it
  (before the odometry said what it observed: SLAM ATE 9.68 m);
- ``gen1:127``: sparsely marked floors and ramp, where single frames read 3–13° of turn while driving
  straight until a floor solution the whole image contradicts was refused (7.92 m before).

On the benchmark (docs/generalization.md) they meet every target with some margin (0.81 m and 0.91 m, ratios
0.26 and 0.36), so a change that costs the blind or sparse cases shows here first. The drives are
deterministic (a recorded seed), so these are exact checks of the code, not samples.
"""

import json

import pytest

from neuroslam.cli import main

WORLDS = ["gen1:108", "gen1:127"]


@pytest.fixture(scope="module", params=WORLDS)
def metrics(request, tmp_path_factory):
    out = tmp_path_factory.mktemp(request.param.replace(":", "_"))
    assert main(["drive", request.param, "--out", str(out)]) == 0
    return json.loads((out / "metrics.json").read_text())


@pytest.mark.slow
def test_slam_halves_the_odometry_error_within_two_metres(metrics):
    ate = metrics["ate_rmse_m"]
    assert metrics["laps"] == 2
    assert ate["slam"] <= 0.5 * ate["odometry"]
    assert ate["slam"] <= 2.0


@pytest.mark.slow
def test_no_false_loop_closure_and_the_true_floor(metrics):
    assert metrics["false_loop_closures"] == 0
    assert metrics["level_accuracy"] >= 0.95


@pytest.mark.slow
def test_the_blind_share_is_reported(metrics):
    """The benchmark counts a world the camera cannot observe separately; the drive says how blind it was."""
    blind = metrics["blind_share"]
    assert set(blind) == {"distance", "yaw", "height"}
    assert all(0.0 <= share < 0.5 for share in blind.values())
