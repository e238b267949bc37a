"""Scripted drives complete their laps on every level and stay on the drivable surface; the camera
stream changes while moving and repeats exactly with the same seed."""

import itertools
import math

import mujoco
import numpy as np
import pytest
from conftest import BUILTIN_WORLDS, GENERATED_WORLDS

import sim


def _floor_distance(simulation, position):
    """Distance from 5 cm above ``position`` straight down to the first world surface, m: the nearest of five
    rays 1 cm apart (a ray down exactly along the seam of two slab boxes can slip between them)."""
    geomid = np.zeros(1, dtype=np.int32)
    robot = simulation.model.body("robot/").id
    down = np.array([0.0, 0.0, -1.0])
    distances = []
    for dx, dy in ((0, 0), (0.01, 0), (-0.01, 0), (0, 0.01), (0, -0.01)):
        start = np.asarray(position, dtype=float) + np.array([dx, dy, 0.05])
        distance = mujoco.mj_ray(simulation.model, simulation.data, start, down, None, 1, robot, geomid)
        distances.append(distance - 0.05 if distance >= 0 else math.inf)
    return min(distances)


@pytest.mark.parametrize("name", BUILTIN_WORLDS + GENERATED_WORLDS)
def test_scripted_drive_completes_two_laps_on_every_level_without_leaving_the_floor(name):
    drive = sim.ScriptedDrive(name, laps=2, speed=1.5, render=False, seed=0)
    route = drive.route
    reference = route.point_at(np.arange(0.0, route.length, 0.05))
    heights, off_route, off_floor, tilt = [], [], [], []
    for frame in drive:
        truth = frame.ground_truth
        heights.append(truth.position[2])
        off_route.append(np.min(np.linalg.norm(reference - truth.position, axis=1)))
        off_floor.append(abs(_floor_distance(drive.simulation, truth.position)))
        _w, x, y, _z = truth.quaternion
        tilt.append(math.degrees(math.acos(min(1.0, 1 - 2 * (x * x + y * y)))))
    # whole laps: the progress covers the route twice and the robot is back where it started
    assert frame.lap == 2 and frame.progress >= 2 * route.length - 0.3
    assert np.linalg.norm(frame.ground_truth.position - route.waypoints[0]) < 1.0
    assert drive.simulation.warnings() == {}
    levels = drive.world.levels
    assert min(heights) == pytest.approx(levels[0], abs=0.05)
    assert max(heights) == pytest.approx(levels[-1], abs=0.05)
    visited = set(np.unique(drive.world.level_of(np.array(heights))))
    assert visited == set(range(len(levels)))
    # on a floor or ramp the whole way: the surface is right under the wheels' contact point
    assert max(off_floor) < 0.05
    # the robot follows its lane (lanes keep more than 1.4 m from any wall) and never tips
    assert max(off_route) < 0.8
    assert max(tilt) < 20.0


@pytest.mark.parametrize("seed", [1, 2, 3, 5, 6, 8, 9, 13])
def test_generated_worlds_are_drivable(seed):
    """Worlds nobody tuned: the route is driven to its end over every level without getting stuck."""
    drive = sim.ScriptedDrive(f"gen:{seed}", laps=1, speed=1.5, render=False)
    heights = np.array([frame.ground_truth.position[2] for frame in drive])
    assert drive.laps_completed == 1
    assert set(np.unique(drive.world.level_of(heights))) == set(range(len(drive.world.levels)))
    assert drive.simulation.warnings() == {}


def test_the_robot_is_driven_not_teleported():
    drive = sim.ScriptedDrive("carpark", max_frames=60, render=False)
    frames = list(drive)
    positions = np.array([f.ground_truth.position for f in frames])
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1)
    assert steps.max() < 2.0 * 0.1 + 1e-3  # never faster than the 2 m/s limit between 10 Hz frames
    assert 0 < steps[-10:].mean()
    assert frames[-1].odometry.distance == pytest.approx(np.sum(steps), rel=0.05)


def test_camera_frames_change_while_moving_and_repeat_with_the_same_seed():
    def run(seed):
        with sim.ScriptedDrive("urban", max_frames=25, seed=seed) as drive:
            return list(drive)
    first, second = run(3), run(3)
    for a, b in zip(first, second, strict=True):
        np.testing.assert_array_equal(a.image, b.image)
        np.testing.assert_array_equal(a.ground_truth.pose, b.ground_truth.pose)
        assert a.odometry == b.odometry
    moving = list(first[5:])
    for a, b in itertools.pairwise(moving):
        assert a.image.shape == (120, 160, 3) and a.image.dtype == np.uint8
        assert np.mean(np.abs(a.image.astype(int) - b.image.astype(int))) > 0.5
    other = run(4)
    assert other[-1].odometry != first[-1].odometry  # the seed drives the sensor noise


def test_panoramic_camera_stitches_four_views():
    camera = sim.CameraConfig(width=256, height=48, panoramic=True)
    with sim.ScriptedDrive("carpark", max_frames=1, camera=camera) as drive:
        (frame,) = list(drive)
    assert frame.image.shape == (48, 256, 3)
    quarters = np.split(frame.image.astype(int), 4, axis=1)
    assert all(np.mean(np.abs(a - b)) > 1.0 for a, b in itertools.pairwise(quarters))


def test_stuck_robot_is_reported(tmp_path):
    (tmp_path / "box.xml").write_text("""<mujoco><worldbody><geom type="plane" size="10 10 .1"/>
      <geom type="box" size="0.1 3 1" pos="2 0 1"/></worldbody></mujoco>""")
    (tmp_path / "box.routes.json").write_text(
        '{"routes": {"through": {"waypoints": [[0,0,0],[5,0,0]], "loop": false}}}')
    drive = sim.ScriptedDrive(sim.load_world(tmp_path / "box.xml"), render=False, stuck_timeout=5.0)
    with pytest.raises(sim.DriveStuckError, match="stuck"):
        for _ in drive:
            pass


def test_a_drive_is_iterated_once():
    drive = sim.ScriptedDrive("gen:1", max_frames=2, render=False)
    assert len(list(drive)) == 2
    with pytest.raises(sim.SimError, match="only once"):
        list(drive)
