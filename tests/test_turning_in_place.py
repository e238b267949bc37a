"""No growth without travel: a robot turning on the spot keeps its map bounded (issue 23, item 3).

The camera turns in a textured 10 × 8 m room (:mod:`scenes`, exact ground truth), with the default
visual odometry and preset. After the first revolution each view meets its own experiences again; the robot
has not driven since it made them, so re-entering them needs no confirming views
(:meth:`~neuroslam.experience_map.ExperienceMap._on_the_spot`), and a place known from before is confirmed by
turning through one field of view on it (``confirmation_turn``), without metres of travel.
"""

import math

import numpy as np
import pytest
from scenes import Scene, arc_path

from neuroslam import NeuroSLAM

ROOM = Scene(half_width=4.0, half_length=5.0)
NOISE = 1 / 255  # ±1 grey level, seeded: no two revolutions give the same frames


def noisy(image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return np.clip(image + rng.uniform(-NOISE, NOISE, image.shape), 0, 1).astype(np.float32)


@pytest.mark.slow
def test_ten_thousand_frames_turning_in_place_keep_the_map_bounded():
    views = [ROOM.render(0.0, 0.0, math.radians(2.0) * k) for k in range(180)]  # 2 degrees a frame
    rng = np.random.default_rng(0)
    slam = NeuroSLAM()
    first_revolution = None
    for k in range(10_000):
        estimate = slam.step(noisy(views[k % 180], rng), 0.1 * k)
        if k == 179:
            first_revolution = (slam.local_view.count, slam.experience_map.size)
    templates, experiences = slam.local_view.count, slam.experience_map.size
    assert experiences <= 2 * first_revolution[1]
    assert templates <= 2 * first_revolution[0]
    # the heading is still right after 55 revolutions: 10,000 × 2° = 20,000° ≡ 200°
    assert abs(math.remainder(estimate.pose[3] - math.radians(20_000.0), 2 * math.pi)) < math.radians(10)
    assert np.linalg.norm(estimate.pose[:2]) < 0.5


def test_a_known_place_is_re_entered_by_turning_on_it_without_travel():
    # a revolution on the spot, 3 m out, turn round, 3 m back, turn round, then two revolutions on the spot
    path = arc_path([(0.0, 2 * math.pi), (3.0, 0.0), (0.0, math.pi), (3.0, 0.0), (0.0, math.pi), (0.0, 4 * math.pi)],
                    start=(-1.5, 0.0, 0.0))
    final_spin = len(path) - 252  # 4π at 0.5 rad/s and 10 frames a second: 252 frames
    rng = np.random.default_rng(1)
    slam = NeuroSLAM()
    closures_on_the_spin, sizes = [], {}
    for k, (x, y, yaw) in enumerate(path):
        estimate = slam.step(noisy(ROOM.render(x, y, yaw), rng), 0.1 * k)
        if k == 126:
            sizes["first revolution"] = slam.experience_map.size
        if k == final_spin:
            sizes["back"] = slam.experience_map.size
        if k > final_spin and estimate.loop_closure and estimate.experience_id < sizes["first revolution"]:
            closures_on_the_spin.append(k - final_spin)
    # the place of the first revolution (made 6 m of travel before) is re-entered, within the first revolution
    # of the spin (0.05 rad a frame: 126 frames a revolution); without confirmation_turn it never is
    assert closures_on_the_spin, "turning on a known place never re-entered it"
    assert closures_on_the_spin[0] < 126
    assert slam.experience_map.size - sizes["back"] <= sizes["first revolution"]
    assert np.linalg.norm(estimate.pose[:2] - path[-1, :2] + path[0, :2]) < 0.5
