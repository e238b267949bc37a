"""The heading against the scene's straight lines (eqs. M1–M3 of neuroslam.vision.structure).

Synthetic scenes with exact ground truth (:mod:`scenes`, the testbed's camera): a floor of tiles along the
world's axes seen at a known heading gives that heading back modulo 90 degrees (eq. M2), a texture without
lines gives nothing to follow, and a heading that drifts is held to the lines (eq. M3).
"""

import math

import numpy as np
import pytest
from scenes import FIELD_OF_VIEW, Scene, Texture

from neuroslam.vision.ground_motion import blurred_with_gradients
from neuroslam.vision.structure import StructureHeading

TILES = Texture("tiles", level=0.55, scale=1.0, contrast=0.3)  # lines every metre along both axes


def stack(scene: Scene, x: float, y: float, yaw: float) -> np.ndarray:
    """The blurred image and its gradients as the odometry holds them (GroundMotion's finest level)."""
    return blurred_with_gradients(scene.render(x, y, yaw), 1.0)


@pytest.mark.parametrize("yaw_degrees", [0.0, 17.0, -30.0, 60.0, 135.0])
def test_tiles_along_the_axes_give_the_heading_modulo_ninety_degrees(yaw_degrees):
    """Eq. M2 on the floor: phi + yaw is a multiple of 90 degrees within 1.5 degrees (a handful of 4 cm lines
    at 160 × 120: measured up to 1.0 degree over three positions and five headings; eq. M3 averages it over a
    window), and most of the edge energy lies along the two families (R 0.76–0.93 measured)."""
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    scene = Scene(floor=TILES, walls=None, ceiling=None)
    phi, strength = lines.edge_orientation(stack(scene, 0.3, 0.2, math.radians(yaw_degrees)), surface=1)
    offset = (math.degrees(phi) + yaw_degrees + 45.0) % 90.0 - 45.0
    assert abs(offset) < 1.5
    assert strength > 0.7


def test_a_ceiling_of_lines_is_read_as_the_floor_is():
    """The plane's height does not enter eq. M1's angles: a ceiling 3 m up with tiles, over a blank floor. Its
    lines lie 2.5 m from the camera, five times the floor's 0.5 m, so fewer pixels show them sharply; R 0.57
    measured, above the strength that counts (0.5)."""
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    scene = Scene(floor=Texture("blank"), walls=None, ceiling=3.0, ceiling_texture=TILES)
    phi, strength = lines.edge_orientation(stack(scene, 0.0, 0.0, math.radians(25.0)), surface=-1)
    assert (math.degrees(phi) + 25.0 + 45.0) % 90.0 - 45.0 == pytest.approx(0.0, abs=1.5)
    assert strength > 0.5


def test_a_texture_without_lines_turns_nothing():
    """Smooth random blobs point every way: R stays below the strength that counts (0.5), and the yaw changes
    pass unchanged (no reference is ever fixed)."""
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    scene = Scene(floor=Texture("blobs"), walls=None, ceiling=None)
    for k in range(60):
        assert lines.correct(stack(scene, 0.1 * k, 0.0, 0.0), 0.001, 0.1) == 0.001
        assert lines.orientation[1] < 0.5
    assert lines.reference is None


def test_a_drifting_heading_is_held_to_the_lines():
    """Driving straight along tiles with an odometry that reads 0.01 degrees of turn every frame (about twice
    the testbed's straight-frame drift, 0.0067 degrees on gen2:107): 3 degrees over 300 frames uncorrected;
    with eq. M3 the heading follows the lines with the lag b / (1 - exp(-rate dt)) of a steady drift b, 0.5
    degrees, so within a degree of them. The reference is fixed after the first window (50 frames)."""
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    scene = Scene(floor=TILES, walls=None, ceiling=None)
    bias = math.radians(0.01)
    for k in range(300):
        lines.correct(stack(scene, 0.1 * k, 0.0, 0.0), bias, 0.1)
    assert lines.reference is not None
    assert abs(math.degrees(lines.heading - lines.reference)) < 1.0
    # and where the lines do not agree (every second frame seen turned by 20 degrees), nothing is turned
    confused = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    for k in range(120):
        confused.correct(stack(scene, 0.1 * k, 0.0, math.radians(20.0) * (k % 2)), 0.0, 0.1)
    assert confused.reference is None and confused.heading == 0.0


def test_the_state_round_trips():
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    scene = Scene(floor=TILES, walls=None, ceiling=None)
    for k in range(60):
        lines.correct(stack(scene, 0.1 * k, 0.0, 0.0), 0.001, 0.1)
    restored = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    restored.load_state_dict(lines.state_dict())
    following = stack(scene, 6.0, 0.0, 0.0)
    assert restored.correct(following, 0.001, 0.1) == lines.correct(following, 0.001, 0.1)
    assert restored.heading == lines.heading and restored.reference == lines.reference


def test_the_odometry_follows_the_lines_only_when_asked():
    """``odometry.manhattan`` (off by default) gives the odometry its StructureHeading; on a straight drive
    along tiles the heading it integrates is the odometry's own yaw plus eq. M3's corrections."""
    from neuroslam.config import VisualOdometryConfig
    from neuroslam.vision.odometry import VisualOdometry

    assert VisualOdometry(VisualOdometryConfig()).lines is None
    assert VisualOdometry(VisualOdometryConfig(manhattan=True, manhattan_first_row=0.5)).lines.first_row == 0.5
    odometry = VisualOdometry(VisualOdometryConfig(manhattan=True))
    scene = Scene(floor=TILES, walls=None, ceiling=None)
    total = 0.0
    for k in range(80):
        total += odometry.step(scene.render(0.1 * k, 0.0, 0.0), 0.1 if k else 0.0).yaw_rate * 0.1
    assert odometry.lines.reference is not None
    assert odometry.lines.heading == pytest.approx(total, abs=1e-12)
    assert abs(math.degrees(total)) < 1.0  # a textured floor straight ahead: no turn


def test_the_odometry_shows_the_image_stack_eq_m1_reads():
    """``VisualOdometry.image_stack``: None before the first frame, then the last image blurred with its
    gradients, exactly what its own eq. M3 is given (so another heading, the wheels' say, can be held to the
    same lines: benchmarks/yaw_sources.py)."""
    from neuroslam.config import VisualOdometryConfig
    from neuroslam.vision.odometry import VisualOdometry

    odometry = VisualOdometry(VisualOdometryConfig(), horizontal_fov=FIELD_OF_VIEW)
    assert odometry.image_stack is None
    scene = Scene(floor=TILES, walls=None, ceiling=None)
    image = scene.render(0.0, 0.0, math.radians(17.0))
    odometry.step(image, 0.0)
    np.testing.assert_array_equal(odometry.image_stack, blurred_with_gradients(image, 1.0))
    lines = StructureHeading(horizontal_fov=FIELD_OF_VIEW)
    phi, strength = lines.edge_orientation(odometry.image_stack, surface=1)
    assert abs((math.degrees(phi) + 17.0 + 45.0) % 90.0 - 45.0) < 1.5 and strength > 0.7
