"""The NeuroSLAM gymnasium wrapper on the testbed's point-goal environment."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import sim  # noqa: F401  (registers the environments, selects headless rendering)
from neuroslam.lab.wrappers import NeuroSLAMWrapper


@pytest.mark.filterwarnings("ignore:.*different from the unwrapped version")  # checking the wrapper is the point
def test_wrapper_passes_check_env_and_reports_the_estimate():
    env = NeuroSLAMWrapper(gym.make("NeuroSLAM/PointNav-v1", world="gen:3").unwrapped, add_to_observation=True)
    try:
        check_env(env, skip_render_check=True)
        observation, info = env.reset(seed=0)
        assert observation["slam_pose"].shape == (4,) and info["slam_experience_id"] == 0
        for _ in range(20):
            observation, _, _, _, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        assert isinstance(info["slam_loop_closure"], bool)
        # driving straight ahead for 2 s: the estimate moved forward (the map frame starts at the start pose)
        assert info["slam_pose"][0] > 0.3 and abs(info["slam_pose"][1]) < 0.5
    finally:
        env.close()


def test_wrapper_can_use_the_environment_odometry():
    env = NeuroSLAMWrapper(gym.make("NeuroSLAM/Drive-v0", world="gen:3").unwrapped, odometry_key="odometry")
    try:
        env.reset(seed=1)
        for _ in range(30):
            _, _, _, _, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        travelled = np.linalg.norm(info["slam_pose"][:2])
        assert 2.0 < travelled < 3.2  # about 2.7 m in 3 s after the acceleration ramp
    finally:
        env.close()
