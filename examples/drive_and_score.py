"""Drive the two-level car park with NeuroSLAM in the loop and score it against the simulator's truth.

What you learn: the whole product in a few lines. A scripted drive is a stream of frames (camera image,
time, ground truth, wheels); the runner feeds them to NeuroSLAM one ``step`` at a time and keeps the run's
history; ``metrics()`` scores it as ``neuroslam drive`` does (the SLAM trajectory is every frame in the
final map, what SLAM evaluations score) and ``write()`` leaves every output file, the report figure too.

Run: ``python examples/drive_and_score.py`` (two laps, about a minute; writes into
``runs/examples/drive_and_score/``). ``NEUROSLAM_EXAMPLE_FRAMES=N`` stops after N frames (the test suite
uses it; the code is the same).
"""

import os
from pathlib import Path

import sim  # the testbed; import it before anything imports mujoco
from neuroslam import NeuroSLAM
from neuroslam.lab.frames import DriveStream
from neuroslam.lab.runner import run

max_frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or None
out = Path("runs") / "examples" / "drive_and_score"

stream = DriveStream(sim.ScriptedDrive("carpark", laps=2, max_frames=max_frames, seed=0))
result = run(stream, NeuroSLAM("sim"))
metrics = result.metrics()
print(f"{metrics['frames']} frames, {metrics['experiences']} experiences, {metrics['loop_closures']} loop closures "
      f"({metrics['false_loop_closures']} false)")
print(f"ATE (Sim(3) aligned): SLAM {metrics['ate_rmse_m']['slam']:.2f} m, "
      f"visual odometry {metrics['ate_rmse_m']['odometry']:.2f} m")
result.write(out)
print(f"wrote {out}/ (report.png, metrics.json, trajectories, map.npz)")
