"""benchmarks/odometry_degrees.py splits the straight frames' yaw error between floors and ramps (issue 23)."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

import odometry_degrees

from neuroslam.tum import write_tum, yaw_quaternion

STEP = 0.1  # m a frame, driven straight east


def _drive(folder: Path, yaw_error_per_frame: dict[str, float], read_per_frame: dict[str, float] | None = None
           ) -> None:
    """A drive straight east over a floor, up a 1.6 m ramp, over the upper floor and down again (0.1 m a frame,
    16 mm of height a ramp frame); the odometry is the truth with the given yaw error added per frame on floor,
    uphill and downhill frames. A ramp frame ends more than 0.15 m from both floors: between 0.15 and 1.45 m
    (no frame's height lies within 5 mm of either bound). ``read_per_frame``: the distance the odometry reads
    per metre driven on each kind of frame (default 1)."""
    heights = np.concatenate([np.zeros(100), np.linspace(0.0, 1.6, 101)[1:], np.full(100, 1.6),
                              np.linspace(1.6, 0.0, 101)[1:], np.zeros(100)])
    count = len(heights)
    truth = np.column_stack([STEP * np.arange(count), np.zeros(count), heights])
    levels = [0.0, 1.6]
    end = heights[1:]
    on_ramp = (end > 0.15) & (end < 1.45)
    rising = np.diff(heights) > 0
    kinds = np.where(on_ramp, np.where(rising, "uphill", "downhill"), "floor")
    assert np.count_nonzero(kinds == "uphill") == np.count_nonzero(kinds == "downhill") == 81
    yaw = np.radians(np.r_[0.0, np.cumsum([yaw_error_per_frame[kind] for kind in kinds])])
    odometry = truth.copy()
    read = STEP * np.array([(read_per_frame or {}).get(kind, 1.0) for kind in kinds])
    odometry[1:, :2] = np.cumsum(np.column_stack([read * np.cos(yaw[:-1]), read * np.sin(yaw[:-1])]), axis=0)
    times = 0.1 * np.arange(count)
    folder.mkdir()
    write_tum(folder / "groundtruth.tum", times, truth, yaw_quaternion(np.zeros(count)))
    write_tum(folder / "odometry.tum", times, odometry, yaw_quaternion(yaw))
    (folder / "metrics.json").write_text(json.dumps({"world": "ramps", "levels": levels}))


def test_the_straight_yaw_error_is_given_per_100_m_on_floors_uphill_and_downhill(tmp_path):
    _drive(tmp_path / "drive", {"floor": 0.01, "uphill": 0.05, "downhill": 0.1})
    row = odometry_degrees.measure(tmp_path / "drive")
    # 0.01° a frame of 0.1 m is 10° per 100 m; the classification is the drive's own, so the split is exact
    assert row["straight_floor_deg_per_100m"] == pytest.approx(10.0, rel=1e-6)
    assert row["straight_uphill_deg_per_100m"] == pytest.approx(50.0, rel=1e-6)
    assert row["straight_downhill_deg_per_100m"] == pytest.approx(100.0, rel=1e-6)
    assert row["yaw_error_turning_deg"] == pytest.approx(0.0, abs=1e-9)  # nothing turns more than 0.5° a frame


def test_a_drive_without_ramps_reports_none_for_them(tmp_path):
    folder = tmp_path / "drive"
    folder.mkdir()
    count = 200
    truth = np.column_stack([STEP * np.arange(count), np.zeros(count), np.zeros(count)])
    times = 0.1 * np.arange(count)
    write_tum(folder / "groundtruth.tum", times, truth, yaw_quaternion(np.zeros(count)))
    write_tum(folder / "odometry.tum", times, truth, yaw_quaternion(np.zeros(count)))
    (folder / "metrics.json").write_text(json.dumps({"world": "flat", "levels": [0.0]}))
    row = odometry_degrees.measure(folder)
    assert row["straight_floor_deg_per_100m"] == pytest.approx(0.0, abs=1e-9)
    assert np.isnan(row["straight_uphill_deg_per_100m"]) and np.isnan(row["straight_downhill_deg_per_100m"])


def test_the_distance_read_is_given_on_the_ramps_uphill_and_downhill(tmp_path):
    """A ramp read 8 % long uphill and 3 % short downhill, the floors exact."""
    _drive(tmp_path / "drive", {"floor": 0.0, "uphill": 0.0, "downhill": 0.0},
           {"floor": 1.0, "uphill": 1.08, "downhill": 0.97})
    row = odometry_degrees.measure(tmp_path / "drive")
    assert row["uphill_distance_ratio"] == pytest.approx(1.08, rel=1e-6)
    assert row["downhill_distance_ratio"] == pytest.approx(0.97, rel=1e-6)
    # 499 steps: 162 ramp frames, the other 337 (floors and the ramps' ends) read exactly
    assert row["distance_ratio"] == pytest.approx((337 + 81 * 1.08 + 81 * 0.97) / 499, rel=1e-9)
