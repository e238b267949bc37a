"""The robot really drives: commands move it with the right signs, walls stop it, sensors are honest."""

import json
import math

import numpy as np
import pytest

import sim
from sim.simulation import OdometryNoise, Simulation

FLAT = """<mujoco><worldbody><light pos="0 0 5" dir="0 0 -1" directional="true"/>
  <geom name="ground" type="plane" size="30 30 0.1" rgba=".5 .5 .5 1"/>
  <geom name="wall" type="box" size="0.1 10 1" pos="6 0 1"/></worldbody></mujoco>"""


@pytest.fixture
def flat_world(tmp_path):
    (tmp_path / "flat.xml").write_text(FLAT)
    (tmp_path / "flat.routes.json").write_text(
        json.dumps({"routes": {"line": {"waypoints": [[0, 0, 0], [5, 0, 0]], "loop": False}}}))
    return sim.load_world(tmp_path / "flat.xml")


def test_forward_command_moves_forward_at_the_commanded_speed(flat_world):
    with Simulation(flat_world, noise=OdometryNoise(0, (0, 0), 0, 0)) as simulation:
        simulation.set_command(1.0, 0.0)
        simulation.step(2.9)
        simulation.wheel_odometry()  # a reading: the next one's speed is the mean over the last 0.1 s
        simulation.step(0.1)
        truth = simulation.ground_truth()
        # 1.5 m/s^2 acceleration limit: 2/3 s to reach 1 m/s, so 3 s cover 3 - 1 / (2 * 1.5) m,
        # less a little lag of the wheels' velocity servos
        assert truth.position[0] == pytest.approx(3.0 - 1 / 3, abs=0.05)
        assert abs(truth.position[1]) < 0.05
        assert truth.velocity[0] == pytest.approx(1.0, abs=0.05)
        odometry = simulation.wheel_odometry()
        assert odometry.x == pytest.approx(truth.position[0], rel=0.02)
        assert odometry.forward_speed == pytest.approx(1.0, abs=0.05)


def test_wheel_rates_are_the_means_since_the_previous_reading(flat_world):
    # a camera frame spans several control periods: the speed and turn rate it reads, times its duration,
    # must be its motion (the last control period's rates alone sample it: 0.24 degrees a frame off, on
    # average, on a generated world's drive)
    with Simulation(flat_world, noise=OdometryNoise(0.02, (0, 0), 0, 0), seed=3) as simulation:
        before = simulation.wheel_odometry()
        for step, (speed, yaw_rate) in enumerate([(1.0, 0.0), (1.0, 0.8), (0.5, -0.6), (1.0, 0.3)] * 3):
            simulation.set_command(speed, yaw_rate)
            start = simulation.time
            for _ in range(5):  # a 0.1 s frame driven one control period at a time, as ScriptedDrive does
                simulation.step(0.02)
            now = simulation.wheel_odometry()
            duration = simulation.time - start
            assert now.yaw_rate * duration == pytest.approx(now.yaw - before.yaw, abs=1e-12), step
            assert abs(now.forward_speed) * duration == pytest.approx(now.distance - before.distance, abs=1e-12)
            again = simulation.wheel_odometry()  # a second reading at the same time repeats the rates
            assert (again.forward_speed, again.yaw_rate) == (now.forward_speed, now.yaw_rate)
            before = now


def test_positive_yaw_rate_turns_counter_clockwise(flat_world):
    with Simulation(flat_world, noise=OdometryNoise(0, (0, 0), 0, 0)) as simulation:
        simulation.set_command(0.0, 1.0)
        simulation.step(1.0)
        truth = simulation.ground_truth()
        assert 0.7 < truth.yaw < 1.0  # 1 rad/s for 1 s, less the acceleration ramp
        assert simulation.wheel_odometry().yaw == pytest.approx(truth.yaw, abs=0.05)
        assert simulation.imu().gyro[2] == pytest.approx(1.0, abs=0.05)


def test_walls_stop_the_robot(flat_world):
    with Simulation(flat_world) as simulation:
        simulation.set_command(2.0, 0.0)
        simulation.step(8.0)
        x = simulation.ground_truth().position[0]
        # the chassis front is 0.15 m ahead of the axle and the wall face at 5.9 m; soft contacts may
        # penetrate a few millimetres under the full drive force
        assert x < 6.0 - 0.1 - 0.15 + 0.005
        assert x > 5.0


def test_commands_are_clipped_and_nan_refused(flat_world):
    with Simulation(flat_world) as simulation:
        assert simulation.set_command(10.0, -10.0) == (2.0, -2.0)
        with pytest.raises(sim.InvalidParameterError, match="forward_speed"):
            simulation.set_command(float("nan"), 0.0)


def test_wheel_odometry_noise_is_seeded(flat_world):
    def run(seed):
        with Simulation(flat_world, seed=seed, noise=OdometryNoise(wheel_relative=0.05)) as simulation:
            simulation.set_command(1.0, 0.3)
            simulation.step(2.0)
            return simulation.wheel_odometry()
    assert run(1) == run(1)
    assert run(1) != run(2)


def test_accelerometer_reads_gravity_at_rest(flat_world):
    with Simulation(flat_world, noise=OdometryNoise(0, (0, 0), 0, 0)) as simulation:
        simulation.step(0.5)
        np.testing.assert_allclose(simulation.imu().accelerometer, [0, 0, 9.81], atol=0.05)


@pytest.mark.parametrize("kwargs, field", [
    ({"camera": {"width": 0}}, "camera.width"),
    ({"camera": {"horizontal_fov": 4.0}}, "camera.horizontal_fov"),
    ({"camera": {"width": 150, "panoramic": True}}, "camera.width"),
    ({"robot": {"wheel_radius": -1}}, "robot.wheel_radius"),
    ({"noise": {"wheel_relative": -0.1}}, "noise.wheel_relative"),
])
def test_bad_parameters_name_the_field(kwargs, field):
    (kind, values), = kwargs.items()
    factory = {"camera": sim.CameraConfig, "robot": sim.RobotConfig, "noise": sim.OdometryNoise}[kind]
    with pytest.raises(sim.InvalidParameterError) as error:
        factory(**values)
    assert error.value.field == field


def test_camera_field_of_view():
    camera = sim.CameraConfig(width=160, height=120, horizontal_fov=math.radians(80))
    expected = 2 * math.atan(math.tan(math.radians(40)) * 120 / 160)
    assert camera.vertical_fov == pytest.approx(expected)


@pytest.mark.parametrize("field, value", [("read_noise", -1.0), ("shot_noise", math.nan), ("exposure", 0.6),
                                          ("read_noise", True)])
def test_camera_noise_parameters_name_the_field(field, value):
    with pytest.raises(sim.InvalidParameterError, match=f"camera.{field}"):
        sim.CameraConfig(**{field: value})


def test_camera_read_and_shot_noise_have_the_stated_spread():
    camera = sim.CameraConfig(read_noise=2.0, shot_noise=4.0)
    grey = np.full((200, 200, 3), 128, dtype=np.uint8)
    noisy = camera.add_noise(grey, np.random.default_rng(0)).astype(float)
    expected = math.sqrt(2.0**2 + 4.0**2 * 128 / 255)  # read and shot noise add in variance
    assert noisy.std() == pytest.approx(expected, rel=0.05)  # 120,000 samples: the estimate is within 0.5 %
    assert noisy.mean() == pytest.approx(128, abs=0.1)
    black = camera.add_noise(np.zeros_like(grey), np.random.default_rng(0)).astype(float)
    assert black.mean() > 0  # clipped at 0: the dark end of the image is relatively noisier
    assert sim.CameraConfig().add_noise(grey, np.random.default_rng(0)) is grey  # no noise: the image itself


def test_a_noisy_camera_is_seeded_and_leaves_the_other_sensors_alone(flat_world):
    def drive(camera):
        frames = list(sim.ScriptedDrive(flat_world, camera=camera, max_frames=12, seed=5))
        return np.array([f.image for f in frames]), np.array([f.odometry.x for f in frames])

    clean, odometry = drive(sim.CameraConfig())
    noisy, noisy_odometry = drive(sim.CameraConfig(read_noise=2.0, shot_noise=4.0, exposure=0.02))
    again, _ = drive(sim.CameraConfig(read_noise=2.0, shot_noise=4.0, exposure=0.02))
    assert np.array_equal(noisy, again)
    assert np.array_equal(odometry, noisy_odometry)
    assert 1.0 < np.abs(noisy.astype(float) - clean).mean() < 6.0


OPEN_PLANE = """<mujoco><worldbody><light pos="0 0 5" dir="0 0 -1" directional="true"/>
  <geom name="ground" type="plane" size="100 100 0.1" rgba=".5 .5 .5 1"/></worldbody></mujoco>"""


def test_wheel_heading_error_is_an_unbiased_random_walk_of_the_stated_size(tmp_path):
    # The encoders' only heading error is their noise: each wheel's increment off by wheel_relative (2 %) of
    # itself, independently every control period (T = 20 ms at 50 Hz). At speed v a wheel turns v T / r per
    # period, so the heading takes sqrt(2) wheel_relative v T / b of noise per period (b: wheel separation), and
    # after a distance s (s / (v T) periods) its spread is sqrt(2) wheel_relative sqrt(v T s) / b: 0.064 rad
    # after 50 m at 1 m/s, with no bias. Driven straight on a flat plane, 16 seeds (chi-square, 15 degrees of
    # freedom: 99 % of such spreads fall within 0.55-1.48 of the truth), the mean within 3 standard errors of zero.
    (tmp_path / "plane.xml").write_text(OPEN_PLANE)
    (tmp_path / "plane.routes.json").write_text(
        json.dumps({"routes": {"line": {"waypoints": [[0, 0, 0], [60, 0, 0]], "loop": False}}}))
    world = sim.load_world(tmp_path / "plane.xml")
    noise = OdometryNoise(wheel_relative=0.02, gyro=0.0, accelerometer=0.0)
    errors, distances = [], []
    for seed in range(16):
        with Simulation(world, seed=seed, noise=noise, control_rate=50.0) as simulation:
            simulation.set_command(1.0, 0.0)
            simulation.step(50.0)
            odometry = simulation.wheel_odometry()
            errors.append(odometry.yaw - simulation.ground_truth().pose[3])
            distances.append(odometry.distance)
    robot = sim.RobotConfig()
    expected = math.sqrt(2) * 0.02 * math.sqrt(1.0 * 0.02 * np.mean(distances)) / robot.wheel_separation
    spread = float(np.std(errors, ddof=1))
    assert 0.55 * expected < spread < 1.48 * expected, (spread, expected)
    assert abs(np.mean(errors)) < 3 * expected / math.sqrt(len(errors)), np.mean(errors)
    # without the noise the encoders read the heading exactly: the physics turns neither way
    with Simulation(world, seed=0, noise=OdometryNoise(0, (0, 0), 0, 0)) as simulation:
        simulation.set_command(1.0, 0.0)
        simulation.step(50.0)
        assert abs(simulation.ground_truth().pose[3]) < 1e-6
        assert abs(simulation.wheel_odometry().yaw) < 1e-9
