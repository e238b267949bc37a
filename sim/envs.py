"""Gymnasium environments: free driving and point-goal navigation in the multi-level worlds.

Both are registered on ``import sim`` as ``NeuroSLAM/Drive-v0`` and ``NeuroSLAM/PointNav-v0``. The
MuJoCo renderer is created on the first observation, never in ``__init__``, so vector environments work;
use ``context="spawn"`` or ``"forkserver"`` for :class:`gymnasium.vector.AsyncVectorEnv` (a GL context
must not cross a fork).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, ClassVar

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree

from .errors import InvalidParameterError
from .robot import CameraConfig, RobotConfig
from .simulation import OdometryNoise, Quality, Simulation
from .world import World, load_world

__all__ = ["DriveEnv", "PointNavEnv", "RouteGraph"]


class RouteGraph:
    """The drivable network of a world: every route densely sampled, nearby samples joined.

    Nodes are points every ``spacing`` metres along all routes; edges join consecutive samples and any
    two samples closer than ``join`` metres (where routes overlap or cross, or lanes run side by side;
    the builders keep lanes on either side of a wall at least 2.8 m apart). Ramps are part of the routes,
    so shortest paths between levels go over them. Distances are metres, 3-D.
    """

    def __init__(self, world: World, *, spacing: float = 0.5, join: float = 1.5):
        self.join = join
        points, rows, columns = [], [], []
        offset = 0
        for route in world.routes.values():
            count = max(2, math.ceil(route.length / spacing) + (0 if route.loop else 1))
            distances = np.linspace(0.0, route.length, count, endpoint=not route.loop)
            samples = route.point_at(distances)
            points.append(samples)
            index = np.arange(offset, offset + count)
            rows.append(index[:-1])
            columns.append(index[1:])
            if route.loop:
                rows.append(index[-1:])
                columns.append(index[:1])
            offset += count
        self.points = np.vstack(points)
        self.tree = cKDTree(self.points)
        near = np.array(sorted(self.tree.query_pairs(join)), dtype=int).reshape(-1, 2)
        i = np.concatenate([*rows, near[:, 0]])
        j = np.concatenate([*columns, near[:, 1]])
        weights = np.linalg.norm(self.points[i] - self.points[j], axis=1) + 1e-9
        self.adjacency = coo_matrix((weights, (i, j)), shape=(len(self.points),) * 2).tocsr()

    def distances_from(self, node: int) -> np.ndarray:
        """Shortest drivable distance from ``node`` to every node, m."""
        return dijkstra(self.adjacency, directed=False, indices=node)

    def nearest(self, position: np.ndarray) -> int:
        """Index of the node nearest to ``position`` (3-D)."""
        return int(self.tree.query(position)[1])

    def distance_to(self, field: np.ndarray, position: np.ndarray, *, candidates: int = 16) -> float:
        """Drivable distance from ``position`` given a field of node distances (from :meth:`distances_from`).

        The robot joins the network at whichever node within ``join`` metres on its own level (less than
        0.5 m higher or lower) gives the shortest total: straight line to the node, then the network.
        A robot farther from the network joins it at the nearest node.
        """
        gaps, nodes = self.tree.query(position, k=min(candidates, len(self.points)))
        usable = (gaps <= self.join) & (np.abs(self.points[nodes, 2] - position[2]) < 0.5)
        if not usable.any():
            return float(gaps[0] + field[nodes[0]])
        return float(np.min(gaps[usable] + field[nodes[usable]]))


def _finite_vector(value: Any, size: int, field: str, reason: str) -> np.ndarray:
    """``value`` as ``size`` finite floats, or InvalidParameterError naming ``field``."""
    shown = value.tolist() if isinstance(value, np.ndarray) else value  # an array's repr spans lines
    try:
        vector = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InvalidParameterError(field, shown, reason) from None
    if vector.shape != (size,) or not np.all(np.isfinite(vector)):
        raise InvalidParameterError(field, shown, reason)
    return vector


class DriveEnv(gym.Env):
    """## Description
    A differential-drive robot with a forward camera drives freely in a multi-level MuJoCo world
    (floors joined by ramps) under real physics. It is the raw material for SLAM and navigation
    experiments: the observation holds only what a robot senses; the truth is in ``info``.

    ## Action Space
    ``Box(2,)`` float32: forward speed in m/s within ±``robot.max_forward_speed`` (2 m/s) and yaw rate in
    rad/s (counter-clockwise positive) within ±``robot.max_yaw_rate`` (2 rad/s). Out-of-range actions are
    clipped; NaN or infinite actions raise :class:`~sim.errors.InvalidParameterError`. Each action is held
    for one camera frame (``1 / frame_rate`` s) and reached within the robot's acceleration limits.

    ## Observation Space
    ``Dict``: ``image``, ``Box(0, 255, (height, width, 3), uint8)`` RGB from the robot's camera;
    ``odometry``, ``Box(2,)`` float32: forward speed (m/s) and yaw rate (rad/s) measured by the wheel
    encoders over the last frame, with the configured noise.

    ## Rewards
    None: free driving returns 0.0 every step (use a wrapper for a task of your own).

    ## Starting State
    At rest on a floor point of the route (not on a ramp) drawn uniformly along it from the ``reset``
    seed, facing along the route. ``options={"start": [x, y, z, yaw]}`` sets it explicitly (z is the floor
    height there).

    ## Episode End
    ``terminated`` when the robot tips over (roll or pitch beyond 45 degrees); ``truncated`` by the time
    limit of the registration (1000 steps = 100 s at 10 Hz).

    ## Info
    ``pose`` (x, y, z, yaw), ``quaternion`` (w, x, y, z), ``level``, ``time`` (s), ``odometry_pose``
    (x, y, yaw from the wheel encoders, odometry frame = start pose), ``collisions`` (frames this episode
    with the chassis touching the world).

    ## Arguments
    ``world`` (built-in name, ``gen:SEED``, MJCF path or :class:`~sim.world.World`), ``route`` (name),
    ``camera`` (:class:`~sim.robot.CameraConfig`), ``robot`` (:class:`~sim.robot.RobotConfig`),
    ``noise`` (:class:`~sim.simulation.OdometryNoise`), ``quality`` (``fast`` or ``high``), ``frame_rate``
    (Hz), ``render_mode`` (``rgb_array`` or None).

    ## Version History
    * v0: initial version.
    """

    metadata: ClassVar[dict[str, Any]] = {"render_modes": ["rgb_array"], "render_fps": 10}
    reset_options: ClassVar[tuple[str, ...]] = ("start",)  # the keys ``reset(options=...)`` accepts

    def __init__(
        self,
        world: World | str | Path = "carpark",
        *,
        route: str | None = None,
        camera: CameraConfig = CameraConfig(),
        robot: RobotConfig = RobotConfig(),
        noise: OdometryNoise = OdometryNoise(),
        quality: Quality = "fast",
        frame_rate: float = 10.0,
        render_mode: str | None = None,
    ):
        if render_mode not in (None, "rgb_array"):
            raise InvalidParameterError("render_mode", render_mode, "must be None or 'rgb_array'")
        if not isinstance(frame_rate, (int, float)) or not 0.5 <= frame_rate <= 100:
            raise InvalidParameterError("frame_rate", frame_rate, "must be between 0.5 and 100 Hz")
        self.world = world if isinstance(world, World) else load_world(world)
        self.route = self.world.route(route)
        self.render_mode = render_mode
        self.frame_period = 1.0 / frame_rate
        self.metadata = {**self.metadata, "render_fps": frame_rate}
        self.simulation = Simulation(self.world, robot=robot, camera=camera, noise=noise, quality=quality)
        self.simulation.check_route(self.route)  # RouteError for a waypoint off every floor
        limits = np.array([robot.max_forward_speed, robot.max_yaw_rate], dtype=np.float32)
        self.action_space = spaces.Box(-limits, limits, dtype=np.float32)
        self.observation_space = spaces.Dict(self._observation_spaces(camera, limits))
        model = self.simulation.model
        robot_body = model.body("robot/").id
        self._chassis = model.geom("robot/chassis").id
        self._robot_geoms = np.flatnonzero(model.body_rootid[model.geom_bodyid] == robot_body)
        self._collisions = 0

    def _observation_spaces(self, camera: CameraConfig, limits: np.ndarray) -> dict[str, spaces.Space]:
        return {
            "image": spaces.Box(0, 255, (camera.height, camera.width, 3), dtype=np.uint8),
            "odometry": spaces.Box(-3 * limits, 3 * limits, dtype=np.float32),
        }

    # gymnasium API -------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        # every option is checked before anything changes: a refused reset leaves the episode as it was
        if options is not None and not isinstance(options, dict):
            raise InvalidParameterError("options", options, "must be a dict (or None)")
        options = dict(options or {})
        unknown = sorted(set(options) - set(self.reset_options))
        if unknown:
            raise InvalidParameterError("options", unknown, f"unknown reset options for {type(self).__name__} "
                                        f"(known: {', '.join(self.reset_options)})")
        start = options.pop("start", None)
        if start is not None:
            start = _finite_vector(start, 4, "options.start", "must be [x, y, z, yaw] in metres and radians")
        self._check_reset_options(options)
        super().reset(seed=seed)
        self._reset_task(options)
        if start is None:
            start = self._sample_start()
        self.simulation.reset(tuple(float(v) for v in start), seed=int(self.np_random.integers(2**31)))
        self._collisions = 0
        self._after_reset()
        return self._observation(), self._info()

    def step(self, action):
        given = action.tolist() if isinstance(action, np.ndarray) else action
        try:
            action = np.asarray(action, dtype=float)
        except (TypeError, ValueError):
            raise InvalidParameterError("action", given, "must be two numbers (forward speed, yaw rate)") from None
        if action.shape != (2,) or given is None:
            raise InvalidParameterError("action", given, "must be (forward speed, yaw rate)")
        if not np.all(np.isfinite(action)):
            raise InvalidParameterError("action", given, "must be finite (NaN or infinity given)")
        # out-of-range actions are clipped to the action space (the robot's limits), as documented
        action = np.clip(action, self.action_space.low, self.action_space.high)
        self.simulation.set_command(float(action[0]), float(action[1]))
        self.simulation.step(self.frame_period)
        if self._chassis_touching():
            self._collisions += 1
        truth = self.simulation.ground_truth()
        _w, x, y, _z = truth.quaternion
        tipped = (1 - 2 * (x * x + y * y)) < math.cos(math.radians(45))  # body z-axis tilted > 45 degrees
        reward, terminated = self._reward_and_termination(truth)
        observation, info = self._observation(), self._info()
        return observation, float(reward), bool(terminated or tipped), False, info

    def render(self):
        if self.render_mode == "rgb_array":
            return self.simulation.render()
        return None

    def close(self):
        self.simulation.close()

    # task hooks (overridden by PointNavEnv) ------------------------------------------------------------
    def _check_reset_options(self, options: dict[str, Any]) -> None:
        """Raise InvalidParameterError for a bad task option (before the reset changes anything)."""

    def _reset_task(self, options: dict[str, Any]) -> None:
        pass

    def _after_reset(self) -> None:
        pass

    def _reward_and_termination(self, truth) -> tuple[float, bool]:
        return 0.0, False

    def _sample_start(self) -> np.ndarray:
        distances = np.arange(0.0, self.route.length, 0.25)
        heights = self.route.point_at(distances)[:, 2]
        on_floor = np.abs(heights - np.asarray(self.world.levels)[self.world.level_of(heights)]) < 0.05
        distance = float(self.np_random.choice(distances[on_floor]))  # never on a ramp
        point = self.route.point_at(distance)
        ahead = self.route.point_at(distance + 0.5)
        return np.array([*point, math.atan2(ahead[1] - point[1], ahead[0] - point[0])])

    # helpers -------------------------------------------------------------------------------------------
    def _chassis_touching(self) -> bool:
        data = self.simulation.data
        if data.ncon == 0:
            return False
        pairs = np.stack([data.contact.geom1[: data.ncon], data.contact.geom2[: data.ncon]], axis=1)
        with_chassis = (pairs == self._chassis).any(axis=1)
        other = np.where(pairs[:, 0] == self._chassis, pairs[:, 1], pairs[:, 0])
        return bool(np.any(with_chassis & ~np.isin(other, self._robot_geoms)))

    def _observation(self) -> dict[str, np.ndarray]:
        odometry = self.simulation.wheel_odometry()
        return {
            "image": self.simulation.render(),
            "odometry": np.clip(np.array([odometry.forward_speed, odometry.yaw_rate], dtype=np.float32),
                                self.observation_space["odometry"].low, self.observation_space["odometry"].high),
        }

    def _info(self) -> dict[str, Any]:
        truth = self.simulation.ground_truth()
        odometry = self.simulation.wheel_odometry()
        return {
            "pose": truth.pose,
            "quaternion": truth.quaternion,
            "level": int(truth.level),
            "time": self.simulation.time,
            "odometry_pose": np.array([odometry.x, odometry.y, odometry.yaw]),
            "collisions": int(self._collisions),
        }


class PointNavEnv(DriveEnv):
    """## Description
    Point-goal navigation across levels: drive to a goal that may be on another floor, reached over the
    ramps. With ``goal_sensor="gps"`` (the default), like Habitat's PointGoal with GPS+compass, the goal's
    position relative to the robot is observed every step; with ``goal_sensor="start"`` (Habitat's harder
    setting since 2020) only in the observation ``reset`` returns, and zeros afterwards, so the agent must
    track itself.

    ## Action Space
    As ``NeuroSLAM/Drive-v0``: (forward speed m/s, yaw rate rad/s), clipped to the robot's range.

    ## Observation Space
    ``Dict``: ``image`` and ``odometry`` as in ``NeuroSLAM/Drive-v0``, and ``goal``, ``Box(3,)`` float32:
    straight-line distance to the goal (m), its bearing from the robot's heading (rad, counter-clockwise
    positive, in [-pi, pi]) and its height above the robot (m).

    ## Rewards
    Progress along the drivable shortest path (metres of geodesic distance gained this step, on the
    world's route network including ramps), minus 0.01 per step, plus 2.5 on success.

    ## Starting State
    Start and goal are points of the world's route network on a floor (not on a ramp) drawn from the
    ``reset`` seed, with a drivable
    distance between ``min_goal_distance`` and ``max_goal_distance``; the robot faces along the route.
    ``options={"start": [x, y, z, yaw], "goal": [x, y, z]}`` sets either explicitly.

    ## Episode End
    ``terminated`` on success (within ``success_distance`` = 1 m of the goal) or when the robot tips over;
    ``truncated`` by the time limit (1500 steps = 150 s at 10 Hz).

    ## Info
    Everything ``NeuroSLAM/Drive-v0`` reports, plus ``goal`` (x, y, z), ``distance_to_goal`` (drivable,
    m), ``success`` (bool), ``spl`` (success weighted by path length: success × geodesic start distance /
    max(path driven, geodesic start distance)), ``path_length`` (m driven).

    ## Arguments
    As ``NeuroSLAM/Drive-v0``, plus ``success_distance``, ``min_goal_distance`` and ``max_goal_distance`` (m),
    and ``goal_sensor`` (``"gps"`` or ``"start"``).

    ## Version History
    * v0: initial version.
    """

    reset_options: ClassVar[tuple[str, ...]] = ("start", "goal")

    def __init__(
        self,
        world: World | str | Path = "carpark",
        *,
        success_distance: float = 1.0,
        min_goal_distance: float = 5.0,
        max_goal_distance: float = 60.0,
        goal_sensor: str = "gps",
        **kwargs: Any,
    ):
        if goal_sensor not in ("gps", "start"):
            raise InvalidParameterError("goal_sensor", goal_sensor, "must be 'gps' or 'start'")
        if not 0 < success_distance < min_goal_distance < max_goal_distance:
            raise InvalidParameterError(
                "goal distances", (success_distance, min_goal_distance, max_goal_distance),
                "need 0 < success_distance < min_goal_distance < max_goal_distance (m)",
            )
        super().__init__(world, **kwargs)
        self.success_distance = success_distance
        self.goal_sensor = goal_sensor
        self._goal_visible = True
        self.min_goal_distance = min_goal_distance
        self.max_goal_distance = max_goal_distance
        self.graph = RouteGraph(self.world)
        heights = self.graph.points[:, 2]
        levels = np.asarray(self.world.levels)[self.world.level_of(heights)]
        self._floor_nodes = np.flatnonzero(np.abs(heights - levels) < 0.05)  # starts and goals avoid ramps
        self.goal = np.zeros(3)
        self._goal_field = np.zeros(len(self.graph.points))

    def _observation_spaces(self, camera: CameraConfig, limits: np.ndarray) -> dict[str, spaces.Space]:
        bound = np.array([1e4, math.pi, 1e3], dtype=np.float32)
        return {**super()._observation_spaces(camera, limits), "goal": spaces.Box(
            np.array([0.0, -math.pi, -1e3], dtype=np.float32), bound, dtype=np.float32)}

    def _check_reset_options(self, options: dict[str, Any]) -> None:
        if options.get("goal") is not None:
            _finite_vector(options["goal"], 3, "options.goal", "must be [x, y, z] in metres")

    def _reset_task(self, options: dict[str, Any]) -> None:
        self._requested_goal = options.pop("goal", None)

    def _sample_start(self) -> np.ndarray:
        node = int(self.np_random.choice(self._floor_nodes))
        point = self.graph.points[node]
        neighbour = self.graph.points[(node + 1) % len(self.graph.points)]
        if np.linalg.norm(neighbour - point) > 1.0:  # the last sample of a route: look back instead
            neighbour = 2 * point - self.graph.points[node - 1]
        return np.array([*point, math.atan2(neighbour[1] - point[1], neighbour[0] - point[0])])

    def _after_reset(self) -> None:
        position = self.simulation.ground_truth().position
        if self._requested_goal is not None:
            self.goal = _finite_vector(self._requested_goal, 3, "options.goal", "must be [x, y, z] in metres")
        else:
            field = self.graph.distances_from(self.graph.nearest(position))
            candidates = field[self._floor_nodes]
            in_range = (candidates >= self.min_goal_distance) & (candidates <= self.max_goal_distance)
            eligible = self._floor_nodes[in_range]
            if eligible.size == 0:  # a small world: take the farthest floor point
                eligible = self._floor_nodes[[int(np.argmax(np.where(np.isfinite(candidates), candidates, -1)))]]
            self.goal = self.graph.points[int(self.np_random.choice(eligible))].copy()
        self._goal_field = self.graph.distances_from(self.graph.nearest(self.goal))
        self._distance = self.graph.distance_to(self._goal_field, position)
        self._start_distance = self._distance
        self._path_length = 0.0
        self._last_position = position
        self._success = False
        self._goal_visible = True  # the observation reset returns always shows the goal

    def _reward_and_termination(self, truth) -> tuple[float, bool]:
        position = truth.position
        self._path_length += float(np.linalg.norm(position - self._last_position))
        self._last_position = position
        distance = self.graph.distance_to(self._goal_field, position)
        self._success = float(np.linalg.norm(self.goal - position)) <= self.success_distance
        reward = (self._distance - distance) - 0.01 + (2.5 if self._success else 0.0)
        self._distance = distance
        return reward, self._success

    def _observation(self) -> dict[str, np.ndarray]:
        observation = super()._observation()
        truth = self.simulation.ground_truth()
        offset = self.goal - truth.position
        bearing = math.atan2(offset[1], offset[0]) - truth.yaw
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        observation["goal"] = np.array([np.linalg.norm(offset), bearing, offset[2]], dtype=np.float32)
        if not self._goal_visible:
            observation["goal"][:] = 0.0
        self._goal_visible = self.goal_sensor == "gps"
        return observation

    def _info(self) -> dict[str, Any]:
        info = super()._info()
        spl = float(self._success) * self._start_distance / max(self._path_length, self._start_distance, 1e-9)
        info.update(goal=self.goal.copy(), distance_to_goal=float(self._distance), success=bool(self._success),
                    spl=spl, path_length=float(self._path_length))
        return info
