"""One frame stream: a camera frame with whatever else is known at its time, from any source.

A :class:`Frame` carries an image and its time and, where the source knows them, the true pose, the wheel
odometry and an IMU reading. A *frame stream* (:class:`FrameStream`) is an iterable of frames that also
says what it is (a name for progress bars and figures, the floor heights, what a run's ``metrics.json``
should say about it). Three sources:

- :class:`DriveStream`: a scripted drive through a simulated world (:class:`sim.ScriptedDrive`);
- :class:`FolderStream`: a folder of recorded images, with the ground truth, wheel odometry and levels it
  holds (``neuroslam record`` writes such folders; your own camera's frames are one too);
- :class:`RolloutStream`: a gymnasium environment of :mod:`sim` stepped by a policy;
- :class:`MemoryStream`: frames held in memory (a drive rendered once and replayed many times, each time
  perhaps changed on the way out: noise added, frames dropped).

:class:`SelfMotionSource` is the one place that turns a frame into self-motion for each odometry mode
(``visual``: the SLAM's own visual odometry; ``wheel``: the encoders' speed and turn, the camera's pitch;
``visual-inertial``: the camera's speed and turn, the IMU's pitch). The grid-network integrator is not a
source of self-motion but a way of integrating it (``Config.integrator``), inside the SLAM.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal, Protocol, runtime_checkable

import numpy as np

from ..errors import InvalidParameterError
from ..geometry import wrap
from ..inertial import GravityPitch
from ..tum import yaw_quaternion
from ..vision.odometry import Observed, SelfMotion
from ..vision.preprocessing import grey

if TYPE_CHECKING:
    from ..slam import NeuroSLAM

__all__ = ["ODOMETRY_MODES", "DriveStream", "FolderStream", "Frame", "FrameStream", "Inertial", "MemoryStream",
           "OdometryMode", "RolloutStream", "SelfMotionSource", "Truth", "Wheels"]

OdometryMode = Literal["visual", "wheel", "visual-inertial"]
ODOMETRY_MODES: tuple[str, ...] = ("visual", "wheel", "visual-inertial")


@dataclass(frozen=True)
class Truth:
    """The true state at a frame's time.

    Attributes:
        pose: (4,) x, y, z (m) and yaw (rad) of the point under the middle of the axle, on the floor.
        quaternion: (4,) full orientation, w-x-y-z (roll and pitch included where the source knows them).
        level: index of the floor level the robot is on (nearest in height), -1 where unknown.
        velocity: (3,) m/s in the world frame, or None where unknown.
    """

    pose: np.ndarray
    quaternion: np.ndarray
    level: int = -1
    velocity: np.ndarray | None = None


@dataclass(frozen=True)
class Wheels:
    """Wheel odometry at a frame's time.

    Attributes:
        forward_speed: m/s and yaw_rate: rad/s, means since the previous frame.
        x, y: m, and yaw: rad, dead-reckoned in the odometry frame (the start's); NaN where the source
            gives only the rates (an environment's observation).
    """

    forward_speed: float
    yaw_rate: float
    x: float = math.nan
    y: float = math.nan
    yaw: float = math.nan


@dataclass(frozen=True)
class Inertial:
    """An IMU reading: body-frame angular velocity (3,), rad/s, and specific force (3,), m/s²."""

    gyro: np.ndarray
    accelerometer: np.ndarray


@dataclass(frozen=True)
class Frame:
    """One camera frame and what else is known at its time.

    Attributes:
        image: (height, width, 3) uint8 RGB, or (height, width) grey.
        time: s, increasing along a stream.
        index: frame number from 0.
        truth: the true state, or None. wheels: the wheel odometry, or None. imu: an IMU reading, or None.
        progress: how far along the stream this frame is, in the stream's :attr:`FrameStream.unit`.
    """

    image: np.ndarray
    time: float
    index: int
    truth: Truth | None = None
    wheels: Wheels | None = None
    imu: Inertial | None = None
    progress: float = 0.0


@runtime_checkable
class FrameStream(Protocol):
    """An iterable of :class:`Frame` that says what it is.

    Attributes:
        name: a short name for progress bars and figure titles ("carpark/main", a folder's name).
        unit, total: what :attr:`Frame.progress` counts ("m", "frame") and how much of it to expect.
        levels: floor heights, m, or None where unknown.
    """

    name: str
    unit: str
    total: float
    levels: tuple[float, ...] | None

    def __iter__(self) -> Iterator[Frame]: ...

    def describe(self) -> dict[str, Any]:
        """What ``metrics.json`` says about the source before the frame count ("world", "route")."""

    def summary(self) -> dict[str, Any]:
        """What ``metrics.json`` says about the source after the frame count, once iterated ("laps")."""

    def timings(self) -> dict[str, float | None]:
        """Seconds spent producing the frames, by stage ("physics", "render"; None where not measured)."""

    def map_metadata(self) -> dict[str, str]:
        """What the saved map records about where it was made."""


def _truth_of(ground_truth) -> Truth:
    """A :class:`sim.GroundTruth` as a :class:`Truth`."""
    return Truth(ground_truth.pose, np.asarray(ground_truth.quaternion, dtype=float), int(ground_truth.level),
                 np.asarray(ground_truth.velocity, dtype=float))


def _wheels_of(odometry) -> Wheels:
    """A :class:`sim.WheelOdometry` as :class:`Wheels`."""
    return Wheels(odometry.forward_speed, odometry.yaw_rate, odometry.x, odometry.y, odometry.yaw)


class DriveStream:
    """The frames of a scripted drive (:class:`sim.ScriptedDrive`): image, ground truth, wheels, IMU.

    Args:
        drive: the drive; iterating the stream runs it (once).
    """

    unit = "m"

    def __init__(self, drive) -> None:
        self.drive = drive
        self.name = f"{drive.world.name}/{drive.route.name}"
        self.total = float(int(drive.total_distance))
        self.levels = tuple(float(level) for level in drive.world.levels)

    def __iter__(self) -> Iterator[Frame]:
        for frame in self.drive:
            yield Frame(frame.image, frame.time, frame.index, _truth_of(frame.ground_truth),
                        _wheels_of(frame.odometry), Inertial(frame.imu.gyro, frame.imu.accelerometer),
                        frame.progress)

    def describe(self) -> dict[str, Any]:
        return {"world": self.drive.world.name, "route": self.drive.route.name}

    def summary(self) -> dict[str, Any]:
        return {"laps": self.drive.laps_completed}

    def timings(self) -> dict[str, float | None]:
        return {"physics": self.drive.timings["physics"], "render": self.drive.timings["render"]}

    def map_metadata(self) -> dict[str, str]:
        return {"world": self.drive.world.name, "route": self.drive.route.name}

    @property
    def title(self) -> str:
        return f"{self.drive.world.name} / {self.drive.route.name}"


class FolderStream:
    """The frames of a folder of images (``frames/`` or the folder itself, in natural order), with the
    ground truth, wheel odometry and floor heights the folder holds.

    Args:
        folder: the dataset folder. groundtruth: a TUM or CSV file of one true pose per frame, or None.
        wheel_odometry: a TUM file of the wheels' (x, y, yaw) per frame (``neuroslam record`` writes
            ``wheel_odometry.tum``), or None: speeds are its differences over the frame times.
        levels: floor heights, m (default: the folder's ``dataset.json``). rate: frames per second where
            the ground truth has no times. max_frames: stop after this many.

    Raises :class:`~neuroslam.datasets.DatasetError` for a folder, file or row count that does not fit.
    """

    unit = "frame"

    def __init__(self, folder: str | Path, *, groundtruth: str | Path | None = None,
                 wheel_odometry: str | Path | None = None, levels=None, rate: float = 10.0,
                 max_frames: int | None = None) -> None:
        from ..datasets import (
            DatasetError,
            check_frame_sizes,
            check_levels,
            frame_times,
            list_frames,
            read_description,
            read_groundtruth,
        )
        from ..evaluation import nearest_level
        from ..tum import read_tum

        self.folder = Path(folder)
        frames = list_frames(folder)
        self.description = read_description(folder)
        self.levels = check_levels(levels, "--levels") if levels is not None else self.description.levels
        truth = read_groundtruth(groundtruth) if groundtruth is not None else None
        if truth is not None and len(truth.positions) != len(frames):
            raise DatasetError(f"ground truth {str(groundtruth)!r}: {len(truth.positions)} rows for "
                               f"{len(frames)} frames (one row per frame)")
        wheels = None
        if wheel_odometry is not None:
            _, positions, quaternions = read_tum(wheel_odometry)
            if len(positions) != len(frames):
                raise DatasetError(f"wheel odometry {str(wheel_odometry)!r}: {len(positions)} rows for "
                                   f"{len(frames)} frames (one row per frame)")
            yaw = 2 * np.arctan2(quaternions[:, 3], quaternions[:, 0])
            wheels = np.column_stack([positions[:, :2], yaw])
        if max_frames is not None:
            frames = frames[:max_frames]
        self.image_size = check_frame_sizes(frames)  # (width, height), pixels
        self.paths = frames
        if truth is not None:
            truth = type(truth)(truth.positions[: len(frames)], truth.yaw[: len(frames)],
                                None if truth.times is None else truth.times[: len(frames)])
        self.times = frame_times(len(frames), truth, rate)
        self.truth = None if truth is None else truth.poses
        # each frame's floor: the level nearest the true height, as the simulator gives it (sim.World.level_of)
        self.true_levels = (None if self.truth is None or self.levels is None
                            else nearest_level(self.truth[:, 2], self.levels))
        self.wheels = None if wheels is None else wheels[: len(frames)]
        self.name = self.folder.name
        self.total = float(len(frames))
        self._read_seconds = 0.0

    def __iter__(self) -> Iterator[Frame]:
        from ..datasets import load_frame

        for index, path in enumerate(self.paths):
            started = time.perf_counter()
            image = load_frame(path)
            self._read_seconds += time.perf_counter() - started
            truth = None
            if self.truth is not None:
                pose = self.truth[index]
                level = -1 if self.true_levels is None else int(self.true_levels[index])
                truth = Truth(pose, yaw_quaternion(pose[3]), level)
            yield Frame(image, float(self.times[index]), index, truth, self._wheels_at(index), None, index + 1)

    def _wheels_at(self, index: int) -> Wheels | None:
        """The wheels at a frame: the recorded pose, and the mean speed and turn rate since the frame before
        (the chord over the time: within 0.1 % of the arc rolled at the testbed's turn rates)."""
        if self.wheels is None:
            return None
        x, y, yaw = self.wheels[index]
        if index == 0:
            return Wheels(0.0, 0.0, float(x), float(y), float(yaw))
        dt = float(self.times[index] - self.times[index - 1])
        dx, dy = self.wheels[index, :2] - self.wheels[index - 1, :2]
        turn = wrap(float(yaw - self.wheels[index - 1, 2]))
        heading = self.wheels[index - 1, 2] + turn / 2
        distance = math.copysign(math.hypot(dx, dy), dx * math.cos(heading) + dy * math.sin(heading))
        return Wheels(distance / dt if dt > 0 else 0.0, turn / dt if dt > 0 else 0.0, float(x), float(y), float(yaw))

    def describe(self) -> dict[str, Any]:
        return {"world": self.description.world or self.folder.resolve().name, "route": self.description.route}

    def summary(self) -> dict[str, Any]:
        return {}

    def timings(self) -> dict[str, float | None]:
        # recorded frames: no physics and no rendering; "read" is decoding the image files
        return {"physics": None, "render": None, "read": self._read_seconds}

    def map_metadata(self) -> dict[str, str]:
        return {"frames": str(self.folder.resolve())}

    @property
    def title(self) -> str:
        return self.folder.name


class RolloutStream:
    """The frames of a :mod:`sim` gymnasium environment stepped by a policy, until it terminates, is
    truncated, or ``steps`` frames have been taken.

    Args:
        env: an environment whose observations hold ``image`` (and ``odometry``, the wheels' speed and turn
            rate, where it has them) and whose infos hold ``time``, ``pose``, ``level`` (and
            ``odometry_pose``, the wheels' x, y, yaw).
        policy: ``policy(observation, info) -> action``.
        steps: frames at most. seed, options: passed to ``env.reset``.
    """

    unit = "frame"

    def __init__(self, env, policy: Callable[[dict, dict], Any], *, steps: int, seed: int | None = None,
                 options: dict | None = None, name: str = "rollout", levels=None) -> None:
        if not isinstance(steps, int) or steps < 1:
            raise InvalidParameterError("steps", steps, "must be an integer >= 1")
        self.env, self.policy, self.steps, self.seed, self.options = env, policy, steps, seed, options
        self.name, self.total = name, float(steps)
        self.levels = None if levels is None else tuple(float(level) for level in levels)

    @staticmethod
    def frame_of(observation, info: dict, index: int, *, time: float | None = None, image_key: str = "image",
                 odometry_key: str | None = "odometry") -> Frame:
        """One environment step's observation and info as a :class:`Frame`: the image (the observation, or
        its ``image_key`` entry), the time (``time``, else ``info["time"]``), the truth where ``info`` has
        ``pose`` (and ``level``), the wheels where the observation has ``odometry_key`` (forward speed, yaw
        rate; with ``info["odometry_pose"]``'s x, y, yaw where given)."""
        image = observation[image_key] if isinstance(observation, dict) else observation
        truth = None
        if "pose" in info:
            pose = np.asarray(info["pose"], dtype=float)
            truth = Truth(pose, yaw_quaternion(pose[3]), int(info.get("level", -1)))
        wheels = None
        if isinstance(observation, dict) and odometry_key is not None and odometry_key in observation:
            speed, yaw_rate = (float(value) for value in observation[odometry_key][:2])
            x, y, yaw = (float(value) for value in info.get("odometry_pose", (math.nan,) * 3))
            wheels = Wheels(speed, yaw_rate, x, y, yaw)
        when = float(info["time"]) if time is None else float(time)
        return Frame(np.asarray(image), when, index, truth, wheels, None, index + 1)

    def __iter__(self) -> Iterator[Frame]:
        observation, info = self.env.reset(seed=self.seed, options=self.options)
        yield self.frame_of(observation, info, 0)
        for index in range(1, self.steps):
            observation, _, terminated, truncated, info = self.env.step(self.policy(observation, info))
            yield self.frame_of(observation, info, index)
            if terminated or truncated:
                return

    def describe(self) -> dict[str, Any]:
        return {"world": self.name, "route": None}

    def summary(self) -> dict[str, Any]:
        return {}

    def timings(self) -> dict[str, float | None]:
        return {"physics": None, "render": None}

    def map_metadata(self) -> dict[str, str]:
        return {"world": self.name}

    @property
    def title(self) -> str:
        return self.name


class MemoryStream:
    """Frames held in memory, replayed as a stream, each passed through ``transform`` on the way out.

    Args:
        frames: the frames (for example ``list(DriveStream(drive))``: a drive rendered once).
        name: for progress bars and titles. levels: floor heights, m, or None.
        description: what ``metrics.json`` says about the source (default: ``{"world": name, "route": None}``).
        transform: ``transform(frame) -> frame`` (for example noise added to the image), or None.
    """

    unit = "frame"

    def __init__(self, frames: list[Frame], *, name: str = "frames", levels=None, description: dict | None = None,
                 transform: Callable[[Frame], Frame] | None = None) -> None:
        self.frames, self.name, self.transform = list(frames), name, transform
        self.levels = None if levels is None else tuple(levels)
        self.description = {"world": name, "route": None} if description is None else dict(description)
        self.total = float(len(self.frames))

    def __iter__(self) -> Iterator[Frame]:
        for frame in self.frames:
            yield frame if self.transform is None else self.transform(frame)

    def describe(self) -> dict[str, Any]:
        return dict(self.description)

    def summary(self) -> dict[str, Any]:
        return {}

    def timings(self) -> dict[str, float | None]:
        return {"physics": None, "render": None}

    def map_metadata(self) -> dict[str, str]:
        return {key: str(value) for key, value in self.description.items() if value is not None}

    @property
    def title(self) -> str:
        return self.name


@dataclass
class SelfMotionSource:
    """Turns each frame into the self-motion the SLAM integrates, for one odometry mode.

    ``visual`` returns None (the SLAM's visual odometry measures it from the image); ``wheel`` takes the
    encoders' speed and turn rate and the camera's pitch (the visual odometry still runs, for the climb);
    ``visual-inertial`` takes the camera's speed and turn rate and the pitch from the IMU's gravity
    (:class:`~neuroslam.inertial.GravityPitch`). Call it once per frame, in order.

    Raises :class:`InvalidParameterError` for an unknown mode, and for a frame without the wheels or the IMU
    its mode needs.
    """

    mode: str
    slam: NeuroSLAM
    gravity: GravityPitch = field(default_factory=GravityPitch)
    previous_time: float | None = None

    def __post_init__(self) -> None:
        if self.mode not in ODOMETRY_MODES:
            raise InvalidParameterError("odometry", self.mode, f"must be one of {', '.join(ODOMETRY_MODES)}")

    def __call__(self, frame: Frame) -> SelfMotion | None:
        dt = 0.0 if self.previous_time is None else frame.time - self.previous_time
        self.previous_time = frame.time
        if self.mode == "visual":
            return None
        odometry = self.slam.visual_odometry
        if self.mode == "visual-inertial":  # the camera for speed and turn; the IMU for the pitch
            if frame.imu is None:
                raise InvalidParameterError("odometry", self.mode, f"frame {frame.index} has no IMU reading")
            visual = odometry.step(grey(frame.image), dt)
            pitch = self.gravity.step(frame.imu.accelerometer, dt)
            seen = None if visual.observed is None else Observed(visual.observed.distance, visual.observed.yaw)
            speed = odometry.surface_speed  # along the surface: its horizontal part and climb on the IMU's pitch
            return SelfMotion(speed * math.cos(pitch), visual.yaw_rate, speed * math.sin(pitch), seen)
        if frame.wheels is None:  # encoders for speed and turn; the camera for the pitch
            raise InvalidParameterError("odometry", self.mode, f"frame {frame.index} has no wheel odometry")
        visual = odometry.step(grey(frame.image), dt)
        seen = None if visual.observed is None else Observed(height=visual.observed.height)
        speed = frame.wheels.forward_speed  # along the surface
        return SelfMotion(odometry.horizontal_speed_at(speed), frame.wheels.yaw_rate, odometry.climb_rate_at(speed),
                          seen)
