"""Two mapping sessions on one world: the second starts somewhere the first never went and merges into it.

What you learn: a map outlives its session (``save``/``load``); a new session (``begin_session``) builds
a map of its own until a run of its views confirms a place of the loaded map, and then the two maps
merge in 4 DoF (``estimate.merged``) and mapping goes on in one map.

Run: ``python examples/multisession.py`` (one lap of the car park's ``west`` loop, then one of its
``ground`` loop, which starts at the north-east corner; about a minute). ``NEUROSLAM_EXAMPLE_FRAMES=N``
stops each session after N frames (the test suite uses it; the code is the same; short sessions may end
before they meet).
"""

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

import sim
from neuroslam import NeuroSLAM
from neuroslam.lab.frames import DriveStream
from neuroslam.lab.runner import run

max_frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or None


def drive(slam, route):
    """One lap of ``route``; returns the frames' true positions and the frame indices that merged maps."""
    result = run(DriveStream(sim.ScriptedDrive("carpark", route=route, laps=1, max_frames=max_frames, seed=0)),
                 slam, progress=False)
    return result.truth[:, :3], [frame for frame, _, _ in result.merges]


first = NeuroSLAM("sim")
west, _ = drive(first, "west")
path = first.save(Path(tempfile.mkdtemp()) / "west.npz")
print(f"session 1 (west): {first.experience_map.size} experiences, saved to {path}")

second = NeuroSLAM.load(path)  # continues exactly where session 1 stopped ...
second.begin_session()  # ... until a new drive starts: fresh clock and odometry, the map kept
ground, merges = drive(second, "ground")
themap = second.experience_map
print(f"session 2 (ground): merged at frames {merges}; {themap.size} experiences in "
      f"{len(set(themap.components))} map(s)")
for frame in merges:
    nearest = np.linalg.norm(west[:, :2] - ground[frame, :2], axis=1).min()
    print(f"  at the merge the robot was truly {nearest:.2f} m from session 1's path")
shutil.rmtree(path.parent)
