"""Navigation experiments on ``NeuroSLAM/PointNav-v0`` (``neuroslam nav``): agents, pose sources, scores.

Glue (it imports the simulator). An episode: the environment is reset with the episode's seed (so every
setting sees the same start and goal), the agent is told its start pose in the world and the goal (the
goal sensor's reading at reset, turned into world coordinates through the start pose), and then it acts
until the episode ends, localising itself with its pose source:

- ``groundtruth``: the simulator's pose (the upper bound);
- ``odometry``: the wheel encoders integrated from the start;
- ``slam``: NeuroSLAM's estimate on the camera frames (with a loaded map of an earlier drive of the same
  world: the session starts in it, ``start="known"``), expressed in the world through the start pose.

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

from .errors import InvalidParameterError

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


def _compose(start: np.ndarray, relative: np.ndarray) -> np.ndarray:
    """``start`` (x, y, z, yaw) composed with a pose relative to it."""
    c, s = math.cos(start[3]), math.sin(start[3])
    return np.array([start[0] + c * relative[0] - s * relative[1], start[1] + s * relative[0] + c * relative[1],
                     start[2] + relative[2], math.remainder(start[3] + relative[3], 2 * math.pi)])


def _relative(origin: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """``pose`` (x, y, z, yaw) in the frame of ``origin``."""
    c, s = math.cos(origin[3]), math.sin(origin[3])
    dx, dy = pose[0] - origin[0], pose[1] - origin[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, pose[2] - origin[2],
                     math.remainder(pose[3] - origin[3], 2 * math.pi)])


def run_episode(world_name: str, seed: int, agent_name: str, pose_source: str, *, graph, goal_sensor: str = "gps",
                load_map: Path | None = None, max_steps: int = 1500) -> Episode:
    """One seeded episode of ``NeuroSLAM/PointNav-v0``; its scores."""
    import gymnasium as gym

    import sim  # noqa: F401 (registers NeuroSLAM/PointNav-v0)

    from .slam import NeuroSLAM

    env = gym.make("NeuroSLAM/PointNav-v0", world=world_name, goal_sensor=goal_sensor,
                   max_episode_steps=max_steps)
    try:
        observation, info = env.reset(seed=seed)
        start, goal = np.array(info["pose"], dtype=float), np.array(info["goal"], dtype=float)
        agent = load_agent(agent_name)(env.unwrapped.world, graph, seed)
        agent.reset(start, goal)
        slam = None
        if pose_source == "slam":
            slam = NeuroSLAM.load(load_map) if load_map is not None else NeuroSLAM("sim")
            if load_map is not None:
                slam.begin_session(start="known")
            slam.step(observation["image"], float(info["time"]))
            slam_origin = slam.last.pose.copy()
        odometry_origin = np.array(info["odometry_pose"], dtype=float)
        pose = start
        steps, done = 0, False
        while not done:
            action = agent.act(observation, pose)
            observation, _, terminated, truncated, info = env.step(action)
            steps += 1
            done = terminated or truncated
            if pose_source == "groundtruth":
                pose = np.array(info["pose"], dtype=float)
            elif pose_source == "odometry":  # the wheel encoders' (x, y, yaw) since the start
                x, y, yaw = np.array(info["odometry_pose"], dtype=float)
                relative = _relative(np.array([odometry_origin[0], odometry_origin[1], 0.0, odometry_origin[2]]),
                                     np.array([x, y, 0.0, yaw]))
                pose = _compose(start, relative)  # the wheels measure no height: the start's is kept
            else:
                estimate = slam.step(observation["image"], float(info["time"]))
                pose = _compose(start, _relative(slam_origin, estimate.pose))
        truth = np.array(info["pose"], dtype=float)
        geodesic = graph.geodesic(start[:3], goal)
        path_length = float(info["path_length"])
        success = bool(info["success"])
        return Episode(world_name, seed, agent_name, pose_source, success,
                       float(success) * geodesic / max(path_length, geodesic, 1e-9), path_length, float(geodesic),
                       steps, int(info["collisions"]), float(np.linalg.norm(pose[:3] - truth[:3])))
    finally:
        env.close()


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
