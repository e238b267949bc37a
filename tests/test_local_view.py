"""Local view cells: a shifted copy of a stored view matches with its shift; an unrelated view does not."""

import math

import numpy as np
import pytest
from scipy import ndimage

from neuroslam import InvalidInputError
from neuroslam.config import LocalViewConfig
from neuroslam.vision import LocalViewCells, VisualOdometry


def scene(seed, shape=(120, 400)):
    """A smooth random grey scene, wider than one view so that views can be cut from it shifted."""
    rng = np.random.default_rng(seed)
    return ndimage.gaussian_filter(rng.random(shape), 3).astype(np.float32)


def view(image, column, width=160):
    return image[:, column:column + width]


def test_shifted_copy_matches_with_its_shift_and_unrelated_view_is_new():
    cells = LocalViewCells(LocalViewConfig(), horizontal_fov=math.radians(80))
    world = scene(1)
    first = cells.observe(cells.thumbnail(view(world, 100)))
    assert first.new and first.template_id == 0
    # the camera turned left by 20 px: the content moves right by 2 thumbnail columns (160 px -> 16 columns)
    again = cells.observe(cells.thumbnail(view(world, 80)))
    assert not again.new and again.template_id == 0
    assert again.column_shift == 2
    assert again.relative_yaw == pytest.approx(2 * math.radians(80) / 16)
    other = cells.observe(cells.thumbnail(view(scene(2), 100)))
    assert other.new and other.template_id == 1
    assert cells.count == 2


def test_a_blank_view_under_sensor_noise_is_one_place():
    """Eq. V1: a blank wall under a camera's noise (3.5 grey levels, fresh every frame) is one template, not one
    a frame (as with eq. 26 alone: noise at unit contrast differs by about 1.13 between frames; with the floor,
    by 1.13 / sqrt(1 + 4²) = 0.27 before the best shift, under the threshold)."""
    rng = np.random.default_rng(4)
    wall = np.full((120, 160), 0.45, np.float32)
    frames = [wall + 3.5 / 255 * rng.standard_normal(wall.shape).astype(np.float32) for _ in range(40)]
    cells = LocalViewCells(LocalViewConfig(), horizontal_fov=math.radians(80))
    assert cells.observe(cells.thumbnail(frames[0])).new
    assert not any(cells.observe(cells.thumbnail(frame)).new for frame in frames[1:])
    assert cells.count == 1
    bare = LocalViewCells(LocalViewConfig(noise_floor=0.0), horizontal_fov=math.radians(80))
    for frame in frames:
        bare.observe(bare.thumbnail(frame))
    assert bare.count > 30


def test_textured_views_under_sensor_noise_keep_their_places_and_shifts():
    """Under the same noise a textured scene's shifted view still matches with its shift, another scene's view is
    still new, and a clean image's thumbnail is eq. 26's bit for bit."""
    rng = np.random.default_rng(5)
    world, other = scene(1), scene(2)

    def noisy(image):
        return image + 3.5 / 255 * rng.standard_normal(image.shape).astype(np.float32)

    cells = LocalViewCells(LocalViewConfig(), horizontal_fov=math.radians(80))
    assert cells.observe(cells.thumbnail(noisy(view(world, 100)))).new
    again = cells.observe(cells.thumbnail(noisy(view(world, 80))))
    assert not again.new and again.template_id == 0 and again.column_shift == 2
    assert cells.observe(cells.thumbnail(noisy(view(other, 100)))).new
    bare = LocalViewCells(LocalViewConfig(noise_floor=0.0), horizontal_fov=math.radians(80))
    np.testing.assert_array_equal(cells.thumbnail(view(world, 100)), bare.thumbnail(view(world, 100)))


@pytest.mark.parametrize("noise", [-0.01, math.nan, math.inf, "0.01", True])
def test_a_bad_noise_deviation_is_refused_naming_it(noise):
    """The image's noise handed to the views or the odometry (eq. V2) must be a finite number >= 0."""
    image = view(scene(1), 100)
    with pytest.raises(InvalidInputError, match="noise="):
        LocalViewCells().thumbnail(image, noise=noise)
    odometry = VisualOdometry()
    odometry.step(image, 0.0)
    before = odometry.state_dict()
    with pytest.raises(InvalidInputError, match="noise="):
        odometry.step(image, 0.1, noise=noise)
    after = odometry.state_dict()
    assert before.keys() == after.keys() and all(np.array_equal(before[key], after[key]) for key in before)


def test_panoramic_views_match_over_the_whole_circle():
    cells = LocalViewCells(LocalViewConfig(thumbnail=(12, 48), max_column_shift=23), panoramic=True)
    strip = scene(3, (120, 480))
    cells.observe(cells.thumbnail(strip))
    turned = np.roll(strip, -200, axis=1)  # the robot turned right by 150 degrees
    match = cells.observe(cells.thumbnail(turned))
    assert not match.new
    assert match.column_shift == -20 and match.relative_yaw == pytest.approx(-20 * 2 * math.pi / 48)


def test_preselection_keeps_the_brute_force_match():
    """Recall of the cheap pre-selection against comparing with every template."""
    cells = LocalViewCells(LocalViewConfig(candidates=16))
    rng = np.random.default_rng(0)
    worlds = [scene(s) for s in range(60)]
    for w in worlds:
        cells.add(cells.thumbnail(view(w, 100)))
    hits = 0
    for _ in range(60):
        index = int(rng.integers(60))
        query = cells.thumbnail(view(worlds[index], 100 + int(rng.integers(-30, 31))))
        everything, _ = cells.compare(query, np.arange(cells.count))
        chosen = cells.candidates(query)
        hits += int(np.argmin(everything)) in set(chosen.tolist())
    assert hits / 60 >= 0.95


def test_templates_grow_in_one_contiguous_array():
    cells = LocalViewCells()
    for seed in range(100):
        cells.add(cells.thumbnail(view(scene(seed), 0)))
    assert cells.templates.shape == (100, 12, 16) and cells.templates.flags.c_contiguous


def test_the_other_templates_within_the_threshold_come_best_first():
    """Two templates of one place (the second with a little noise) and one of another: a view of the place
    matches the closer of the two and lists the other as its alternative; the unrelated one is not listed.
    A view of the other place has no alternative."""
    cells = LocalViewCells(LocalViewConfig(), horizontal_fov=math.radians(80))
    world, rng = scene(4), np.random.default_rng(5)
    cells.add(cells.thumbnail(view(world, 100)))
    cells.add(cells.thumbnail(view(world, 100) + rng.normal(0.0, 0.02, (120, 160)).astype(np.float32)))
    cells.add(cells.thumbnail(view(scene(6), 100)))
    match = cells.observe(cells.thumbnail(view(world, 100) + rng.normal(0.0, 0.005, (120, 160)).astype(np.float32)))
    differences, _ = cells.compare(cells.thumbnail(view(world, 100)), np.arange(3))
    assert differences[2] > cells.config.threshold >= max(differences[:2])  # the premise
    assert not match.new and match.template_id == 0 and match.alternatives == (1,)
    other = cells.observe(cells.thumbnail(view(scene(6), 100)))
    assert other.template_id == 2 and other.alternatives == ()
