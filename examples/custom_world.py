"""Your own world: a two-level hall with a mezzanine and two ramps, as an MJCF string, driven and scored.

What you learn: any MJCF file of static geometry plus a routes sidecar (``NAME.routes.json``: floor
heights and waypoints, each with the floor height under it) is a world the testbed can drive and NeuroSLAM
can map; textures matter, because NeuroSLAM sees with its camera.

Run: ``python examples/custom_world.py`` (two laps of about 60 m, about 30 s).
``NEUROSLAM_EXAMPLE_FRAMES=N`` stops after N frames (the test suite uses it; the code is the same).
"""

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import sim
from neuroslam import NeuroSLAM
from neuroslam.lab.frames import DriveStream
from neuroslam.lab.runner import run

DECK = 1.5  # m, the mezzanine's floor
FOOT, TOP = 7.0, -4.0  # x of the ramps' feet (on the ground) and tops (at the mezzanine's edge)
slope = math.atan2(DECK, FOOT - TOP)
half_length = math.hypot(DECK, FOOT - TOP) / 2
quaternion = f"{math.cos(slope / 2):.6f} 0 {math.sin(slope / 2):.6f} 0"  # pitched about y: up towards -x


def ramp(name, y):
    """A 3 m wide ramp from the ground at x = FOOT up to the mezzanine at x = TOP, centred on ``y``."""
    x = (FOOT + TOP) / 2 - 0.1 * math.sin(slope)
    z = DECK / 2 - 0.1 * math.cos(slope)
    return (f'<geom name="{name}" type="box" pos="{x:.4f} {y} {z:.4f}" size="{half_length:.4f} 1.5 0.1" '
            f'quat="{quaternion}" material="ramp"/>')


landmarks = "\n".join(  # coloured boxes along the walls: something for the camera to recognise
    f'<geom type="box" pos="{x} {side * 5.8} 1.0" size="0.6 0.1 0.5" rgba="{(k * 0.37) % 1:.2f} '
    f'{(k * 0.61) % 1:.2f} {(k * 0.83) % 1:.2f} 1" contype="0" conaffinity="0"/>'
    for k, (x, side) in enumerate((x, side) for x in range(-14, 16, 3) for side in (-1, 1)))
xml = f"""<mujoco model="hall">
  <asset>
    <texture name="floor" type="2d" builtin="checker" rgb1="0.55 0.5 0.4" rgb2="0.35 0.3 0.25" width="64"
             height="64" mark="random" random="0.1" markrgb="0.9 0.9 0.9"/>
    <material name="floor" texture="floor" texrepeat="16 6" texuniform="false"/>
    <texture name="deck" type="2d" builtin="checker" rgb1="0.3 0.45 0.6" rgb2="0.2 0.3 0.4" width="64"
             height="64" mark="cross" markrgb="1 1 1"/>
    <material name="deck" texture="deck" texrepeat="6 6"/>
    <texture name="ramp" type="2d" builtin="gradient" rgb1="0.7 0.3 0.2" rgb2="0.3 0.1 0.1" width="64"
             height="64" mark="edge" markrgb="1 1 0.5"/>
    <material name="ramp" texture="ramp" texrepeat="4 1"/>
    <texture name="wall" type="2d" builtin="checker" rgb1="0.8 0.8 0.7" rgb2="0.5 0.6 0.5" width="64"
             height="64" mark="random" random="0.2" markrgb="0.2 0.2 0.2"/>
    <material name="wall" texture="wall" texrepeat="10 2"/>
  </asset>
  <worldbody>
    <light pos="0 0 12" dir="0 0 -1" diffuse="0.8 0.8 0.8"/>
    <geom name="floor" type="box" pos="0 0 -0.1" size="16 6 0.1" material="floor"/>
    <geom name="deck" type="box" pos="-10 0 {DECK - 0.1}" size="6 6 0.1" material="deck"/>
    {ramp("ramp_up", 3.5)}
    {ramp("ramp_down", -3.5)}
    <geom type="box" pos="0 6.1 2" size="16 0.1 2" material="wall"/>
    <geom type="box" pos="0 -6.1 2" size="16 0.1 2" material="wall"/>
    <geom type="box" pos="16.1 0 2" size="0.1 6 2" material="wall"/>
    <geom type="box" pos="-16.1 0 2" size="0.1 6 2" material="wall"/>
    {landmarks}
  </worldbody>
</mujoco>"""
# up the northern ramp heading west, round the mezzanine, down the southern ramp, round the ground floor
routes = {"levels": [0.0, DECK], "routes": {"main": {"loop": True, "waypoints": [
    [12.0, 3.5, 0.0], [FOOT, 3.5, 0.0], [TOP, 3.5, DECK], [-12.0, 3.5, DECK], [-12.0, -3.5, DECK],
    [TOP, -3.5, DECK], [FOOT, -3.5, 0.0], [12.0, -3.5, 0.0]]}}}

folder = Path(tempfile.mkdtemp(prefix="neuroslam-world-"))
(folder / "hall.xml").write_text(xml)
(folder / "hall.routes.json").write_text(json.dumps(routes))
world = sim.load_world(folder / "hall.xml")
print(f"world {world.name}: levels {world.levels}, route of {world.route().length:.0f} m, ramps of "
      f"{math.degrees(slope):.1f} degrees")

max_frames = int(os.environ.get("NEUROSLAM_EXAMPLE_FRAMES", "0")) or None
result = run(DriveStream(sim.ScriptedDrive(world, laps=2, max_frames=max_frames, seed=0)), NeuroSLAM("sim"))
metrics = result.metrics()
low, high = metrics["height_range_m"]
print(f"{metrics['frames']} frames over {low:.2f}..{high:.2f} m of height; levels visited "
      f"{metrics['levels_visited']}; {metrics['loop_closures']} loop closures; SLAM ATE "
      f"{metrics['ate_rmse_m']['slam']:.2f} m")
shutil.rmtree(folder)  # keep yours: hall.xml and hall.routes.json are a world like any other
