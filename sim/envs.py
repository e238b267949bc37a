"""Gymnasium environments: free driving and point-goal navigation in the multi-level worlds.

Both are registered on ``import sim`` as ``NeuroSLAM/Drive-v0`` and ``NeuroSLAM/PointNav-v1``. The
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

from .errors import InvalidParameterError
from .navigation import DrivableGraph
from .robot import CameraConfig, RobotConfig
from .simulation import OdometryNoise, Quality, Simulation
from .world import World, load_world

__all__ = ["DriveEnv", "PointNavEnv"]


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
        reward, terminated, truncated = self._task_step(truth, tipped)
        observation, info = self._observation(), self._info()
        return observation, float(reward), bool(terminated or tipped), bool(truncated and not tipped), info

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

    def _task_step(self, truth, tipped: bool) -> tuple[float, bool, bool]:
        """The task's reward, termination and truncation after a step (the robot's truth, whether it tipped)."""
        return 0.0, False, False

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
    setting since 2020) only when the goal is given (in the observation ``reset`` returns, and the one after
    a new goal of a sequence), zeros otherwise, so the agent must track itself.

    With ``goals=N`` (``NeuroSLAM/SequentialPointNav-v0``, default 50) the robot drives N goals in a row:
    when one ends, the next is drawn from wherever the robot is, and nothing is reset (not the pose, not the
    wheel odometry, not the clock), the long-horizon setting in which a robot's odometry drifts without bound.
    With ``patrol=K`` as well, the goals are a patrol's K places, visited in order round after round (goal
    ``i`` is place ``i mod K``): the places are drawn when the episode starts, the first from the start and
    each next from the one before, as a sequence's goals are; a round ends where it began. A patrol re-drives
    its routes in the same direction, the setting in which a robot can recognise the places it passed.

    Everything is measured on one graph, the drivable surface derived from the world's geometry
    (:class:`sim.navigation.DrivableGraph`, ramp-aware, decks and mezzanines included): start and goal
    sampling, the reward, the geodesic of SPL, and the planner of ``neuroslam nav``.

    ## Action Space
    As ``NeuroSLAM/Drive-v0``: (forward speed m/s, yaw rate rad/s), clipped to the robot's range.

    ## Observation Space
    ``Dict``: ``image`` and ``odometry`` as in ``NeuroSLAM/Drive-v0``; ``goal``, ``Box(3,)`` float32:
    straight-line distance to the goal (m), its bearing from the robot's heading (rad, counter-clockwise
    positive, in [-pi, pi]) and its height above the robot (m); ``bumper``, ``MultiBinary(1)``: 1 while the
    chassis touches the world (a mobile robot's bump switch; a robot that keeps pushing spins its wheels,
    and its wheel odometry runs on).

    ## Rewards
    Progress along the drivable shortest path (metres of geodesic distance gained this step), minus 0.01
    per step, plus 2.5 on reaching a goal. A new goal of a sequence starts from its own distance (no reward
    for the switch).

    ## Starting State
    The start is a standing place of the drivable graph (flat, not on a ramp, with room to turn) drawn
    from the ``reset`` seed, facing a direction drawn uniformly; the goal a standing place at a drivable
    distance between ``min_goal_distance`` and ``max_goal_distance`` (the farthest one in a smaller world).
    ``options={"start": [x, y, z, yaw], "goal": [x, y, z]}`` sets either explicitly; a given goal that no
    drivable path comes within ``success_distance`` of is reported (``info["goal_reachable"]`` False) and
    ends at the first step with the outcome ``unreachable``.

    ## Episode End
    A goal ends with an outcome (``info["goal_outcome"]``): ``success`` within ``success_distance`` = 1 m;
    ``stalled`` when the robot has stayed within ``stall_distance`` (0.25 m) of one point for
    ``stall_steps`` steps (100 = 10 s at 10 Hz: it is stuck or has given up); ``timeout`` after
    ``goal_steps`` steps on it (sequences only; default 1500); ``unreachable``; ``tipped`` (roll or pitch
    beyond 45 degrees). The episode ends with its last goal (``goals``), or at once when the robot tips:
    ``terminated`` when that goal was reached or the robot tipped, ``truncated`` otherwise (a stall is a
    failure but not a terminal state). The registration's time limit also truncates: 1500 steps for
    ``PointNav-v1``, none for ``SequentialPointNav-v0`` (its goals are bounded by ``goal_steps``).

    ## Info
    Everything ``NeuroSLAM/Drive-v0`` reports, plus ``goal`` (x, y, z), ``goal_index`` (0-based),
    ``goal_reachable``, ``geodesic`` (the drivable distance from where this goal was given, m),
    ``distance_to_goal`` (drivable, m), ``success`` (this goal reached), ``spl`` (success × geodesic /
    max(path driven, geodesic)), ``path_length`` (m driven toward this goal), ``goal_steps`` (steps on it),
    ``goal_finished`` and ``goal_outcome`` (empty while it runs). On the step a goal ends, these figures are
    that goal's final ones, and ``next_goal`` (x, y, z) gives the next goal of a sequence, which the
    observation already shows.

    ## Arguments
    As ``NeuroSLAM/Drive-v0``, plus ``success_distance``, ``min_goal_distance`` and ``max_goal_distance``
    (m), ``goal_sensor`` (``"gps"`` or ``"start"``), ``goals`` (goals per episode), ``goal_steps`` (steps
    per goal before ``timeout``; None for no limit), ``patrol`` (places in a patrol's round, at least 2;
    None: every goal drawn afresh), ``stall_steps`` (None: never stall) and ``stall_distance`` (m).

    ## Version History
    * v1: starts, goals, reward and SPL on the drivable graph derived from the geometry (v0 used the route
      network: two geodesics for one episode); stalls end an episode; sequences of goals; the start faces
      a random direction; a ``bumper`` observation; patrols (``patrol``). v0's scores are not comparable and
      it is no longer registered.
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
        goals: int = 1,
        goal_steps: int | None = 1500,
        patrol: int | None = None,
        stall_steps: int | None = 100,
        stall_distance: float = 0.25,
        **kwargs: Any,
    ):
        if goal_sensor not in ("gps", "start"):
            raise InvalidParameterError("goal_sensor", goal_sensor, "must be 'gps' or 'start'")
        if not 0 < success_distance < min_goal_distance < max_goal_distance:
            raise InvalidParameterError(
                "goal distances", (success_distance, min_goal_distance, max_goal_distance),
                "need 0 < success_distance < min_goal_distance < max_goal_distance (m)",
            )
        for field, value in (("goals", goals), ("goal_steps", goal_steps), ("stall_steps", stall_steps)):
            if value is not None and (not isinstance(value, (int, np.integer)) or isinstance(value, bool)
                                      or value < 1):
                raise InvalidParameterError(field, value, "must be a positive whole number"
                                            + ("" if field == "goals" else " (or None)"))
        if goals is None:
            raise InvalidParameterError("goals", goals, "must be a positive whole number")
        if patrol is not None and (not isinstance(patrol, (int, np.integer)) or isinstance(patrol, bool)
                                   or patrol < 2):
            raise InvalidParameterError("patrol", patrol, "must be a whole number of places >= 2 (or None)")
        if not isinstance(stall_distance, (int, float)) or not 0 < stall_distance < success_distance:
            raise InvalidParameterError("stall_distance", stall_distance, "must be between 0 and success_distance (m)")
        super().__init__(world, **kwargs)
        self.success_distance = success_distance
        self.goal_sensor = goal_sensor
        self.min_goal_distance = min_goal_distance
        self.max_goal_distance = max_goal_distance
        self.goals, self.goal_steps = int(goals), goal_steps
        self.patrol = None if patrol is None else int(patrol)
        self._places: list[np.ndarray] = []  # a patrol's places, in the order visited
        self.stall_steps, self.stall_distance = stall_steps, float(stall_distance)
        self.graph = DrivableGraph.of(self.world)
        self.goal = np.zeros(3)
        self._goal_visible = True
        self._goal_field = np.zeros(len(self.graph.points))
        self._goal_index = 0
        self._finished: dict[str, Any] | None = None  # the figures of a goal that ended this step

    def _observation_spaces(self, camera: CameraConfig, limits: np.ndarray) -> dict[str, spaces.Space]:
        bound = np.array([1e4, math.pi, 1e3], dtype=np.float32)
        return {**super()._observation_spaces(camera, limits), "goal": spaces.Box(
            np.array([0.0, -math.pi, -1e3], dtype=np.float32), bound, dtype=np.float32),
            "bumper": spaces.MultiBinary(1)}

    def _check_reset_options(self, options: dict[str, Any]) -> None:
        if options.get("goal") is not None:
            _finite_vector(options["goal"], 3, "options.goal", "must be [x, y, z] in metres")

    def _reset_task(self, options: dict[str, Any]) -> None:
        self._requested_goal = options.pop("goal", None)

    def _sample_start(self) -> np.ndarray:
        point = self.graph.points[int(self.np_random.choice(self.graph.standing))]
        return np.array([*point, float(self.np_random.uniform(-math.pi, math.pi))])

    def _after_reset(self) -> None:
        self._goal_index = 0
        self._finished = None
        requested = self._requested_goal
        first = None if requested is None else _finite_vector(requested, 3, "options.goal",
                                                               "must be [x, y, z] in metres")
        self._places = []
        if self.patrol is not None:  # the round's places: the first from the start, each next from the last
            self._places = [self._draw_goal(self.simulation.ground_truth().position) if first is None else first]
            while len(self._places) < self.patrol:
                self._places.append(self._draw_goal(self._places[-1]))
            first = self._places[0]
        self._begin_goal(first)

    def _draw_goal(self, position: np.ndarray) -> np.ndarray:
        """A standing place at a drivable distance from ``position`` between the goal distances (the
        farthest one in a smaller world), drawn with the episode's generator."""
        field = self.graph.distances_from(self.graph.nearest(position))
        candidates = field[self.graph.standing]
        in_range = (candidates >= self.min_goal_distance) & (candidates <= self.max_goal_distance)
        eligible = self.graph.standing[in_range]
        if eligible.size == 0:  # a small world (or a robot stuck off the graph): the farthest standing place
            eligible = self.graph.standing[[int(np.argmax(np.where(np.isfinite(candidates), candidates, -1)))]]
        return self.graph.points[int(self.np_random.choice(eligible))].copy()

    def _begin_goal(self, goal: np.ndarray | None) -> None:
        """Give the robot a goal (drawn from where it stands when ``goal`` is None) and start its scores."""
        position = self.simulation.ground_truth().position
        if goal is None:
            goal = self._draw_goal(position)
        self.goal = np.asarray(goal, dtype=float).copy()
        self._goal_field = self.graph.goal_field(self.goal, reach=self.success_distance)
        self._distance = self.graph.distance_to(self._goal_field, position)
        self._reachable = bool(np.isfinite(self._distance))
        self._start_distance = self._distance
        self._path_length = 0.0
        self._steps_on_goal = 0
        self._last_position = position
        self._stall_anchor, self._stall_since = position, 0
        self._success = False
        self._goal_visible = True  # the observation that follows shows the goal, whatever the sensor

    def _task_step(self, truth, tipped: bool) -> tuple[float, bool, bool]:
        position = truth.position
        self._steps_on_goal += 1
        self._path_length += float(np.linalg.norm(position - self._last_position))
        self._last_position = position
        if np.linalg.norm(position - self._stall_anchor) > self.stall_distance:
            self._stall_anchor, self._stall_since = position, self._steps_on_goal
        reward = -0.01
        if self._reachable:
            distance = self.graph.distance_to(self._goal_field, position)
            self._success = float(np.linalg.norm(self.goal - position)) <= self.success_distance
            reward += (self._distance - distance) + (2.5 if self._success else 0.0)
            self._distance = distance
        outcome = None
        if not self._reachable:
            outcome = "unreachable"
        elif self._success:
            outcome = "success"
        elif tipped:
            outcome = "tipped"
        elif self.stall_steps is not None and self._steps_on_goal - self._stall_since >= self.stall_steps:
            outcome = "stalled"
        elif self.goal_steps is not None and self.goals > 1 and self._steps_on_goal >= self.goal_steps:
            outcome = "timeout"
        self._finished = None
        if outcome is None:
            return reward, False, False
        self._finished = {**self._goal_report(), "goal_finished": True, "goal_outcome": outcome}
        success = self._success
        if tipped or self._goal_index + 1 >= self.goals:
            return reward, success, not success
        self._goal_index += 1  # the next goal (from where the robot is, or the patrol's next place)
        self._begin_goal(self._places[self._goal_index % len(self._places)] if self._places else None)
        self._finished["next_goal"] = self.goal.copy()
        return reward, False, False

    def _goal_report(self) -> dict[str, Any]:
        """The current goal's figures (see the Info section)."""
        spl = float(self._success) * self._start_distance / max(self._path_length, self._start_distance, 1e-9)
        return {"goal": self.goal.copy(), "goal_index": self._goal_index, "goal_reachable": self._reachable,
                "geodesic": float(self._start_distance), "distance_to_goal": float(self._distance),
                "success": bool(self._success), "spl": spl, "path_length": float(self._path_length),
                "goal_steps": self._steps_on_goal, "goal_finished": False, "goal_outcome": ""}

    def _observation(self) -> dict[str, np.ndarray]:
        observation = super()._observation()
        truth = self.simulation.ground_truth()
        offset = self.goal - truth.position
        bearing = math.atan2(offset[1], offset[0]) - truth.yaw
        bearing = (bearing + math.pi) % (2 * math.pi) - math.pi
        observation["goal"] = np.array([np.linalg.norm(offset), bearing, offset[2]], dtype=np.float32)
        observation["bumper"] = np.array([self._chassis_touching()], dtype=np.int8)
        if not self._goal_visible:
            observation["goal"][:] = 0.0
        self._goal_visible = self.goal_sensor == "gps"
        return observation

    def _info(self) -> dict[str, Any]:
        info = super()._info()
        info.update(self._finished if self._finished is not None else self._goal_report())
        return info
