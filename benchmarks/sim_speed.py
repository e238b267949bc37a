"""Speed of the testbed: milliseconds per camera frame for physics (with control) and rendering.

Run: ``python benchmarks/sim_speed.py [--frames N] [--worlds ...]``. Prints one row per world and image size;
a frame is 0.1 s of simulated time (10 Hz camera, 50 Hz control, 5 ms physics steps). Then the ``high`` visual
profile (shadows and multisampling, ``--quality high``) on the first world at 160×120 and 320×240, with its
render cost as a multiple of the ``fast`` profile's. Then, for each world with a finite plane (the generated
worlds' ground, ``--planes`` names others), the fast profile's coarse plane grid against the world's own: both
grids render the same poses one after the other in one process, and the frames are compared pixel by pixel.
"""

import argparse
import copy
import statistics
import time

import mujoco
import numpy as np

import sim
from sim.simulation import compose_model


def measure(world: str, width: int, height: int, frames: int, panoramic: bool = False,
            quality: str = "fast") -> tuple[float, float]:
    """Median ms per frame of physics and of rendering over ``frames`` frames of the main route."""
    camera = sim.CameraConfig(width=width, height=height, panoramic=panoramic)
    drive = sim.ScriptedDrive(world, camera=camera, speed=1.5, max_frames=frames + 10, quality=quality)
    simulation = drive.simulation
    physics, render = [], []
    period = 0.1
    with drive:
        simulation.render()  # the first render creates the GL context
        for _ in range(frames):
            started = time.perf_counter()
            for _ in range(5):
                truth = simulation.ground_truth()
                simulation.set_command(*drive.controller.command(truth.position, truth.yaw))
                simulation.step(period / 5)
            physics.append(time.perf_counter() - started)
            started = time.perf_counter()
            simulation.render()
            render.append(time.perf_counter() - started)
    return 1000 * statistics.median(physics), 1000 * statistics.median(render)


def plane_grids(world: str, frames: int) -> tuple[float, float, int, int] | None:
    """Median ms per 160×120 frame rendered with the world's own plane grids and with the fast profile's,
    on the same poses of the main route (one frame every 2 s), and the frames that differ and their most
    differing pixels' count; None for a world without a finite plane."""
    drive = sim.ScriptedDrive(world, speed=1.5, max_frames=20 * frames + 10)
    simulation = drive.simulation
    # the high profile keeps the world's grids; the geoms are in one order
    own_sizes = compose_model(drive.world, simulation.robot, simulation.camera, "high").geom_size[:, 2]
    if np.array_equal(own_sizes, simulation.model.geom_size[:, 2]):  # no plane the fast profile coarsened
        drive.close()
        return None
    own = copy.deepcopy(simulation.model)
    own.geom_size[:, 2] = own_sizes
    height, width = simulation.camera.height, simulation.camera.view_width
    renderers = {"own": mujoco.Renderer(own, height, width), "fast": mujoco.Renderer(simulation.model, height, width)}
    times: dict[str, list[float]] = {name: [] for name in renderers}
    differing, most = 0, 0
    with drive:
        for _ in range(frames):
            for _ in range(100):
                truth = simulation.ground_truth()
                simulation.set_command(*drive.controller.command(truth.position, truth.yaw))
                simulation.step(0.02)
            images = {}
            for name, renderer in renderers.items():
                renderer.update_scene(simulation.data, camera=simulation.model.camera("robot/view0").id)
                started = time.perf_counter()
                images[name] = renderer.render()
                times[name].append(time.perf_counter() - started)
            pixels = int(np.any(images["own"] != images["fast"], axis=2).sum())
            differing += pixels > 0
            most = max(most, pixels)
    for renderer in renderers.values():
        renderer.close()
    return 1000 * statistics.median(times["own"]), 1000 * statistics.median(times["fast"]), differing, most


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=200, help="frames measured per row (default: 200)")
    parser.add_argument("--worlds", nargs="+", default=["carpark", "urban", "building", "gen:4"])
    parser.add_argument("--planes", nargs="+", default=["gen3:133", "gen3:136", "gen3:137"],
                        help="worlds for the plane-grid comparison (default: three benchmark worlds with a ground)")
    args = parser.parse_args()
    print(f"{'world':<10} {'image':<16} {'physics ms/frame':>17} {'render ms/frame':>16}")
    for world in args.worlds:
        for width, height, panoramic in ((160, 120, False), (320, 240, False), (512, 64, True)):
            physics, render = measure(world, width, height, args.frames, panoramic)
            label = f"{width}x{height}" + (" panoramic" if panoramic else "")
            print(f"{world:<10} {label:<16} {physics:>17.2f} {render:>16.2f}")
    world = args.worlds[0]
    for width, height in ((160, 120), (320, 240)):
        _, fast = measure(world, width, height, args.frames // 4)
        _, high = measure(world, width, height, args.frames // 4, quality="high")
        label = f"{width}x{height} high"
        print(f"{world:<10} {label:<16} {'':>17} {high:>16.2f}   ({high / fast:.1f} x fast: {fast:.2f})")
    frames = max(args.frames // 4, 10)
    print(f"\nplane grids, 160x120, {frames} poses a world: render ms/frame with the world's own grid and the fast"
          " profile's")
    for world in args.planes:
        measured = plane_grids(world, frames)
        if measured is None:
            print(f"{world:<10} no finite plane")
            continue
        own, fast, differing, most = measured
        print(f"{world:<10} {own:>6.2f} -> {fast:>6.2f} ms   frames differing {differing} of {frames}"
              f" (at most {most} pixels)")


if __name__ == "__main__":
    main()
