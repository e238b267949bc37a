"""The drivable surface of a world, found from its geometry: a graph for shortest paths across levels.

Nothing is written by hand per world. Over a grid of cells (``cell`` metres) covering the world, rays
cast straight down from just above each floor level find every surface under each cell (floors, ramps,
decks; a cell under a deck has one surface per level). Geometry that collides with nothing (decals, the
land around an open deck) is neither surface nor obstacle. A surface is a node when the robot fits there:
no geometry within ``clearance`` metres of it horizontally, in eight directions, at 0.3 m above the
surface (walls, pillars, parked cars), and none within ``headroom`` metres above it. Nodes of
neighbouring cells (eight-connected) are joined when their heights differ by at most ``step_height``
(a ramp's slope; a drop-off at a deck's edge is not joined). The largest connected part is the drivable
area; ramps join its levels. Edge weights are the 3-D distances, so shortest paths are ramp-aware;
a planned path (:meth:`DrivableGraph.shortest_path`) also keeps away from obstacles where it can: each
edge costs its length times 1 + 2 × (how far its nodes' free radius falls short of ``comfort``) / comfort.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from .world import World

__all__ = ["DrivableGraph"]

_NEIGHBOURS = [(1, 0), (0, 1), (1, 1), (1, -1)]  # half of the eight: each edge once
_SOLID_GROUPS = np.array([1, 1, 1, 1, 1, 0], dtype=np.uint8)  # every geom group but 5: see DrivableGraph
_DIRECTIONS = [(math.cos(a), math.sin(a), 0.0) for a in np.linspace(0, 2 * math.pi, 8, endpoint=False)]


def _static_model(world: World) -> mujoco.MjModel:
    if world.xml is not None:
        return mujoco.MjModel.from_xml_string(world.xml)
    return mujoco.MjModel.from_xml_path(str(world.path))


class DrivableGraph:
    """The drivable surface of ``world`` as a graph (see the module's description).

    Args:
        world: a loaded world (:func:`sim.world.load_world`).
        cell: grid spacing, m. clearance: free radius around the robot's centre, m.
        step_height: largest height difference between neighbouring cells, m. headroom: free height, m.

    Attributes:
        points: (N, 3) node positions on the surface, m. adjacency: sparse (N, N) edge lengths, m.
        levels: (N,) the level index of each node's height (ramps: the nearest level).
        free_radius: (N,) distance to the nearest obstacle around each node (at most ``comfort``), m.
    """

    def __init__(self, world: World, *, cell: float = 0.5, clearance: float = 0.45, step_height: float = 0.15,
                 headroom: float = 0.9, comfort: float = 1.5):
        model = _static_model(world)
        # geometry that collides with nothing (decals, ceilings' undersides, the land an open deck overlooks)
        # is neither a surface to drive on nor an obstacle: the rays skip it (group 5 of this private copy)
        solid = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
        model.geom_group[~solid] = 5
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        reach = data.geom_xpos[solid, :2]
        radius = model.geom_rbound[solid, None]
        low, high = (reach - radius).min(axis=0), (reach + radius).max(axis=0)
        xs = np.arange(low[0] + cell / 2, high[0], cell)
        ys = np.arange(low[1] + cell / 2, high[1], cell)
        geom = np.zeros(1, dtype=np.int32)
        down, up = np.array([0.0, 0.0, -1.0]), np.array([0.0, 0.0, 1.0])

        def ray(start, direction) -> float:
            return mujoco.mj_ray(model, data, np.asarray(start, dtype=float), np.asarray(direction, dtype=float),
                                 _SOLID_GROUPS, 1, -1, geom)

        nodes: dict[tuple[int, int], list[float]] = {}
        free_radius: dict[tuple[int, int, float], float] = {}
        for i, x in enumerate(xs):
            for j, y in enumerate(ys):
                heights: list[float] = []
                for level in world.levels:
                    start = level + 1.2
                    distance = ray((x, y, start), down)
                    if distance < 0:
                        continue
                    height = start - distance
                    if all(abs(height - other) > 0.05 for other in heights):
                        heights.append(height)
                free = []
                for height in heights:
                    above = ray((x, y, height + 0.02), up)
                    if 0 <= above < headroom:
                        continue
                    centre = (x, y, height + 0.3)
                    distances = [ray(centre, direction) for direction in _DIRECTIONS]
                    radius = min([d for d in distances if d >= 0] or [comfort])
                    if radius < clearance:
                        continue
                    free.append(height)
                    free_radius[(i, j, height)] = min(radius, comfort)
                if free:
                    nodes[(i, j)] = free
        index: dict[tuple[int, int, int], int] = {}
        points, radii = [], []
        for (i, j), heights in nodes.items():
            for k, height in enumerate(heights):
                index[(i, j, k)] = len(points)
                points.append((xs[i], ys[j], height))
                radii.append(free_radius[(i, j, height)])
        points = np.array(points, dtype=float).reshape(-1, 3)
        radii = np.array(radii, dtype=float)
        rows, columns = [], []
        for (i, j), heights in nodes.items():
            for di, dj in _NEIGHBOURS:
                others = nodes.get((i + di, j + dj))
                if not others:
                    continue
                for k, height in enumerate(heights):
                    for m, other in enumerate(others):
                        if abs(height - other) <= step_height * (math.sqrt(2) if di and dj else 1.0):
                            rows.append(index[(i, j, k)])
                            columns.append(index[(i + di, j + dj, m)])
        rows, columns = np.array(rows, dtype=int), np.array(columns, dtype=int)
        weights = np.linalg.norm(points[rows] - points[columns], axis=1)
        shortfall = comfort - (radii[rows] + radii[columns]) / 2
        costs = weights * (1.0 + 2.0 * np.maximum(shortfall, 0.0) / comfort)
        adjacency = coo_matrix((weights, (rows, columns)), shape=(len(points),) * 2).tocsr()
        adjacency = adjacency + adjacency.T
        _, labels = connected_components(adjacency, directed=False)
        largest = np.bincount(labels).argmax() if len(points) else 0
        keep = np.flatnonzero(labels == largest)
        self.points = points[keep]
        self.free_radius = radii[keep]
        self.adjacency = adjacency[keep][:, keep].tocsr()
        cost_matrix = coo_matrix((costs, (rows, columns)), shape=(len(points),) * 2).tocsr()
        self._costs = (cost_matrix + cost_matrix.T)[keep][:, keep].tocsr()
        self.levels = np.asarray(world.level_of(self.points[:, 2]))
        self.cell = cell
        self._tree = cKDTree(self.points)

    def nearest(self, position: np.ndarray) -> int:
        """The node nearest to ``position`` (x, y, z; heights count, so the right level is found)."""
        return int(self._tree.query(np.asarray(position, dtype=float)[:3])[1])

    def distances_from(self, node: int) -> np.ndarray:
        """Shortest drivable distance from ``node`` to every node, m (inf where unreachable)."""
        return dijkstra(self.adjacency, directed=False, indices=node)

    def geodesic(self, start: np.ndarray, goal: np.ndarray) -> float:
        """The shortest drivable distance from ``start`` to ``goal`` (positions), m (inf if unreachable)."""
        return float(self.distances_from(self.nearest(start))[self.nearest(goal)])

    def shortest_path(self, start: np.ndarray, goal: np.ndarray) -> tuple[np.ndarray, float]:
        """A path to drive from ``start`` to ``goal`` (positions): the cheapest with the clearance costs (near
        the shortest, away from obstacles where it can): (K, 3) points and its length, m."""
        first, last = self.nearest(start), self.nearest(goal)
        costs, predecessors = dijkstra(self._costs, directed=False, indices=first, return_predecessors=True)
        if not np.isfinite(costs[last]):
            return np.zeros((0, 3)), math.inf
        path = [last]
        while path[-1] != first:
            path.append(int(predecessors[path[-1]]))
        points = self.points[path[::-1]]
        return points, float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
