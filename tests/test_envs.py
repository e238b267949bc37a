"""The gymnasium environments pass the checker, run vectorised, and choose starts and goals from the seed."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim
from sim.navigation import DrivableGraph

ENV_IDS = ["NeuroSLAM/Drive-v0", "NeuroSLAM/PointNav-v1"]


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
        if env_id.endswith("PointNav-v1"):
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
    env = gym.make("NeuroSLAM/PointNav-v1", world="carpark").unwrapped
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


def test_the_drivable_distance_goes_over_the_ramp():
    world = sim.load_world("carpark")
    graph = DrivableGraph.of(world)
    assert DrivableGraph.of(world) is graph  # one graph per world in a process
    below, above = np.array([-14.0, -12.5, 0.0]), np.array([-14.0, -12.5, 3.0])
    field = graph.goal_field(above)
    # the way up goes east to the ramp (x = 18.7), climbs it (17.3 m) and comes back west on the deck
    assert graph.distance_to(field, below) > 2 * 30 + 17
    assert graph.geodesic(below, above) == graph.distance_to(field, below)
    assert graph.distance_to(field, above) == pytest.approx(0.0, abs=0.3)
    assert np.all(np.isfinite(graph.distances_from(graph.nearest(below))))  # the drivable area is connected


def test_a_goal_off_the_drivable_area_is_reported_and_ends_at_once():
    """Inside a pillar (the car park's at the origin, 0.6 m wide; nothing drivable within 0.45 m of it) a goal
    is reachable (within 1 m of a drivable node); 30 m outside the walls it is not."""
    env = gym.make("NeuroSLAM/PointNav-v1", world="carpark").unwrapped
    try:
        start = [-14.0, -12.5, 0.0, 0.0]
        _, info = env.reset(seed=0, options={"start": start, "goal": [0.0, 0.0, 0.0]})
        assert info["goal_reachable"] and 14 < info["geodesic"] < 25
        _, info = env.reset(seed=0, options={"start": start, "goal": [50.0, 0.0, 0.0]})
        assert not info["goal_reachable"] and info["geodesic"] == math.inf
        _, reward, terminated, truncated, info = env.step(np.array([1.0, 0.0]))
        assert (terminated, truncated) == (False, True)
        assert info["goal_outcome"] == "unreachable" and not info["success"] and reward == -0.01
    finally:
        env.close()


def test_the_bumper_closes_when_the_robot_drives_into_a_wall():
    """Facing the car park's west wall (its inner face at x = -19.9) from 6 m away: the bumper reads 0 in
    the open and 1 once the chassis touches the wall, as the environment's collision count says."""
    env = gym.make("NeuroSLAM/PointNav-v1", world="carpark", stall_steps=None).unwrapped
    try:
        observation, _ = env.reset(seed=0, options={"start": [-14.0, -12.5, 0.0, math.pi], "goal": [10.0, -12.5, 0.0]})
        assert observation["bumper"].tolist() == [0] and observation["bumper"] in env.observation_space["bumper"]
        readings = []
        for _ in range(120):
            observation, _, _, _, info = env.step(np.array([1.0, 0.0]))
            readings.append(int(observation["bumper"][0]))
        first = readings.index(1)
        assert info["pose"][0] < -19.0 and 50 < first and readings[-1] == 1
        assert info["collisions"] == sum(readings)
    finally:
        env.close()


def test_a_robot_that_stops_ends_its_episode_as_stalled():
    env = gym.make("NeuroSLAM/PointNav-v1", world="gen:3", stall_steps=30).unwrapped
    try:
        env.reset(seed=1)
        steps = 0
        while steps < 40:
            _, _, terminated, truncated, info = env.step(np.array([0.0, 1.0]))  # turning on the spot
            steps += 1
            if terminated or truncated:
                break
        assert steps == 30 and truncated and not terminated
        assert info["goal_outcome"] == "stalled" and not info["success"] and info["spl"] == 0.0
    finally:
        env.close()


def test_a_sequence_gives_the_next_goal_from_where_the_robot_is_without_a_reset():
    """SequentialPointNav: a goal that ends (here each by stalling, quickly) is followed by the next, drawn
    from the robot's place; the clock and the wheel odometry run on; the episode ends with the last goal."""
    env = gym.make("NeuroSLAM/SequentialPointNav-v0", world="gen:3", goals=3, stall_steps=5, goal_sensor="start")
    try:
        observation, info = env.reset(seed=4)
        goals, times, outcomes = [info["goal"]], [], []
        for _ in range(40):
            observation, _, terminated, truncated, info = env.step(np.array([0.0, 0.0], dtype=np.float32))
            times.append(info["time"])
            if info["goal_finished"]:
                outcomes.append((info["goal_index"], info["goal_outcome"], info["goal_steps"]))
                if "next_goal" in info:
                    goals.append(info["next_goal"])
                    assert observation["goal"][0] > 0  # the start sensor shows the new goal once
                    position = info["pose"][:3]
                    assert np.linalg.norm(info["next_goal"] - position) == pytest.approx(observation["goal"][0],
                                                                                         abs=1e-4)
            elif info["goal_index"] > 0:
                assert np.all(observation["goal"] == 0)
            if terminated or truncated:
                break
        assert outcomes == [(0, "stalled", 5), (1, "stalled", 5), (2, "stalled", 5)]
        assert truncated and not terminated and len(times) == 15
        assert np.allclose(np.diff(times), 0.1)  # one clock through all goals
        assert len({tuple(goal) for goal in goals}) == 3
    finally:
        env.close()


def test_a_patrol_visits_its_places_in_order_round_after_round():
    """SequentialPointNav with patrol=3: goal i is place i mod 3; the places are standing places, each at a
    goal distance from the one before (the first from the start), and the first is the goal a plain sequence
    with the same seed draws (a patrol adds draws, it does not change the first)."""
    env = gym.make("NeuroSLAM/SequentialPointNav-v0", world="gen:3", goals=7, patrol=3, stall_steps=3).unwrapped
    plain = gym.make("NeuroSLAM/SequentialPointNav-v0", world="gen:3", goals=2, stall_steps=3).unwrapped
    try:
        _, info = env.reset(seed=6)
        start = info["pose"][:3]
        goals = [info["goal"]]
        for _ in range(30):
            _, _, terminated, truncated, info = env.step(np.array([0.0, 0.0], dtype=np.float32))
            if "next_goal" in info:
                goals.append(info["next_goal"])
            if terminated or truncated:
                break
        assert len(goals) == 7 and info["goal_index"] == 6
        for index, goal in enumerate(goals):
            np.testing.assert_array_equal(goal, goals[index % 3])
        assert len({tuple(goal) for goal in goals}) == 3
        graph = env.graph
        for before, place in zip([start, *goals[:2]], goals[:3], strict=True):
            assert graph.nearest(place) in graph.standing
            distance = graph.distances_from(graph.nearest(before))[graph.nearest(place)]
            assert env.min_goal_distance <= distance <= env.max_goal_distance
        _, plain_info = plain.reset(seed=6)
        np.testing.assert_array_equal(plain_info["goal"], goals[0])
    finally:
        env.close()
        plain.close()


def test_pointnav_goals_span_levels():
    env = gym.make("NeuroSLAM/PointNav-v1", world="carpark", max_goal_distance=200.0).unwrapped
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
    envs = gym.make_vec("NeuroSLAM/PointNav-v1", num_envs=2, vectorization_mode=mode, vector_kwargs=kwargs,
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
