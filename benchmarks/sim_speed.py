"""Speed of the testbed: milliseconds per camera frame for physics (with control) and rendering.

Run: ``python benchmarks/sim_speed.py [--frames N]``. Prints one row per world and image size; a frame
is 0.1 s of simulated time (10 Hz camera, 50 Hz control, 5 ms physics steps). Then the ``high`` visual
profile (shadows and multisampling, ``--quality high``) on the first world at 160×120 and 320×240, with its
render cost as a multiple of the ``fast`` profile's.
"""

import argparse
import statistics
import time

import sim


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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=200, help="frames measured per row (default: 200)")
    parser.add_argument("--worlds", nargs="+", default=["carpark", "urban", "building", "gen:4"])
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


if __name__ == "__main__":
    main()
