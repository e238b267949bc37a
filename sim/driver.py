"""Scripted drives: a pure-pursuit route follower and the frame stream it produces.

A :class:`ScriptedDrive` drives the robot along a route for a number of laps under physics and yields
one :class:`Frame` per camera frame: the image, the sim time, ground truth (pose, full orientation,
level), wheel odometry and the IMU. It is the testbed's *frame stream*; everything downstream consumes
an iterable of such frames.

Example::

    from sim import ScriptedDrive
    with ScriptedDrive("carpark", laps=1) as drive:
        for frame in drive:
            ...  # frame.image, frame.time, frame.ground_truth.pose, frame.odometry
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import InvalidParameterError, SimError
from .robot import CameraConfig, RobotConfig
from .simulation import GroundTruth, ImuReading, OdometryNoise, Quality, Simulation, WheelOdometry
from .world import Route, World, load_world

__all__ = ["DriveStuckError", "Frame", "PurePursuit", "ScriptedDrive"]

FINISH_TOLERANCE = 0.3  # m: a lap or route counts as done this close to its end

logger = logging.getLogger(__name__)


class DriveStuckError(SimError, RuntimeError):
    """The robot made no progress along its route for too long (blocked by geometry)."""


@dataclass(frozen=True)
class Frame:
    """One camera frame of a drive.

    Attributes:
        index: frame number from 0.
        time: simulated time, s.
        image: (height, width, 3) uint8 RGB.
        ground_truth: the true pose, orientation and level at the frame's time.
        odometry: wheel odometry at the frame's time.
        imu: IMU reading at the frame's time.
        lap: laps completed so far (see :attr:`ScriptedDrive.laps_completed`).
        progress: distance driven along the route, m (all laps).
    """

    index: int
    time: float
    image: np.ndarray
    ground_truth: GroundTruth
    odometry: WheelOdometry
    imu: ImuReading
    lap: int
    progress: float

    @property
    def timestamp(self) -> float:
        """Alias of :attr:`time`, s."""
        return self.time


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


class PurePursuit:
    """Follows a route by steering towards a point a fixed distance ahead on it.

    Progress along the route is tracked as an arc length that only searches a short window around its
    last value, so a route whose upper level passes over its lower level is never confused between them.

    Args:
        route: the route to follow.
        speed: cruise speed, m/s.
        lookahead: distance ahead of the robot's progress to steer at, m.
        max_yaw_rate: steering limit, rad/s.
    """

    def __init__(self, route: Route, *, speed: float = 1.0, lookahead: float = 1.0, max_yaw_rate: float = 2.0):
        if not math.isfinite(speed) or speed <= 0:
            raise InvalidParameterError("speed", speed, "must be a positive speed in m/s")
        if not math.isfinite(lookahead) or lookahead <= 0:
            raise InvalidParameterError("lookahead", lookahead, "must be a positive distance in m")
        self.route = route
        self.speed = speed
        self.lookahead = lookahead
        self.max_yaw_rate = max_yaw_rate
        self.progress = 0.0
        self._vertices = route.vertices
        self._cumulative = route.cumulative_length

    def _project(self, position: np.ndarray) -> float:
        """Arc length of the point of the route nearest to ``position`` within the search window.

        The window reaches 0.6 m ahead: at 2 m/s and 50 Hz control the robot moves 4 cm per call, and a
        short window cannot jump to a later part of the route that passes the same place (a loop's end
        runs along its start).
        """
        length = self.route.length
        window = np.linspace(self.progress - 0.2, self.progress + 0.6, 41)
        if not self.route.loop:
            window = np.clip(window, 0.0, length)
        points = self.route.point_at(window)
        distances = np.linalg.norm(points - position, axis=1)
        best = window[int(distances.argmin())]
        return max(self.progress, float(best))

    def command(self, position: np.ndarray, yaw: float) -> tuple[float, float]:
        """Forward speed (m/s) and yaw rate (rad/s) for the robot at ``position`` (m) heading ``yaw`` (rad)."""
        self.progress = self._project(np.asarray(position, dtype=float))
        # the target one lookahead on, and two more points a lookahead apart for the corner ahead
        ahead = self.route.point_at(self.progress + np.array([self.lookahead, 2 * self.lookahead, 3 * self.lookahead]))
        target = ahead[0]
        bearing = _wrap(math.atan2(target[1] - position[1], target[0] - position[0]) - yaw)
        # slow down in sharp turns and ahead of corners, turn on the spot when facing away
        d1, d2 = ahead[1, :2] - ahead[0, :2], ahead[2, :2] - ahead[1, :2]
        corner = abs(_wrap(math.atan2(d2[1], d2[0]) - math.atan2(d1[1], d1[0])))
        speed = self.speed * max(0.0, math.cos(bearing)) ** 2 * max(0.35, 1.0 - corner / math.pi)
        if abs(bearing) > math.pi / 2:  # target behind: turn on the spot (sin would vanish at pi)
            yaw_rate = math.copysign(0.75 * self.max_yaw_rate, bearing)
        else:
            yaw_rate = 2.0 * max(speed, 0.3) * math.sin(bearing) / self.lookahead
        return speed, float(np.clip(yaw_rate, -self.max_yaw_rate, self.max_yaw_rate))

    @property
    def finished(self) -> bool:
        """True once an open route's end is reached (loops never finish by themselves)."""
        return not self.route.loop and self.progress >= self.route.length - FINISH_TOLERANCE


class ScriptedDrive:
    """Drive a route for some laps and yield one :class:`Frame` per camera frame.

    Args:
        world: a :class:`~sim.world.World`, a world name (built-in, ``gen:SEED``) or an MJCF path.
        route: route name (default: the world's first route).
        laps: laps to drive (loops); an open route is driven once.
        speed: cruise speed, m/s.
        camera_rate: frames per simulated second, Hz.
        max_frames: stop after this many frames (None: when the laps are done).
        seed: seed of the sensor noise.
        camera, robot, noise, quality: see :class:`~sim.simulation.Simulation`.
        render: False skips the camera (``frame.image`` is then an empty array), for physics-only runs.
        stuck_timeout: simulated seconds without 0.5 m of progress before :class:`DriveStuckError`.

    Attributes:
        timings: wall-clock seconds spent in physics (with control) and in rendering so far.

    Raises:
        WorldError: unknown world, MJCF that does not compile. RouteError: unknown route, malformed route
            file, a waypoint off every floor. InvalidParameterError: a bad option.
    """

    def __init__(
        self,
        world: World | str | Path = "carpark",
        *,
        route: str | None = None,
        laps: int = 1,
        speed: float = 1.0,
        camera_rate: float = 10.0,
        max_frames: int | None = None,
        seed: int | None = 0,
        camera: CameraConfig = CameraConfig(),
        robot: RobotConfig = RobotConfig(),
        noise: OdometryNoise = OdometryNoise(),
        quality: Quality = "fast",
        render: bool = True,
        stuck_timeout: float = 20.0,
    ):
        if not isinstance(laps, int) or isinstance(laps, bool) or laps < 1:
            raise InvalidParameterError("laps", laps, "must be an integer >= 1")
        if not isinstance(camera_rate, (int, float)) or not 0.5 <= camera_rate <= 100:
            raise InvalidParameterError("camera_rate", camera_rate, "must be between 0.5 and 100 Hz")
        if max_frames is not None and (not isinstance(max_frames, int) or max_frames < 1):
            raise InvalidParameterError("max_frames", max_frames, "must be a positive integer or None")
        self.world = world if isinstance(world, World) else load_world(world)
        self.route = self.world.route(route)
        self.laps = laps
        self.camera_rate = float(camera_rate)
        self.max_frames = max_frames
        self.render = render
        self.stuck_timeout = stuck_timeout
        self.controller = PurePursuit(self.route, speed=speed, max_yaw_rate=robot.max_yaw_rate)
        x, y, z = self.route.waypoints[0]
        self.simulation = Simulation(self.world, start=(x, y, z, self.route.start_yaw), robot=robot, camera=camera,
                                     noise=noise, seed=seed, quality=quality)
        self.simulation.check_route(self.route)  # RouteError for a waypoint off every floor
        self.timings = {"physics": 0.0, "render": 0.0}  # wall-clock seconds spent so far
        self._started = False

    @property
    def laps_completed(self) -> int:
        """Whole laps driven so far (a lap counts once the robot is within 0.3 m of closing it)."""
        if not self.route.loop:
            return int(self.controller.finished)
        return int((self.controller.progress + FINISH_TOLERANCE) // self.route.length)

    @property
    def total_distance(self) -> float:
        """Route length the drive covers, m."""
        return self.route.length * (self.laps if self.route.loop else 1)

    def _frame(self, index: int, exposure: list[np.ndarray] | None = None) -> Frame:
        """The frame now; ``exposure``: renders from earlier in the shutter's open time, averaged in (motion
        blur) before the camera's noise is added."""
        simulation = self.simulation
        started = time.perf_counter()
        if not self.render:
            image = np.zeros((0, 0, 3), np.uint8)
        elif exposure:
            image = np.mean([*exposure, simulation.render(noise=False)], axis=0)
            image = simulation.camera.add_noise(np.rint(image).astype(np.uint8), simulation.camera_rng)
        else:
            image = simulation.render()
        self.timings["render"] += time.perf_counter() - started
        lap = self.laps_completed
        return Frame(index, simulation.time, image, simulation.ground_truth(), simulation.wheel_odometry(),
                     simulation.imu(), lap, self.controller.progress)

    def __iter__(self) -> Iterator[Frame]:
        if self._started:
            raise SimError("a ScriptedDrive can be iterated only once; create a new one to drive again")
        self._started = True
        simulation = self.simulation
        period = 1.0 / self.camera_rate
        control_period = simulation.substeps * simulation.model.opt.timestep
        periods_per_frame = max(1, round(period / control_period))
        # motion blur: renders at the start and the middle of the exposure, the frame's own at its end
        exposure = simulation.camera.exposure if self.render else 0.0
        open_periods = min(periods_per_frame, round(exposure / control_period)) if exposure > 0 else 0
        marks = {periods_per_frame - open_periods, periods_per_frame - open_periods // 2} if open_periods else set()
        last_progress, last_time = 0.0, 0.0
        index = 0
        try:
            yield self._frame(index)
            while self.max_frames is None or index + 1 < self.max_frames:
                started = time.perf_counter()
                samples = []
                for period_index in range(periods_per_frame):
                    if period_index in marks:
                        rendering = time.perf_counter()
                        samples.append(simulation.render(noise=False))
                        self.timings["render"] += time.perf_counter() - rendering
                        started += time.perf_counter() - rendering
                    truth = simulation.ground_truth()
                    simulation.set_command(*self.controller.command(truth.position, truth.yaw))
                    simulation.step(control_period)
                self.timings["physics"] += time.perf_counter() - started
                index += 1
                yield self._frame(index, samples)
                progress = self.controller.progress
                if progress >= self.total_distance - FINISH_TOLERANCE or self.controller.finished:
                    logger.info("drive of %r/%r done: %d frames, %.1f m, %.1f s simulated", self.world.name,
                                self.route.name, index + 1, progress, simulation.time)
                    return
                if progress - last_progress >= 0.5:
                    last_progress, last_time = progress, simulation.time
                elif simulation.time - last_time > self.stuck_timeout:
                    position = simulation.ground_truth().position.round(2).tolist()
                    raise DriveStuckError(
                        f"world={self.world.name!r} route={self.route.name!r}: robot stuck at {position} "
                        f"after {simulation.time:.1f} s, {progress:.1f} of {self.total_distance:.1f} m driven"
                    )
        finally:
            simulation.close()

    def close(self) -> None:
        """Release the renderer (also done when the iteration ends)."""
        self.simulation.close()

    def __enter__(self) -> ScriptedDrive:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
