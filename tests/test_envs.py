"""The gymnasium environments pass the checker, run vectorised, and choose starts and goals from the seed."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim
from sim.envs import RouteGraph

ENV_IDS = ["NeuroSLAM/Drive-v0", "NeuroSLAM/PointNav-v0"]


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_check_env_passes(env_id):
    env = gym.make(env_id, world="gen:3")
    try:
        check_env(env.unwrapped, skip_render_check=False)
    finally:
        env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_reset_is_deterministic_in_the_seed(env_id):
    env = gym.make(env_id)
    try:
        first, info_a = env.reset(seed=11)
        second, info_b = env.reset(seed=11)
        np.testing.assert_array_equal(first["image"], second["image"])
        np.testing.assert_array_equal(info_a["pose"], info_b["pose"])
        _, info_c = env.reset(seed=12)
        assert not np.array_equal(info_a["pose"], info_c["pose"])
        if env_id.endswith("PointNav-v0"):
            np.testing.assert_array_equal(info_a["goal"], info_b["goal"])
    finally:
        env.close()


def test_observations_are_copies_and_truth_stays_in_info():
    env = gym.make("NeuroSLAM/Drive-v0")
    try:
        observation, info = env.reset(seed=0)
        assert set(observation) == {"image", "odometry"}
        assert observation["image"].flags.owndata
        step_observation, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        assert step_observation["image"] is not observation["image"]
        assert type(terminated) is bool and type(truncated) is bool and reward == 0.0
        assert {"pose", "quaternion", "level", "time", "odometry_pose", "collisions"} <= set(info)
        assert info["time"] == pytest.approx(0.1)
    finally:
        env.close()


# bad actions and reset options: tests/test_bad_input.py


def test_pointnav_reaches_an_explicit_goal_and_reports_success_and_spl():
    env = gym.make("NeuroSLAM/PointNav-v0", world="carpark").unwrapped
    try:
        start = [-14.0, -12.5, 0.0, 0.0]
        goal = [-6.0, -12.5, 0.0]
        observation, info = env.reset(seed=0, options={"start": start, "goal": goal})
        distance, bearing, _height = observation["goal"]
        assert distance == pytest.approx(8.0, abs=0.02) and bearing == pytest.approx(0.0, abs=0.01)
        assert info["distance_to_goal"] == pytest.approx(8.0, abs=0.3)
        total = 0.0
        for _ in range(200):
            observation, reward, terminated, _truncated, info = env.step(np.array([1.5, 2.0 * observation["goal"][1]]))
            total += reward
            if terminated:
                break
        assert terminated and info["success"]
        assert np.linalg.norm(info["pose"][:3] - goal) <= 1.0
        assert 0.9 < info["spl"] <= 1.0  # a straight drive is nearly the shortest path
        assert total == pytest.approx(8.0 - 1.0 + 2.5, abs=0.6)  # progress to within 1 m, slack, bonus
    finally:
        env.close()


def test_route_graph_distances_go_over_the_ramp():
    world = sim.load_world("carpark")
    graph = RouteGraph(world)
    below = graph.nearest(np.array([-14.0, -12.5, 0.0]))
    above = graph.nearest(np.array([-14.0, -12.5, 3.0]))
    distances = graph.distances_from(below)
    # the way up goes east to the ramp (x = 18.7), climbs it (17.3 m) and comes back west on the deck
    assert distances[above] > 2 * 30 + 17
    assert np.all(np.isfinite(distances))  # the network is connected
    assert math.isclose(graph.distance_to(distances, np.array([-14.0, -12.5, 0.0])), 0.0, abs_tol=0.3)


def test_pointnav_goals_span_levels():
    env = gym.make("NeuroSLAM/PointNav-v0", world="carpark", max_goal_distance=200.0).unwrapped
    try:
        levels = set()
        for seed in range(12):
            _, info = env.reset(seed=seed)
            levels.add(env.world.level_of(info["goal"][2]))
            assert 5.0 <= info["distance_to_goal"] <= 200.0 + 1.0
        assert levels == {0, 1}
    finally:
        env.close()


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_env_rollout(mode):
    kwargs = {"context": "spawn"} if mode == "async" else {}
    envs = gym.make_vec("NeuroSLAM/PointNav-v0", num_envs=2, vectorization_mode=mode, vector_kwargs=kwargs,
                        world="gen:3")
    try:
        observations, _ = envs.reset(seed=[1, 2])
        assert observations["image"].shape == (2, 120, 160, 3)
        for _ in range(5):
            observations, rewards, _terminated, _truncated, _infos = envs.step(envs.action_space.sample())
        assert rewards.shape == (2,) and observations["goal"].shape == (2, 3)
        assert not np.array_equal(observations["image"][0], observations["image"][1])
    finally:
        envs.close()
