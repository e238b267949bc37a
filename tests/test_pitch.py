"""Pitch from the camera alone (eqs. R1–R3): the rotation alignment on images warped by a known rotation,
the transition rule on exact sequences, and the height it gives up and down the car park's ramp."""

import itertools
import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam.config import VisualOdometryConfig
from neuroslam.errors import InvalidInputError, InvalidParameterError
from neuroslam.vision import VisualOdometry
from neuroslam.vision.ground_motion import blurred_with_gradients
from neuroslam.vision.kernels import rotation_cost, rotation_normal
from neuroslam.vision.pitch import LevelTransitions, RotationAlignment

WIDTH, HEIGHT = 160, 120
FOV = math.radians(80)


def scene(seed=0):
    """A smooth random grey image (features a few pixels across), values in [0, 1]."""
    rng = np.random.default_rng(seed)
    image = ndimage.gaussian_filter(rng.random((HEIGHT, WIDTH)), 2.0)
    return ((image - image.min()) / np.ptp(image)).astype(np.float32)


def rotated(image, yaw, pitch, expansion=0.0):
    """The view after the camera turned by ``yaw`` and pitched by ``pitch`` (and the scene expanded by
    ``expansion``): each pixel takes the previous image at eq. R1's position, computed independently here
    with rotation matrices."""
    focal = (WIDTH / 2) / math.tan(FOV / 2)
    v, u = np.mgrid[0:HEIGHT, 0:WIDTH].astype(float)
    rays = np.stack([u - (WIDTH / 2 - 0.5), v - (HEIGHT / 2 - 0.5), np.full(u.shape, focal)]).reshape(3, -1)
    c, s = math.cos(pitch), math.sin(pitch)
    nose_up = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])  # the forward ray (0, 0, 1) goes to (0, -s, c)
    c, s = math.cos(yaw), math.sin(yaw)
    turn_left = np.array([[c, 0, -s], [0, 1, 0], [s, 0, c]])  # the forward ray goes to (-s, 0, c)
    previous = turn_left @ nose_up @ rays
    x = (1 - expansion) * focal * previous[0] / previous[2] + (WIDTH / 2 - 0.5)
    y = (1 - expansion) * focal * previous[1] / previous[2] + (HEIGHT / 2 - 0.5)
    return ndimage.map_coordinates(image, [y, x], order=3, mode="nearest").reshape(HEIGHT, WIDTH).astype(np.float32)


@pytest.mark.parametrize(("yaw", "pitch", "expansion"), [(0.0, 0.03, 0.0), (0.0, -0.05, 0.0), (0.06, 0.0, 0.0),
                                                         (-0.04, 0.02, 0.0), (0.02, -0.03, 0.01), (0.1, 0.05, 0.0)])
def test_alignment_recovers_a_known_rotation(yaw, pitch, expansion):
    """From rest, yaw and pitch within 1 mrad of the rotation that made the second image (the resampling of
    the synthetic scene sets that tolerance; 0.03 rad is 2.9 pixels at the image centre)."""
    first = scene()
    second = rotated(first, yaw, pitch, expansion)
    alignment = RotationAlignment(horizontal_fov=FOV)
    found_yaw, found_pitch = alignment.step(blurred_with_gradients(first, 1.0), blurred_with_gradients(second, 1.0),
                                            floor_yaw=yaw)
    assert found_yaw == pytest.approx(yaw, abs=1e-3)
    assert found_pitch == pytest.approx(pitch, abs=1e-3)
    assert alignment.yaw == found_yaw  # the next frame starts here


@pytest.mark.parametrize(("yaw", "pitch", "expansion", "sign"), [(0.0, 0.0, 0.0, 0), (0.06, 0.02, 0.0, 0),
                                                                 (-0.04, 0.0, 0.0, 0), (0.0, 0.0, 0.003, 1),
                                                                 (0.06, 0.0, 0.01, 1), (0.0, 0.0, -0.01, -1)])
def test_the_expansions_significance_says_whether_the_camera_moved_along_its_axis(yaw, pitch, expansion, sign):
    """Eq. R4: an image that grew by 0.3 % (0.2 pixels at the edge) stands out by far more than the odometry's
    10 (118 measured; 212 with a turn of 3.4 degrees as well; shrinking, as many below -10), and a pure
    rotation or the same image again by far less (within 0.3 measured: the rotation is eq. R1's exactly)."""
    first = scene()
    second = rotated(first, yaw, pitch, expansion) if (yaw, pitch, expansion) != (0.0, 0.0, 0.0) else first.copy()
    alignment = RotationAlignment(horizontal_fov=FOV)
    alignment.step(blurred_with_gradients(first, 1.0), blurred_with_gradients(second, 1.0), floor_yaw=yaw)
    significance = alignment.expansion_significance()
    if sign:
        assert sign * significance > 50
    else:
        assert abs(significance) < 1


def test_alignment_keeps_the_better_of_two_starts():
    """A floor yaw far off (the plane model fails where the floor bends) does not pull the solution away:
    the start from the previous frame's yaw wins."""
    first = scene(1)
    second = rotated(first, 0.0, -0.06)
    alignment = RotationAlignment(horizontal_fov=FOV)
    yaw, pitch = alignment.step(blurred_with_gradients(first, 1.0), blurred_with_gradients(second, 1.0),
                                floor_yaw=0.2)
    assert yaw == pytest.approx(0.0, abs=1e-3)
    assert pitch == pytest.approx(-0.06, abs=1e-3)


def faint(image, level=0.5, contrast=0.04):
    """``image`` (in [0, 1]) scaled to a faint structure: ``level`` give or take ``contrast`` / 2."""
    return (level + contrast * (image - 0.5)).astype(np.float32)


def test_the_faint_image_s_yaw_stands_out_from_structure_not_from_noise():
    """Eq. R11: a faint structure (10 grey levels across, turned 2 degrees) stands out from the yaws around its
    solution by more than 2, above the odometry's 1.5 (3.1 measured: the cubic resampling leaves a residual at the
    solution), and reads its yaw within 1 mrad; uniform images under independent sensor
    noise of 1–8 grey levels (information per pixel up to the image's own threshold, 0.2) stand out by at most
    1.12 (measured), whatever the noise's level: the contrast, unlike the information, tells them apart."""
    first = faint(scene(3))
    second = faint(rotated(scene(3), math.radians(2.0), 0.0))
    alignment = RotationAlignment(horizontal_fov=FOV)
    alignment.step(blurred_with_gradients(first, 1.0), blurred_with_gradients(second, 1.0), floor_yaw=0.0)
    yaw, _ = alignment.column_yaw()
    assert yaw == pytest.approx(math.radians(2.0), abs=1e-3)
    assert alignment.column_yaw_contrast() > 2.0
    rng = np.random.default_rng(0)
    for sigma in (1.0, 2.0, 3.5, 5.0, 8.0):
        noisy = [np.round(np.clip(0.5 + rng.normal(0, sigma / 255, (HEIGHT, WIDTH)), 0, 1) * 255) / 255
                 for _ in range(6)]
        alignment = RotationAlignment(horizontal_fov=FOV)
        for before, after in itertools.pairwise(noisy):
            alignment.step(blurred_with_gradients(before.astype(np.float32), 1.0),
                           blurred_with_gradients(after.astype(np.float32), 1.0), floor_yaw=0.0)
            alignment.column_yaw()
            assert alignment.column_yaw_contrast() < 1.3


def test_the_faint_image_s_contrast_is_0_without_a_solution():
    """Before any frame, after a step whose column_yaw was not solved, and where the image has no information
    at all (a rendered uniform image), eq. R11 says nothing stands out."""
    alignment = RotationAlignment(horizontal_fov=FOV)
    assert alignment.column_yaw_contrast() == 0.0
    # a frame's contrast is that frame's column_yaw's: a new step without it has none
    first, second = faint(scene(3)), faint(rotated(scene(3), math.radians(2.0), 0.0))
    alignment.step(blurred_with_gradients(first, 1.0), blurred_with_gradients(second, 1.0), floor_yaw=0.0)
    alignment.column_yaw()
    assert alignment.column_yaw_contrast() > 2.0
    alignment.step(blurred_with_gradients(second, 1.0), blurred_with_gradients(second, 1.0), floor_yaw=0.0)
    assert alignment.column_yaw_contrast() == 0.0
    uniform = blurred_with_gradients(np.full((HEIGHT, WIDTH), 0.5, dtype=np.float32), 1.0)
    alignment.step(uniform, uniform.copy(), floor_yaw=0.0)
    alignment.column_yaw()
    assert alignment.column_yaw_contrast() == 0.0


def test_a_ray_turned_past_the_image_plane_adds_nothing_to_the_sums():
    """At a yaw of 90 degrees the centre column's rays lie in the image plane (eq. R1 would divide by zero):
    the normal equations stay finite, and no pixel is in view."""
    stack = blurred_with_gradients(scene(2), 1.0)
    alignment = RotationAlignment(horizontal_fov=FOV)
    focal, indices, x, y, _ = alignment._grid(stack.shape[1:])
    target, labels = stack[0].ravel()[indices], np.zeros(len(x), dtype=np.intp)
    for yaw in (math.pi / 2, -math.pi / 2, math.pi):
        normal, gradient = rotation_normal(stack, target, x, y, labels, np.array([yaw, 0.0, 0.0]), focal, 0.05)
        assert np.all(np.isfinite(normal)) and np.all(np.isfinite(gradient))
        assert rotation_cost(stack, target, x, y, labels, np.array([yaw, 0.0, 0.0]), focal, 0.05)[1] == 0.0


def test_a_diverged_solve_reads_no_rotation_instead_of_raising():
    """Gauss-Newton that runs off (an expansion so large that its scale overflows: the sums turn to NaN,
    as a robot against a blank wall once walked its yaw off towards 90 degrees) used to raise numpy's
    LinAlgError out of the visual odometry. Now the solve reports no solution (infinite cost, no
    information), and the frame's step falls back to the floor's yaw with no information."""
    first, second = blurred_with_gradients(scene(3), 1.0), blurred_with_gradients(scene(4), 1.0)
    alignment = RotationAlignment(horizontal_fov=FOV)
    _, cost, information = alignment._solve(first, second, np.array([0.1, 0.0, -1e38]))
    assert cost == math.inf and np.all(information == 0)


def transitions(**overrides):
    settings = {"transition_rate": math.radians(10), "transition_min": math.radians(3),
                "max_slope": math.radians(15), "level_snap": math.radians(4)}
    return LevelTransitions(**(settings | overrides))


def feed(tracker, changes_degrees, dt=0.1):
    """Per-frame pitch changes (degrees) in; (in transition, current pitch in degrees) per frame out."""
    return [(tracker.step(math.radians(change), dt), math.degrees(tracker.current)) for change in changes_degrees]


def test_a_ramp_up_and_down_returns_exactly_to_level():
    """Up by 10.5° (measured), along the ramp with noise below the threshold, down by 9.8°: the pitch holds
    between transitions and is level again (within ``level_snap``), whatever the noise."""
    tracker = transitions()
    noise = [0.3, -0.4, 0.5, -0.2, 0.9, -0.9] * 5
    out = feed(tracker, [0.0, 3.5, 3.6, 3.4] + noise + [-3.3, -3.2, -3.3] + noise)
    flags = [flag for flag, _ in out]
    assert flags == [False, True, True, True] + [False] * 30 + [True, True, True] + [False] * 30
    assert out[3][1] == pytest.approx(10.5)  # during the transition the pitch follows it
    assert all(pitch == pytest.approx(10.5) for _, pitch in out[4:34])  # along the ramp: held
    assert all(pitch == 0.0 for _, pitch in out[37:])  # 0.7° left: level


def test_a_transition_is_one_sign_and_at_least_transition_min():
    """A run that changes sign is two runs; runs below ``transition_min`` change nothing; a run from level is a
    slope, however gentle, and one back towards level that ends within ``level_snap`` of it is level."""
    tracker = transitions()
    feed(tracker, [2.0, -2.0, 0.0])  # two runs of 2°, each too small
    assert tracker.pitch == 0.0
    feed(tracker, [1.5, 1.7, 0.0])  # one run of 3.2° from level: a gentle ramp's foot
    assert math.degrees(tracker.pitch) == pytest.approx(3.2)
    feed(tracker, [-1.5, -1.5, 0.0])  # 3.0° back towards level, 0.2° left: within level_snap, level
    assert tracker.pitch == 0.0
    feed(tracker, [4.0, 4.0, 0.0])
    assert math.degrees(tracker.pitch) == pytest.approx(8.0)


def test_a_transition_steeper_than_max_slope_is_refused():
    """A turn beside a wall read as -22°: no ramp is that steep; the pitch stays, also while it is read. A run
    that would carry a slope back through level leaves it level, however far past it would go."""
    tracker = transitions()
    out = feed(tracker, [-3.0] * 8 + [0.0])
    assert [pitch for _, pitch in out[:4]] == pytest.approx([-3.0, -6.0, -9.0, -12.0])
    assert all(pitch == 0.0 for _, pitch in out[5:])
    feed(tracker, [3.0, 3.0, 3.0, 0.0])
    assert math.degrees(tracker.pitch) == pytest.approx(9.0)
    feed(tracker, [3.0, 2.5, 0.0])  # 14.5°: allowed
    assert math.degrees(tracker.pitch) == pytest.approx(14.5)
    feed(tracker, [1.5, 1.5, 0.0])  # 17.5°: refused
    assert math.degrees(tracker.pitch) == pytest.approx(14.5)
    feed(tracker, [-3.5, -15.4, -8.8, -1.8, 0.0])  # back through level to -15°: a top with a wrong frame, level
    assert tracker.pitch == 0.0
    feed(tracker, [-3.5, -15.4, -8.8, -1.8, 0.0])  # from level, the same run is refused
    assert tracker.pitch == 0.0
    feed(tracker, [3.3, 3.3, 3.3, 0.0, -1.1, -1.1, -1.1, 0.0])  # up 9.9°, then a partial top: 6.6°
    assert math.degrees(tracker.pitch) == pytest.approx(6.6)
    feed(tracker, [-2.8, -3.8, -2.5, -2.5, 0.0])  # the rest read too large, -5.0° in all: through level, level
    assert tracker.pitch == 0.0


def test_a_transition_commits_only_where_a_frame_of_it_sees_the_pitch():
    """Frames that see the pitch too little join a run but cannot make one alone: unseen -3.4° and -3.9°
    then a seen -2.4° (a ramp's top against a blank upper level) take a 10° ramp back to level; the same
    unseen frames alone (7.3° of the 10°: 2.7° left, within ``level_snap``) end the slope too, since a run
    that cancels a slope is its own evidence, and so do unseen frames that carry it through level (19.8°
    back from 10°: a top read too large); but unseen frames that leave the slope more than ``level_snap``
    from level, or start one from level, or go on away from level, change nothing; an unconfirmed run does
    not show in the current pitch."""
    def feed_seen(tracker, changes):
        return [(tracker.step(math.radians(change), 0.1, seen=seen), math.degrees(tracker.current))
                for change, seen in changes]

    tracker = transitions()
    feed(tracker, [3.5, 3.5, 3.0, 0.0])
    assert math.degrees(tracker.pitch) == pytest.approx(10.0)
    out = feed_seen(tracker, [(-3.4, False), (-3.9, False), (-2.4, True), (0.0, True)])
    assert [flag for flag, _ in out] == [True, True, True, False]
    assert [pitch for _, pitch in out[:2]] == pytest.approx([10.0, 10.0])  # not yet seen: held
    assert out[2][1] == pytest.approx(0.3)  # seen: the whole run shows
    assert tracker.pitch == 0.0  # 0.3° from level: level
    for unseen, tail in (([-3.4, -3.9], []), ([-3.4, -3.9], [(0.5, True)]), ([-3.4, -3.9], [(2.0, True)]),
                         ([-4.7, -9.9, -5.2], [])):  # the last: 19.8° back, through level (gen2:116's top)
        tracker = transitions()
        feed(tracker, [3.5, 3.5, 3.0, 0.0])
        out = feed_seen(tracker, [*((change, False) for change in unseen), *tail, (0.0, True)])
        assert [pitch for _, pitch in out[:2]] == pytest.approx([10.0, 10.0])  # unseen: held while it runs
        assert tracker.pitch == 0.0, (unseen, tail)  # the run ended the slope (a trailing frame of another
        # sign or below the rate is not part of it)
    for start, unseen in (([3.5, 3.5, 3.0], [-2.0, -2.0]),  # 4° back: 6° left, beyond level_snap
                          ([], [-3.4, -3.9]),  # from level: a slope's start needs a frame that sees it
                          ([3.5, 3.5, 3.0], [3.4, 1.2])):  # away from level
        tracker = transitions()
        feed(tracker, [*start, 0.0])
        before = tracker.pitch
        feed_seen(tracker, [(change, False) for change in unseen] + [(0.0, True)])
        assert tracker.pitch == before, (start, unseen)


def test_the_threshold_is_a_rate():
    """The same 12° transition over 4 frames at 10 Hz or over 12 frames at 30 Hz is found; 0.8° per
    frame at 10 Hz (8°/s) is not a transition, but at 30 Hz (24°/s) it is."""
    for changes, dt in (([3.0] * 4, 0.1), ([1.0] * 12, 1 / 30)):
        tracker = transitions()
        feed(tracker, [*changes, 0.0], dt)
        assert math.degrees(tracker.pitch) == pytest.approx(12.0)
    slow, fast = transitions(), transitions()
    assert not any(flag for flag, _ in feed(slow, [0.8] * 5, 0.1))
    assert all(flag for flag, _ in feed(fast, [0.8] * 5, 1 / 30))


def test_another_sensors_speed_climbs_on_the_cameras_pitch():
    """With the wheels' speed (``drive --odometry wheel``): views pitching up 12° then holding still (a blank
    ramp: the camera sees no travel, so its own climb is 0) climb at speed × sin(12°), clipped at
    ``max_climb_rate``; a speed that is not a finite number is refused and changes nothing."""
    first = scene(2)
    views, pitch = [first], 0.0
    for change in [0.0, 3.0, 3.0, 3.0, 3.0, 0.0, 0.0, 0.0]:
        pitch += math.radians(change)
        views.append(rotated(first, 0.0, pitch))
    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FOV)
    for view in views:
        own = odometry.step(view, 0.1)
    assert abs(own.climb_rate) < 1e-6  # the image stands still: the camera measured no travel
    expected = math.sin(odometry.pitch)
    assert math.degrees(odometry.pitch) == pytest.approx(12.0, abs=0.5)
    assert odometry.climb_rate_at(1.0) == pytest.approx(expected, rel=1e-12)
    assert odometry.climb_rate_at(-0.5) == pytest.approx(-0.5 * expected, rel=1e-12)
    assert odometry.climb_rate_at(10.0) == odometry.config.max_climb_rate  # 2.08 m/s: clipped at 0.6
    # eq. R7: the wheels' speed is along the ramp; over the ground plan it moves the robot by its cosine
    assert odometry.horizontal_speed_at(1.0) == pytest.approx(math.cos(odometry.pitch), rel=1e-12)
    assert odometry.horizontal_speed_at(-0.5) == pytest.approx(-0.5 * math.cos(odometry.pitch), rel=1e-12)
    state = odometry.state_dict()
    for bad in (math.nan, math.inf, "fast", None):
        with pytest.raises(InvalidInputError, match="forward_speed"):
            odometry.climb_rate_at(bad)
        with pytest.raises(InvalidInputError, match="forward_speed"):
            odometry.horizontal_speed_at(bad)
    assert all(np.array_equal(state[key], value) for key, value in odometry.state_dict().items())


def test_a_speed_along_a_slope_moves_the_robot_by_its_cosine_and_climbs_by_its_sine():
    """Eq. R7: views pitching up by 3° a frame to 12° while the odometry holds 1 m/s read on the floor before
    the bend (eq. R6): each frame's speed along the surface is 1 m/s, its horizontal part 1 × cos(pitch) and
    its climb 1 × sin(pitch) (the paper's integration took all of it as horizontal: 2.2 % long at 12°)."""
    first = scene(2)
    views, pitch = [first], 0.0
    for change in [0.0, 3.0, 3.0, 3.0, 3.0]:
        pitch += math.radians(change)
        views.append(rotated(first, 0.0, pitch))
    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FOV,
                              vertical_fov=2 * math.atan(math.tan(FOV / 2) * 0.75))
    for view in views[:2]:
        odometry.step(view, 0.1)
    odometry._readings.clear()  # 1 m/s observed over the last 2 m (eq. R6's readings)
    for _ in range(20):
        odometry._readings.append((odometry._travelled, 1.0))
        odometry._travelled += 0.1
    pitches = []
    for view in views[2:]:
        motion = odometry.step(view, 0.1)
        assert motion.observed.distance == "held"
        assert odometry.surface_speed == pytest.approx(1.0, abs=1e-12)
        assert motion.forward_speed == pytest.approx(math.cos(odometry.pitch), rel=1e-12)
        assert motion.climb_rate == pytest.approx(math.sin(odometry.pitch), rel=1e-12)
        pitches.append(math.degrees(odometry.pitch))
    assert pitches == pytest.approx([3.0, 6.0, 9.0, 12.0], abs=0.1)
    assert motion.forward_speed < 0.98  # 1 m/s along a 12° slope: 0.978 m/s over the ground plan


@pytest.mark.parametrize("planar_motion", ["ground", "profile"])
def test_the_transition_state_saves_and_continues_exactly(planar_motion):
    """Views pitching up by 3° a frame for four frames, then holding: the odometry's state saved in the
    middle of the transition and loaded into a fresh one continues bit for bit (with the floor alignment's
    images, or without it, its own)."""
    config = VisualOdometryConfig(planar_motion=planar_motion)
    first = scene(2)
    views, pitch = [first], 0.0
    for change in [0.0, 3.0, 3.0, 3.0, 3.0, 0.0, 0.0, 0.0]:
        pitch += math.radians(change)
        views.append(rotated(first, 0.0, pitch))
    odometry = VisualOdometry(config, horizontal_fov=FOV)
    for view in views[:4]:
        odometry.step(view, 0.1)
    copy = VisualOdometry(config, horizontal_fov=FOV)
    copy.load_state_dict(odometry.state_dict())
    assert odometry.transitions.run > 0  # saved mid-transition
    for view in views[4:]:
        assert copy.step(view, 0.1) == odometry.step(view, 0.1)
    assert copy.state_dict().keys() == odometry.state_dict().keys()
    assert math.degrees(odometry.pitch) == pytest.approx(12.0, abs=0.5)


def test_panoramic_cameras_need_the_profile_height():
    with pytest.raises(InvalidParameterError, match="height_model"):
        VisualOdometry(VisualOdometryConfig(planar_motion="profile"), horizontal_fov=2 * math.pi, panoramic=True)


@pytest.mark.slow
def test_height_up_and_down_the_car_park_ramp():
    """The car park's main route up its ramp, along the deck and down again (the first 1,800 frames, 174 m),
    camera only, no gain fitted: the height within 0.3 m of the truth at every frame (the deck is 3 m up;
    levels are told apart at 1.5 m), both transitions of each ramp found, and no other."""
    import sim
    from neuroslam.vision import grey

    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FOV,
                              vertical_fov=2 * math.atan(math.tan(FOV / 2) * 0.75))
    height, errors, pitches, found, previous = 0.0, [], [], 0, None
    with sim.ScriptedDrive("carpark", max_frames=1800, seed=0) as stream:
        for frame in stream:
            before = odometry.transitions.pitch
            motion = odometry.step(grey(frame.image), 0.1 if previous is not None else 0.0)
            height += motion.climb_rate * 0.1
            truth = frame.ground_truth
            errors.append(height - truth.position[2])
            pitches.append(truth.pitch)
            found += odometry.transitions.pitch != before
            previous = truth
    pitches = np.array(pitches)
    true_transitions = int(np.sum(np.abs(np.diff(np.abs(pitches) > math.radians(3)))))
    assert true_transitions == 4  # up the ramp and down again
    assert found == true_transitions
    assert np.max(np.abs(errors)) < 0.3


def _bend_odometry(speeds, dt=0.1):
    """A ``ground`` odometry whose observed speeds (m/s, one a frame ``dt`` apart, oldest first) are
    ``speeds``, as eq. R6 keeps them."""
    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FOV,
                              vertical_fov=2 * math.atan(math.tan(FOV / 2) * 0.75))
    for speed in speeds:
        odometry._readings.append((odometry._travelled, speed))
        odometry._travelled += speed * dt
    odometry._speed = speeds[-1]
    return odometry


# gen3:125's first descent, replayed (frames 4179-4206 of `neuroslam record gen3:125 --laps 2`): leaving a turn,
# the floor read its speed within 1 % up to 0.9 m before the top, then its far rows took in the ramp dropping
# away; the true speed stayed 0.99-1.01 m/s
_LEAVING_A_TURN = [0.72, 0.75, 0.79, 0.82, 0.85, 0.88, 0.90, 0.93, 0.95, 0.96, 0.97, 0.99, 0.99, 0.99, 1.00, 0.99,
                   0.99, 1.00, 0.99]
_BENT_DOWN = [0.90, 0.79, 0.66, 0.69, 0.67, 0.72, 0.57, 0.58, 0.62]
# its first climb (frames 2264-2291): the floor ahead rising read up to 7 % long; true 0.99 m/s
_BENT_UP = [1.01, 1.03, 1.01, 1.02, 1.02, 1.04, 1.05, 1.05, 1.07, 1.07]


def test_a_transition_holds_the_speed_read_before_the_bend_came_into_view():
    """Eq. R6: the held speed is the upper quartile of the last near floor's reach of readings before a bend
    down (a ramp's top, read short) and the lower quartile before a bend up (a ramp's foot, read long); the
    last reading held instead was 0.62 and 1.07 m/s on these two. A bend of 0 or a reversing robot keeps the
    last speed."""
    down = _bend_odometry(_LEAVING_A_TURN + _BENT_DOWN)
    assert down._speed_before_bend(-0.02) == pytest.approx(1.0, abs=0.02)
    up = _bend_odometry(_LEAVING_A_TURN + _BENT_UP)
    assert up._speed_before_bend(+0.02) == pytest.approx(1.0, abs=0.02)
    # the reach is the near floor's (eq. G4's rows, 1.7 m at this camera): a slower stretch before it is not taken
    slow_then_steady = _bend_odometry([0.3] * 20 + [1.0] * 16)
    assert slow_then_steady._speed_before_bend(+0.02) == pytest.approx(1.0, abs=1e-12)
    assert _bend_odometry(_LEAVING_A_TURN + _BENT_DOWN)._speed_before_bend(0.0) == _BENT_DOWN[-1]
    reversing = _bend_odometry([-0.5] * 10)
    assert reversing._speed_before_bend(-0.02) == -0.5
