"""Run NeuroSLAM on a folder of images, as you would with your own camera.

What you learn: NeuroSLAM needs nothing from the simulator. First this script records a short drive as a
dataset (``frames/NNNNNN.png`` and ``groundtruth.tum``, what ``neuroslam record`` writes); then it reads the
folder back with the library's dataset helpers and feeds the frames to ``NeuroSLAM.step`` with their times.
Ground truth is optional: without it you still get the trajectory and the map.

Run: ``python examples/slam_on_images.py`` (one lap of the car park, about a minute).
``NEUROSLAM_EXAMPLE_FRAMES=N`` records only N frames (the test suite uses it; the code is the same).
"""

import os
import shutil
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

import sim
from neuroslam import NeuroSLAM
from neuroslam.datasets import frame_times, list_frames, load_frame, read_groundtruth
from neuroslam.evaluation import ate_rmse
from neuroslam.tum import write_tum

max_frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or None
folder = Path(tempfile.mkdtemp(prefix="neuroslam-dataset-"))

# 1. a dataset: numbered PNG frames and TUM ground truth (t x y z qx qy qz qw)
(folder / "frames").mkdir()
times, positions, quaternions = [], [], []
with sim.ScriptedDrive("carpark", laps=1, max_frames=max_frames, seed=0) as drive:
    for index, frame in enumerate(drive):
        Image.fromarray(frame.image).save(folder / "frames" / f"{index:06d}.png")
        times.append(frame.time)
        positions.append(frame.ground_truth.position)
        quaternions.append(frame.ground_truth.quaternion)
write_tum(folder / "groundtruth.tum", np.array(times), np.array(positions), np.array(quaternions))
print(f"recorded {len(times)} frames into {folder}")

# 2. your own camera's folder: frames in natural order, times from the ground truth (or a frame rate)
paths = list_frames(folder / "frames")
groundtruth = read_groundtruth(folder / "groundtruth.tum")
stamps = frame_times(len(paths), groundtruth, rate=10.0)
slam = NeuroSLAM("sim")
for path, stamp in zip(paths, stamps, strict=True):
    slam.step(load_frame(path), float(stamp))

estimate = slam.trajectory()
print(f"{slam.local_view.count} templates, {slam.experience_map.size} experiences, "
      f"{slam.experience_map.loop_closures} loop closures")
print(f"ATE (Sim(3) aligned) against the folder's ground truth: "
      f"{ate_rmse(estimate[:, :3], groundtruth.positions[: len(estimate)]):.2f} m")
shutil.rmtree(folder)  # your own data would stay, of course
