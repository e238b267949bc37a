"""The paper's profile odometry (eqs. 27–32) on synthetic sequences with known motion: a textured panorama
panned and shifted. The ground-plane method has its own tests (test_ground_motion.py)."""

import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam.config import Region, VisualOdometryConfig
from neuroslam.errors import InvalidParameterError
from neuroslam.vision import VisualOdometry
from neuroslam.vision.odometry import best_shift, profile_turn, vertical_shift

WIDTH, HEIGHT = 160, 120


def panorama(seed=0, shape=(600, 1440)):
    rng = np.random.default_rng(seed)
    return ndimage.gaussian_filter(rng.random(shape), 2.0).astype(np.float32)


def frames(columns_per_frame, rows_per_frame, count, *, strip=None):
    """Views cut from a panorama moving ``columns_per_frame`` right and ``rows_per_frame`` down."""
    strip = panorama() if strip is None else strip
    for k in range(count):
        row = int(round(240 - k * rows_per_frame))
        column = int(round(600 - k * columns_per_frame))
        yield strip[row:row + HEIGHT, column:column + WIDTH]


def test_best_shift_finds_sub_pixel_shifts():
    profile = ndimage.gaussian_filter1d(np.random.default_rng(1).random(300), 3)
    x = np.arange(300)
    moved = np.interp(x - 3.4, x, profile)  # content moved right by 3.4
    shift, _ = best_shift(profile[20:280], moved[20:280], 10)
    assert shift == pytest.approx(3.4, abs=0.15)
    image = np.tile(profile[:60, None], (1, 50))
    assert vertical_shift(image[5:55], image[3:53], 5) == pytest.approx(2.0, abs=0.05)


def test_profile_turn_stands_out_for_structure_and_never_for_noise_alone():
    rng = np.random.default_rng(2)
    odometry = VisualOdometry()

    def profile(image):
        return odometry._profiles(np.clip(image, 0, 1).astype(np.float32))["rotation"]

    # a thin band of structure (8 of 120 rows, posts 0.15 darker) along the horizon, moved by 6 columns, on a
    # uniform image with 1 grey level of noise: the column profile's shift is found and stands out
    band = np.full((120, 220), 0.5)
    band[54:62, ::20] -= 0.15
    band = ndimage.gaussian_filter1d(band, 1.0, axis=1)
    noisy = [band + 1 / 255 * rng.standard_normal(band.shape) for _ in range(2)]
    shift, stands_out = profile_turn(profile(noisy[0][:, 30:190]), profile(noisy[1][:, 24:184]), 32)
    assert stands_out and shift == pytest.approx(6.0, abs=0.5)
    # noise alone, alike at every shift, never stands out (its ratio reaches 1.31 of the 1.5 needed); nor
    # does a uniform image without noise, whose profiles agree at every shift
    for _ in range(200):
        level = rng.uniform(1, 20) / 255
        images = [0.5 + level * rng.standard_normal((120, 160)) for _ in range(2)]
        assert not profile_turn(profile(images[0]), profile(images[1]), 32)[1]
    uniform = profile(np.full((120, 160), 0.5))
    assert not profile_turn(uniform, uniform, 32)[1]


def test_profile_turn_with_the_expansion_fitted_reads_the_shift_alone():
    # a profile in equal-angle samples (160 across 80 degrees) with its structure on the right only (four
    # dark posts at 4–30 degrees), the next frame expanded 6 % (tan θ' = 1.06 tan θ: 0.3 m toward a wall
    # 5 m ahead) and turned by s samples. The shift alone takes the posts' outward motion for a turn; with the
    # expansion fitted (eq. R9) the turn is s within half a sample
    bearings = np.radians(-40 + 80 * (np.arange(160) + 0.5) / 160)

    def scene(theta):
        return 0.5 - 0.2 * sum(np.exp(-0.5 * ((theta - math.radians(post)) / 0.01) ** 2) for post in (4, 11, 19, 30))

    previous = scene(bearings).astype(np.float32)
    for turn in (0.0, 3.0, -5.0):
        seen = np.arctan(np.tan(bearings - turn * (bearings[1] - bearings[0])) / 1.06)
        current = scene(seen).astype(np.float32)
        alone, _ = profile_turn(previous, current, 32)
        fitted, stands_out = profile_turn(previous, current, 32, bearings=bearings, max_expansion=0.29)
        assert stands_out and fitted == pytest.approx(turn, abs=0.5)
        assert abs(alone - turn) > 1.0  # 1.7 samples at no turn (0.9 degrees a frame)
    with pytest.raises(InvalidParameterError, match="max_expansion"):
        profile_turn(previous, previous, 32, bearings=bearings, max_expansion=-0.1)
    with pytest.raises(InvalidParameterError, match="bearings"):
        profile_turn(previous, previous, 32, bearings=bearings[:-1], max_expansion=0.1)


def pinhole_views(yaw_rate, count, fov, dt=0.1):
    """A pinhole camera at a panorama's centre turning at ``yaw_rate`` (rad/s, counter-clockwise): each
    pixel column looks at its own angle, so a rotation moves the image centre more than its edges."""
    strip = panorama(shape=(120, 2880))  # 8 columns per degree, all around
    focal = (WIDTH / 2) / math.tan(fov / 2)
    offsets = np.arctan((np.arange(WIDTH) + 0.5 - WIDTH / 2) / focal)  # angle of each column, right positive
    positions = np.arange(strip.shape[1] + 1)
    wrapped = np.concatenate([strip, strip[:, :1]], axis=1)
    for k in range(count):
        # a column to the right looks clockwise of the heading; the strip's column index grows clockwise
        angles = (-k * yaw_rate * dt + offsets) % (2 * math.pi)
        columns = angles / (2 * math.pi) * strip.shape[1]
        yield np.stack([np.interp(columns, positions, row) for row in wrapped]).astype(np.float32)


@pytest.mark.parametrize("yaw_rate", [0.5, -1.2])
def test_yaw_rate_of_a_turning_pinhole_camera(yaw_rate):
    fov = math.radians(80)
    odometry = VisualOdometry(VisualOdometryConfig(planar_motion="profile", yaw_scale=1.0), horizontal_fov=fov,
                              vertical_fov=math.radians(64))
    rates = [odometry.step(view, 0.1).yaw_rate for view in pinhole_views(yaw_rate, 12, fov)][1:]
    assert np.sign(np.median(rates)) == np.sign(yaw_rate)
    assert np.median(rates) == pytest.approx(yaw_rate, rel=0.05)


@pytest.mark.parametrize("rows", [1, -1])
def test_height_rate_from_a_pitching_view(rows):
    """The view tilts by ``rows`` per frame (content moving down: nose up); the climb rate must be the
    measured speed times the sine of the integrated pitch."""
    vertical_fov = math.radians(64)
    config = VisualOdometryConfig(planar_motion="profile", height_model="profile", pitch_leak=0.0,
                                  pitch_flow_bias=0.0, climb_scale=1.0, max_climb_rate=10.0,
                                  height_region=Region(0.1, 0.9, 0.1, 0.9), max_row_shift=0.25)
    odometry = VisualOdometry(config, horizontal_fov=math.radians(80), vertical_fov=vertical_fov)
    angle_per_row = 2 * math.tan(vertical_fov / 2) / HEIGHT
    motions = [odometry.step(frame, 0.1) for frame in frames(0, rows, 16)]
    pitch = 15 * rows * angle_per_row
    assert odometry.pitch == pytest.approx(pitch, rel=0.10)
    last = motions[-1]
    assert np.sign(last.climb_rate) == np.sign(rows)
    assert last.climb_rate == pytest.approx(last.forward_speed * math.sin(pitch), rel=0.10)


def test_first_frame_has_no_motion_and_rates_are_clipped():
    odometry = VisualOdometry(VisualOdometryConfig(planar_motion="profile", max_yaw_rate=0.5))
    views = list(frames(12, 0, 3))
    assert odometry.step(views[0], 0.1).yaw_rate == 0.0
    assert abs(odometry.step(views[1], 0.1).yaw_rate) <= 0.5 + 1e-9
