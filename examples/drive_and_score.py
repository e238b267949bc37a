"""Drive the two-level car park with NeuroSLAM in the loop and score it against the simulator's truth.

What you learn: the whole product in a few lines. A scripted drive is a stream of frames (camera image,
time, ground truth); NeuroSLAM takes one frame per ``step``; ``trajectory()`` is every frame in the final
map, which is what SLAM evaluations score; the report figure shows ground truth, odometry and the map.

Run: ``python examples/drive_and_score.py`` (two laps, about 90 s). ``NEUROSLAM_EXAMPLE_FRAMES=N`` stops
after N frames (the test suite uses it; the code is the same).
"""

import os

import numpy as np

import sim  # the testbed; import it before anything imports mujoco
from neuroslam import NeuroSLAM
from neuroslam.evaluation import ate_rmse
from neuroslam.lab.plots import plot_report

max_frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or None

slam = NeuroSLAM("sim")
truth, odometry, times, active = [], [], [], []
with sim.ScriptedDrive("carpark", laps=2, max_frames=max_frames, seed=0) as drive:
    for frame in drive:
        estimate = slam.step(frame.image, frame.time)
        truth.append(frame.ground_truth.pose)
        odometry.append(slam.odometry_pose)
        times.append(frame.time)
        active.append((estimate.template_id, estimate.experience_id))

truth, odometry, estimate = np.array(truth), np.array(odometry), slam.trajectory()
print(f"{len(times)} frames, {slam.experience_map.size} experiences, {slam.experience_map.loop_closures} loop closures")
print(f"ATE (Sim(3) aligned): SLAM {ate_rmse(estimate[:, :3], truth[:, :3]):.2f} m, "
      f"visual odometry {ate_rmse(odometry[:, :3], truth[:, :3]):.2f} m")

themap, active = slam.experience_map, np.array(active)
plot_report(truth=truth, odometry=odometry, estimate=estimate, experiences=themap.poses,
            experience_frames=np.searchsorted(times, themap.creation_times), links=themap.links,
            template_ids=active[:, 0], experience_ids=active[:, 1], times=np.array(times),
            title="carpark, 2 laps", path="drive_and_score.png")
print("wrote drive_and_score.png")
