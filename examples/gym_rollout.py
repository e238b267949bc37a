"""NeuroSLAM's estimate inside a gymnasium environment, for navigation agents.

What you learn: ``NeuroSLAMWrapper`` runs NeuroSLAM on any environment whose observation holds an image and
puts the estimate into ``info`` (``slam_pose``, ``slam_experience_id``, ``slam_loop_closure``), next to the
environment's own ground truth (``info["pose"]``) that an agent must not use. Here the scripted drives'
route follower stands in for an agent (it steers by the true pose, which a real agent would not have);
the script prints how far the SLAM estimate is from the truth as the episode goes.

Run: ``python examples/gym_rollout.py`` (400 steps, about 20 s). ``NEUROSLAM_EXAMPLE_FRAMES=N`` takes N
steps (the test suite uses it; the code is the same).
"""

import math
import os

import gymnasium as gym
import numpy as np

import sim  # registers the NeuroSLAM/... environments
from neuroslam import geometry
from neuroslam.lab.wrappers import NeuroSLAMWrapper

steps = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or 400

env = NeuroSLAMWrapper(gym.make("NeuroSLAM/Drive-v0", world="carpark"))
route = env.unwrapped.route
first, second = route.waypoints[0], route.waypoints[1]
heading = math.atan2(second[1] - first[1], second[0] - first[0])
observation, info = env.reset(seed=0, options={"start": [*first, heading]})
start = np.array(info["pose"])
driver = sim.PurePursuit(route, speed=1.0)
for step in range(steps):
    action = np.array(driver.command(np.array(info["pose"][:3]), info["pose"][3]))  # m/s, rad/s
    observation, reward, terminated, truncated, info = env.step(action)
    if step % 50 == 49 or step == steps - 1:
        # the SLAM starts at its own origin facing +x: compare in the start's frame
        truth = geometry.relative(start, np.array(info["pose"]))
        error = np.linalg.norm(np.array(info["slam_pose"][:2]) - truth[:2])
        print(f"step {step + 1:4d}: experience {info['slam_experience_id']:4d}, "
              f"SLAM position error {error:.2f} m after {np.linalg.norm(truth[:2]):.1f} m from the start")
    if terminated or truncated:
        break
env.close()
