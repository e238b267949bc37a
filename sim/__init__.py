"""The MuJoCo testbed of neuroslam: multi-level worlds, a wheeled robot, its camera, scripted drives and
gymnasium environments (``NeuroSLAM/Drive-v0``, ``NeuroSLAM/PointNav-v0``).

Importing ``sim`` selects headless rendering (``MUJOCO_GL=egl``) unless the user chose a backend already;
it must therefore be imported before anything imports ``mujoco``.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
