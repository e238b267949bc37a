"""Ground-plane odometry (eqs. G1–G3) on a synthetic textured floor seen by the testbed's camera geometry,
and in the testbed itself."""

import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam.config import VisualOdometryConfig
from neuroslam.vision import VisualOdometry
from neuroslam.vision.ground_motion import GroundMotion

WIDTH, HEIGHT = 160, 120
FOV = math.radians(80)
CAMERA_HEIGHT, CAMERA_FORWARD = 0.5, 0.1
TEXTURE_CELL = 0.01  # m per texture sample


def floor_texture(seed=0, size=2000):
    rng = np.random.default_rng(seed)
    return ndimage.gaussian_filter(rng.random((size, size)), 3.0)


def render(texture, x, y, yaw):
    """The camera image of a robot at (x, y, yaw) on the textured floor (eq. G1 inverted); sky above."""
    focal = (WIDTH / 2) / math.tan(FOV / 2)
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH].astype(float)
    below = v - (HEIGHT / 2 - 0.5)
    image = np.full((HEIGHT, WIDTH), 0.5)
    floor = below > 1.0
    depth = CAMERA_HEIGHT * focal / below[floor]
    ahead = depth + CAMERA_FORWARD
    left = -(u[floor] - (WIDTH / 2 - 0.5)) * depth / focal
    world_x = x + math.cos(yaw) * ahead - math.sin(yaw) * left
    world_y = y + math.sin(yaw) * ahead + math.cos(yaw) * left
    centre = texture.shape[0] / 2
    image[floor] = ndimage.map_coordinates(texture, [world_y / TEXTURE_CELL + centre, world_x / TEXTURE_CELL + centre],
                                           order=1)
    return image.astype(np.float32)


def drive(texture, steps):
    """Images along an arc path given per-frame (distance, turn) steps, and the true steps."""
    x = y = yaw = 0.0
    images = [render(texture, x, y, yaw)]
    for distance, turn in steps:
        x += distance * math.cos(yaw + turn / 2)
        y += distance * math.sin(yaw + turn / 2)
        yaw += turn
        images.append(render(texture, x, y, yaw))
    return images


@pytest.mark.parametrize("near_row", [0.0, 0.5])
@pytest.mark.parametrize(("distance", "turn"), [(0.1, 0.0), (0.05, 0.04), (0.08, -0.06), (0.0, 0.1), (-0.05, 0.0)])
def test_recovers_known_motion_on_a_textured_floor(distance, turn, near_row):
    """Constant motion over 8 frames from rest: every frame's estimate within 1 mm and 0.5 mrad of the
    truth (the bilinear resampling of the synthetic floor), the first within 3 mm and 1 mrad (the
    constant-velocity prior of eq. G3 still pulls it towards rest); the same with the yaw solved again on
    the near floor (eq. G4), where the whole floor is floor."""
    motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                          near_row=near_row)
    images = drive(floor_texture(), [(distance, turn)] * 8)
    motion.step(images[0])
    for index, image in enumerate(images[1:]):
        estimated_distance, estimated_turn = motion.step(image)
        assert estimated_distance == pytest.approx(distance, abs=3e-3 if index == 0 else 1e-3)
        assert estimated_turn == pytest.approx(turn, abs=1e-3 if index == 0 else 5e-4)


def test_follows_changing_motion_and_scales_with_camera_height():
    """Accelerating and turning both ways: the estimate tracks each frame; a camera assumed twice as high
    and twice as far ahead of the axis reads every distance twice as long, within 3 mm (halved), and every
    turn the same (metric scale comes from the camera's geometry alone: a world scaled by 2 looks the same;
    only the constant-velocity prior, in metres, does not scale, and pulls the accelerating estimate back
    twice as hard)."""
    steps = [(0.02 * k, 0.03 * math.sin(k / 2)) for k in range(1, 10)]
    images = drive(floor_texture(1), steps)
    motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD)
    doubled = GroundMotion(horizontal_fov=FOV, camera_height=2 * CAMERA_HEIGHT, camera_forward=2 * CAMERA_FORWARD)
    motion.step(images[0])
    doubled.step(images[0])
    for (distance, turn), image in zip(steps, images[1:], strict=True):
        estimated_distance, estimated_turn = motion.step(image)
        assert estimated_distance == pytest.approx(distance, abs=2e-3)
        assert estimated_turn == pytest.approx(turn, abs=1e-3)
        doubled_distance, doubled_turn = doubled.step(image)
        assert doubled_distance / 2 == pytest.approx(distance, abs=3e-3)
        assert doubled_turn == pytest.approx(turn, abs=1e-3)


def test_a_blank_floor_keeps_the_previous_motion():
    """Between two blank images the data say nothing and the constant-velocity prior (eq. G3) repeats the
    last motion exactly."""
    images = drive(floor_texture(2), [(0.1, 0.02)] * 3)
    motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD)
    for image in images:
        motion.step(image)
    blank = np.full((HEIGHT, WIDTH), 0.5, dtype=np.float32)
    last = motion.step(blank)
    assert motion.step(blank) == pytest.approx(last, abs=1e-12)


def test_panoramic_cameras_need_the_profile_method():
    from neuroslam.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="planar_motion"):
        VisualOdometry(VisualOdometryConfig(planar_motion="ground"), horizontal_fov=2 * math.pi, panoramic=True)


@pytest.mark.slow
def test_testbed_distance_and_turns_without_calibration():
    """The car park's first 600 frames, with no gains fitted (speed_scale = yaw_scale = 1): on level floor
    (true pitch below 1 degree for the frame and the two before it) the distance and the total turn
    within 3 % of the truth. Ramp transitions are excluded on purpose: where the floor bends, the plane
    model reads up to 0.3 m wrong for a few frames (see the module docstring)."""
    import sim
    from neuroslam.vision import grey

    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FOV,
                              vertical_fov=2 * math.atan(math.tan(FOV / 2) * 0.75))
    rows, pitches, previous = [], [], None
    with sim.ScriptedDrive("carpark", max_frames=600, seed=0) as stream:
        for frame in stream:
            motion = odometry.step(grey(frame.image), 0.1 if previous is not None else 0.0)
            truth = frame.ground_truth
            pitches.append(abs(truth.pitch))
            if previous is not None and max(pitches[-3:]) < math.radians(1):
                rows.append((motion.forward_speed * 0.1, motion.yaw_rate * 0.1,
                             float(np.linalg.norm(truth.position[:2] - previous.position[:2])),
                             math.remainder(truth.yaw - previous.yaw, math.tau)))
            previous = truth
    distance, turn, true_distance, true_turn = np.array(rows).T
    assert len(rows) > 400
    assert distance.sum() / true_distance.sum() == pytest.approx(1.0, abs=0.03)
    turning = np.abs(true_turn) > 0.01
    assert abs(true_turn[turning]).sum() > 1.5  # the stretch has real turns
    assert np.sum(turn[turning] * np.sign(true_turn[turning])) / abs(true_turn[turning]).sum() == pytest.approx(
        1.0, abs=0.03)


def test_a_floor_marked_only_along_the_path_keeps_the_speed():
    """A uniform floor whose only mark is a line along the path (like the building's tiles between their
    cross lines) says nothing about the distance: the image does not change from frame to frame. The
    resampling of the line on the pixel grid then favours no motion. With ``min_information`` the
    constant-velocity prior holds the last measured distance through 3 m of such floor (the frame where
    the textured floor leaves the view measured it 9 mm long: held, within 1.1 cm); without it (0) the
    estimate walks down to under a tenth of the speed (measured 0.007 m), the building's floors in
    miniature."""
    texture = floor_texture(3)
    centre = texture.shape[0] / 2
    across = (np.arange(texture.shape[0]) - centre) * TEXTURE_CELL  # world y of each texture row, m
    along = (np.arange(texture.shape[1]) - centre) * TEXTURE_CELL  # world x of each texture column, m
    line = 0.5 - 0.2 * np.exp(-0.5 * ((across - 0.3) / 0.02) ** 2)  # 2 cm wide, 0.3 m to the left
    floor = np.where(along[None, :] < 3.5, texture, np.broadcast_to(line[:, None], texture.shape))
    images = drive(floor, [(0.1, 0.0)] * 60)  # x = 0 to 6 m; beyond x = 2.6 m only the line is in view
    estimates = {}
    for min_information in (0.3, 0.0):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              min_information=min_information)
        estimates[min_information] = np.array([motion.step(image)[0] for image in images])
    line_only = slice(30, None)
    held = estimates[0.3][line_only]
    assert np.ptp(held) < 1e-6
    assert np.abs(held - 0.1).max() < 0.011
    assert estimates[0.0][-1] < 0.01


def test_an_edge_along_the_path_does_not_see_the_distance():
    """A blank floor beside a dark strip (a ramp's side, a wall's foot) 0.6 m to the right: the strong edge
    runs along the path, slides along itself and the image does not change from frame to frame. Counted
    whole (``aperture`` 0), its gradients, a few degrees off perpendicular to their image motion, give the
    distance 1.5 times the prior's weight of information and walk it down to rest (measured -0.3 mm a
    frame, the truth 100 mm); eq. G6 counts almost none of it (0.01), so the floor is blind and the prior
    holds the last measured distance (12 mm long on the frame the texture left the view: held)."""
    texture = floor_texture(3)
    centre = texture.shape[0] / 2
    across = (np.arange(texture.shape[0]) - centre) * TEXTURE_CELL  # world y of each texture row, m
    along = (np.arange(texture.shape[1]) - centre) * TEXTURE_CELL  # world x of each texture column, m
    edge = np.where(across < -0.6, 0.1, 0.5)
    floor = np.where(along[None, :] < 3.5, texture, np.broadcast_to(edge[:, None], texture.shape))
    images = drive(floor, [(0.1, 0.0)] * 60)  # beyond x = 2.6 m only the blank floor and the edge are in view
    estimates, information = {}, {}
    for aperture in (math.radians(10.0), 0.0):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              aperture=aperture)
        steps = [(motion.step(image)[0], motion.information[0]) for image in images]
        estimates[aperture], information[aperture] = np.array(steps)[30:].T
    held = estimates[math.radians(10.0)]
    assert np.all(information[math.radians(10.0)] < 0.3)
    assert np.ptp(held) < 1e-6
    assert np.abs(held - 0.1).max() < 0.015
    assert np.all(information[0.0] > 0.3)
    assert estimates[0.0][-1] < 0.01


def test_an_aperture_outside_its_range_is_refused():
    with pytest.raises(ValueError, match="aperture"):
        GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                     aperture=math.pi / 2)


def render_beside_wall(floor, wall, x, wall_left, wall_height=2.0):
    """The camera image of a robot at (x, 0) heading along +x on the textured floor, beside a textured wall
    standing ``wall_left`` metres to its left (rays cast to the nearer of floor and wall); sky above."""
    focal = (WIDTH / 2) / math.tan(FOV / 2)
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH].astype(float)
    left = -(u - (WIDTH / 2 - 0.5)) / focal  # the ray's leftward and downward run per metre ahead
    down = (v - (HEIGHT / 2 - 0.5)) / focal
    to_floor = np.where(down > 1e-9, CAMERA_HEIGHT / np.maximum(down, 1e-9), np.inf)  # metres ahead
    to_wall = np.where(left > 1e-9, wall_left / np.maximum(left, 1e-9), np.inf)
    wall_z = CAMERA_HEIGHT - to_wall * down
    on_wall = (to_wall < to_floor) & (wall_z < wall_height)
    on_floor = ~on_wall & np.isfinite(to_floor)
    centre = floor.shape[0] / 2
    image = np.full((HEIGHT, WIDTH), 0.5)
    ahead = x + CAMERA_FORWARD + to_floor[on_floor]
    image[on_floor] = ndimage.map_coordinates(
        floor, [left[on_floor] * to_floor[on_floor] / TEXTURE_CELL + centre, ahead / TEXTURE_CELL + centre], order=1)
    along = x + CAMERA_FORWARD + to_wall[on_wall]
    image[on_wall] = ndimage.map_coordinates(wall, [wall_z[on_wall] / TEXTURE_CELL, along / TEXTURE_CELL + centre],
                                             order=1)
    return image.astype(np.float32)


def test_a_wall_beside_the_path_no_longer_turns_the_robot():
    """Driving straight 3 m with a textured wall 1 m to the left: its lowest part, in the far floor rows,
    is taken for floor lying farther away than it is, and eq. G3 reads a turn away from it (measured
    -0.47 degrees over the 3 m, the building's corridors in miniature); the yaw solved again on the near
    floor (eq. G4, rows from half of half the height below the centre) reads -0.10 degrees. The distance
    is the same either way (the whole floor's, within 1 mm of the truth)."""
    floor, wall = floor_texture(4), 0.3 + 0.4 * floor_texture(5)[:400]
    images = [render_beside_wall(floor, wall, 0.1 * k, wall_left=1.0) for k in range(31)]
    turned, distances = {}, {}
    for near_row in (0.0, 0.5):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              near_row=near_row)
        estimates = np.array([motion.step(image) for image in images])
        turned[near_row] = math.degrees(estimates[1:, 1].sum())
        distances[near_row] = estimates[2:, 0]
    assert turned[0.0] < -0.3
    assert abs(turned[0.5]) < 0.15
    for near_row in (0.0, 0.5):
        assert np.abs(distances[near_row] - 0.1).max() < 1e-3


def test_a_blank_near_floor_leaves_the_yaw_to_the_whole_floor():
    """Where the near floor is blank (its information on the yaw below ``near_information`` times the
    prior's weight), eq. G4 is not used: the estimates are exactly those without it."""
    texture = floor_texture(6)
    along = (np.arange(texture.shape[1]) - texture.shape[0] / 2) * TEXTURE_CELL
    floor = np.where(along[None, :] > 2.2, texture, 0.5)  # texture only from 2.2 m: beyond the near rows' 1.7 m
    images = drive(floor, [(0.1, 0.02)] * 4)  # the near rows reach x = 1.7 + 0.4 m at most: blank throughout
    estimates = {}
    for near_row in (0.0, 0.5):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              near_row=near_row)
        estimates[near_row] = np.array([motion.step(image) for image in images])
    assert np.abs(estimates[0.0][1:]).max() > 0.01  # the far floor did measure a motion
    np.testing.assert_array_equal(estimates[0.5], estimates[0.0])


def striped_wall(rows=400):
    """A wall texture of vertical dark stripes 6 cm wide every 25 cm (the testbed's tiled walls), blurred by one
    texture sample."""
    along = np.arange(2000) * TEXTURE_CELL
    return ndimage.gaussian_filter(np.where((along % 0.25) < 0.06, 0.25, 0.55)[None, :].repeat(rows, 0), 1.0)


@pytest.mark.parametrize("near_floor", [False, True])
@pytest.mark.parametrize("wall_left", [1.1, 1.3])
def test_on_a_slope_the_near_floor_is_the_lane(wall_left, near_floor):
    """Eq. G7: driving straight 10 m over a faint floor (intensity's standard deviation 0.027) beside a striped
    wall 1.1 m to the left, the wall's face enters eq. G4's near floor at its top outer corner (its top row spans
    1.3 m to either side) and outweighs the floor: the whole near floor reads -4.7 degrees (measured), the lane
    within 1 m of the path -0.36. With the wall 1.3 m away it does not reach the near floor and the two read alike
    (-0.30, -0.36). Off a slope ``slope_half_width`` changes nothing (the estimates are identical). With eq. G9
    (``near_floor``: eq. G3 itself reads the near floor on a slope) the lane bounds that region too: -5.6 degrees
    without it beside the 1.1 m wall, -0.36 with it (the lane did nothing there before 8835008, the forty-sixth
    step)."""
    floor, wall = floor_texture(4), striped_wall()
    images = [render_beside_wall(floor, wall, 0.1 * k, wall_left=wall_left) for k in range(101)]
    turned, estimates = {}, {}
    for lane, on_slope in ((0.0, True), (1.0, True), (1.0, False), (0.0, False)):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              near_row=0.5, slope_half_width=lane, slope_near_floor=near_floor)
        motion.on_slope = on_slope
        estimates[lane, on_slope] = np.array([motion.step(image) for image in images])
        turned[lane, on_slope] = math.degrees(estimates[lane, on_slope][1:, 1].sum())
    assert abs(turned[1.0, True]) < 0.5
    if wall_left < 1.3:
        assert turned[0.0, True] < -3.0  # the wall's face in the whole near floor
    else:
        assert abs(turned[0.0, True]) < 0.5
    np.testing.assert_array_equal(estimates[1.0, False], estimates[0.0, False])
    if not near_floor:  # eq. G4's near floor solves the yaw again, so on a slope without the lane nothing changes
        np.testing.assert_array_equal(estimates[1.0, False], estimates[0.0, True])


def test_the_odometry_takes_the_lane_where_its_pitch_is_a_slope():
    """The visual odometry sets :attr:`GroundMotion.on_slope` from the pitch its transitions hold (eq. R3): at
    least ``transition_min`` is a slope."""
    config = VisualOdometryConfig(slope_half_width=1.0)
    odometry = VisualOdometry(config, horizontal_fov=FOV, vertical_fov=2 * math.atan(math.tan(FOV / 2) * 0.75))
    image = render(floor_texture(2), 0.0, 0.0, 0.0)
    odometry.step(image, 0.1)
    assert not odometry._ground.on_slope
    odometry.transitions.pitch = -config.transition_min
    odometry.step(image, 0.1)
    assert odometry._ground.on_slope
    odometry.transitions.pitch = 0.5 * config.transition_min
    odometry.step(image, 0.1)
    assert not odometry._ground.on_slope


def _noisy(image, grey_levels, rng):
    """``image`` (in [0, 1]) under independent sensor noise of ``grey_levels`` (of 255), rounded to 8 bits."""
    noisy = np.clip(image + rng.normal(0.0, grey_levels / 255, image.shape), 0.0, 1.0)
    return (np.round(noisy * 255) / 255).astype(np.float32)


@pytest.mark.parametrize("grey_levels", [1.0, 3.5, 8.0])
def test_sensor_noise_on_a_blank_floor_is_no_floor_to_eq_g8(grey_levels):
    """A blank floor at rest under independent sensor noise: eq. G3's information counts the noise's gradients
    (above ``min_information`` on every frame, from 1 grey level up), and the floor then reads motion; eq. G8's,
    the part both images share, where it stands out of its own noise, never sees the distance, and the
    floor keeps the prior's rest."""
    seen, motions = {}, {}
    for shared in (False, True):
        rng = np.random.default_rng(7)
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              shared_information=shared)
        seen[shared], motions[shared] = [], []
        for _ in range(20):
            motions[shared].append(motion.step(_noisy(np.full((HEIGHT, WIDTH), 0.5), grey_levels, rng)))
            seen[shared].append(motion.sees_distance)
    assert all(seen[False][1:])  # the defect eq. G8 mends
    assert not any(seen[True])
    assert np.abs(np.array(motions[True])[:, 0]).max() < 1e-3  # m: the distance stays at rest


@pytest.mark.parametrize("grey_levels", [0.0, 3.5])
def test_eq_g8_sees_a_textured_floor_under_noise(grey_levels):
    """A textured floor, 0.1 m and 0.02 rad a frame, clean or under 3.5 grey levels of noise: eq. G8 sees the
    distance on every frame and the estimates stay within 3 mm and 1 mrad of the truth after the first
    frame."""
    rng = np.random.default_rng(3)
    images = [_noisy(image, grey_levels, rng) for image in drive(floor_texture(4), [(0.1, 0.02)] * 10)]
    motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                          shared_information=True)
    motion.step(images[0])
    for index, image in enumerate(images[1:]):
        distance, turn = motion.step(image)
        assert motion.sees_distance
        if index > 0:
            assert distance == pytest.approx(0.1, abs=3e-3)
            assert turn == pytest.approx(0.02, abs=1e-3)


def test_eq_g8_sees_sparse_marks():
    """A blank floor with a dark 4 cm spot every 0.5 m each way (a few dozen floor pixels each frame), clean, the
    robot speeding up from rest to 0.1 m a frame: eq. G8 sees the distance wherever eq. G3 does, the same
    distances, within 1 mm of the truth once the speed has been steady for two frames."""
    size = 2000
    spots = np.zeros((size, size))
    spots[::50, ::50] = 1.0
    texture = 0.6 - 0.3 * np.minimum(ndimage.gaussian_filter(spots, 2.0) / ndimage.gaussian_filter(spots, 2.0).max(),
                                     1.0)
    images = drive(texture, [(0.02, 0.0), (0.04, 0.0), (0.06, 0.0), (0.08, 0.0)] + [(0.1, 0.0)] * 16)
    readings = {}
    for shared in (False, True):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              shared_information=shared)
        readings[shared] = [(motion.step(image)[0], motion.sees_distance) for image in images]
    assert readings[True] == readings[False]  # where eq. G8 agrees, the solution is eq. G3's, bit for bit
    assert all(seen for _, seen in readings[True][1:])
    assert np.abs(np.array([d for d, _ in readings[True][7:]]) - 0.1).max() < 1e-3


def test_on_a_slope_the_floor_region_is_the_near_floor():
    """Eq. G9: on a slope with ``slope_near_floor``, eq. G3 reads the near floor alone (the estimates of a floor
    region starting at ``near_row`` without eq. G4, exactly); off a slope it changes nothing."""
    images = drive(floor_texture(8), [(0.1, 0.01)] * 20)

    def estimates(on_slope, near_row=0.5, **options):
        motion = GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD,
                              near_row=near_row, **options)
        motion.on_slope = on_slope
        return np.array([motion.step(image) for image in images])
    near = estimates(True, slope_near_floor=True)
    np.testing.assert_array_equal(near, estimates(True, near_row=0.0, first_row=0.5))
    np.testing.assert_array_equal(estimates(False, slope_near_floor=True), estimates(True))
    assert not np.array_equal(near, estimates(True))  # the far floor did take part without it
    np.testing.assert_allclose(near[1:], [(0.1, 0.01)] * 20, atol=0.005)
    with pytest.raises(ValueError, match="slope_near_floor"):
        GroundMotion(horizontal_fov=FOV, camera_height=CAMERA_HEIGHT, camera_forward=CAMERA_FORWARD, near_row=0.0,
                     slope_near_floor=True)
