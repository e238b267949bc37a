"""The drivable surface of a world, found from its geometry: a graph for shortest paths across levels.

Nothing is written by hand per world. Over a grid of cells (``cell`` metres) covering the world, rays
cast straight down from just above each floor level find every surface under each cell (floors, ramps,
decks; a cell under a deck has one surface per level). Geometry that collides with nothing (decals, the
land around an open deck) is neither surface nor obstacle. A surface is a node when the robot fits there:
no geometry within ``clearance`` metres of it horizontally, in 24 directions (every 15°, so a post 8 cm
thick within 0.6 m falls on a ray), at 0.3 m above the
surface (walls, pillars, parked cars), and none within ``headroom`` metres above it. Nodes of
neighbouring cells (eight-connected; a diagonal only where both cells beside it are drivable too, so no edge
cuts an obstacle's corner) are joined when their heights differ by at most ``step_height``
(a ramp's slope; a drop-off at a deck's edge is not joined). The largest connected part is the drivable
area; ramps join its levels. Edge weights are the 3-D distances, so shortest paths are ramp-aware;
a planned path (:meth:`DrivableGraph.shortest_path`) also keeps away from obstacles where it can: each
edge costs its length times 1 + 2 × (how far its nodes' free radius falls short of ``comfort``) / comfort.

This one graph serves every navigation use: the environments draw starts and goals from its standing
places (:attr:`DrivableGraph.standing`) and pay their reward on its distances
(:meth:`DrivableGraph.distance_to`), the planner plans on it, and SPL's geodesic is measured on it.
:meth:`DrivableGraph.of` keeps one graph per world in the process (building one takes 0.3–1 s).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.sparse import coo_matrix, diags
from scipy.sparse.csgraph import connected_components, dijkstra
from scipy.spatial import cKDTree

from .world import World

__all__ = ["DrivableGraph"]

_GRAPHS: dict[tuple, DrivableGraph] = {}  # DrivableGraph.of's cache: one graph per world geometry
_GRAPHS_KEPT = 8

_NEIGHBOURS = [(1, 0), (0, 1), (1, 1), (1, -1)]  # half of the eight: each edge once
_SOLID_GROUPS = np.array([1, 1, 1, 1, 1, 0], dtype=np.uint8)  # every geom group but 5: see DrivableGraph
_DIRECTIONS = np.array([(math.cos(a), math.sin(a), 0.0) for a in np.linspace(0, 2 * math.pi, 24, endpoint=False)])


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
        directions = _DIRECTIONS.ravel().copy()
        hit_geoms = np.zeros(len(_DIRECTIONS), dtype=np.int32)
        hit_distances = np.zeros(len(_DIRECTIONS))

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
                    mujoco.mj_multiRay(model, data, np.array(centre), directions, _SOLID_GROUPS, 1, -1, hit_geoms,
                                       hit_distances, None, len(_DIRECTIONS), comfort)
                    hits = hit_distances[hit_distances >= 0]
                    radius = float(hits.min()) if hits.size else comfort
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
                        if abs(height - other) > step_height * (math.sqrt(2) if di and dj else 1.0):
                            continue
                        if di and dj and not all(  # a diagonal never cuts a corner: both cells beside it are free
                                any(abs(side - (height + other) / 2) <= step_height for side in nodes.get(cell, ()))
                                for cell in ((i + di, j), (i, j + dj))):
                            continue
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
        # standing places: flat (every neighbour at the same height: not on a ramp) with room to turn
        adjacency = self.adjacency.tocoo()
        rise = np.zeros(len(self.points))
        np.maximum.at(rise, adjacency.row, np.abs(self.points[adjacency.row, 2] - self.points[adjacency.col, 2]))
        flat = rise < 0.02
        roomy = flat & (self.free_radius >= 0.75)
        self.standing = np.flatnonzero(roomy if roomy.any() else flat)

    @classmethod
    def of(cls, world: World) -> DrivableGraph:
        """The graph of ``world`` with the default settings, built once per world geometry in this process
        (the environments, the planner and the scores share it)."""
        key = (world.name, str(world.path), hash(world.xml), tuple(world.levels))
        if key not in _GRAPHS:
            if len(_GRAPHS) >= _GRAPHS_KEPT:
                _GRAPHS.pop(next(iter(_GRAPHS)))
            _GRAPHS[key] = cls(world)
        return _GRAPHS[key]

    def nearest(self, position: np.ndarray) -> int:
        """The node nearest to ``position`` (x, y, z; heights count, so the right level is found)."""
        return int(self._tree.query(np.asarray(position, dtype=float)[:3])[1])

    def distances_from(self, node: int) -> np.ndarray:
        """Shortest drivable distance from ``node`` to every node, m (inf where unreachable)."""
        return dijkstra(self.adjacency, directed=False, indices=node)

    def joins(self, position: np.ndarray, *, reach: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
        """Where a robot at ``position`` (x, y, z) joins the graph: the nodes within ``reach`` metres
        horizontally on its own level (less than 0.5 m higher or lower) and their horizontal distances, m.
        Empty arrays when the position is off the drivable area."""
        position = np.asarray(position, dtype=float)[:3]
        gaps, nodes = self._tree.query(position, k=min(32, len(self.points)), distance_upper_bound=reach + 0.5)
        found = np.isfinite(gaps)
        nodes = nodes[found]
        horizontal = np.linalg.norm(self.points[nodes, :2] - position[:2], axis=1)
        usable = (horizontal <= reach) & (np.abs(self.points[nodes, 2] - position[2]) < 0.5)
        return nodes[usable], horizontal[usable]

    def distance_to(self, field: np.ndarray, position: np.ndarray, *, reach: float = 1.0) -> float:
        """The drivable distance from ``position`` given a field of node distances (:meth:`distances_from`
        of the target's node), m: the straight line to a node within ``reach`` on the same level, then the
        graph, whichever node gives the least. A position off the drivable area (a robot pushed into a
        corner) joins at its nearest node."""
        nodes, gaps = self.joins(position, reach=reach)
        if len(nodes) == 0:
            node = self.nearest(position)
            return float(np.linalg.norm(self.points[node] - np.asarray(position, dtype=float)[:3]) + field[node])
        return float(np.min(gaps + field[nodes]))

    def goal_field(self, goal: np.ndarray, *, reach: float = 1.0) -> np.ndarray:
        """Every node's drivable distance to within ``reach`` metres of ``goal`` (x, y, z), m: the distance
        to whichever node near the goal is closest, plus that node's horizontal gap to the goal. All inf when
        the goal is unreachable (no drivable node within ``reach`` of it on its level)."""
        nodes, gaps = self.joins(goal, reach=reach)
        if len(nodes) == 0:
            return np.full(len(self.points), np.inf)
        distances = dijkstra(self.adjacency, directed=False, indices=nodes)
        return np.min(distances + gaps[:, None], axis=0)

    def geodesic(self, start: np.ndarray, goal: np.ndarray) -> float:
        """The shortest drivable distance from ``start`` to ``goal`` (positions), m (inf if unreachable)."""
        return self.distance_to(self.goal_field(goal), start)

    def shortest_path(self, start: np.ndarray, goal: np.ndarray, *,
                      avoid: np.ndarray | None = None, avoid_radius: float = 0.5) -> tuple[np.ndarray, float]:
        """A path to drive from ``start`` to ``goal`` (positions): the cheapest with the clearance costs (near
        the shortest, away from obstacles where it can): (K, 3) points and its length, m (an empty path and
        inf where none exists).

        ``avoid``: (M, 3) points (m) the path must keep ``avoid_radius`` metres from horizontally, on their
        level (less than 0.5 m higher or lower): obstacles the graph does not hold, such as what a robot's
        bumper found. The nodes nearest ``start`` and ``goal`` are never avoided."""
        first, last = self.nearest(start), self.nearest(goal)
        graph = self._costs
        if avoid is not None and len(avoid):
            avoid = np.asarray(avoid, dtype=float).reshape(-1, 3)
            near = self._tree.query_ball_point(avoid, avoid_radius + 0.5)
            blocked = {int(node) for point, nodes in zip(avoid, near, strict=True) for node in nodes
                       if np.linalg.norm(self.points[node, :2] - point[:2]) <= avoid_radius
                       and abs(self.points[node, 2] - point[2]) < 0.5} - {first, last}
            if blocked:
                keep = np.ones(len(self.points))
                keep[list(blocked)] = 0.0
                mask = diags(keep)
                graph = (mask @ graph @ mask).tocsr()
                graph.eliminate_zeros()
        costs, predecessors = dijkstra(graph, directed=False, indices=first, return_predecessors=True)
        if not np.isfinite(costs[last]):
            return np.zeros((0, 3)), math.inf
        path = [last]
        while path[-1] != first:
            path.append(int(predecessors[path[-1]]))
        points = self.points[path[::-1]]
        return points, float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
