"""Navigation experiments on ``NeuroSLAM/PointNav-v0`` (``neuroslam nav``): agents, pose sources, scores.

Glue (it imports the simulator). An episode: the environment is reset with the episode's seed (so every
setting sees the same start and goal), the agent is told its start pose in the world and the goal (the
goal sensor's reading at reset, turned into world coordinates through the start pose), and then it acts
until the episode ends, localising itself with its pose source:

- ``groundtruth``: the simulator's pose (the upper bound);
- ``odometry``: the wheel encoders integrated from the start;
- ``slam``: NeuroSLAM's estimate from the wheels' speed and turn rate and the camera's views and pitch
  (the height rate is the wheels' speed times the sine of the camera's pitch; as ``neuroslam drive
  --odometry wheel``; with a loaded map of an earlier drive of the same world, the session starts in it,
  ``start="known"``), expressed in the world through the start pose.

The agent protocol (a user's agent plugs in as ``module:Class``)::

    class MyAgent:
        def __init__(self, world, graph, seed): ...      # sim World, sim.navigation.DrivableGraph, int
        def reset(self, start, goal): ...                # start (x, y, z, yaw), goal (x, y, z): world, m
        def act(self, observation, pose): ...            # pose: the pose source's (x, y, z, yaw) in the
                                                         # world; returns (forward speed m/s, yaw rate rad/s)

Scores per episode: success (the environment's: within 1 m of the goal), SPL (success × geodesic /
max(path driven, geodesic), the geodesic on the drivable graph), path length, geodesic, steps,
collisions, and the final localisation error (the pose source against the truth at the end, m).
"""

from __future__ import annotations

import csv
import importlib
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .. import geometry
from ..errors import InvalidParameterError
from .frames import RolloutStream, SelfMotionSource

__all__ = ["PlannerAgent", "RandomAgent", "load_agent", "run_episode", "summarise"]


class RandomAgent:
    """Uniformly random actions within the robot's range (the lower bound)."""

    def __init__(self, world, graph, seed: int):
        self.rng = np.random.default_rng(seed)

    def reset(self, start: np.ndarray, goal: np.ndarray) -> None:
        pass

    def act(self, observation: dict, pose: np.ndarray) -> np.ndarray:
        return np.array([self.rng.uniform(-0.5, 1.5), self.rng.uniform(-1.5, 1.5)], dtype=np.float32)


class PlannerAgent:
    """Plans once at reset the shortest drivable path (ramp-aware, on the graph derived from the world's
    geometry) and follows it with the scripted drives' pure-pursuit controller, steering by its pose."""

    def __init__(self, world, graph, seed: int, *, speed: float = 1.0):
        self.graph = graph
        self.speed = speed
        self.driver = None

    def reset(self, start: np.ndarray, goal: np.ndarray) -> None:
        import sim

        path, _ = self.graph.shortest_path(start[:3], goal)
        points = np.vstack([start[:3], path[1::2], goal]) if len(path) else np.vstack([start[:3], goal])
        keep = np.concatenate([[True], np.linalg.norm(np.diff(points[:, :2], axis=0), axis=1) > 1e-6])
        self.driver = sim.PurePursuit(sim.world.Route("plan", points[keep], False), speed=self.speed)

    def act(self, observation: dict, pose: np.ndarray) -> np.ndarray:
        return np.array(self.driver.command(np.asarray(pose[:3]), float(pose[3])), dtype=np.float32)


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
class Episode:
    """One row of ``episodes.csv``."""

    world: str
    seed: int
    agent: str
    pose: str
    success: bool
    spl: float
    path_length_m: float
    geodesic_m: float
    steps: int
    collisions: int
    final_localisation_error_m: float


class EpisodeRunner:
    """One episode's agent and pose source, fed by whoever steps the environment (a single environment or
    one slot of a vector environment): :meth:`begin` with the reset's observation and info, then
    :meth:`act` and :meth:`observe` each step, and :meth:`finish` with the last info."""

    def __init__(self, world_name: str, seed: int, agent_name: str, pose_source: str, *, graph, world,
                 load_map: Path | None = None):
        self.world_name, self.seed, self.agent_name, self.pose_source = world_name, seed, agent_name, pose_source
        self.graph = graph
        self.agent = load_agent(agent_name)(world, graph, seed)
        self.load_map = load_map
        self.steps = 0

    def begin(self, observation: dict, info: dict) -> None:
        from ..slam import NeuroSLAM

        self.start = np.array(info["pose"], dtype=float)
        self.goal = np.array(info["goal"], dtype=float)
        self.agent.reset(self.start, self.goal)
        self.pose = self.start
        self.odometry_origin = np.array(info["odometry_pose"], dtype=float)
        self.slam = None
        if self.pose_source == "slam":
            self.slam = NeuroSLAM.load(self.load_map) if self.load_map is not None else NeuroSLAM("sim")
            if self.load_map is not None:
                self.slam.begin_session(start="known")
            # the wheels' speed and turn rate, the camera's views and pitch (as drive --odometry wheel)
            self.self_motion = SelfMotionSource("wheel", self.slam)
            frame = RolloutStream.frame_of(observation, info, 0)
            self.slam.step(frame.image, frame.time, odometry=self.self_motion(frame))
            self.slam_anchor, self.slam_origin = self.start, self.slam.last.pose.copy()

    def act(self, observation: dict) -> np.ndarray:
        return np.asarray(self.agent.act(observation, self.pose), dtype=np.float32)

    def observe(self, observation: dict, info: dict) -> None:
        self.steps += 1
        if self.pose_source == "groundtruth":
            self.pose = np.array(info["pose"], dtype=float)
        elif self.pose_source == "odometry":  # the wheel encoders' (x, y, yaw) since the start
            origin, (x, y, yaw) = self.odometry_origin, np.array(info["odometry_pose"], dtype=float)
            travelled = geometry.relative(np.array([origin[0], origin[1], 0.0, origin[2]]), np.array([x, y, 0.0, yaw]))
            self.pose = geometry.compose(self.start, travelled)  # the wheels measure no height: the start's is kept
        else:  # the SLAM's estimate
            frame = RolloutStream.frame_of(observation, info, self.steps)
            estimate = self.slam.step(frame.image, frame.time, odometry=self.self_motion(frame))
            if estimate.merged:  # the estimate moved into the loaded map's frame: keep the pose continuous
                self.slam_anchor, self.slam_origin = self.pose, estimate.pose.copy()
            self.pose = geometry.compose(self.slam_anchor, geometry.relative(self.slam_origin, estimate.pose))

    def finish(self, info: dict) -> Episode:
        truth = np.array(info["pose"], dtype=float)
        geodesic = self.graph.geodesic(self.start[:3], self.goal)
        path_length, success = float(info["path_length"]), bool(info["success"])
        return Episode(self.world_name, self.seed, self.agent_name, self.pose_source, success,
                       float(success) * geodesic / max(path_length, geodesic, 1e-9), path_length, float(geodesic),
                       self.steps, int(info["collisions"]), float(np.linalg.norm(self.pose[:3] - truth[:3])))


def _environment(world_name: str, goal_sensor: str, max_steps: int):
    import gymnasium as gym

    import sim  # noqa: F401 (registers NeuroSLAM/PointNav-v0)

    return gym.make("NeuroSLAM/PointNav-v0", world=world_name, goal_sensor=goal_sensor, max_episode_steps=max_steps)


def run_episode(world_name: str, seed: int, agent_name: str, pose_source: str, *, graph, goal_sensor: str = "gps",
                load_map: Path | None = None, max_steps: int = 1500) -> Episode:
    """One seeded episode of ``NeuroSLAM/PointNav-v0``; its scores."""
    env = _environment(world_name, goal_sensor, max_steps)
    try:
        observation, info = env.reset(seed=seed)
        runner = EpisodeRunner(world_name, seed, agent_name, pose_source, graph=graph, world=env.unwrapped.world,
                               load_map=load_map)
        runner.begin(observation, info)
        done = False
        while not done:
            observation, _, terminated, truncated, info = env.step(runner.act(observation))
            runner.observe(observation, info)
            done = terminated or truncated
        return runner.finish(info)
    finally:
        env.close()


def _slot(batch: dict, index: int) -> dict:
    """Environment ``index``'s entries of a vector environment's observation or info dict."""
    return {key: value[index] for key, value in batch.items() if not key.startswith("_")}


def run_episodes_vector(world_name: str, seeds: list[int], agent_name: str, pose_source: str, *, graph, world,
                        num_envs: int, goal_sensor: str = "gps", load_map: Path | None = None,
                        max_steps: int = 1500, progress=None) -> list[Episode]:
    """The episodes of ``seeds`` on a gymnasium async vector environment of ``num_envs`` copies (spawned
    processes; automatic resets off, so each slot is reset with the next episode's own seed and every
    setting sees the same pairs). Returns them in the order of ``seeds``."""
    import functools

    import gymnasium as gym

    count = min(num_envs, len(seeds))
    envs = gym.vector.AsyncVectorEnv([functools.partial(_environment, world_name, goal_sensor, max_steps)] * count,
                                     context="spawn", autoreset_mode=gym.vector.AutoresetMode.DISABLED)
    pending = list(seeds)
    runners: list[EpisodeRunner | None] = [None] * count
    finished: dict[int, Episode] = {}
    try:
        first = [pending.pop(0) for _ in range(count)]
        observations, infos = envs.reset(seed=first)
        for index, seed in enumerate(first):
            runners[index] = EpisodeRunner(world_name, seed, agent_name, pose_source, graph=graph, world=world,
                                           load_map=load_map)
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
                                                       world=world, load_map=load_map)
                        runners[index].begin(_slot(observations, index), _slot(infos, index))
    finally:
        envs.close()
    return [finished[seed] for seed in seeds]


def write_episodes(path: Path, episodes: list[Episode]) -> None:
    rows = [asdict(episode) for episode in episodes]
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=list(rows[0]) if rows else list(Episode.__dataclass_fields__))
        writer.writeheader()
        writer.writerows(rows)


def summarise(episodes: list[Episode]) -> dict[str, Any]:
    """``{"settings": [{world, agent, pose, episodes, success_rate, spl, spl_ci95}]}`` (the 95 % interval
    of the mean SPL by the normal approximation, 1.96 × standard error)."""
    groups: dict[tuple, list[Episode]] = {}
    for episode in episodes:
        groups.setdefault((episode.world, episode.agent, episode.pose), []).append(episode)
    settings = []
    for (world, agent, pose), members in groups.items():
        spl = np.array([episode.spl for episode in members])
        half = 1.96 * spl.std(ddof=1) / math.sqrt(len(spl)) if len(spl) > 1 else math.nan
        settings.append({"world": world, "agent": agent, "pose": pose, "episodes": len(members),
                         "success_rate": float(np.mean([episode.success for episode in members])),
                         "spl": float(spl.mean()), "spl_ci95": [float(spl.mean() - half), float(spl.mean() + half)]})
    return {"settings": settings}


def write_summary(path: Path, episodes: list[Episode]) -> dict[str, Any]:
    summary = summarise(episodes)
    path.write_text(json.dumps(summary, indent=2) + "\n")
    return summary
