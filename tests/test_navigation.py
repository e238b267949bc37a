"""The drivable graph comes from the world's geometry: it joins a generated world's levels over its ramps,
keeps clear of obstacles, and its shortest paths climb gently."""

import numpy as np
import pytest

import sim
from sim.navigation import DrivableGraph


@pytest.mark.parametrize("name", ["gen:2", "gen:4"])  # gen:4 has three levels
def test_the_graph_of_a_generated_world_connects_its_levels(name):
    world = sim.load_world(name)
    graph = DrivableGraph(world)
    assert set(np.unique(graph.levels)) == set(range(len(world.levels)))  # one connected part holds them all
    start = world.route().waypoints[0]
    top = graph.points[graph.levels == len(world.levels) - 1][0]
    path, length = graph.shortest_path(start, top)
    assert np.isfinite(length) and length >= np.linalg.norm(top - start)
    steps = np.diff(path, axis=0)
    slopes = np.abs(steps[:, 2]) / np.maximum(np.linalg.norm(steps[:, :2], axis=1), 1e-9)
    assert slopes.max() <= np.tan(np.radians(17))  # over the ramps (at most 12 degrees), never a drop-off


def test_the_graph_keeps_clear_of_walls_pillars_and_parked_cars():
    world = sim.load_world("carpark")
    graph = DrivableGraph(world)
    ground = graph.points[graph.levels == 0]
    for obstacle in ([0.0, 0.0], [-5.6, 10.1]):  # pillars, 0.3 m half-width: 0.45 m of clearance from the centre
        assert np.linalg.norm(ground[:, :2] - obstacle, axis=1).min() >= 0.45
    # the parked car at (-8.4, -7.9), about 4.5 m long along y and 1.8 m wide: no node on its footprint
    assert not np.any((np.abs(ground[:, 0] + 8.4) < 0.9) & (np.abs(ground[:, 1] + 7.9) < 2.2))
    assert np.abs(ground[:, 0]).max() <= 20 - 0.1 - 0.45 + 0.25  # inside the outer walls (half a cell)
    # the routes' waypoints are on the drivable area
    for point in world.route().waypoints:
        assert np.linalg.norm(graph.points[graph.nearest(point)] - point) < 0.5
