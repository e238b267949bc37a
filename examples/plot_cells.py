"""What NeuroSLAM's cells look like: the 3D grid cells, the multilayered head-direction cells and the map.

What you learn: the state behind each estimate is plain arrays you can look at. The grid cells are a
3-D torus of activity (x, y, z) with one packet; the head-direction cells a 2-D torus (yaw, height);
the experience map a graph of poses. The figure shows the grid-cell activity summed over height, the
head-direction activity, and the experience map with its links, after a drive up the car park's ramp.

Run: ``python examples/plot_cells.py`` (400 frames, about 15 s; writes ``runs/examples/cells.png``).
``NEUROSLAM_EXAMPLE_FRAMES=N`` drives N frames (the test suite uses it; the code is the same).
"""

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

import sim
from neuroslam import NeuroSLAM
from neuroslam.lab.frames import DriveStream
from neuroslam.lab.runner import run

frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or 400

result = run(DriveStream(sim.ScriptedDrive("carpark", laps=1, max_frames=frames, seed=0)), NeuroSLAM("sim"))
slam, estimate = result.slam, result.slam.last

figure, (grid, direction, experiences) = plt.subplots(1, 3, figsize=(13, 4))
grid.imshow(slam.grid_cells.activity.sum(axis=2).T, origin="lower", cmap="magma")
grid.set(title=f"grid cells, summed over z (packet at {estimate.grid_cell.round(1)})", xlabel="x cell",
         ylabel="y cell")
direction.imshow(slam.head_direction.activity.T, origin="lower", aspect="auto", cmap="magma")
direction.set(title="head-direction cells", xlabel="yaw cell", ylabel="height cell")
themap = slam.experience_map
for source, target in themap.links:
    experiences.plot(*themap.poses[[source, target], :2].T, color="0.7", linewidth=0.8)
points = experiences.scatter(*themap.poses[:, :2].T, c=themap.poses[:, 2], s=6, cmap="viridis")
figure.colorbar(points, ax=experiences, label="height (m)")
experiences.set(title=f"experience map ({themap.size} experiences)", xlabel="x (m)", ylabel="y (m)", aspect="equal")
figure.tight_layout()
out = Path("runs") / "examples"
out.mkdir(parents=True, exist_ok=True)
figure.savefig(out / "cells.png", dpi=80)
print(f"{frames} frames; pose {estimate.pose.round(2)}; wrote {out / 'cells.png'}")
