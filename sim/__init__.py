"""The MuJoCo testbed of neuroslam: multi-level worlds, a wheeled robot, its camera, scripted drives and
gymnasium environments (``NeuroSLAM/Drive-v0``, ``NeuroSLAM/PointNav-v1``, ``NeuroSLAM/SequentialPointNav-v0``).

Importing ``sim`` selects headless rendering (``MUJOCO_GL=egl``) unless the user chose a backend already;
import it before anything imports ``mujoco``. It also asks Mesa's software rasteriser (llvmpipe, the renderer
on a machine without a GPU) to draw in the calling thread (``LP_NUM_THREADS=0``) unless that is set: at
160 × 120 its worker threads cost more in hand-overs than they save (measured: 3.8 against 3.4 ms a frame on
the car park on this project's 2-core machine); GPU drivers ignore the variable.

Example::

    import sim
    with sim.ScriptedDrive("carpark", laps=1) as drive:
        for frame in drive:
            frame.image, frame.ground_truth.pose, frame.odometry
"""

import os
import sys
import warnings

# MuJoCo picks its GL backend once, when it is imported
_MUJOCO_IMPORTED_WITHOUT_BACKEND = "mujoco" in sys.modules and "MUJOCO_GL" not in os.environ
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("LP_NUM_THREADS", "0")  # llvmpipe: render in the calling thread (see above)
if _MUJOCO_IMPORTED_WITHOUT_BACKEND:
    warnings.warn(
        "mujoco was imported before sim with MUJOCO_GL unset, so it chose its default GL backend; headless "
        "rendering will fail without a display. Import sim first or set MUJOCO_GL=egl.",
        RuntimeWarning, stacklevel=2,
    )

from gymnasium.envs.registration import register, registry  # noqa: E402

from .driver import DriveStuckError, Frame, PurePursuit, ScriptedDrive  # noqa: E402
from .errors import InvalidParameterError, RouteError, SimError, WorldError  # noqa: E402
from .robot import CameraConfig, RobotConfig  # noqa: E402
from .simulation import GroundTruth, ImuReading, OdometryNoise, Simulation, WheelOdometry  # noqa: E402
from .world import Route, World, builtin_worlds, load_world, parse_routes  # noqa: E402

__all__ = [
    "CameraConfig", "DriveStuckError", "Frame", "GroundTruth", "ImuReading", "InvalidParameterError",
    "OdometryNoise", "PurePursuit", "RobotConfig", "Route", "RouteError", "ScriptedDrive", "SimError",
    "Simulation", "WheelOdometry", "World", "WorldError", "builtin_worlds", "load_world", "parse_routes",
]

for _id, _entry_point, _steps, _kwargs in (
    ("NeuroSLAM/Drive-v0", "sim.envs:DriveEnv", 1000, {}),
    ("NeuroSLAM/PointNav-v1", "sim.envs:PointNavEnv", 1500, {}),
    # goals in a row with no reset between them; each goal is bounded by goal_steps, so no time limit
    ("NeuroSLAM/SequentialPointNav-v0", "sim.envs:PointNavEnv", None, {"goals": 50}),
):
    if _id not in registry:
        register(id=_id, entry_point=_entry_point, max_episode_steps=_steps, kwargs=_kwargs)
