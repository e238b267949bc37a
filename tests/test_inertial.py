"""The IMU pitch: gravity's direction in the body frame gives the slope; short accelerations are filtered out;
bad readings are refused and change nothing."""

import math

import numpy as np
import pytest

from neuroslam import InvalidInputError
from neuroslam.inertial import GravityPitch

G = 9.81


def _force(pitch, forward_acceleration=0.0):
    """Specific force (body frame) of a robot pitched nose-up by ``pitch`` rad, accelerating along its heading."""
    return np.array([G * math.sin(pitch) + forward_acceleration, 0.0, G * math.cos(pitch)])


def test_a_steady_slope_reads_its_pitch():
    pitch = GravityPitch()
    for _ in range(50):
        value = pitch.step(_force(math.radians(10)), 0.1)
    assert value == pytest.approx(math.radians(10), abs=1e-9)


def test_a_change_of_slope_follows_the_time_constant():
    pitch = GravityPitch(time_constant=0.5)
    pitch.step(_force(0.0), 0.1)
    value = pitch.step(_force(0.2), 0.5)  # one time constant after the step: 1 - 1/e of the way
    assert value == pytest.approx(0.2 * (1 - math.exp(-1)), rel=1e-9)


def test_a_short_acceleration_moves_the_pitch_little():
    """Speeding up at 1 m/s² for 0.3 s on level ground reads 5.8° unfiltered; filtered, 1 - exp(-0.3 / 0.5) of
    it at most (2.6°), and it decays once the acceleration ends."""
    pitch = GravityPitch(time_constant=0.5)
    for _ in range(10):
        pitch.step(_force(0.0), 0.1)
    peak = max(pitch.step(_force(0.0, 1.0), 0.1) for _ in range(3))
    assert peak == pytest.approx(math.atan2(1.0, G) * (1 - math.exp(-0.6)), rel=1e-9)
    for _ in range(10):
        after = pitch.step(_force(0.0), 0.1)
    assert after == pytest.approx(peak * math.exp(-2.0), rel=1e-9)


@pytest.mark.parametrize("reading, dt, field", [
    ([0.0, 9.8], 0.1, "accelerometer"),
    ([0.0, 0.0, float("nan")], 0.1, "accelerometer"),
    (["a", "b", "c"], 0.1, "accelerometer"),
    ([0.0, 0.0, -9.8], 0.1, "accelerometer"),
    ([0.0, 0.0, 9.8], -0.1, "dt"),
])
def test_bad_readings_are_refused_and_change_nothing(reading, dt, field):
    pitch = GravityPitch()
    before = pitch.step(_force(0.1), 0.1)
    with pytest.raises(InvalidInputError) as error:
        pitch.step(reading, dt)
    assert error.value.field == field
    assert pitch.pitch == before


def test_the_testbed_robot_climbs_the_car_parks_ramp_with_the_imu_pitch():
    """Up the car park's first ramp (3 m in 400 frames, physics only): wheel speed times the sine of the IMU
    pitch gives the height within 0.25 m all the way (measured 0.16 m at most: the filter's lag at the ramp's
    ends and the wheels' speed error); the pitch is not fitted to anything."""
    sim = pytest.importorskip("sim")
    pitch, height, previous, worst = GravityPitch(), 0.0, None, 0.0
    with sim.ScriptedDrive("carpark", seed=0, max_frames=400, render=False) as drive:
        for frame in drive:
            dt = 0.0 if previous is None else frame.time - previous
            previous = frame.time
            if dt == 0.0:
                start = frame.ground_truth.position[2]
            height += frame.odometry.forward_speed * dt * math.sin(pitch.step(frame.imu.accelerometer, dt))
            worst = max(worst, abs(height - (frame.ground_truth.position[2] - start)))
    assert frame.ground_truth.position[2] - start > 2.9  # it did climb to the upper level
    assert worst < 0.25
