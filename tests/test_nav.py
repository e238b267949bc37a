"""neuroslam nav: the ground-truth planner reaches its goals on a small generated world; every agent and
pose source runs and writes episodes.csv and summary.json; a goal sensor that reads only at reset."""

import csv
import json
import math

import gymnasium as gym
import numpy as np
import pytest

import sim
from neuroslam.lab.cli import main
from neuroslam.lab.nav import PlannerAgent, WheelPose
from sim.navigation import DrivableGraph


def test_the_ground_truth_planner_reaches_its_goals_on_a_generated_world(tmp_path):
    assert main(["nav", "gen:2", "--episodes", "3", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert len(rows) == 3 and all(row["success"] == "True" for row in rows)
    assert all(float(row["spl"]) > 0.9 and int(row["collisions"]) == 0 for row in rows)
    summary = json.loads((tmp_path / "summary.json").read_text())
    (setting,) = summary["settings"]
    assert setting["success_rate"] == 1.0 and setting["episodes"] == 3 and len(setting["spl_ci95"]) == 2


@pytest.mark.parametrize("agent, pose", [("random", "groundtruth"), ("planner", "odometry"), ("planner", "slam"),
                                         ("planner", "slam-camera")])
def test_every_agent_and_pose_source_runs(tmp_path, agent, pose):
    assert main(["nav", "gen:2", "--episodes", "1", "--agent", agent, "--pose", pose, "--max-steps", "60",
                 "--out", str(tmp_path)]) == 0
    (row,) = list(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert row["agent"] == agent and row["pose"] == pose and int(row["steps"]) <= 60
    assert float(row["localisation_error_m"]) >= 0 and float(row["geodesic_m"]) > 0


def test_a_sequence_drives_its_goals_in_a_row_and_reports_each(tmp_path):
    """--sequential 3: one episode, three goals from wherever the last ended; a row per goal with the
    distance driven so far, and the summary's localisation error per goal index."""
    assert main(["nav", "gen:2", "--sequential", "3", "--episodes", "1", "--out", str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert [row["goal_index"] for row in rows] == ["0", "1", "2"] and {row["seed"] for row in rows} == {"0"}
    assert all(row["outcome"] == "success" and float(row["spl"]) > 0.9 and row["corrections"] == "0" for row in rows)
    driven = [float(row["distance_driven_m"]) for row in rows]
    assert driven == pytest.approx(np.cumsum([float(row["path_length_m"]) for row in rows]))
    (setting,) = json.loads((tmp_path / "summary.json").read_text())["settings"]
    assert setting["goals"] == 3 and setting["episodes"] == 1 and setting["localisation_error_by_goal"] == [0, 0, 0]


def test_a_patrol_re_drives_its_round(tmp_path):
    """--sequential 4 --patrol 2: places A, B, A, B; the ground-truth planner reaches each, and the second
    A-to-B leg starts where the first did (within the 1 m of success at both ends: geodesics within 2 m)."""
    assert main(["nav", "gen:2", "--sequential", "4", "--patrol", "2", "--episodes", "1", "--out",
                 str(tmp_path)]) == 0
    rows = list(csv.DictReader((tmp_path / "episodes.csv").open()))
    assert [row["outcome"] for row in rows] == ["success"] * 4
    geodesics = [float(row["geodesic_m"]) for row in rows]
    assert abs(geodesics[3] - geodesics[1]) <= 2.0 and abs(geodesics[2] - geodesics[1]) <= 2.0


def test_a_sequence_cut_short_by_a_tip_counts_its_goals_never_given_as_failures():
    """A robot that tips on the second of four goals ends the episode there (the environment's rule); the
    runner reports all four goals, the last two ``not_given`` (no error, path or geodesic), so the
    sequence's success is 1 of 4, not 1 of 2, and the summary's errors leave them out."""
    from neuroslam.lab.nav import EpisodeRunner, summarise

    runner = EpisodeRunner("gen:2", 0, "random", "groundtruth", graph=None, world=None, goals=4)
    start = np.array([0.0, 0.0, 0.0, 0.0])
    runner.begin({}, {"pose": start, "odometry_pose": start[[0, 1, 3]], "goal": np.array([5.0, 0.0, 0.0])})

    def goal_end(index, outcome, x):
        return {"pose": np.array([x, 0.0, 0.0, 0.0]), "odometry_pose": np.array([x, 0.0, 0.0]),
                "goal_finished": True, "goal_outcome": outcome, "goal_index": index, "success": outcome == "success",
                "spl": 1.0 if outcome == "success" else 0.0, "path_length": 5.0, "geodesic": 5.0, "goal_steps": 50,
                "collisions": 0, "next_goal": np.array([10.0, 0.0, 0.0])}

    runner.observe({}, goal_end(0, "success", 5.0))
    last = goal_end(1, "tipped", 7.0)
    del last["next_goal"]
    runner.observe({}, last)
    rows = runner.finish(last)
    assert [(row.goal_index, row.outcome, row.success) for row in rows] == [
        (0, "success", True), (1, "tipped", False), (2, "not_given", False), (3, "not_given", False)]
    assert all(math.isnan(row.localisation_error_m) and row.distance_driven_m == 10.0 for row in rows[2:])
    (setting,) = summarise(rows)["settings"]
    assert setting["goals"] == 4 and setting["success_rate"] == 0.25
    assert setting["median_localisation_error_m"] == 0.0
    assert setting["localisation_error_by_goal"] == [0.0, 0.0, None, None]
    assert setting["outcomes"] == {"success": 1, "tipped": 1, "not_given": 2}
    assert setting["median_wheel_error_m"] == 0.0 and setting["not_worse_than_wheels"] == 1.0


def test_every_row_carries_the_wheels_error_on_the_same_frames(tmp_path):
    """The wheels' pose runs beside every pose source: with the wheels as the pose source the two errors are
    one; with ground truth the wheels' is what they would have read on the same drive (not zero after 2
    goals), and the summary's paired figures compare them goal by goal."""
    for pose in ("odometry", "groundtruth"):
        out = tmp_path / pose
        assert main(["nav", "gen:2", "--sequential", "2", "--episodes", "1", "--pose", pose, "--out", str(out)]) == 0
        rows = list(csv.DictReader((out / "episodes.csv").open()))
        (setting,) = json.loads((out / "summary.json").read_text())["settings"]
        wheels = [float(row["wheel_error_m"]) for row in rows]
        if pose == "odometry":
            assert wheels == [float(row["localisation_error_m"]) for row in rows]
            assert setting["plane_error_above_wheels_m"] == 0.0 and setting["not_worse_than_wheels"] == 1.0
        else:
            assert wheels[-1] > 0.0 and setting["median_wheel_error_m"] > 0.0
            assert setting["plane_error_above_wheels_m"] < 0.0 and setting["not_worse_than_wheels"] == 1.0


def test_run_episode_calls_its_recorder_after_every_step():
    """``on_step`` sees every step the runner took, with the runner's pose for it."""
    from neuroslam.lab.nav import run_episode

    world = sim.load_world("gen:2")
    seen = []
    rows = run_episode("gen:2", 0, "planner", "groundtruth", graph=DrivableGraph.of(world),
                       on_step=lambda runner, observation, info: seen.append((runner.steps, runner.pose.copy(),
                                                                             np.array(info["pose"]))))
    assert [step for step, _, _ in seen] == list(range(1, rows[0].steps + 1))
    assert all(np.array_equal(pose, truth) for _, pose, truth in seen)


def test_an_unknown_agent_is_refused_before_any_episode(tmp_path):
    assert main(["nav", "gen:2", "--agent", "nowhere:Agent", "--out", str(tmp_path)]) == 2
    assert not (tmp_path / "episodes.csv").exists()


def test_the_start_goal_sensor_reads_only_at_reset():
    env = gym.make("NeuroSLAM/PointNav-v1", world="gen:2", goal_sensor="start")
    observation, _ = env.reset(seed=0)
    assert observation["goal"][0] > 0
    observation, *_ = env.step(np.array([0.5, 0.0], dtype=np.float32))
    assert np.all(observation["goal"] == 0)
    env.close()


def test_a_vector_env_runs_the_same_episodes(tmp_path):
    """--num-envs 2: the episodes run in a gymnasium async vector env (spawned processes), each slot reset
    with its episode's own seed, so they are the episodes the single environment runs; a sequence's next
    goal reaches each slot's agent (the vector env's info keeps it only for the slots that have one)."""
    single, vector = tmp_path / "single", tmp_path / "vector"
    assert main(["nav", "gen:2", "--episodes", "3", "--sequential", "2", "--out", str(single)]) == 0
    assert main(["nav", "gen:2", "--episodes", "3", "--sequential", "2", "--num-envs", "2", "--out", str(vector)]) == 0
    rows = [list(csv.DictReader((folder / "episodes.csv").open())) for folder in (single, vector)]
    assert [(row["seed"], row["goal_index"]) for row in rows[1]] == [(str(seed), str(goal)) for seed in range(3)
                                                                     for goal in range(2)]
    for a, b in zip(*rows, strict=True):
        assert a["success"] == b["success"] and a["steps"] == b["steps"]
        assert float(a["path_length_m"]) == pytest.approx(float(b["path_length_m"]), abs=1e-9)


def _drive_kinematically(agent, pose: np.ndarray, steps: int, dt: float = 0.1) -> np.ndarray:
    """Move a pose by the agent's commands (unicycle, no physics); the pose's height never changes."""
    pose = pose.astype(float).copy()
    for _ in range(steps):
        speed, yaw_rate = agent.act({"bumper": np.array([0])}, pose)
        pose[3] += yaw_rate * dt
        pose[:2] += speed * dt * np.array([np.cos(pose[3]), np.sin(pose[3])])
    return pose


@pytest.mark.parametrize("height", [0.0, 1.2])
def test_the_planner_keeps_its_level_whatever_height_its_pose_claims(height):
    """A pose between storeys (1.2 m above the ground floor: NeuroSLAM's height after a missed ramp top)
    still reaches a goal on the ground floor of the car park, and so does the next goal planned from
    there: the planner steers in the plane on its plan's level (before, the 1.2 m pose made a
    near-vertical first step whose lookahead point lay under the robot, and it turned on the spot for
    good)."""
    world = sim.load_world("carpark")
    agent = PlannerAgent(world, DrivableGraph.of(world), 0)
    start, goal = np.array([-14.0, -12.5, height, 0.0]), np.array([-6.0, -12.5, 0.0])
    agent.reset(start, goal)
    final = _drive_kinematically(agent, start, 200)
    assert np.linalg.norm(final[:2] - goal[:2]) < 1.0
    agent.reset(final, start[:3] - [0.0, 0.0, height])  # back to the start, planned from the pose as it is
    final = _drive_kinematically(agent, final, 300)
    assert np.linalg.norm(final[:2] - start[:2]) < 1.0


def test_the_planner_plans_around_what_its_bumper_found():
    """A bump 4 m along a straight path on the car park's ground floor: the next plan keeps its nodes 0.5 m
    from the obstacle remembered 0.35 m ahead of the pose, and still ends at the goal; with no memory it
    goes straight through again."""
    world = sim.load_world("carpark")
    graph = DrivableGraph.of(world)
    start, goal = np.array([-14.0, -12.5, 0.0, 0.0]), np.array([-6.0, -12.5, 0.0])
    at_bump = np.array([-10.0, -12.5, 0.0, 0.0])
    obstacle = at_bump[:2] + [0.35, 0.0]
    gaps = {}
    for memory in (600, 0):
        agent = PlannerAgent(world, graph, 0, bump_memory=memory)
        agent.reset(start, goal)
        for k in range(agent.back_off_steps):
            agent.act({"bumper": np.array([int(k == 0)])}, at_bump)
        waypoints = agent.driver.route.waypoints
        assert np.allclose(waypoints[-1], goal)
        gaps[memory] = np.linalg.norm(waypoints[1:-1, :2] - obstacle, axis=1).min()
    assert gaps[600] >= 0.5 and gaps[0] < 0.5


def test_the_wheel_pose_leaves_out_the_steps_with_the_bumper_closed():
    """The encoders' travel in their own frame is applied to the start pose in the world; a step with the
    bumper closed (wheels spinning against a wall, here a metre and 0.3 rad) is not counted, and the next
    step's travel is taken from where the encoders then were."""
    wheels = WheelPose(np.array([1.0, 2.0, 0.5, math.pi / 2]), np.array([10.0, 0.0, 0.0]))
    np.testing.assert_allclose(wheels.step(np.array([11.0, 0.0, 0.0])), [1.0, 3.0, 0.5, math.pi / 2], atol=1e-12)
    np.testing.assert_allclose(wheels.step(np.array([12.0, 0.0, 0.3]), True), [1.0, 3.0, 0.5, math.pi / 2],
                               atol=1e-12)
    after = wheels.step(np.array([12.0 + math.cos(0.3), math.sin(0.3), 0.3]))  # a metre straight ahead
    np.testing.assert_allclose(after, [1.0, 4.0, 0.5, math.pi / 2], atol=1e-12)


def test_a_bumper_still_closed_after_backing_off_sends_the_planner_forward():
    """Backing into a wall behind keeps the bumper closed: after the back-off the planner drives forward as
    far, remembers the obstacle behind it, and then plans again."""
    world = sim.load_world("carpark")
    agent = PlannerAgent(world, DrivableGraph.of(world), 0)
    pose = np.array([-10.0, -12.5, 0.0, 0.0])
    agent.reset(pose, np.array([-6.0, -12.5, 0.0]))
    actions = [agent.act({"bumper": np.array([1])}, pose)[0] for _ in range(agent.back_off_steps)]
    actions += [agent.act({"bumper": np.array([0])}, pose)[0] for _ in range(agent.back_off_steps)]
    assert actions == pytest.approx([-0.3] * 5 + [0.3] * 5)
    (_, obstacle), = agent.bumps
    assert np.allclose(obstacle, [-10.4, -12.5, 0.0])


def test_the_planner_backs_off_when_its_bumper_closes_and_then_plans_again():
    world = sim.load_world("carpark")
    agent = PlannerAgent(world, DrivableGraph.of(world), 0)
    start, goal = np.array([-14.0, -12.5, 0.0, 0.0]), np.array([-6.0, -12.5, 0.0])
    agent.reset(start, goal)
    assert agent.act({"bumper": np.array([0])}, start)[0] > 0.5  # facing its goal: ahead
    moved = np.array([-14.0, -11.0, 0.0, 0.0])  # where its pose says it is after the bump
    actions = [agent.act({"bumper": np.array([int(k == 0)])}, moved) for k in range(5)]
    assert all(action.tolist() == pytest.approx([-0.3, 0.0]) for action in actions)
    assert np.allclose(agent.driver.route.waypoints[0], moved[:3])  # the new plan starts where it is
    assert agent.act({"bumper": np.array([0])}, moved)[0] >= 0
