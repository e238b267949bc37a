"""neuroslam: a fast, correct implementation of NeuroSLAM, the brain-inspired 4-DoF SLAM system
(Yu, Shang, Hu and Milford 2019): 3D grid cells, multilayered head-direction cells, local view cells
and a multilayered experience map.

Example::

    from neuroslam import NeuroSLAM, presets
    slam = NeuroSLAM(presets.get("sim"))
    estimate = slam.step(image, timestamp)      # estimate.pose = (x, y, z, yaw)
"""

from . import presets
from .config import Config, load_config
from .errors import InvalidInputError, InvalidParameterError, NeuroSLAMError
from .slam import Estimate, NeuroSLAM
from .vision.odometry import SelfMotion

__version__ = "0.1.0"

__all__ = [
    "Config", "Estimate", "InvalidInputError", "InvalidParameterError", "NeuroSLAM", "NeuroSLAMError", "SelfMotion",
    "load_config", "presets",
]
