"""Navigation experiments on ``NeuroSLAM/PointNav-v1`` and ``NeuroSLAM/SequentialPointNav-v0``
(``neuroslam nav``): agents, pose sources, scores.

Glue (it imports the simulator). An episode: the environment is reset with the episode's seed (so every
setting sees the same starts and goals), the agent is told its start pose in the world and the goal (in the
world: a patrol's goals are places, not readings relative to the robot), and then it acts until the
episode ends, localising itself with its pose source. In a sequence (``goals`` > 1) each next goal is
given where the last one ended, with the agent's own pose estimate as its start; nothing is reset.

Pose sources:

- ``groundtruth``: the simulator's pose (the upper bound);
- ``odometry``: the wheel encoders integrated from the start (they measure no height: the start's is kept);
- ``slam``: :class:`neuroslam.localisation.Localiser` on NeuroSLAM with the wheels' speed and turn rate
  and the camera's views and pitch (as ``neuroslam drive --odometry wheel``): the wheels' pose, corrected
  only where NeuroSLAM confirms a recognised place, with its uncertainty; with a loaded map of an earlier
  drive the session starts as an unknown start and the map's frame is aligned from recognitions;
- ``slam-camera``: the same with NeuroSLAM's visual odometry as the self-motion (no wheels).

The agent protocol (a user's agent plugs in as ``module:Class``)::

    class MyAgent:
        def __init__(self, world, graph, seed): ...      # sim World, sim.navigation.DrivableGraph, int
        def reset(self, start, goal): ...                # start (x, y, z, yaw): the pose source's at the
                                                         # goal's start; goal (x, y, z): world, m
        def act(self, observation, pose): ...            # pose: the pose source's (x, y, z, yaw) in the
                                                         # world; returns (forward speed m/s, yaw rate rad/s)

Scores per goal (one row of ``episodes.csv``): its outcome (``success``, ``stalled``, ``timeout``,
``unreachable``, ``tipped``: the environment's; ``not_given`` for the goals of a sequence that ended
first), success (within 1 m), SPL (success × geodesic / max(path driven, geodesic), the geodesic on the
environment's drivable graph), path length, geodesic, steps,
collisions, the localisation error when the goal ended (the pose source against the truth, 3-D, m) and
its height part, the pose source's own uncertainty then (1σ horizontal, m; 0 for ground truth, NaN where
a source gives none), the recognitions that corrected it during the goal (the localiser's; 0 for the
others), the distance driven since the episode began (m), and the wheels' error and its height part on the
same frames (:class:`WheelPose`, whatever the pose source: a comparison with the odometry that the runs'
diverging paths do not blur).
"""

from __future__ import annotations

import csv
import dataclasses
import importlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import geometry
from ..errors import InvalidParameterError
from ..localisation import LocalisationConfig, Localiser
from .frames import RolloutStream, SelfMotionSource

__all__ = ["POSE_SOURCES", "GoalResult", "PlannerAgent", "RandomAgent", "WheelPose", "load_agent", "run_episode",
           "summarise"]

POSE_SOURCES = ("groundtruth", "odometry", "slam", "slam-camera")
# m: a pose source is "not worse than the wheels" on a goal whose horizontal error is at most the wheels' on
# the same frames plus this. Without a correction the localiser's prediction and WheelPose agree within 1 cm
# over 130-220 m of driving (six traced sequences): they integrate the same encoders differently.
PAIRED_TOLERANCE = 0.1


def _planar(reading: np.ndarray) -> np.ndarray:
    x, y, yaw = np.asarray(reading, dtype=float)
    return np.array([x, y, 0.0, yaw])


class WheelPose:
    """The wheel encoders' pose in the world, step by step: their travel since the start applied to the
    ``start`` pose (x, y, z m, yaw rad; the wheels measure no height, so the start's is kept), leaving out
    the steps on which the bumper was closed. Then the chassis touches something and the wheels slip or
    spin: a robot pushing against a wall, or turning with its tail against one, reads metres or radians
    it never moved.

    Args:
        start: the start pose in the world. reading: the encoders' (x, y, yaw) at the start, m and rad.
    """

    def __init__(self, start: np.ndarray, reading: np.ndarray):
        self.start = np.asarray(start, dtype=float)
        self._last = _planar(reading)
        self._travelled = np.zeros(4)  # since the start, in the start's frame

    def step(self, reading: np.ndarray, bumped: bool = False) -> np.ndarray:
        """The pose after one more step: the encoders' (x, y, yaw) now, and whether the bumper is closed."""
        reading = _planar(reading)
        if not bumped:
            self._travelled = geometry.compose(self._travelled, geometry.relative(self._last, reading))
        self._last = reading
        return geometry.compose(self.start, self._travelled)


def _bumped(observation: dict) -> bool:
    return bool(np.asarray(observation.get("bumper", 0)).any())


class RandomAgent:
    """Uniformly random actions within the robot's range (the lower bound)."""

    def __init__(self, world, graph, seed: int):
        self.rng = np.random.default_rng(seed)

    def reset(self, start: np.ndarray, goal: np.ndarray) -> None:
        pass

    def act(self, observation: dict, pose: np.ndarray) -> np.ndarray:
        return np.array([self.rng.uniform(-0.5, 1.5), self.rng.uniform(-1.5, 1.5)], dtype=np.float32)


class PlannerAgent:
    """Plans at each goal's start the shortest drivable path (ramp-aware, on the graph derived from the
    world's geometry) from where its pose says it is, and follows it with the scripted drives' pure-pursuit
    controller, steering by its pose; where the path's next point lies more than ``turn_in_place`` off its
    heading it turns on the spot first (an arc from a standstill would swing the chassis into whatever it
    stands beside). When its bumper closes it backs off ``back_off_steps`` steps at 0.3 m/s and plans
    again from where its pose then says it is; if the bumper is still closed when it has backed off, what
    it touches is behind it (the chassis reaches 0.35 m behind the axle, and swings out when it turns on
    the spot), so it drives forward as far instead. A goal no drivable path reaches is not driven toward:
    it stands.

    Where its bumper closed it remembers an obstacle, 0.35 m ahead of where its pose then said it was
    (the chassis' front), or 0.4 m behind when backing did not free it, for ``bump_memory`` steps, and
    plans around what it remembers (0.5 m clear of each): a robot whose pose is off no longer plans into
    the same wall after every back-off.

    It steers in the plane and takes its level from its own plan, not from the pose's height: the first
    plan starts on the level nearest the pose's height, every later one on the level its last plan had
    brought it to (where its progress along that plan lies). A pose source that measures no height (the
    wheels) or one whose height is off by a storey then still plans and follows paths on the right level;
    and a height a metre off, between two levels, does not put a near-vertical first step into the path,
    whose lookahead point would lie under the robot (it turned on the spot for good)."""

    def __init__(self, world, graph, seed: int, *, speed: float = 1.0, turn_in_place: float = 0.5,
                 back_off_steps: int = 5, bump_memory: int = 600):
        self.graph = graph
        self.speed = speed
        self.turn_in_place = turn_in_place
        self.back_off_steps = back_off_steps
        self.bump_memory = bump_memory
        self.bumps: list[tuple[int, np.ndarray]] = []  # (step, x, y, z m): obstacles the bumper found
        self._step = 0
        self.driver = None
        self.goal: np.ndarray | None = None
        self._backing = 0  # steps of the escape from a bump still to drive
        self._escape_direction = -1.0  # -1: backing off, +1: forward (backing did not free the bumper)
        self._obstacle = np.zeros(3)  # where the bump's obstacle is believed to be, m
        self._height: float | None = None  # m: the level of the last plan's start, while it has no driver

    def reset(self, start: np.ndarray, goal: np.ndarray) -> None:
        self.goal = np.asarray(goal, dtype=float)
        self._backing = 0
        self._plan(start)

    def _level_position(self, pose: np.ndarray) -> np.ndarray:
        """The pose's x, y (m) at the height of the level the planner believes it is on: its plan's height
        where its progress lies, or the pose's own height before any plan."""
        height = float(pose[2])
        if self.driver is not None:
            height = float(self.driver.route.point_at(self.driver.progress)[2])
        elif self._height is not None:
            height = self._height
        return np.array([pose[0], pose[1], height], dtype=float)

    def _plan(self, start: np.ndarray) -> None:
        import sim

        position = self._level_position(start)
        self.bumps = [(step, point) for step, point in self.bumps if self._step - step < self.bump_memory]
        avoid = np.array([point for _, point in self.bumps]).reshape(-1, 3)
        path, length = self.graph.shortest_path(position, self.goal, avoid=avoid)
        if not math.isfinite(length) and len(avoid):  # walled in by what it remembers: forget it
            self.bumps = []
            path, length = self.graph.shortest_path(position, self.goal)
        self._height = position[2]
        if not math.isfinite(length):
            self.driver = None
            return
        points = np.vstack([[position[0], position[1], path[0][2]], path[1:], self.goal])
        keep = np.concatenate([[True], np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1) > 1e-6])
        self.driver = sim.PurePursuit(sim.world.Route("plan", points[keep], False), speed=self.speed)

    def act(self, observation: dict, pose: np.ndarray) -> np.ndarray:
        self._step += 1
        if self.driver is None:
            return np.zeros(2, dtype=np.float32)
        bumped = _bumped(observation)
        heading = np.array([math.cos(pose[3]), math.sin(pose[3]), 0.0])
        if bumped and self._backing == 0:
            self._backing, self._escape_direction = self.back_off_steps, -1.0
            self._obstacle = self._level_position(pose) + 0.35 * heading
        if self._backing > 0:
            self._backing -= 1
            command = np.array([0.3 * self._escape_direction, 0.0], dtype=np.float32)
            if self._backing == 0:
                if bumped and self._escape_direction < 0:  # backing kept it touching: the obstacle is behind
                    self._backing, self._escape_direction = self.back_off_steps, 1.0
                    self._obstacle = self._level_position(pose) - 0.4 * heading
                else:
                    self.bumps.append((self._step, self._obstacle))
                    self._plan(pose)
            return command
        speed, yaw_rate = self.driver.command(self._level_position(pose), float(pose[3]))
        target = self.driver.route.point_at(self.driver.progress + self.driver.lookahead)
        bearing = geometry.wrap(math.atan2(target[1] - pose[1], target[0] - pose[0]) - float(pose[3]))
        if abs(bearing) > self.turn_in_place:
            speed, yaw_rate = 0.0, float(np.clip(2.0 * bearing, -1.5, 1.5))
        return np.array([speed, yaw_rate], dtype=np.float32)


AGENTS = {"random": RandomAgent, "planner": PlannerAgent}


def load_agent(name: str) -> type:
    """An agent class: ``random``, ``planner`` or ``module:Class``."""
    if name in AGENTS:
        return AGENTS[name]
    module, separator, attribute = name.partition(":")
    if not separator:
        raise InvalidParameterError("--agent", name, f"must be one of {', '.join(AGENTS)} or module:Class")
    try:
        return getattr(importlib.import_module(module), attribute)
    except (ImportError, AttributeError) as error:
        raise InvalidParameterError("--agent", name, f"cannot be imported ({error})") from None


@dataclass
class GoalResult:
    """One row of ``episodes.csv``: one goal of an episode (see the module's description)."""

    world: str
    seed: int
    agent: str
    pose: str
    goal_index: int
    outcome: str
    success: bool
    spl: float
    path_length_m: float
    geodesic_m: float
    steps: int
    collisions: int
    localisation_error_m: float
    height_error_m: float
    position_uncertainty_m: float
    corrections: int
    distance_driven_m: float
    wheel_error_m: float = math.nan
    wheel_height_error_m: float = math.nan


class EpisodeRunner:
    """One episode's agent and pose source, fed by whoever steps the environment (a single environment or
    one slot of a vector environment): :meth:`begin` with the reset's observation and info, then
    :meth:`act` and :meth:`observe` each step, and :meth:`finish` with the last info; :attr:`results` holds
    a row per goal."""

    def __init__(self, world_name: str, seed: int, agent_name: str, pose_source: str, *, graph, world,
                 load_map: Path | None = None, goals: int = 1):
        if pose_source not in POSE_SOURCES:
            raise InvalidParameterError("--pose", pose_source, f"must be one of {', '.join(POSE_SOURCES)}")
        self.world_name, self.seed, self.agent_name, self.pose_source = world_name, seed, agent_name, pose_source
        self.graph = graph
        self.agent = load_agent(agent_name)(world, graph, seed)
        self.load_map = load_map
        self.goals = goals
        self.steps = 0
        self.results: list[GoalResult] = []
        self.uncertainty = 0.0 if pose_source == "groundtruth" else math.nan
        self._driven = 0.0  # m driven in the goals that ended
        self._collisions = 0  # the environment's count when the current goal began
        self._corrections = 0  # the localiser's count when the current goal began
        self.localiser = None
        self._last_finished = False

    def begin(self, observation: dict, info: dict) -> None:
        from ..slam import NeuroSLAM

        self.start = np.array(info["pose"], dtype=float)
        self.pose = self.start
        self.wheels = WheelPose(self.start, info["odometry_pose"])
        self.wheel_pose = self.start
        self.localiser = None
        if self.pose_source.startswith("slam"):
            slam = NeuroSLAM.load(self.load_map) if self.load_map is not None else NeuroSLAM("sim")
            mode = "wheel" if self.pose_source == "slam" else "visual"
            self.localiser = Localiser(slam, self.start, LocalisationConfig.preset(mode),
                                       loaded_map=self.load_map is not None)
            # wheel: the wheels' speed and turn rate, the camera's views and pitch (as drive --odometry wheel)
            self.self_motion = SelfMotionSource(mode, slam)
            self._localise(observation, info, 0)
        self.agent.reset(self.pose, np.array(info["goal"], dtype=float))

    def _localise(self, observation: dict, info: dict, index: int) -> None:
        frame = RolloutStream.frame_of(observation, info, index)
        if _bumped(observation) and frame.wheels is not None:  # the wheels slip: not the robot's motion
            frame = dataclasses.replace(frame, wheels=dataclasses.replace(frame.wheels, forward_speed=0.0,
                                                                          yaw_rate=0.0))
        where = self.localiser.step(frame.image, frame.time, odometry=self.self_motion(frame))
        self.pose, self.uncertainty = where.pose, where.position_error

    def act(self, observation: dict) -> np.ndarray:
        return np.asarray(self.agent.act(observation, self.pose), dtype=np.float32)

    def observe(self, observation: dict, info: dict) -> None:
        self.steps += 1
        # the wheels' pose on the same frames, whatever the pose source: the paired baseline of every row
        self.wheel_pose = self.wheels.step(info["odometry_pose"], _bumped(observation))
        if self.pose_source == "groundtruth":
            self.pose = np.array(info["pose"], dtype=float)
        elif self.pose_source == "odometry":
            self.pose = self.wheel_pose
        else:
            self._localise(observation, info, self.steps)
        self._last_finished = bool(info["goal_finished"])
        if self._last_finished:
            self._record(info, str(info["goal_outcome"]))
            if "next_goal" in info:  # the next goal of a sequence, from where the agent thinks it is
                self.agent.reset(self.pose, np.array(info["next_goal"], dtype=float))

    def _record(self, info: dict, outcome: str) -> None:
        truth = np.array(info["pose"], dtype=float)
        path_length, success = float(info["path_length"]), bool(info["success"])
        self._driven += path_length
        collisions = int(info["collisions"])
        corrections = 0 if self.localiser is None else self.localiser.corrections
        self.results.append(GoalResult(
            self.world_name, self.seed, self.agent_name, self.pose_source, int(info["goal_index"]), outcome, success,
            float(info["spl"]), path_length, float(info["geodesic"]), int(info["goal_steps"]),
            collisions - self._collisions, float(np.linalg.norm(self.pose[:3] - truth[:3])),
            float(abs(self.pose[2] - truth[2])), float(self.uncertainty), corrections - self._corrections,
            self._driven, float(np.linalg.norm(self.wheel_pose[:3] - truth[:3])),
            float(abs(self.wheel_pose[2] - truth[2]))))
        self._corrections = corrections
        self._collisions = collisions

    def finish(self, info: dict) -> list[GoalResult]:
        """The rows of the episode's ``goals`` goals: a goal cut off by the time limit counts as ``timeout``,
        and each goal never given because the episode ended first (the robot tipped) as ``not_given``, a
        failure with no path, geodesic or error (NaN), so that a sequence's success is over all its goals."""
        if not self._last_finished:
            self._record(info, "timeout")
        for index in range(len(self.results), self.goals):
            self.results.append(GoalResult(
                self.world_name, self.seed, self.agent_name, self.pose_source, index, "not_given", False, 0.0, 0.0,
                math.nan, 0, 0, math.nan, math.nan, math.nan, 0, self._driven))
        return self.results


def _environment(world_name: str, goal_sensor: str, max_steps: int, goals: int = 1, patrol: int | None = None):
    import gymnasium as gym

    import sim  # noqa: F401 (registers the environments)

    if goals > 1:
        return gym.make("NeuroSLAM/SequentialPointNav-v0", world=world_name, goal_sensor=goal_sensor, goals=goals,
                        goal_steps=max_steps, patrol=patrol)
    return gym.make("NeuroSLAM/PointNav-v1", world=world_name, goal_sensor=goal_sensor, max_episode_steps=max_steps)


def run_episode(world_name: str, seed: int, agent_name: str, pose_source: str, *, graph, goal_sensor: str = "gps",
                load_map: Path | None = None, max_steps: int = 1500, goals: int = 1,
                patrol: int | None = None, on_step=None) -> list[GoalResult]:
    """One seeded episode (``goals`` in a row, the places of a ``patrol`` round after round where given;
    ``max_steps`` per goal); a row per goal. ``on_step(runner, observation, info)``, where given, is called
    after every step (the :class:`EpisodeRunner` has taken it: its ``pose``, its ``localiser``), to record
    what the rows do not hold."""
    env = _environment(world_name, goal_sensor, max_steps, goals, patrol)
    try:
        observation, info = env.reset(seed=seed)
        runner = EpisodeRunner(world_name, seed, agent_name, pose_source, graph=graph, world=env.unwrapped.world,
                               load_map=load_map, goals=goals)
        runner.begin(observation, info)
        done = False
        while not done:
            observation, _, terminated, truncated, info = env.step(runner.act(observation))
            runner.observe(observation, info)
            if on_step is not None:
                on_step(runner, observation, info)
            done = terminated or truncated
        return runner.finish(info)
    finally:
        env.close()


def _slot(batch: dict, index: int) -> dict:
    """Environment ``index``'s entries of a vector environment's observation or info dict (the keys it has)."""
    return {key: value[index] for key, value in batch.items()
            if not key.startswith("_") and batch.get(f"_{key}", np.ones(index + 1, dtype=bool))[index]}


def run_episodes_vector(world_name: str, seeds: list[int], agent_name: str, pose_source: str, *, graph, world,
                        num_envs: int, goal_sensor: str = "gps", load_map: Path | None = None,
                        max_steps: int = 1500, goals: int = 1, patrol: int | None = None,
                        progress=None) -> list[GoalResult]:
    """The episodes of ``seeds`` on a gymnasium async vector environment of ``num_envs`` copies (spawned
    processes; automatic resets off, so each slot is reset with the next episode's own seed and every
    setting sees the same episodes). Returns their rows in the order of ``seeds``."""
    import functools

    import gymnasium as gym

    count = min(num_envs, len(seeds))
    make = functools.partial(_environment, world_name, goal_sensor, max_steps, goals, patrol)
    envs = gym.vector.AsyncVectorEnv([make] * count, context="spawn",
                                     autoreset_mode=gym.vector.AutoresetMode.DISABLED)
    pending = list(seeds)
    runners: list[EpisodeRunner | None] = [None] * count
    finished: dict[int, list[GoalResult]] = {}
    try:
        first = [pending.pop(0) for _ in range(count)]
        observations, infos = envs.reset(seed=first)
        for index, seed in enumerate(first):
            runners[index] = EpisodeRunner(world_name, seed, agent_name, pose_source, graph=graph, world=world,
                                           load_map=load_map, goals=goals)
            runners[index].begin(_slot(observations, index), _slot(infos, index))
        while any(runner is not None for runner in runners):
            actions = np.zeros((count, 2), dtype=np.float32)
            for index, runner in enumerate(runners):
                if runner is not None:
                    actions[index] = runner.act(_slot(observations, index))
            observations, _, terminated, truncated, infos = envs.step(actions)
            reset_seeds: list[int | None] = [None] * count
            for index, runner in enumerate(runners):
                if runner is None:
                    continue
                runner.observe(_slot(observations, index), _slot(infos, index))
                if terminated[index] or truncated[index]:
                    finished[runner.seed] = runner.finish(_slot(infos, index))
                    runners[index] = None
                    if progress is not None:
                        progress.update()
                    if pending:
                        reset_seeds[index] = pending.pop(0)
            if any(seed is not None for seed in reset_seeds):
                mask = np.array([seed is not None for seed in reset_seeds])
                observations, infos = envs.reset(seed=reset_seeds, options={"reset_mask": mask})
                for index, seed in enumerate(reset_seeds):
                    if seed is not None:
                        runners[index] = EpisodeRunner(world_name, seed, agent_name, pose_source, graph=graph,
                                                       world=world, load_map=load_map, goals=goals)
                        runners[index].begin(_slot(observations, index), _slot(infos, index))
    finally:
        envs.close()
    return [row for seed in seeds for row in finished[seed]]


def write_episodes(path: Path, results: list[GoalResult]) -> None:
    rows = [asdict(result) for result in results]
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(GoalResult.__dataclass_fields__))
        writer.writeheader()
        writer.writerows(rows)


def _interval(values: np.ndarray) -> list[float]:
    """The 95 % interval of the mean (normal approximation, 1.96 × standard error)."""
    half = 1.96 * values.std(ddof=1) / math.sqrt(len(values)) if len(values) > 1 else math.nan
    return [float(values.mean() - half), float(values.mean() + half)]


def _plane(errors: np.ndarray, heights: np.ndarray) -> np.ndarray:
    """The horizontal part of 3-D errors whose vertical part is ``heights`` (m)."""
    return np.sqrt(np.maximum(errors**2 - heights**2, 0.0))


def _median(values: np.ndarray) -> float | None:
    """The median of the finite values (goals never given have no error), None where there are none."""
    finite = values[np.isfinite(values)]
    return float(np.median(finite)) if len(finite) else None


def summarise(results: list[GoalResult]) -> dict[str, Any]:
    """Per setting (world, agent, pose): ``goals``, ``episodes``, ``success_rate`` and ``success_ci95``,
    ``spl`` and ``spl_ci95`` (95 % intervals of the mean, 1.96 × standard error), ``outcomes`` (counts),
    ``median_localisation_error_m``; the paired comparison with the wheels on the same frames (every row
    carries the wheels' error where its goal ended, ``wheel_error_m``): ``median_wheel_error_m``,
    ``plane_error_above_wheels_m`` (the median over goals of the pose source's horizontal error minus the
    wheels', m) and ``not_worse_than_wheels`` (the share of goals whose horizontal error is at most the
    wheels' plus ``PAIRED_TOLERANCE``); and, for sequences, ``localisation_error_by_goal`` (the median over
    episodes at each goal index, m) and ``localisation_error_trend`` (least-squares slope of the error
    against the distance driven, m per 100 m). Medians leave out goals without an error (``not_given``) and
    are None where none is left."""
    groups: dict[tuple, list[GoalResult]] = {}
    for result in results:
        groups.setdefault((result.world, result.agent, result.pose), []).append(result)
    settings = []
    for (world, agent, pose), members in groups.items():
        spl = np.array([member.spl for member in members])
        success = np.array([member.success for member in members], dtype=float)
        errors = np.array([member.localisation_error_m for member in members])
        outcomes: dict[str, int] = {}
        for member in members:
            outcomes[member.outcome] = outcomes.get(member.outcome, 0) + 1
        wheels = np.array([member.wheel_error_m for member in members])
        # in the plane: the wheels measure no height, which the camera's climb adds (height_error_m)
        plane = _plane(errors, np.array([member.height_error_m for member in members]))
        wheel_plane = _plane(wheels, np.array([member.wheel_height_error_m for member in members]))
        paired = np.isfinite(plane) & np.isfinite(wheel_plane)
        setting = {"world": world, "agent": agent, "pose": pose, "goals": len(members),
                   "episodes": len({member.seed for member in members}),
                   "success_rate": float(success.mean()), "success_ci95": _interval(success),
                   "spl": float(spl.mean()), "spl_ci95": _interval(spl), "outcomes": outcomes,
                   "median_localisation_error_m": _median(errors), "median_wheel_error_m": _median(wheels),
                   "plane_error_above_wheels_m": _median(plane[paired] - wheel_plane[paired]),
                   "not_worse_than_wheels": (float(np.mean(plane[paired] <= wheel_plane[paired] + PAIRED_TOLERANCE))
                                             if paired.any() else None)}
        indices = np.array([member.goal_index for member in members])
        if indices.max() > 0:
            setting["localisation_error_by_goal"] = [_median(errors[indices == k])
                                                     for k in range(int(indices.max()) + 1)]
            driven = np.array([member.distance_driven_m for member in members])
            finite = np.isfinite(errors)
            slope = (np.polyfit(driven[finite], errors[finite], 1)[0]
                     if finite.sum() > 1 and np.ptp(driven[finite]) > 0 else math.nan)
            setting["localisation_error_trend"] = None if math.isnan(slope) else float(100 * slope)
        settings.append(setting)
    return {"settings": settings}


def write_summary(path: Path, results: list[GoalResult]) -> dict[str, Any]:
    summary = summarise(results)
    path.write_text(json.dumps(summary, indent=2) + "\n")
    return summary
