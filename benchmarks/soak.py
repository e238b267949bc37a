"""Soak test of NeuroSLAM: a long looping stream (one lap of a route replayed again and again).

Run: ``python benchmarks/soak.py [--frames 100000] [--every 10000] [--world carpark] [--route NAME]
[--noise 2] [--seed 0] [--preset sim]``. This is a measurement, not a test: it asserts nothing and is not part
of the pytest run; it prints a table and verdict lines for a person to read.

What it does:

1. Drives one lap of the world's route (default: the main route of ``carpark``, the project's default world)
   with the testbed's :class:`sim.ScriptedDrive` (what ``neuroslam record`` and ``neuroslam drive`` use: 160×120
   camera at 10 Hz, 1 m/s) and keeps the lap's frames in memory as grey uint8 images (``NeuroSLAM.step``
   turns every frame into grey levels first and accepts HxW grey uint8 as ``neuroslam run`` does for grey
   PNGs; grey frames take a third of the memory of RGB ones). The lap is cut so that it closes on itself:
   it starts once the robot has driven ``LEAD_IN`` m (past the start from rest) and ends at the frame before
   the one a route length further on, so the replay's jump from the last frame to the first is at most about
   one frame's motion; the printed "closure gap" is that jump against the true poses. An open route cannot
   close; it is replayed whole and the gap (a teleport back to the start) is printed.
   ``carpark`` rather than ``gen1:2``: a generated world is not shorter (gen1:2's main route is 293 m, carpark's
   279 m) and recording either takes only some 10-15 s against the minutes of the soak itself.
2. Feeds ``NeuroSLAM.step(image, timestamp)`` (preset ``sim``, camera only: visual odometry, no external
   odometry, as ``neuroslam run`` calls it) with the lap replayed up to ``--frames`` frames, timestamps
   increasing by the recorded frame period without a break between laps. Each frame gets small seeded
   noise (uniform integers in [-noise, noise] grey levels, default 2, clipped to 0..255), so the replays are
   not bit-identical copies of the first lap, as a real revisit never is; ``--noise 0`` replays exact copies.
   The noise is drawn outside the timed region.
3. Every ``--every`` frames prints: frames, laps, resident memory (VmRSS, MiB), templates, experiences,
   links, loop closures, ms per frame over the block (mean, p99, max), and the SLAM state's size (MiB,
   the arrays of ``NeuroSLAM.state_dict()``) split into the map (everything but the per-frame trajectory)
   and the per-frame history (one experience id and relative pose per frame, which ``trajectory()``
   needs and which grows by design, 40 bytes a frame).
4. Ends with verdict lines computed from the table: growth of templates and experiences over the second
   half of the run (on revisits the map should stop growing), ms per frame of the last block against the
   second (the first block holds the first lap's mapping), and RSS growth against the state's growth
   (memory should follow the map).

Timing is on one thread (``OMP_NUM_THREADS=1`` unless set) and wall-clock; on a shared machine other
work inflates the mean and above all the p99 and max of a block, so compare the mean across blocks and
treat a single slow block with suspicion (the load average is printed at the start and the end).
"""

from __future__ import annotations

import argparse
import logging
import math
import os
import sys
import time
from dataclasses import dataclass

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the other benchmarks time

import numpy as np
from tqdm import tqdm

from neuroslam import NeuroSLAM, presets
from neuroslam.errors import NeuroSLAMError
from neuroslam.vision.preprocessing import grey

LEAD_IN = 5.0  # m driven before the lap starts: the robot has left the start from rest and is at cruise speed
FLAT = 0.02  # growth of templates / experiences over the second half below this fraction counts as flat
SLOWER = 1.25  # last block's mean ms per frame above this times the second block's counts as slowing down
SLACK_MIB = 16.0  # RSS growth beyond the state's growth tolerated (allocator, caches) before it is flagged
HISTORY = ("slam.frame_experiences", "slam.frame_offsets")  # per-frame arrays of state_dict()


@dataclass(frozen=True)
class Lap:
    """One lap of camera frames, closed on itself."""

    images: np.ndarray  # (N, H, W) uint8 grey
    period: float  # s between frames
    world: str
    route: str
    length: float  # m, the route's length
    closed: bool  # the route is a loop, cut so that the last frame leads on to the first
    gap_m: float  # distance from where the frame after the last was taken to the first frame's place
    gap_deg: float  # the same for the heading
    seconds: float  # wall-clock time the recording took


def grey_uint8(image: np.ndarray) -> np.ndarray:
    """The grey image NeuroSLAM computes from ``image``, rounded to uint8."""
    return np.clip(np.rint(grey(image) * 255.0), 0, 255).astype(np.uint8)


def record_lap(world: str, route: str | None = None, seed: int = 0) -> Lap:
    """One lap of ``world``'s ``route`` (default: its first) driven by the testbed (see the module's doc)."""
    import sim  # importing sim selects headless rendering before mujoco loads

    started = time.perf_counter()
    drive = sim.ScriptedDrive(world, route=route, laps=2, seed=seed)
    length, loop = drive.route.length, drive.route.loop
    images, times, poses, progress = [], [], [], []
    with drive, tqdm(total=round(length + (LEAD_IN if loop else 0)), unit="m", file=sys.stderr,
                     desc=f"record {drive.world.name}/{drive.route.name}") as bar:
        for frame in drive:
            bar.update(min(round(frame.progress), bar.total) - bar.n)
            if loop and frame.progress < LEAD_IN:
                continue
            images.append(grey_uint8(frame.image))
            times.append(frame.time)
            poses.append(frame.ground_truth.pose)
            progress.append(frame.progress)
            if loop and frame.progress >= progress[0] + length:
                break
    if len(images) < 3:
        raise SystemExit(f"{world}: the drive gave only {len(images)} frames")
    if loop:
        if progress[-1] < progress[0] + length:
            raise SystemExit(f"{world}/{drive.route.name}: the drive ended before closing a lap")
        # the frame standing in for the first one on the next lap: the one whose progress is nearer a lap on
        target = progress[0] + length
        after = len(images) - 1 if progress[-1] - target <= target - progress[-2] else len(images) - 2
    else:
        after = len(images)  # an open route: replay all of it; the next lap starts back at the beginning
    period = float(np.median(np.diff(times)))
    end = poses[after] if after < len(poses) else poses[-1]
    gap_m = float(np.linalg.norm(np.asarray(end[:3]) - np.asarray(poses[0][:3])))
    gap_deg = abs(math.degrees(math.remainder(float(end[3]) - float(poses[0][3]), 2 * math.pi)))
    return Lap(np.stack(images[:after]), period, drive.world.name, drive.route.name, length, loop, gap_m, gap_deg,
               time.perf_counter() - started)


def resident_mib() -> float:
    """Resident memory of this process, MiB (VmRSS; the peak from getrusage where /proc is missing)."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # KiB on Linux (peak, not current)


def state_mib(slam: NeuroSLAM) -> tuple[float, float]:
    """(map, per-frame history) size of the SLAM state's arrays, MiB."""
    sizes = {name: np.asarray(value).nbytes for name, value in slam.state_dict().items()}
    history = sum(sizes.get(name, 0) for name in HISTORY)
    return (sum(sizes.values()) - history) / 2**20, history / 2**20


@dataclass(frozen=True)
class Row:
    frames: int
    laps: float
    rss: float  # MiB
    templates: int
    experiences: int
    links: int
    closures: int
    ms_mean: float
    ms_p99: float
    ms_max: float
    map_mib: float
    history_mib: float

    HEADER = (f"{'frames':>8} {'laps':>6} {'RSS MiB':>8} {'templates':>9} {'experiences':>11} {'links':>7} "
              f"{'closures':>8} {'ms mean':>8} {'ms p99':>7} {'ms max':>7} {'map MiB':>8} {'hist MiB':>8}")

    def __str__(self) -> str:
        return (f"{self.frames:>8} {self.laps:>6.2f} {self.rss:>8.1f} {self.templates:>9} {self.experiences:>11} "
                f"{self.links:>7} {self.closures:>8} {self.ms_mean:>8.2f} {self.ms_p99:>7.2f} {self.ms_max:>7.1f} "
                f"{self.map_mib:>8.2f} {self.history_mib:>8.2f}")


def soak(lap: Lap, frames: int, every: int, noise: int, seed: int, preset: str, out=sys.stdout) -> list[Row]:
    """Replay ``lap`` into a fresh NeuroSLAM for ``frames`` frames; a :class:`Row` every ``every`` frames."""
    slam = NeuroSLAM(presets.get(preset))
    rng = np.random.default_rng(seed)
    count = len(lap.images)
    seconds = np.empty(every)
    rows: list[Row] = []
    block = 0
    with tqdm(total=frames, unit="frame", file=sys.stderr, desc="soak", mininterval=1.0) as bar:
        for n in range(frames):
            image = lap.images[n % count]
            if noise:
                jitter = rng.integers(-noise, noise + 1, size=image.shape, dtype=np.int16)
                image = np.clip(image + jitter, 0, 255).astype(np.uint8)
            started = time.perf_counter()
            slam.step(image, n * lap.period)
            seconds[block] = time.perf_counter() - started
            block += 1
            bar.update()
            if block == every or n + 1 == frames:
                ms = 1000 * seconds[:block]
                themap = slam.experience_map
                map_mib, history_mib = state_mib(slam)
                row = Row(n + 1, (n + 1) / count, resident_mib(), slam.local_view.count, themap.size,
                          len(themap.links), themap.loop_closures, float(ms.mean()), float(np.percentile(ms, 99)),
                          float(ms.max()), map_mib, history_mib)
                rows.append(row)
                bar.write(str(row), file=out)
                out.flush()
                block = 0
    return rows


def percent(new: float, old: float) -> str:
    return f"{100 * (new - old) / old:+.1f} %" if old else "n/a"


def verdict(rows: list[Row], count: int) -> list[str]:
    """Verdict lines from the table (see the module's doc); each ends in OK or a warning in capitals."""
    last = rows[-1]
    half = min(rows, key=lambda row: abs(row.frames - last.frames / 2))  # the row nearest half-way
    if half is last:
        half = rows[0]
    span = last.frames - half.frames
    laps = span / count
    lines = []
    if half.laps < 2:
        lines.append(f"note: the reference row ({half.frames} frames, {half.laps:.1f} laps) lies within the first two "
                     "laps, where the map is still being built; run more frames for a verdict on revisits")
    for name in ("templates", "experiences", "links"):
        old, new = getattr(half, name), getattr(last, name)
        grown = new - old
        if name == "links":  # one per new experience and per loop closure between experiences not yet linked
            judgement = "not judged (a closure between two experiences not yet linked adds one)"
        else:
            judgement = "flat, OK" if old and grown <= FLAT * old else "STILL GROWING"
        per_lap = f", {grown / laps:.1f} per lap" if laps > 0 else ""
        lines.append(f"{name:<11} {half.frames} -> {last.frames} frames: {old} -> {new} ({grown:+d}, "
                     f"{percent(new, old)}{per_lap}): {judgement}")
    reference = rows[1] if len(rows) > 2 else rows[0]
    ratio = last.ms_mean / reference.ms_mean
    judgement = "flat, OK" if ratio <= SLOWER else "SLOWER (check the load average before believing it)"
    lines.append(f"ms / frame  last block {last.ms_mean:.2f} (p99 {last.ms_p99:.2f}) vs block ending at "
                 f"{reference.frames} {reference.ms_mean:.2f} (p99 {reference.ms_p99:.2f}): x{ratio:.2f}: {judgement}")
    state_growth = (last.map_mib + last.history_mib) - (half.map_mib + half.history_mib)
    rss_growth = last.rss - half.rss
    judgement = "follows the state, OK" if rss_growth <= state_growth + SLACK_MIB else \
        "RSS GROWS BEYOND THE STATE"
    lines.append(f"RSS         {half.frames} -> {last.frames} frames: {half.rss:.1f} -> {last.rss:.1f} MiB "
                 f"({rss_growth:+.1f}); state {half.map_mib + half.history_mib:.2f} -> "
                 f"{last.map_mib + last.history_mib:.2f} MiB ({state_growth:+.2f}, of which per-frame history "
                 f"{last.history_mib - half.history_mib:+.2f}): {judgement}")
    lines.append(f"RSS         whole run {rows[0].frames} -> {last.frames} frames: {rows[0].rss:.1f} -> "
                 f"{last.rss:.1f} MiB ({last.rss - rows[0].rss:+.1f})")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--frames", type=int, default=100_000, help="SLAM frames in all (default: 100000)")
    parser.add_argument("--every", type=int, default=10_000, help="frames per table row (default: 10000)")
    parser.add_argument("--world", default="carpark",
                        help="built-in world, gen:SEED or an MJCF path (default: carpark)")
    parser.add_argument("--route", help="route name (default: the world's first, its main route)")
    parser.add_argument("--noise", type=int, default=2,
                        help="per-frame image noise, uniform in [-NOISE, NOISE] grey levels; 0: exact replays "
                        "(default: 2)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the drive's sensor noise and the image noise")
    parser.add_argument("--preset", default="sim", help="NeuroSLAM parameter preset (default: sim)")
    args = parser.parse_args()
    if args.frames < 1:
        parser.error("--frames must be at least 1")
    if not 1 <= args.every <= args.frames:
        parser.error("--every must be between 1 and --frames")
    if not 0 <= args.noise <= 255:
        parser.error("--noise must be between 0 and 255 grey levels")
    try:
        presets.get(args.preset)
    except NeuroSLAMError as error:
        parser.error(str(error))
    for name in ("neuroslam", "sim"):  # the library logs map merges and drives at INFO; keep the table readable
        logging.getLogger(name).setLevel(logging.WARNING)
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")

    started = time.perf_counter()
    try:
        lap = record_lap(args.world, args.route, args.seed)
    except Exception as error:
        simulator = sys.modules.get("sim")
        if simulator is not None and isinstance(error, simulator.SimError):
            parser.error(str(error))
        raise
    count, (height, width) = len(lap.images), lap.images.shape[1:]
    print(f"soak: world {lap.world}, route {lap.route} ({lap.length:.0f} m), preset {args.preset!r}, camera only")
    print(f"lap: {count} frames of {width}x{height} grey uint8 ({lap.images.nbytes / 2**20:.0f} MiB in memory), "
          f"{1 / lap.period:g} Hz, {count * lap.period:.1f} s; recorded in {lap.seconds:.0f} s")
    if lap.closed:
        print(f"lap closes on itself: the replay jumps {lap.gap_m:.2f} m and {lap.gap_deg:.1f} deg from the last "
              "frame to the first (about one frame's motion is expected)")
    else:
        print(f"the route is open: every replay jumps {lap.gap_m:.1f} m and {lap.gap_deg:.0f} deg from its end "
              "back to its start")
    print(f"stream: {args.frames} frames ({args.frames / count:.1f} laps), noise +-{args.noise} grey levels, "
          f"seed {args.seed}; {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}, "
          f"OMP_NUM_THREADS={os.environ['OMP_NUM_THREADS']}; RSS before SLAM {resident_mib():.1f} MiB")
    print(Row.HEADER, flush=True)
    soak_started = time.perf_counter()
    rows = soak(lap, args.frames, args.every, args.noise, args.seed, args.preset)
    soaked = time.perf_counter() - soak_started
    print()
    for line in verdict(rows, count):
        print(line)
    print(f"time: soak {soaked:.0f} s ({1000 * soaked / args.frames:.2f} ms per frame with noise and bookkeeping), "
          f"total {time.perf_counter() - started:.0f} s; load average now {os.getloadavg()[0]:.2f}; wall-clock "
          "timings on a shared machine are noisy")


if __name__ == "__main__":
    main()
