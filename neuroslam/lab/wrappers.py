"""A gymnasium wrapper that runs NeuroSLAM on an image-observation environment (glue: imports gymnasium).

The estimate lands in ``info`` (``slam_pose`` (x, y, z, yaw), ``slam_experience_id``,
``slam_loop_closure``) and, with ``add_to_observation=True``, in the observation as ``slam_pose``.
Frame times come from ``info["time"]`` when the environment reports it (the testbed's environments
do), otherwise from the step count and ``metadata["render_fps"]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from .. import presets
from ..config import Config
from ..errors import InvalidParameterError
from ..slam import NeuroSLAM
from .frames import RolloutStream, SelfMotionSource

__all__ = ["NeuroSLAMWrapper"]


class NeuroSLAMWrapper(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Run NeuroSLAM on every observation of ``env``.

    Args:
        env: an environment whose observation is an image or a dict holding one under ``image_key``.
        config: NeuroSLAM configuration (a Config, preset name or file; default: the ``sim`` preset).
        image_key: the image's key in a dict observation.
        odometry_key: a dict observation's (forward speed, yaw rate) entry to use as self-motion instead of
            visual odometry (the climb rate from the camera's pitch, as ``neuroslam drive --odometry wheel``),
            or None for visual odometry.
        add_to_observation: also put the estimated pose into the (dict) observation as ``slam_pose``.
    """

    def __init__(self, env: gym.Env, config: Config | str | Path | None = None, *, image_key: str = "image",
                 odometry_key: str | None = None, add_to_observation: bool = False):
        gym.utils.RecordConstructorArgs.__init__(self, config=config, image_key=image_key, odometry_key=odometry_key,
                                                 add_to_observation=add_to_observation)
        gym.Wrapper.__init__(self, env)
        space = env.observation_space
        if isinstance(space, spaces.Dict):
            for field, key in (("image_key", image_key), ("odometry_key", odometry_key)):
                if key is not None and key not in space.spaces:
                    raise InvalidParameterError(field, key, f"not a key of the observation ({', '.join(space.spaces)})")
        elif odometry_key is not None:
            raise InvalidParameterError("odometry_key", odometry_key, "needs a Dict observation space")
        image_space = space.spaces[image_key] if isinstance(space, spaces.Dict) else space
        if not isinstance(image_space, spaces.Box) or len(image_space.shape) not in (2, 3):
            raise InvalidParameterError("env", str(image_space), "must observe an image (a Box HxW or HxWx3)")
        self.slam_config = presets.resolve(config)  # a bad configuration fails here, not at the first reset
        self.image_key = image_key
        self.odometry_key = odometry_key
        self.add_to_observation = add_to_observation
        self.slam: NeuroSLAM | None = None
        self._self_motion: SelfMotionSource | None = None
        self._steps = 0
        if add_to_observation:
            if not isinstance(env.observation_space, spaces.Dict):
                raise InvalidParameterError("add_to_observation", True, "needs a Dict observation space")
            self.observation_space = spaces.Dict({
                **env.observation_space.spaces,
                "slam_pose": spaces.Box(np.array([-1e6, -1e6, -1e6, -np.pi], dtype=np.float32),
                                        np.array([1e6, 1e6, 1e6, np.pi], dtype=np.float32), dtype=np.float32),
            })

    def _time(self, info: dict[str, Any]) -> float:
        if "time" in info:
            return float(info["time"])
        return self._steps / float(self.env.metadata.get("render_fps", 10))

    def _observe(self, observation: Any, info: dict[str, Any]) -> tuple[Any, dict[str, Any]]:
        frame = RolloutStream.frame_of(observation, info, self._steps, time=self._time(info), image_key=self.image_key,
                                       odometry_key=self.odometry_key)
        estimate = self.slam.step(frame.image, frame.time, odometry=self._self_motion(frame))
        info = {**info, "slam_pose": estimate.pose.copy(), "slam_experience_id": int(estimate.experience_id),
                "slam_loop_closure": bool(estimate.loop_closure)}
        if self.add_to_observation:
            observation = {**observation, "slam_pose": estimate.pose.astype(np.float32)}
        return observation, info

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        observation, info = self.env.reset(seed=seed, options=options)
        self.slam = NeuroSLAM(self.slam_config)
        self._self_motion = SelfMotionSource("visual" if self.odometry_key is None else "wheel", self.slam)
        self._steps = 0
        return self._observe(observation, info)

    def step(self, action):
        observation, reward, terminated, truncated, info = self.env.step(action)
        self._steps += 1
        observation, info = self._observe(observation, info)
        return observation, reward, terminated, truncated, info
