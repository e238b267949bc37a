"""A 20-goal patrol steered by NeuroSLAM, with the wheel odometry's error beside it.

What you learn: in the long-horizon setting (``NeuroSLAM/SequentialPointNav-v0``: goals in a row from
wherever the last one ended, nothing reset) the wheel odometry's error grows with the distance driven, and
NeuroSLAM's recognitions of places it has seen bound it. The planner steers by
:class:`neuroslam.localisation.Localiser` (the wheels, corrected only where NeuroSLAM confirms a recognised
place); on the same frames the script also integrates the wheel encoders alone (as ``neuroslam nav --pose
odometry`` does: not while the bumper is closed), and compares both with the simulator's truth at every
step. The script prints each goal's outcome and both errors, and writes
``runs/examples/long_patrol.png``: both errors against time, with the localiser's own 1σ uncertainty.

Run: ``python examples/long_patrol.py`` (20 goals on the car park, about 8,000 steps, 2–3 minutes).
``NEUROSLAM_EXAMPLE_FRAMES=N`` stops after N steps (the test suite uses it; the code is the same).
"""

import os
from pathlib import Path

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import sim  # noqa: F401 (registers the NeuroSLAM/... environments)
from neuroslam.lab.nav import EpisodeRunner, WheelPose

limit = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or 100_000
world = "carpark"
env = gym.make("NeuroSLAM/SequentialPointNav-v0", world=world, goals=20)
observation, info = env.reset(seed=0)
graph = env.unwrapped.graph
runner = EpisodeRunner(world, 0, "planner", "slam", graph=graph, world=env.unwrapped.world)
runner.begin(observation, info)
wheel_pose = WheelPose(info["pose"], info["odometry_pose"])  # the wheel encoders alone
times, slam_errors, wheel_errors, uncertainties = [], [], [], []
for _ in range(limit):
    observation, _, terminated, truncated, info = env.step(runner.act(observation))
    runner.observe(observation, info)
    truth = np.array(info["pose"])
    wheels = wheel_pose.step(info["odometry_pose"], bool(observation["bumper"][0]))
    times.append(info["time"])
    slam_errors.append(float(np.linalg.norm(runner.pose[:3] - truth[:3])))
    wheel_errors.append(float(np.linalg.norm(wheels[:3] - truth[:3])))
    uncertainties.append(runner.uncertainty)
    if info["goal_finished"]:
        print(f"goal {info['goal_index'] + 1:2d}: {info['goal_outcome']:<8} after {info['path_length']:5.1f} m; "
              f"error NeuroSLAM {slam_errors[-1]:5.2f} m, wheels {wheel_errors[-1]:5.2f} m")
    if terminated or truncated:
        break
env.close()
print(f"{len(times)} steps: final error NeuroSLAM {slam_errors[-1]:.2f} m, wheels {wheel_errors[-1]:.2f} m; "
      f"{runner.localiser.corrections} corrections, {runner.localiser.rejections} rejected")

out = Path("runs/examples")
out.mkdir(parents=True, exist_ok=True)
figure, axes = plt.subplots(figsize=(8, 4))
axes.plot(times, wheel_errors, label="wheel odometry")
axes.plot(times, slam_errors, label="NeuroSLAM (wheels + camera)")
axes.plot(times, uncertainties, ":", color="grey", label="NeuroSLAM's own 1σ")
axes.set_xlabel("time, s")
axes.set_ylabel("localisation error, m")
axes.set_title(f"{world}: a patrol of {info['goal_index'] + 1} goals")
axes.legend()
figure.tight_layout()
figure.savefig(out / "long_patrol.png", dpi=100)
print(f"wrote {out / 'long_patrol.png'}")
