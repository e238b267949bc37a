"""A world with the robot in it: physics, camera rendering, sensors, wheel odometry and ground truth.

The renderer is created lazily on the first :meth:`Simulation.render` (never in ``__init__``), so a
simulation can be built in one process and used in a forked worker; close it with :meth:`close` or a
``with`` block, since a renderer left to the garbage collector prints EGL errors at exit.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import dataclass, field
from typing import Literal

import mujoco  # the package's __init__ has chosen MUJOCO_GL before this runs
import numpy as np
from dm_control import mjcf

from .errors import InvalidParameterError, RouteError, SimError, WorldError
from .robot import CameraConfig, RobotConfig, build_robot
from .world import Route, World

__all__ = ["GroundTruth", "ImuReading", "OdometryNoise", "Simulation", "WheelOdometry"]

logger = logging.getLogger(__name__)

Quality = Literal["fast", "high"]

ROUTE_FLOOR_TOLERANCE = 0.5  # m: a waypoint's height may differ this much from the surface under it


@dataclass(frozen=True)
class OdometryNoise:
    """Noise of the wheel encoders and the IMU; all zero gives exact readings.

    Attributes:
        wheel_relative: standard deviation of each wheel's rotation increment, relative to the increment.
        wheel_radius_bias: systematic relative error of the (left, right) wheel radii assumed by odometry.
        gyro: standard deviation of the gyro, rad/s.
        accelerometer: standard deviation of the accelerometer, m/s^2.
    """

    wheel_relative: float = 0.02
    wheel_radius_bias: tuple[float, float] = (0.0, 0.0)
    gyro: float = 0.002
    accelerometer: float = 0.02

    def __post_init__(self) -> None:
        for name in ("wheel_relative", "gyro", "accelerometer"):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
                raise InvalidParameterError(f"noise.{name}", value, "must be a finite number >= 0")
        bias = self.wheel_radius_bias
        if len(bias) != 2 or not all(isinstance(v, (int, float)) and abs(v) < 0.5 for v in bias):
            raise InvalidParameterError("noise.wheel_radius_bias", bias, "must be two numbers in (-0.5, 0.5)")


@dataclass(frozen=True)
class GroundTruth:
    """The robot's true state from the simulator (map frame = world frame).

    Attributes:
        position: x, y, z of the point under the middle of the axle, on the floor, m.
        yaw: heading about +z, counter-clockwise from +x, rad in (-pi, pi].
        quaternion: full orientation, w-x-y-z.
        level: index of the nearest floor level.
        velocity: linear velocity in the world frame, m/s.
    """

    position: np.ndarray
    yaw: float
    quaternion: np.ndarray
    level: int
    velocity: np.ndarray

    @property
    def pose(self) -> np.ndarray:
        """(x, y, z, yaw) in m and rad."""
        return np.array([*self.position, self.yaw])

    @property
    def pitch(self) -> float:
        """Nose-up angle, rad."""
        w, x, y, z = self.quaternion
        return float(math.asin(max(-1.0, min(1.0, 2 * (x * z - w * y)))))


@dataclass(frozen=True)
class WheelOdometry:
    """Planar dead reckoning from the wheel encoders (no height: wheels cannot sense it).

    Attributes:
        x, y: position in the odometry frame (the start pose's frame, aligned with the world at start), m.
        yaw: heading, rad (unwrapped).
        distance: path length rolled by the wheels, m.
        forward_speed: mean since the previous reading (:meth:`Simulation.wheel_odometry`), m/s: the
            distance rolled since then over the time since then, so that speed × that time is the motion
            (a camera frame's, an action's), not the last control period's sampled.
        yaw_rate: mean since the previous reading, rad/s.
    """

    x: float
    y: float
    yaw: float
    distance: float
    forward_speed: float
    yaw_rate: float


@dataclass(frozen=True)
class ImuReading:
    """Body-frame angular velocity (rad/s) and specific force (m/s^2), with the configured noise."""

    gyro: np.ndarray
    accelerometer: np.ndarray


@dataclass
class _OdometryState:
    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    distance: float = 0.0
    forward_speed: float = 0.0
    yaw_rate: float = 0.0
    encoders: np.ndarray = field(default_factory=lambda: np.zeros(2))
    # since the previous reading: signed distance rolled (m), turn (rad), time (s)
    rolled: float = 0.0
    turned: float = 0.0
    elapsed: float = 0.0


def _yaw_of(quaternion: np.ndarray) -> float:
    w, x, y, z = quaternion
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _one_line(error: Exception) -> str:
    """An error's message on one line (MuJoCo's span several: the error, then the element and line)."""
    return "; ".join(line.strip() for line in str(error).splitlines() if line.strip())


# texels of the high profile's shadow map: a shadow pass per light costs in proportion to its area on a CPU
# (measured on the car park at 160 x 120 with Mesa's llvmpipe: 91 ms a frame at 4096, 41 at 2048, 25 at 1024;
# the fast profile 2.6 ms), and at 1024 a 40 m level's shadows have 4 cm texels, finer than a 320 x 240
# camera's pixels beyond a few metres
HIGH_SHADOW_SIZE = 1024

# grid cells along each side of a finite plane in the fast profile. MuJoCo draws a plane as a grid of quads
# spaced its third size apart, to refine per-vertex lighting; the generated worlds' 400 m ground at 1 m
# spacing (capped by MuJoCo) cost Mesa's llvmpipe 7-8 ms a 160 x 120 frame, half of those worlds' render
# time. At 20 cells a side the lighting is the same (their lights are directional); only where the grid's
# triangle edges fall moves, which changes a few single pixels in a drive
FAST_PLANE_GRID_CELLS = 20


def compose_model(world: World, robot: RobotConfig, camera: CameraConfig, quality: Quality) -> mujoco.MjModel:
    """Attach the robot to the world, apply the visual profile and compile.

    The integrator is set to ``implicitfast`` and the timestep to at most 5 ms, whatever the world says.

    ``fast``: no shadow map, no multisampling, lights without shadows, and a finite plane's render grid
    at most :data:`FAST_PLANE_GRID_CELLS` cells a side (a 160×120 frame in a few ms on a CPU). ``high``:
    shadows on, a 1024 shadow map (:data:`HIGH_SHADOW_SIZE`), 4× multisampling, the world's plane grids.
    """
    if quality not in ("fast", "high"):
        raise InvalidParameterError("quality", quality, "must be 'fast' or 'high'")
    try:
        if world.xml is not None:
            arena = mjcf.from_xml_string(world.xml)
        else:
            arena = mjcf.from_path(str(world.path))
    except Exception as error:  # PyMJCF raises several types for bad files
        raise WorldError(f"world={world.name!r}: cannot parse MJCF ({_one_line(error)})") from None
    attachment = arena.attach(build_robot(robot, camera))
    attachment.add("freejoint")
    # the wheels' velocity servos are stiff: only an implicit integrator keeps them stable at any timestep
    arena.option.integrator = "implicitfast"
    if arena.option.timestep is None or arena.option.timestep > 0.005:
        arena.option.timestep = 0.005
    fast = quality == "fast"
    arena.visual.quality.shadowsize = 0 if fast else HIGH_SHADOW_SIZE
    arena.visual.quality.offsamples = 0 if fast else 4
    for light in arena.find_all("light"):
        light.castshadow = not fast
    arena.visual.get_children("global").offwidth = max(640, camera.view_width)
    arena.visual.get_children("global").offheight = max(480, camera.height)
    try:
        model = mujoco.MjModel.from_xml_string(arena.to_xml_string(), arena.get_assets())
    except ValueError as composed_error:
        # MuJoCo's message names a line of the composed model; the world on its own names the user's file's
        message = _one_line(composed_error)
        try:
            if world.xml is not None:
                mujoco.MjModel.from_xml_string(world.xml)
            else:
                mujoco.MjModel.from_xml_path(str(world.path))
        except ValueError as own_error:
            message = _one_line(own_error)
        raise WorldError(f"world={world.name!r}: MuJoCo cannot compile it ({message})") from None
    model.vis.map.znear = 0.03 / max(model.stat.extent, 1e-6)  # 3 cm near plane whatever the world's size
    if fast:
        coarsen_plane_grids(model, FAST_PLANE_GRID_CELLS)
    logger.info("compiled world %r with the robot: %d geoms, %s profile", world.name, model.ngeom, quality)
    return model


# a geom group the renderer's scene option leaves out (MuJoCo shows groups 0-2 by default): geoms outside
# the view are moved there for one scene update
CULLED_GEOM_GROUP = 5


def view_frustum_normals(fovy: float, aspect: float) -> np.ndarray:
    """The inward unit normals, in the camera's frame (x right, y up, looking along -z), of the four side
    planes of a perspective view with vertical field of view ``fovy`` (degrees) and width/height ``aspect``,
    and of the plane through the camera facing forward: (5, 3). A point p is inside the view's pyramid where
    every normal · p ≥ 0."""
    vertical = math.radians(fovy) / 2
    horizontal = math.atan(math.tan(vertical) * aspect)
    ch, sh, cv, sv = math.cos(horizontal), math.sin(horizontal), math.cos(vertical), math.sin(vertical)
    return np.array([[-ch, 0.0, -sh], [ch, 0.0, -sh], [0.0, -cv, -sv], [0.0, cv, -sv], [0.0, 0.0, -1.0]])


def geoms_outside_view(positions: np.ndarray, radii: np.ndarray, camera_position: np.ndarray,
                       camera_matrix: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """Which geoms lie wholly outside a camera's view: (n,) bool, True where a geom's bounding sphere
    (``positions`` (n, 3) m in the world, ``radii`` (n,) m) is farther than its radius beyond one of the
    view's planes (:func:`view_frustum_normals`); the camera at ``camera_position`` (3,) m with orientation
    ``camera_matrix`` (9,) row-major, its columns the camera's axes. Conservative: the near and far planes
    are not used, and a zero radius (MuJoCo's for planes, which are unbounded) is never outside."""
    in_camera = (positions - camera_position) @ np.reshape(camera_matrix, (3, 3))
    return (radii > 0) & np.any(in_camera @ normals.T < -radii[:, None], axis=1)


def coarsen_plane_grids(model: mujoco.MjModel, cells: int) -> None:
    """Widen each finite plane's render-grid spacing (its third size, m) so that the grid has at most
    ``cells`` cells along either side; planes already coarser and infinite planes (a zero size) are left.

    The spacing only subdivides the plane for per-vertex lighting: physics and ray casts ignore it. Call it
    before the renderer is created (MuJoCo builds the grids with the GL context)."""
    planes = (model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE) & np.all(model.geom_size[:, :2] > 0, axis=1)
    widest = 2.0 * np.max(model.geom_size[:, :2], axis=1)
    model.geom_size[planes, 2] = np.maximum(model.geom_size[planes, 2], widest[planes] / cells)


class Simulation:
    """The robot in a world under MuJoCo physics.

    Args:
        world: the world to load (see :func:`sim.world.load_world`).
        start: initial (x, y, z, yaw) in m and rad, z being the floor height (default: the default
            route's first waypoint, facing the second).
        robot: physical parameters. camera: camera parameters.
        noise: sensor noise. seed: seed of the sensor-noise generator.
        quality: visual profile, ``fast`` (default) or ``high``.
        control_rate: rate at which commands reach the wheels and odometry integrates, Hz.
    """

    def __init__(
        self,
        world: World,
        *,
        start: tuple[float, float, float, float] | None = None,
        robot: RobotConfig = RobotConfig(),
        camera: CameraConfig = CameraConfig(),
        noise: OdometryNoise = OdometryNoise(),
        seed: int | None = 0,
        quality: Quality = "fast",
        control_rate: float = 50.0,
    ):
        if not isinstance(control_rate, (int, float)) or not 1.0 <= control_rate <= 1000.0:
            raise InvalidParameterError("control_rate", control_rate, "must be between 1 and 1000 Hz")
        self.world = world
        self.robot = robot
        self.camera = camera
        self.noise = noise
        self.model = compose_model(world, robot, camera, quality)
        self.data = mujoco.MjData(self.model)
        self.substeps = max(1, round(1.0 / (control_rate * self.model.opt.timestep)))
        self._renderer: mujoco.Renderer | None = None
        self._body = self.model.body("robot/").id
        self._root = self.model.joint(int(self.model.body_jntadr[self._body]))
        self._base_site = self.model.site("robot/base").id
        self._actuators = [self.model.actuator(f"robot/{side}_wheel").id for side in ("left", "right")]
        self._encoder_address = [self.model.sensor(f"robot/{s}_encoder").adr[0] for s in ("left", "right")]
        self._gyro_address = self.model.sensor("robot/gyro").adr[0]
        self._accelerometer_address = self.model.sensor("robot/accelerometer").adr[0]
        self._robot_bodies = {int(b) for b in np.flatnonzero(self.model.body_rootid == self._body)}
        self._collidable = (self.model.geom_contype != 0) | (self.model.geom_conaffinity != 0)
        self._cameras = [self.model.camera(f"robot/view{i}").id for i in range(len(camera.view_yaws))]
        # culling is exact only where nothing outside the view reaches the frame: no shadows, no reflections
        self._cull = quality == "fast" and not np.any(self.model.mat_reflectance > 0)
        self._frustum_normals = {view: view_frustum_normals(float(self.model.cam_fovy[view]),
                                                            camera.view_width / camera.height)
                                 for view in self._cameras}
        self._scene_option = mujoco.MjvOption()  # MuJoCo's default: geom groups 0-2 shown
        self._scene_option.geomgroup[CULLED_GEOM_GROUP] = 0
        if start is None:
            route = world.route()
            x, y, z = route.waypoints[0]
            start = (float(x), float(y), float(z), route.start_yaw)
        self.reset(start, seed=seed)

    # state ---------------------------------------------------------------------------------------------
    def reset(self, start: tuple[float, float, float, float], *, seed: int | None = 0) -> None:
        """Put the robot at rest at ``start`` = (x, y, z_floor, yaw) and restart the sensors."""
        values = np.asarray(start, dtype=float)
        if values.shape != (4,) or not np.all(np.isfinite(values)):
            raise InvalidParameterError("start", start, "must be four finite numbers (x, y, z, yaw)")
        x, y, z, yaw = values
        mujoco.mj_resetData(self.model, self.data)
        address = self._root.qposadr[0]
        self.data.qpos[address:address + 7] = [x, y, z + self.robot.wheel_radius + 0.005,
                                               math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]
        mujoco.mj_forward(self.model, self.data)
        self.rng = np.random.default_rng(seed)
        # the camera's noise from a stream of its own, so that switching it on leaves the other sensors' alone
        self.camera_rng = np.random.default_rng(None if seed is None else [seed, 0xCA3])
        self._odometry = _OdometryState(encoders=self._encoders().copy())
        self._command = np.zeros(2)  # applied (forward speed, yaw rate), slewing towards the target
        self._target = np.zeros(2)

    def _encoders(self) -> np.ndarray:
        return self.data.sensordata[self._encoder_address]

    @property
    def time(self) -> float:
        """Simulated time since reset, s."""
        return float(self.data.time)

    def set_command(self, forward_speed: float, yaw_rate: float) -> tuple[float, float]:
        """Command a forward speed (m/s) and yaw rate (rad/s), clipped to the robot's range.

        The wheels reach the command within the robot's acceleration limits. Returns the clipped command.
        Raises :class:`InvalidParameterError` on NaN or infinity.
        """
        for name, value in (("forward_speed", forward_speed), ("yaw_rate", yaw_rate)):
            if not math.isfinite(value):
                raise InvalidParameterError(name, value, "must be finite")
        v = float(np.clip(forward_speed, -self.robot.max_forward_speed, self.robot.max_forward_speed))
        w = float(np.clip(yaw_rate, -self.robot.max_yaw_rate, self.robot.max_yaw_rate))
        self._target = np.array([v, w])
        return v, w

    def step(self, duration: float) -> None:
        """Advance physics by ``duration`` seconds (rounded to whole control periods)."""
        periods = max(1, round(duration / (self.substeps * self.model.opt.timestep)))
        period = self.substeps * self.model.opt.timestep
        limits = np.array([self.robot.max_acceleration, self.robot.max_yaw_acceleration]) * period
        for _ in range(periods):
            self._command += np.clip(self._target - self._command, -limits, limits)
            self.data.ctrl[self._actuators] = self.robot.wheel_speeds(*self._command)
            mujoco.mj_step(self.model, self.data, nstep=self.substeps)
            self._integrate_odometry(period)

    def _integrate_odometry(self, period: float) -> None:
        encoders = self._encoders().copy()
        increments = encoders - self._odometry.encoders
        self._odometry.encoders = encoders
        if self.noise.wheel_relative > 0:
            increments = increments * (1 + self.rng.normal(0.0, self.noise.wheel_relative, 2))
        radii = self.robot.wheel_radius * (1 + np.asarray(self.noise.wheel_radius_bias))
        left, right = increments * radii
        distance = (left + right) / 2
        turn = (right - left) / self.robot.wheel_separation
        state = self._odometry
        heading = state.yaw + turn / 2
        state.x += distance * math.cos(heading)
        state.y += distance * math.sin(heading)
        state.yaw += turn
        state.distance += abs(distance)
        state.rolled += distance
        state.turned += turn
        state.elapsed += period

    def floor_height(self, x: float, y: float, z: float, *, reach: float = ROUTE_FLOOR_TOLERANCE) -> float | None:
        """Height of the world's surface under ``(x, y)`` within ``reach`` m of ``z``, or None.

        A vertical ray is cast down from ``z + reach`` against the geoms the robot can touch: the robot's own
        geoms and purely visual ones (no collision) are passed through, invisible colliders count.
        """
        model = self.model
        hidden = np.flatnonzero((model.geom_rgba[:, 3] == 0) & self._collidable)
        alpha = model.geom_rgba[hidden, 3].copy()
        model.geom_rgba[hidden, 3] = 1.0  # mj_ray skips transparent geoms; a hidden collider is still a floor
        try:
            start = np.array([x, y, z + reach], dtype=float)
            down = np.array([0.0, 0.0, -1.0])
            geom = np.zeros(1, dtype=np.int32)
            travelled = 0.0
            while travelled <= 2 * reach:
                distance = mujoco.mj_ray(model, self.data, start, down, None, 1, -1, geom)
                if distance < 0:
                    return None
                travelled += distance
                hit = int(geom[0])
                if self._collidable[hit] and int(model.geom_bodyid[hit]) not in self._robot_bodies:
                    return float(z + reach - travelled) if travelled <= 2 * reach else None
                start = start + down * (distance + 1e-4)  # through the robot's or a visual-only geom
                travelled += 1e-4
            return None
        finally:
            model.geom_rgba[hidden, 3] = alpha

    def check_route(self, route: Route) -> None:
        """Raise :class:`RouteError` naming the first waypoint with no floor within
        ``ROUTE_FLOOR_TOLERANCE`` m of its height (a waypoint off every floor: the robot could not drive it)."""
        for index, (x, y, z) in enumerate(route.waypoints):
            if self.floor_height(float(x), float(y), float(z)) is None:
                raise RouteError(
                    f"world={self.world.name!r} route={route.name!r}: waypoints[{index}]="
                    f"[{x:g}, {y:g}, {z:g}] is off every floor (no surface within {ROUTE_FLOOR_TOLERANCE:g} m "
                    "above or below it)")

    # sensors ---------------------------------------------------------------------------------------------
    def ground_truth(self) -> GroundTruth:
        """The robot's true pose and level now."""
        quaternion = self.data.xquat[self._body].copy()
        position = self.data.site_xpos[self._base_site].copy()
        velocity = self.data.qvel[self._root.dofadr[0]:self._root.dofadr[0] + 3].copy()
        return GroundTruth(position, _yaw_of(quaternion), quaternion, int(self.world.level_of(position[2])), velocity)

    def wheel_odometry(self) -> WheelOdometry:
        """Dead-reckoned planar pose from the wheel encoders, in the start pose's frame, with the mean speed
        and turn rate since the previous reading (a second reading at the same time repeats them)."""
        s = self._odometry
        if s.elapsed > 0:
            s.forward_speed, s.yaw_rate = s.rolled / s.elapsed, s.turned / s.elapsed
            s.rolled = s.turned = s.elapsed = 0.0
        return WheelOdometry(s.x, s.y, s.yaw, s.distance, s.forward_speed, s.yaw_rate)

    def imu(self) -> ImuReading:
        """Gyro and accelerometer readings in the body frame, with noise."""
        gyro = self.data.sensordata[self._gyro_address:self._gyro_address + 3].copy()
        accelerometer = self.data.sensordata[self._accelerometer_address:self._accelerometer_address + 3].copy()
        gyro += self.rng.normal(0.0, self.noise.gyro, 3) if self.noise.gyro else 0.0
        accelerometer += self.rng.normal(0.0, self.noise.accelerometer, 3) if self.noise.accelerometer else 0.0
        return ImuReading(gyro, accelerometer)

    def render(self, *, noise: bool = True) -> np.ndarray:
        """The camera image now: (height, width, 3) uint8 RGB, a fresh array, with the camera's read and shot
        noise (:class:`~sim.robot.CameraConfig`) unless ``noise`` is False."""
        if self._renderer is None:
            try:
                self._renderer = mujoco.Renderer(self.model, self.camera.height, self.camera.view_width)
            except mujoco.FatalError as error:
                raise SimError(
                    f"cannot create an offscreen renderer with MUJOCO_GL={os.environ.get('MUJOCO_GL')!r} ({error}); "
                    "on a machine without a display, set MUJOCO_GL=egl (or import sim before mujoco)"
                ) from None
        views = []
        for camera in self._cameras:
            self._update_scene(camera)
            views.append(self._renderer.render())
        image = views[0].copy() if len(views) == 1 else np.concatenate(views, axis=1)
        return self.camera.add_noise(image, self.camera_rng) if noise else image

    def _update_scene(self, camera: int) -> None:
        """Fill the renderer's scene for one camera, leaving out the geoms wholly outside its view (fast
        profile): they would draw no pixel, but each costs a software rasteriser its vertices and state."""
        if not self._cull:
            self._renderer.update_scene(self.data, camera=camera, scene_option=self._scene_option)
            return
        outside = geoms_outside_view(self.data.geom_xpos, self.model.geom_rbound, self.data.cam_xpos[camera],
                                     self.data.cam_xmat[camera], self._frustum_normals[camera])
        groups = self.model.geom_group.copy()
        self.model.geom_group[outside] = CULLED_GEOM_GROUP
        try:
            self._renderer.update_scene(self.data, camera=camera, scene_option=self._scene_option)
        finally:
            self.model.geom_group[:] = groups

    def warnings(self) -> dict[str, int]:
        """MuJoCo warnings raised so far, by name (empty when none)."""
        return {
            mujoco.mjtWarning(i).name: int(self.data.warning[i].number)
            for i in range(int(mujoco.mjtWarning.mjNWARNING))
            if self.data.warning[i].number
        }

    def close(self) -> None:
        """Release the renderer (its GL context); the simulation can render again afterwards."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> Simulation:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
