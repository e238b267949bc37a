"""Preprocessing: grey levels, area resizing, patch normalisation (eq. 26) and the noise estimate (eq. V2)."""

import numpy as np
import pytest
from scipy import ndimage

from neuroslam.config import Region
from neuroslam.vision import crop, grey, noise_deviation, patch_normalise, resize


def test_grey_from_rgb_uint8_and_float():
    image = np.zeros((2, 2, 3), np.uint8)
    image[0, 0] = (255, 255, 255)
    image[1, 1] = (255, 0, 0)
    levels = grey(image)
    assert levels.dtype == np.float32
    assert levels[0, 0] == pytest.approx(1.0) and levels[1, 1] == pytest.approx(0.299)
    np.testing.assert_allclose(grey(np.full((3, 3), 0.25)), 0.25)


def test_area_resize_averages_every_pixel():
    image = np.arange(120 * 160, dtype=np.float32).reshape(120, 160)
    small = resize(image, (12, 16))
    assert small[0, 0] == pytest.approx(image[:10, :10].mean())
    assert small.mean() == pytest.approx(image.mean(), rel=1e-5)
    assert resize(image, (7, 9)).mean() == pytest.approx(image.mean(), rel=1e-5)  # uneven cells too


def test_crop_by_fractions():
    image = np.arange(100).reshape(10, 10)
    np.testing.assert_array_equal(crop(image, Region(0.2, 0.5, 0.0, 0.3)), image[2:5, 0:3])


def test_patch_normalisation_gives_local_zero_mean_and_unit_spread():
    rng = np.random.default_rng(0)
    image = (rng.random((40, 40)) * 0.2 + np.linspace(0, 1, 40)[None]).astype(np.float32)  # a ramp plus noise
    normalised = patch_normalise(image, 5)
    assert abs(normalised[5:-5, 5:-5].mean()) < 0.1
    assert normalised[5:-5, 5:-5].std() == pytest.approx(1.0, abs=0.25)
    assert np.all(patch_normalise(np.full((10, 10), 0.5, np.float32), 5) == 0)  # flat: zero, not noise


def test_patch_normalisation_with_a_noise_floor():
    """Eq. V1: a patch of noise alone (deviation s) counted with a floor of c s comes out at the contrast
    1 / sqrt(1 + c²); a texture many times the floor keeps unit contrast; no floor is eq. 26 bit for bit."""
    rng = np.random.default_rng(1)
    deviation = 0.01
    noise = (0.5 + deviation * rng.standard_normal((200, 200))).astype(np.float32)
    for c in (3.0, 12.0):
        floored = patch_normalise(noise, 5, noise=c * deviation)[5:-5, 5:-5]
        # a 5 x 5 patch's sample deviation of noise is sqrt(24 / 25) of the noise's: the contrast within 5 %
        assert floored.std() == pytest.approx(np.sqrt(24 / 25) / np.sqrt(24 / 25 + c * c), rel=0.05)
    texture = (0.5 + 0.2 * rng.standard_normal((40, 40))).astype(np.float32)
    assert patch_normalise(texture, 5, noise=3 * deviation)[5:-5, 5:-5].std() == pytest.approx(
        patch_normalise(texture, 5)[5:-5, 5:-5].std(), rel=0.02)
    np.testing.assert_array_equal(patch_normalise(texture, 5, noise=0.0), patch_normalise(texture, 5))


def test_noise_deviation_reads_the_noise_and_not_the_scene():
    """Eq. V2: the deviation of independent Gaussian noise on a smooth scene with edges, within 5 % (the median
    of 13,000 responses: about 1 %), and none on the clean scene."""
    rng = np.random.default_rng(2)
    scene = ndimage.gaussian_filter(rng.random((120, 160)), 4).astype(np.float32)
    scene[:, 80:] += 0.3  # an edge
    scene[60:, :] *= 0.5  # another
    assert noise_deviation(scene) < 0.05 / 255  # the smooth scene's curvature and its edges are not noise
    for levels in (1.0, 3.5, 8.0):
        noisy = scene + levels / 255 * rng.standard_normal(scene.shape).astype(np.float32)
        assert noise_deviation(noisy) == pytest.approx(levels / 255, rel=0.05)
    assert noise_deviation(np.full((120, 160), 0.4, np.float32)) == 0.0
    assert noise_deviation(np.zeros((2, 9), np.float32)) == 0.0  # too small to have inner pixels


def test_reduce_to_width_averages_blocks_and_leaves_narrow_images_alone():
    from neuroslam.vision.preprocessing import reduce_to_width

    image = np.random.default_rng(3).random((240, 320)).astype(np.float32)
    reduced = reduce_to_width(image, 160)
    assert reduced.shape == (120, 160)
    np.testing.assert_allclose(reduced, image.reshape(120, 2, 160, 2).mean(axis=(1, 3)), atol=1e-6)
    assert reduce_to_width(image, 320) is image and reduce_to_width(image, 0) is image
    assert reduce_to_width(np.zeros((480, 640), np.float32), 160).shape == (120, 160)
    assert reduce_to_width(np.zeros((90, 200), np.float32), 160).shape == (72, 160)
