"""Eq. M6: a familiar view's heading holds the map's heading where no loop closes."""

import math

import numpy as np
import pytest

from neuroslam.config import ExperienceMapConfig
from neuroslam.errors import InvalidParameterError
from neuroslam.experience_map import ExperienceMap
from neuroslam.geometry import wrap
from neuroslam.relaxation import ViewHeadingTerms, solve_least_squares, view_heading_weights
from neuroslam.vision.local_view import LocalViewCells

COLUMN = math.radians(5.0)  # one column of the sim camera's view thumbnail


def test_weights_follow_the_neighbours_not_zero():
    # a map whose heading has drifted 60° gives every true observation a residual near 60°: they agree with
    # each other and count fully; a look-alike facing the other way departs by 180° and counts almost nothing,
    # the newest one too (its neighbours are the ones before it)
    residuals = np.full(30, math.radians(60.0)) + np.linspace(0, math.radians(2.0), 30)
    residuals[[7, 29]] = wrap(residuals[[7, 29]] + math.pi)
    weights = view_heading_weights(residuals, 0.05, COLUMN)
    good = np.delete(np.arange(30), [7, 29])
    assert np.all(weights[good] > 0.045) and np.all(weights[[7, 29]] < 0.05 * 1e-3)
    # across the wrap at ±π the departures are wrapped: 179° and −179° are neighbours
    across = np.array([math.radians(179.0), math.radians(-179.0)] * 5)
    assert np.all(view_heading_weights(across, 1.0, COLUMN) > 0.8)
    # an observation with no other counts nothing
    assert view_heading_weights(np.array([0.3]), 1.0, COLUMN).tolist() == [0.0]
    assert len(view_heading_weights(np.zeros(0), 1.0, COLUMN)) == 0


def _two_laps(seed: int, steps: int = 200, step: float = 0.5):
    """A square loop of ``steps`` half-metre links driven twice, the odometry's heading biased 0.25° a link on
    the second lap only (a stretch of false turns the first lap did not have). Returns the truth, the chain's
    links, the odometry's poses and each second-lap experience's twin on the first lap."""
    rng = np.random.default_rng(seed)
    true_turns = np.zeros(2 * steps)
    true_turns[steps // 4 :: steps // 4] = math.pi / 2
    measured = true_turns + rng.normal(0.0, 0.004, 2 * steps)
    measured[steps:] += math.radians(0.25)
    truth, odometry = np.zeros((2 * steps + 1, 4)), np.zeros((2 * steps + 1, 4))
    for poses, turns in ((truth, true_turns), (odometry, measured)):
        for k in range(2 * steps):
            yaw = poses[k, 3] + turns[k]
            poses[k + 1] = [poses[k, 0] + step * math.cos(yaw), poses[k, 1] + step * math.sin(yaw), 0.0, yaw]
    link_poses = np.column_stack([np.full(2 * steps, step), measured, measured, np.zeros(2 * steps)])
    sources = np.arange(2 * steps)
    return truth, sources, sources + 1, link_poses, odometry, np.arange(steps + 1, 2 * steps + 1) - steps


def _solve(poses, sources, targets, link_poses, views=None):
    weights = np.ones(len(sources))
    for _ in range(50):
        poses, settled = solve_least_squares(poses, sources, targets, link_poses, weights, None, None, views)
        if settled:
            break
    return poses


def test_views_seen_again_hold_the_second_laps_heading():
    # no loop closure: the chain alone keeps the second lap's 50° of false turn. Each second-lap experience
    # sees the view its first-lap twin learned, the turn between them read in whole columns of 5° (the true
    # offset plus a small scatter, rounded), and a tenth of them matched to look-alikes facing 90° or 180° off
    for seed in range(4):
        truth, sources, targets, link_poses, odometry, twins = _two_laps(seed)
        rng = np.random.default_rng(50 + seed)
        second = np.arange(len(twins)) + len(twins)
        offsets = wrap(truth[second, 3] - truth[twins, 3])
        facings = np.round((offsets + rng.normal(0.0, math.radians(1.0), len(twins))) / COLUMN) * COLUMN
        wrong = rng.random(len(twins)) < 0.1
        facings[wrong] += rng.choice([math.pi / 2, math.pi, -math.pi / 2], wrong.sum())
        views = ViewHeadingTerms(twins, second, facings, 0.05, COLUMN)
        alone = _solve(odometry.copy(), sources, targets, link_poses)
        held = _solve(odometry.copy(), sources, targets, link_poses, views)
        before = np.abs(wrap(alone[second, 3] - truth[second, 3]))
        after = np.abs(wrap(held[second, 3] - truth[second, 3]))
        assert np.median(before) > math.radians(10.0), np.degrees(np.median(before))  # 18–25° measured
        # the twins' headings are the first lap's (within its own small drift), so the second lap's: measured
        # 0.35–1.2° in the median over these draws; the positions 0.38–0.85 m against 4.2–5.5 m
        assert np.median(after) < math.radians(2.0), (seed, np.degrees(np.median(after)))
        assert np.sqrt(np.mean(np.sum((held[:, :2] - truth[:, :2]) ** 2, axis=1))) < 0.3 * np.sqrt(
            np.mean(np.sum((alone[:, :2] - truth[:, :2]) ** 2, axis=1)))


def test_without_views_the_solve_is_the_links_alone():
    _truth, sources, targets, link_poses, odometry, _twins = _two_laps(0, steps=40)
    weights = np.ones(len(sources))
    plain, settled = solve_least_squares(odometry.copy(), sources, targets, link_poses, weights)
    empty = ViewHeadingTerms(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0), 0.05, COLUMN)
    again, settled_again = solve_least_squares(odometry.copy(), sources, targets, link_poses, weights, None, None,
                                               empty)
    assert np.array_equal(plain, again) and settled == settled_again


def _map(**settings) -> ExperienceMap:
    return ExperienceMap(ExperienceMapConfig(threshold=0.5, confirmation_age=30.0, **settings))


def test_an_experience_keeps_its_views_yaw_and_observes_where_the_view_was_learned():
    themap = _map(view_heading_weight=0.05)
    themap.update(0, np.zeros(3), np.zeros(2), 0.0)  # view 0 learned here
    themap.integrate(2.0, 0.0, 0.0)
    themap.update(1, np.array([2.0, 0, 0]), np.zeros(2), 1.0)  # view 1 learned here
    for k, (view, yaw, difference, time) in enumerate([
            (0, 0.1, 0.05, 10.0),  # seen again too soon (the same view a moment later)
            (0, 0.2, 0.10, 40.0),  # seen again: observes experience 0
            (1, -0.1, 0.20, 50.0),  # matched too loosely
            (1, math.nan, 0.05, 60.0),  # the match did not pin the yaw
            (1, 0.3, 0.05, 70.0)]):  # observes experience 1
        themap.integrate(2.0, 0.0, 0.0)
        themap.update(view, np.array([4.0 + 2 * k, 0, 0]), np.zeros(2), time, view_yaw=yaw,
                      view_difference=difference)
    assert themap.size == 7
    assert themap.view_yaws[[0, 1, 3]].tolist() == [0.0, 0.0, 0.2] and math.isnan(themap.view_yaws[5])
    sources, targets, facings = themap.view_headings()
    assert sources.tolist() == [0, 1] and targets.tolist() == [3, 6] and facings.tolist() == pytest.approx([0.2, 0.3])
    # a map saved before eq. M6 loads, with no view's heading
    state = themap.state_dict()
    del state["view_yaws"], state["view_differences"]
    loaded = _map(view_heading_weight=0.05)
    loaded.load_state_dict(state)
    assert np.isnan(loaded.view_yaws).all() and loaded.view_headings()[0].size == 0


@pytest.mark.parametrize("panoramic", [False, True])
def test_a_blank_template_pins_no_column_shift(panoramic):
    cells = LocalViewCells(panoramic=panoramic)
    rng = np.random.default_rng(0)
    # random 8 × 8 pixel blocks (per-pixel random values would be read as the sensor's noise, eq. V2)
    textured = cells.thumbnail(np.kron(rng.random((15, 20)), np.ones((8, 8))).astype(np.float32))
    blank = cells.thumbnail(np.full((120, 160), 0.5, dtype=np.float32))
    cells.add(textured)
    cells.add(blank)
    contrast = cells.column_contrasts
    assert contrast[0] > 0.5 and contrast[1] == 0.0
    # derived, not saved: a loaded set has the same
    again = LocalViewCells(panoramic=panoramic)
    again.load_state_dict(cells.state_dict())
    assert np.array_equal(again.column_contrasts, contrast)


@pytest.mark.parametrize("field, value", [("view_heading_weight", -0.1), ("view_heading_tolerance", 0.0),
                                          ("view_heading_difference", math.nan)])
def test_bad_view_heading_settings_name_the_field(field, value):
    with pytest.raises(InvalidParameterError, match=f"experience_map.{field}"):
        ExperienceMapConfig(**{field: value})
