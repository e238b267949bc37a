"""The wheeled robot: a differential-drive base with a forward camera, wheel encoders and an IMU.

Two driven wheels on one axle and a frictionless rear caster give three contact points, so both drive
wheels keep traction on ramps and at the kinks where ramps meet floors. The robot's frame has its origin
at the middle of the axle; x points forward, z up. Built as a PyMJCF model that the simulator attaches to
a world with a free joint.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from dm_control import mjcf

from .errors import InvalidParameterError

__all__ = ["CameraConfig", "RobotConfig", "build_robot"]


def _check_positive(owner: str, **values: float) -> None:
    for field, value in values.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise InvalidParameterError(f"{owner}.{field}", value, "must be a positive finite number")


@dataclass(frozen=True)
class RobotConfig:
    """Physical parameters of the robot.

    Attributes:
        wheel_radius: m.
        wheel_separation: distance between the wheels' contact points, m.
        max_forward_speed: limit of the commanded forward speed, m/s.
        max_yaw_rate: limit of the commanded yaw rate, rad/s.
        max_acceleration: forward acceleration limit of the drive, m/s^2.
        max_yaw_acceleration: yaw acceleration limit of the drive, rad/s^2.
        mass: chassis mass, kg (each wheel adds 0.5 kg).
        camera_height: camera above the floor, m.
        camera_forward: camera ahead of the axle, m.
    """

    wheel_radius: float = 0.1
    wheel_separation: float = 0.44
    max_forward_speed: float = 2.0
    max_yaw_rate: float = 2.0
    max_acceleration: float = 1.5
    max_yaw_acceleration: float = 6.0
    mass: float = 8.0
    camera_height: float = 0.5
    camera_forward: float = 0.1

    def __post_init__(self) -> None:
        _check_positive("robot", **{k: getattr(self, k) for k in self.__dataclass_fields__})

    def wheel_speeds(self, forward_speed: float, yaw_rate: float) -> tuple[float, float]:
        """Left and right wheel angular speeds (rad/s) for a body motion (m/s, rad/s)."""
        half = self.wheel_separation / 2
        left = (forward_speed - yaw_rate * half) / self.wheel_radius
        right = (forward_speed + yaw_rate * half) / self.wheel_radius
        return left, right


@dataclass(frozen=True)
class CameraConfig:
    """The robot's camera.

    Attributes:
        width: image width, pixels.
        height: image height, pixels.
        horizontal_fov: horizontal field of view, rad (ignored when panoramic).
        panoramic: when True, four cameras 90 degrees apart are stitched into a 360-degree strip whose
            centre column looks straight ahead and whose left edge looks straight back (bearing +pi);
            ``width`` must then be a multiple of 4.
        read_noise: grey levels (of 255): standard deviation of the Gaussian noise added to every pixel and
            channel whatever the light (a sensor's read noise); 0 for none.
        shot_noise: grey levels: standard deviation of the photon (shot) noise at full white; at intensity I
            it is shot_noise × sqrt(I / 255), so dark parts of the image are relatively noisier; 0 for none.
        exposure: seconds the shutter is open before each frame; above 0 each frame is the mean of renders at
            the start, middle and end of that time (motion blur; three times the render cost). Scripted
            drives only.
    """

    width: int = 160
    height: int = 120
    horizontal_fov: float = math.radians(80.0)
    panoramic: bool = False
    read_noise: float = 0.0
    shot_noise: float = 0.0
    exposure: float = 0.0

    def __post_init__(self) -> None:
        for field in ("width", "height"):
            value = getattr(self, field)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not 8 <= value <= 4096:
                raise InvalidParameterError(f"camera.{field}", value, "must be an integer from 8 to 4096 pixels")
        if not isinstance(self.horizontal_fov, (int, float)) or not 0.05 < self.horizontal_fov < math.pi - 0.05:
            raise InvalidParameterError("camera.horizontal_fov", self.horizontal_fov,
                                        "must be in (0.05, pi - 0.05) radians")
        for field in ("read_noise", "shot_noise", "exposure"):
            value = getattr(self, field)
            if (not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value)
                    or not 0 <= value <= (0.5 if field == "exposure" else 255)):
                limit = "0.5 s" if field == "exposure" else "255 grey levels"
                raise InvalidParameterError(f"camera.{field}", value, f"must be a number from 0 to {limit}")
        if self.panoramic and self.width % 4:
            raise InvalidParameterError("camera.width", self.width, "must be a multiple of 4 for a panoramic camera")

    @property
    def noisy(self) -> bool:
        """Any read or shot noise is added to the images."""
        return self.read_noise > 0 or self.shot_noise > 0

    def add_noise(self, image: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """``image`` (uint8 RGB) with this camera's read and shot noise drawn from ``rng``, rounded to uint8."""
        if not self.noisy:
            return image
        signal = image.astype(np.float32)
        deviation = np.sqrt(self.read_noise**2 + self.shot_noise**2 * signal / 255.0)
        noisy = signal + deviation * rng.standard_normal(image.shape, dtype=np.float32)
        return np.clip(np.rint(noisy), 0, 255).astype(np.uint8)

    @property
    def view_width(self) -> int:
        """Width of one rendered view, pixels (a quarter of the strip when panoramic)."""
        return self.width // 4 if self.panoramic else self.width

    @property
    def view_yaws(self) -> tuple[float, ...]:
        """Yaw of each rendered view relative to the robot, rad, in stitching order (left to right)."""
        return (3 * math.pi / 4, math.pi / 4, -math.pi / 4, -3 * math.pi / 4) if self.panoramic else (0.0,)

    @property
    def vertical_fov(self) -> float:
        """Vertical field of view of one view, rad."""
        horizontal = math.pi / 2 if self.panoramic else self.horizontal_fov
        return 2 * math.atan(math.tan(horizontal / 2) * self.height / self.view_width)


def build_robot(robot: RobotConfig = RobotConfig(), camera: CameraConfig = CameraConfig()) -> mjcf.RootElement:
    """The robot as a PyMJCF model (no free joint: the simulator adds it when attaching)."""
    model = mjcf.RootElement(model="robot")
    r = robot.wheel_radius
    body = model.worldbody
    # the chassis (and its centre of mass) sits behind the axle so braking downhill cannot tip it forward
    body.add("geom", name="chassis", type="box", size=[0.25, 0.16, 0.06], pos=[-0.1, 0, 0.03],
             mass=robot.mass, rgba=[0.9, 0.5, 0.1, 1])
    body.add("geom", name="mast", type="box", size=[0.02, 0.02, (robot.camera_height - r) / 2],
             pos=[robot.camera_forward - 0.04, 0, (robot.camera_height - r) / 2], mass=0.2, contype=0,
             conaffinity=0, rgba=[0.2, 0.2, 0.2, 1])
    # caster: frictionless sphere whose bottom touches the floor when the base is level
    caster_radius = 0.05
    caster = body.add("body", name="caster", pos=[-0.3, 0, caster_radius - r])
    caster.add("joint", name="caster", type="ball", damping=0.0005)
    caster.add("geom", name="caster", type="sphere", size=[caster_radius], mass=0.2, rgba=[0.2, 0.2, 0.2, 1])
    body.add("site", name="imu", pos=[0, 0, 0.05])
    body.add("site", name="base", pos=[0, 0, -r])
    for i, yaw in enumerate(camera.view_yaws):
        cx, cy = math.cos(yaw), math.sin(yaw)
        # MuJoCo cameras look along their -z axis with +y up: x-axis = right of the view direction
        body.add("camera", name=f"view{i}", pos=[robot.camera_forward, 0, robot.camera_height - r],
                 xyaxes=[cy, -cx, 0, 0, 0, 1], fovy=math.degrees(camera.vertical_fov))
    for side, y in (("left", robot.wheel_separation / 2), ("right", -robot.wheel_separation / 2)):
        wheel = body.add("body", name=f"{side}_wheel", pos=[0, y, 0])
        wheel.add("joint", name=f"{side}_wheel", type="hinge", axis=[0, 1, 0], damping=0.01, armature=0.01)
        wheel.add("geom", name=f"{side}_wheel", type="sphere", size=[r], mass=0.5, friction=[1.2, 0.01, 0.001],
                  rgba=[0.1, 0.1, 0.1, 1])
        limit = robot.max_forward_speed / r + robot.max_yaw_rate * robot.wheel_separation / (2 * r)
        model.actuator.add("velocity", name=f"{side}_wheel", joint=f"{side}_wheel", kv=4.0,
                           ctrlrange=[-limit, limit], forcerange=[-8, 8])
        model.sensor.add("jointpos", name=f"{side}_encoder", joint=f"{side}_wheel")
    model.sensor.add("gyro", name="gyro", site="imu")
    model.sensor.add("accelerometer", name="accelerometer", site="imu")
    return model
