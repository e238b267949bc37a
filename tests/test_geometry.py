"""The 4-DoF pose algebra (neuroslam.geometry): group laws as properties, and exact examples."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from neuroslam.geometry import compose, inverse, relative, wrap

coordinate = st.floats(-1e3, 1e3, allow_nan=False)
angle = st.floats(-20.0, 20.0, allow_nan=False)
pose = st.tuples(coordinate, coordinate, coordinate, angle).map(np.array)
poses = st.integers(1, 6).flatmap(lambda n: st.lists(pose, min_size=n, max_size=n).map(np.array))

# positions up to 1e3 m composed twice: float64 rounding stays far below a micrometre
METRES = 1e-6
RADIANS = 1e-9


def assert_same_pose(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_allclose(a[..., :3], b[..., :3], atol=METRES)
    assert np.all(np.abs(wrap(a[..., 3] - b[..., 3])) <= RADIANS)


def test_exact_examples() -> None:
    quarter = math.pi / 2
    np.testing.assert_allclose(compose(np.array([1.0, 2.0, 3.0, quarter]), np.array([1.0, 0.0, 0.5, quarter])),
                               [1.0, 3.0, 3.5, -math.pi], atol=1e-15)  # pi wraps to -pi
    # at (1, 0) facing +y the origin is 1 m to the left
    np.testing.assert_allclose(inverse(np.array([1.0, 0.0, 0.0, quarter])), [0.0, 1.0, 0.0, -quarter], atol=1e-15)
    np.testing.assert_allclose(relative(np.array([1.0, 1.0, 0.0, quarter]), np.array([1.0, 3.0, -1.0, 0.0])),
                               [2.0, 0.0, -1.0, -quarter], atol=1e-15)
    assert wrap(math.pi) == -math.pi and wrap(-math.pi) == -math.pi and wrap(0.25) == 0.25
    assert isinstance(wrap(7.0), float)
    np.testing.assert_allclose(wrap(np.array([3 * math.pi, -3 * math.pi + 0.5])), [-math.pi, -math.pi + 0.5])


@given(angle)
def test_wrap_lands_in_range_on_the_same_angle(value: float) -> None:
    wrapped = wrap(value)
    assert -math.pi <= wrapped < math.pi
    assert math.isclose(math.cos(wrapped), math.cos(value), abs_tol=1e-12)
    assert math.isclose(math.sin(wrapped), math.sin(value), abs_tol=1e-12)


@given(pose)
def test_inverse_undoes_a_pose(a: np.ndarray) -> None:
    assert_same_pose(compose(a, inverse(a)), np.zeros(4))
    assert_same_pose(compose(inverse(a), a), np.zeros(4))


@given(pose, pose, pose)
def test_composition_is_associative(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> None:
    assert_same_pose(compose(compose(a, b), c), compose(a, compose(b, c)))


@given(pose, pose)
def test_relative_is_what_composes_onto_the_pose(a: np.ndarray, c: np.ndarray) -> None:
    assert_same_pose(compose(a, relative(a, c)), c)
    assert_same_pose(relative(a, c), compose(inverse(a), c))


@given(pose, pose)
def test_composition_keeps_distances_and_heights(a: np.ndarray, b: np.ndarray) -> None:
    moved = compose(a, b)
    assert math.isclose(math.hypot(*(moved[:2] - a[:2])), math.hypot(*b[:2]), rel_tol=1e-12, abs_tol=METRES)
    assert math.isclose(moved[2], a[2] + b[2], abs_tol=METRES)


@given(poses, poses)
def test_many_poses_at_once_match_one_at_a_time(first: np.ndarray, second: np.ndarray) -> None:
    second = second[: len(first)]
    first = first[: len(second)]
    for batch, single in ((compose, compose), (relative, relative)):
        together = batch(first, second)
        assert together.shape == first.shape
        for row, (a, b) in enumerate(zip(first, second, strict=True)):
            assert_same_pose(together[row], single(a, b))
    np.testing.assert_allclose(inverse(first), np.array([inverse(a) for a in first]), atol=METRES)
    # one pose against many broadcasts
    assert_same_pose(compose(first[0], second), np.array([compose(first[0], b) for b in second]))


@given(arrays(float, (3, 4), elements=st.floats(-50, 50)))
def test_stacked_shapes_broadcast(stack: np.ndarray) -> None:
    grid = np.broadcast_to(stack, (2, 3, 4))
    assert compose(grid, stack).shape == (2, 3, 4)
    assert relative(stack[None], grid).shape == (2, 3, 4)
    assert inverse(grid).shape == (2, 3, 4)
