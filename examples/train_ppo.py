"""Train a point-goal agent with a standard RL library: Stable-Baselines3's PPO on NeuroSLAM/PointNav-v1.

What you learn: the environments are plain gymnasium environments with a ``Dict`` observation (``image``
uint8 H×W×3, ``odometry``, ``goal``, ``bumper``), so Stable-Baselines3's ``MultiInputPolicy`` takes them as
they are (a CNN on the image, an MLP on the rest; SB3 moves the image's channels first itself). Run the
copies in spawned processes (``SubprocVecEnv`` with ``start_method="spawn"``: a GL context must not cross
a fork). The reward is the progress along the drivable shortest path, so it is dense from the first step.
The script trains, saves the policy into ``runs/examples/ppo_pointnav.zip`` and scores it with
``neuroslam nav``'s scores on a few seeded episodes.

Run: ``pip install "neuroslam[rl]"`` (Stable-Baselines3 and PyTorch, about 1 GB with CUDA's libraries),
then ``python examples/train_ppo.py`` (50,000 steps, about an hour on two cores; a useful agent needs
millions: it is a recipe, not a result). ``NEUROSLAM_EXAMPLE_FRAMES=N`` trains N steps (the test suite uses
it; the code is the same). Without Stable-Baselines3 it says how to install it and stops.
"""

import importlib.util
import os
import sys
from pathlib import Path

if importlib.util.find_spec("stable_baselines3") is None:
    print('this recipe needs Stable-Baselines3: pip install "neuroslam[rl]"')
    sys.exit(0)

# Triton (PyTorch's compiler, loaded late by its optimisers) and Mesa's software renderer (loaded with
# mujoco's EGL backend) each carry an LLVM; Triton loaded second crashes the process. Load it first.
if importlib.util.find_spec("triton") is not None:
    import triton  # noqa: F401

import gymnasium as gym
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import SubprocVecEnv

import sim  # noqa: F401 (registers the NeuroSLAM/... environments)


def main() -> None:
    steps = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or 50_000
    world = "gen:2"
    environments = make_vec_env("NeuroSLAM/PointNav-v1", n_envs=2, seed=0, env_kwargs={"world": world},
                                vec_env_cls=SubprocVecEnv, vec_env_kwargs={"start_method": "spawn"})
    rollout = min(256, max(steps // 2, 8))  # steps per copy between updates
    model = PPO("MultiInputPolicy", environments, n_steps=rollout, batch_size=min(64, 2 * rollout), seed=0, verbose=0)
    model.learn(total_timesteps=steps)
    environments.close()
    out = Path("runs/examples")
    out.mkdir(parents=True, exist_ok=True)
    model.save(out / "ppo_pointnav.zip")
    print(f"trained {steps} steps; saved {out / 'ppo_pointnav.zip'}")

    # score it as neuroslam nav scores an agent: seeded episodes, success and SPL
    env = gym.make("NeuroSLAM/PointNav-v1", world=world, max_episode_steps=min(steps, 300))
    for seed in range(3):
        observation, info = env.reset(seed=seed)
        done = False
        while not done:
            action, _ = model.predict(observation, deterministic=True)
            observation, _, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        outcome = info["goal_outcome"] or "timeout"
        print(f"episode {seed}: {outcome}, SPL {info['spl']:.2f}, {info['distance_to_goal']:.1f} m left of "
              f"{info['geodesic']:.1f} m")
    env.close()


if __name__ == "__main__":  # the copies run in spawned processes, which import this file again
    main()
