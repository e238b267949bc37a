"""Closed loop against ground truth: the car park's main route, two laps, camera only, default settings.

These are issue 4's accuracy properties, asserted on the drive the README's main command runs (about
1.5 minutes here). The other built-in and generated worlds do not meet them yet; the README's accuracy
table lists every world's numbers and why.
"""

import json

import pytest

from neuroslam.cli import main


@pytest.fixture(scope="module")
def carpark_metrics(tmp_path_factory):
    out = tmp_path_factory.mktemp("carpark")
    assert main(["drive", "carpark", "--out", str(out)]) == 0
    return json.loads((out / "metrics.json").read_text())


@pytest.mark.slow
def test_slam_halves_the_visual_odometry_error_and_stays_within_two_metres(carpark_metrics):
    ate = carpark_metrics["ate_rmse_m"]
    assert carpark_metrics["laps"] == 2
    assert ate["slam"] <= 0.5 * ate["odometry"]
    assert ate["slam"] <= 2.0
    assert carpark_metrics["map_rmse_m"] <= 2.0


@pytest.mark.slow
def test_no_false_loop_closure_and_a_true_one_on_every_level(carpark_metrics):
    assert carpark_metrics["false_loop_closures"] == 0
    per_level = carpark_metrics["true_loop_closures_per_level"]
    assert carpark_metrics["levels_visited"] == [0, 1]
    assert all(per_level[str(level)] >= 1 for level in carpark_metrics["levels_visited"])


@pytest.mark.slow
def test_the_estimate_stays_on_the_true_floor(carpark_metrics):
    assert carpark_metrics["level_accuracy"] >= 0.95
