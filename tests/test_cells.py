"""Grid and head-direction cells: a resting packet stays put, a moved packet reads out where it should."""

import math

import numpy as np
import pytest

from neuroslam.cells import AttractorNetwork, GridCells, HeadDirectionCells, gaussian_kernel
from neuroslam.config import GridCellConfig, HeadDirectionConfig


def wrapped_error(a, b, size):
    difference = (np.asarray(a) - np.asarray(b) + np.asarray(size) / 2) % np.asarray(size) - np.asarray(size) / 2
    return np.abs(difference).max()


def test_kernels_are_normalised_and_symmetric():
    kernel = gaussian_kernel(3, 7, 1.5)
    assert kernel.shape == (7, 7, 7)
    assert kernel.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(kernel, kernel[::-1, ::-1, ::-1])


@pytest.mark.parametrize("network", ["grid", "head_direction"])
def test_resting_packet_keeps_its_position_and_total_activity(network):
    cells = GridCells() if network == "grid" else HeadDirectionCells()
    start = cells.decode()
    for _ in range(500):
        cells.step((0.0, 0.0, 0.0)) if network == "grid" else cells.step(0.0, 0.0)
    assert wrapped_error(cells.decode(), start, cells.config.size) < 0.01
    assert cells.activity.sum() == pytest.approx(1.0, abs=1e-5)
    assert np.all(cells.activity >= 0)


@pytest.mark.parametrize("translation", [(2.5, -1.25, 0.7), (0.1, 0.0, 0.0), (7.3, 11.6, -4.2), (-30.4, 20.1, 35.5)])
def test_grid_packet_moves_by_a_translation_in_one_frame(translation):
    cells = GridCells()
    start = cells.decode()
    cells.step(translation)
    expected = start + np.asarray(translation) / np.asarray(cells.config.cell_size)
    assert wrapped_error(cells.decode(), expected, cells.config.size) < 0.05


def test_grid_packet_integrates_many_frames_across_the_wrap_around():
    cells = GridCells(GridCellConfig(cell_size=(0.5, 0.5, 0.25)))
    start = cells.decode()
    step = np.array([0.37, -0.11, 0.05])  # m per frame: 0.74, -0.22, 0.2 cells
    for _ in range(60):  # 44 cells along x: more than once around the 36-cell torus
        cells.step(step)
    expected = start + 60 * step / np.array([0.5, 0.5, 0.25])
    assert wrapped_error(cells.decode(), expected, cells.config.size) < 0.05


@pytest.mark.parametrize("config", [GridCellConfig(), GridCellConfig(size=(36, 36, 36), cell_size=(1.0, 1.0, 1.0))])
def test_slow_motion_is_not_pinned_to_the_lattice(config):
    """10 cm per frame (1 m/s at 10 Hz) is a small fraction of a cell; the packet must still move exactly."""
    cells = GridCells(config)
    start = cells.decode()
    for _ in range(70):
        cells.step((0.1, 0.0, 0.0))
    assert wrapped_error(cells.decode(), start + [7.0 / config.cell_size[0], 0, 0], cells.config.size) < 0.05


def test_head_direction_packet_follows_yaw_and_height():
    cells = HeadDirectionCells()
    for _ in range(9):
        cells.step(math.radians(40.0), 0.3)
    yaw, height = cells.decode()
    assert wrapped_error([yaw, height], [36.0, 2.7], cells.config.size) < 0.05  # 360 deg = 36 cells
    assert cells.yaw() == pytest.approx(0.0, abs=math.radians(0.5))
    cells.step(math.radians(-95.0), 0.0)
    assert cells.yaw() == pytest.approx(math.radians(-95.0), abs=math.radians(0.5))


def test_linear_shift_of_the_paper_is_available_and_moves_whole_cells_exactly():
    cells = GridCells(GridCellConfig(shift="linear", size=(36, 36, 36), cell_size=(1.0, 1.0, 1.0)))
    start = cells.decode()
    cells.step((3.0, -2.0, 5.0))
    assert wrapped_error(cells.decode(), start + [3, -2, 5], cells.config.size) < 0.01


def test_injected_energy_pulls_the_packet():
    network = AttractorNetwork((36, 36), excitation_width=9, excitation_variance=1.9, inhibition_width=5,
                               inhibition_variance=3.0, global_inhibition=2e-4, readout_radius=6, start=(10, 10))
    for _ in range(40):
        network.inject((14.0, 10.0), 0.2)
        network.normalise()
        network.step()
    assert wrapped_error(network.decode(), [14.0, 10.0], (36, 36)) < 0.5


def test_bad_network_parameters_name_the_field():
    from neuroslam.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="excitation_width"):
        HeadDirectionConfig(excitation_width=8)
    with pytest.raises(InvalidParameterError, match=r"grid_cells\.cell_size"):
        GridCellConfig(cell_size=(1.0, -1.0, 1.0))
