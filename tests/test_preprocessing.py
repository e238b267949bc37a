"""Preprocessing: grey levels, area resizing and patch normalisation (eq. 26)."""

import numpy as np
import pytest

from neuroslam.config import Region
from neuroslam.vision import crop, grey, patch_normalise, resize


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


def test_reduce_to_width_averages_blocks_and_leaves_narrow_images_alone():
    from neuroslam.vision.preprocessing import reduce_to_width

    image = np.random.default_rng(3).random((240, 320)).astype(np.float32)
    reduced = reduce_to_width(image, 160)
    assert reduced.shape == (120, 160)
    np.testing.assert_allclose(reduced, image.reshape(120, 2, 160, 2).mean(axis=(1, 3)), atol=1e-6)
    assert reduce_to_width(image, 320) is image and reduce_to_width(image, 0) is image
    assert reduce_to_width(np.zeros((480, 640), np.float32), 160).shape == (120, 160)
    assert reduce_to_width(np.zeros((90, 200), np.float32), 160).shape == (72, 160)
