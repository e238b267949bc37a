"""Can walls standing on a blank floor give the distance? Eq. G1 at each wall's foot, measured.

Run: ``python benchmarks/wall_feet.py [--worlds gen2:101 ...] [--laps 2] [--max-frames 4000] [--texture 0.02]
[--span K] [--preset sim] [--config FILE]``. A measurement, not a test: it asserts nothing and is not part of the pytest
run. About two minutes per world of 4,000 frames here (rendering, then the odometry and this cue on every frame).

The idea (a "column world", the stixel model of driver-assistance stereo vision): with the camera level, an
image column is a vertical plane through the camera, and it meets any vertical surface standing on the floor
along a vertical line, all at one depth. Where the floor below a surface is blank, the surface's foot is the
lowest row where texture starts; eq. G1 puts that row at the depth D = f h / (v_foot - c_v), and the whole
surface above it, in that column, at the same depth. A pixel (u, v) of it is the point (D + a, -(u - c_u) D / f)
on the ground plan at the height making eq. G1 hold with

    eta(v) = (v - c_v) D / f    in place of the camera height h                                (W1)

(eta = h at the foot itself; negative above the horizon). The robot's motion (d, w) then warps it by eqs. G2 and
G1 as it warps a floor pixel, and eq. G3's Gauss–Newton solves (d, w) over these pixels: a metric distance from
the walls, where the floor itself has nothing to align. Each column's foot is the lowest row below the horizon
that is textured (image gradient above ``--texture`` per pixel, blurred as eq. G3's images are), whose rows up
to halfway to the horizon are at least half textured (a wall's face, not a line on the floor), and below which
the floor is at least 90 % blank; it is refined to the centroid of the vertical gradient around it. The
surface is taken from its foot up to as many rows above the horizon as the foot lies below it (up to 2 h above
the floor: walls, pillars and furniture, not the ceiling beyond them). Columns without such a foot are left out.

What it prints, per world: the odometry's own distance source on each frame (``Observed.distance``: floor,
ceiling, held, none) and, for the frames of each, how many this cue sees (its information on the distance at
least 0.3 or 3 times eq. G3's prior weight) and the ratio of its summed distance to the true one, with the
10th and 90th percentiles of the per-frame ratio on moving frames. It solves each frame twice: from rest
with a tenth of eq. G3's prior weight (what the walls alone say), and from the odometry's own distance (the
held speed where blind) with the full weight (what it would add to the odometry). First, a synthetic check:
a blank floor between textured walls (``tests/scenes.py``), 6 m straight, where the cue must read the truth.

With ``--span K`` (K > 1) it measures the walls over a longer baseline instead: each frame against the frame K
earlier, the distance found by a search, not by Gauss–Newton from rest: eq. G3's robust cost (Huber, over the
pixels in view at every candidate) at 48 distances from 0 to ``max_speed`` K dt, the turn held at the
odometry's own summed over the K frames, the least refined by a parabola through its neighbours; its
information is eq. G3's Gauss–Newton term on d at that distance, in the prior's weights. Why: the testbed's
default (``fast``) render has no anti-aliasing, so a wall's foot, the sharpest thing on a blank floor, moves
in whole pixels (at 5 m a robot at 1 m/s moves it 0.2 px a frame: it stands still for four frames and jumps
one pixel in the fifth), and a frame's alignment from rest sees no motion or a jump beyond its reach. It
prints the same rows with the odometry's own distance over the same frames beside the cue's.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from pathlib import Path

import numpy as np
from sensitivity import record
from tqdm import tqdm

from neuroslam import presets
from neuroslam.config import load_config
from neuroslam.vision.ground_motion import _PRIOR_DISTANCE, _PRIOR_TURN, GroundMotion, sample_bilinear
from neuroslam.vision.odometry import VisualOdometry
from neuroslam.vision.preprocessing import grey

RUN = 0.5  # least share of textured pixels in the rows above a foot (up to halfway to the horizon)
BLANK = 0.1  # largest share of textured pixels on the floor below a foot
SEES = (0.3, 3.0)  # information on the distance, in eq. G3's prior weights, from which the cue counts as seeing


def feet(image: np.ndarray, centre_v: float, texture: float) -> np.ndarray:
    """Per column of ``image`` (3, rows, columns: blurred, gradients), its wall's foot row (sub-pixel), or -1."""
    _, gradient_u, gradient_v = image
    rows, columns = gradient_u.shape
    textured = (np.hypot(gradient_u, gradient_v) > texture).astype(np.int32)
    row = np.arange(rows)
    below = np.zeros_like(textured)
    below[:-1] = np.cumsum(textured[::-1], axis=0)[::-1][1:]  # textured pixels in the rows below each row
    rows_below = (rows - 1 - row)[:, None]
    blank_below = below <= BLANK * np.maximum(rows_below, 1)
    window = np.maximum(4, (0.5 * (row - centre_v)).astype(int))
    first = np.maximum(row - window, 0)
    cumulative = np.cumsum(textured, axis=0)
    above = cumulative[row] - np.where((first > 0)[:, None], cumulative[np.maximum(first - 1, 0)], 0)
    candidate = (textured > 0) & (above >= RUN * (row - first + 1)[:, None]) & blank_below
    candidate &= rows_below >= max(2, rows // 12)  # some floor must show below it
    candidate[: int(math.ceil(centre_v)) + 1] = False
    foot = np.full(columns, -1.0)
    has = candidate.any(axis=0)
    lowest = rows - 1 - np.argmax(candidate[::-1], axis=0)
    column = np.flatnonzero(has)
    around = np.clip(lowest[has][:, None] + np.arange(-3, 2)[None, :], 0, rows - 1)
    weight = np.abs(gradient_v[around, column[:, None]])
    foot[has] = (around * weight).sum(axis=1) / np.maximum(weight.sum(axis=1), 1e-9)
    return foot


def surfaces(ground: GroundMotion, image: np.ndarray, texture: float):
    """Eq. W1's pixels of one pyramid level: focal length, centre, flat indices, ground points q, heights eta."""
    rows, columns = image.shape[1:]
    focal = (columns / 2) / math.tan(ground.horizontal_fov / 2)
    centre_u, centre_v = columns / 2 - 0.5, rows / 2 - 0.5
    foot = feet(image, centre_v, texture)
    step = 2 if columns > 100 else 1
    u_all, v_all, depth_all = [], [], []
    for u in range(1, columns - 1, step):
        if foot[u] < 0:
            continue
        depth = ground.camera_height * focal / (foot[u] - centre_v)
        v = np.arange(max(1, int(math.floor(2 * centre_v - foot[u]))), int(math.floor(foot[u])) + 1)
        u_all.append(np.full(len(v), u))
        v_all.append(v)
        depth_all.append(np.full(len(v), depth))
    if not u_all:
        return None
    u, v, depth = np.concatenate(u_all), np.concatenate(v_all), np.concatenate(depth_all)
    ground_points = np.stack([depth + ground.camera_forward, -(u - centre_u) * depth / focal])
    return focal, centre_u, centre_v, v * columns + u, ground_points, (v - centre_v) * depth / focal


def wall_motion(
    ground: GroundMotion,
    previous: list,
    current: list,
    prior: tuple[float, float],
    texture: float,
    prior_scale: float = 1.0,
) -> tuple[float, float]:
    """(d, information on d in eq. G3's prior weights) from eq. W1's pixels, coarse to fine from ``prior``."""
    distance, turn = prior
    unit = (ground.robust_scale / _PRIOR_DISTANCE) ** 2
    weight_distance, weight_turn = unit * prior_scale, (ground.robust_scale / _PRIOR_TURN) ** 2 * prior_scale
    information = 0.0
    for old, new in zip(previous, current, strict=True):
        found = surfaces(ground, new, texture)
        if found is None:
            return distance, 0.0
        focal, centre_u, centre_v, indices, (qx, qy), eta = found
        rows, columns = old.shape[1:]
        target = new[0].ravel()[indices]
        for _ in range(ground.iterations):
            c, s, ch, sh = math.cos(turn), math.sin(turn), math.cos(turn / 2), math.sin(turn / 2)
            px, py = distance * ch + c * qx - s * qy, distance * sh + s * qx + c * qy  # eq. G2
            inverse = 1.0 / np.maximum(px - ground.camera_forward, 0.2)
            u, v = centre_u - focal * py * inverse, centre_v + focal * eta * inverse  # eqs. G1, W1
            visible = (
                (px - ground.camera_forward > 0.2) & (u >= 0) & (u <= columns - 1.001) & (v >= 0) & (v <= rows - 1.001)
            )
            intensity, gradient_u, gradient_v = sample_bilinear(old, u, v)
            residual = intensity - target
            d_py = -focal * gradient_u * inverse
            d_px = -(d_py * py + focal * eta * gradient_v * inverse) * inverse
            j_turn = d_px * (-distance / 2 * sh - s * qx - c * qy) + d_py * (distance / 2 * ch + c * qx - s * qy)
            j_distance = d_px * ch + d_py * sh
            weight = ground.robust_scale / np.maximum(np.abs(residual), ground.robust_scale) * visible
            wd, wt = weight * j_distance, weight * j_turn
            a11, a12, a22 = float(wd @ j_distance), float(wd @ j_turn), float(wt @ j_turn)
            information = a11 / unit
            b1 = float(wd @ residual) + weight_distance * (distance - prior[0])
            b2 = float(wt @ residual) + weight_turn * (turn - prior[1])
            n11, n22 = a11 + weight_distance, a22 + weight_turn
            determinant = n11 * n22 - a12 * a12
            step_distance, step_turn = -(n22 * b1 - a12 * b2) / determinant, -(n11 * b2 - a12 * b1) / determinant
            distance, turn = distance + step_distance, turn + step_turn
            if abs(step_distance) < 1e-4 and abs(step_turn) < 1e-5:
                break
    return float(distance), information


def _odometry(config) -> VisualOdometry:
    """The configuration's visual odometry, with its camera's fields of view."""
    return VisualOdometry(config.odometry, horizontal_fov=config.horizontal_fov, vertical_fov=config.vertical_fov,
                          panoramic=config.panoramic)


def span_distance(ground: GroundMotion, old: np.ndarray, new: np.ndarray, turn: float, max_distance: float,
                  texture: float, candidates: int = 48) -> tuple[float, float]:
    """(d m, information on d in eq. G3's prior weights) from eq. W1's pixels of one pyramid level ``new`` (3,
    rows, columns) against ``old``, by a search over d in [0, ``max_distance``] at the turn ``turn`` (rad)."""
    found = surfaces(ground, new, texture)
    if found is None:
        return 0.0, 0.0
    focal, centre_u, centre_v, indices, (qx, qy), eta = found
    rows, columns = old.shape[1:]
    target = new[0].ravel()[indices]
    grid = np.linspace(0.0, max_distance, candidates)
    c, s, ch, sh = math.cos(turn), math.sin(turn), math.cos(turn / 2), math.sin(turn / 2)
    px = grid[:, None] * ch + (c * qx - s * qy)[None]  # eq. G2 at every candidate
    py = grid[:, None] * sh + (s * qx + c * qy)[None]
    inverse = 1.0 / np.maximum(px - ground.camera_forward, 0.2)
    u, v = centre_u - focal * py * inverse, centre_v + focal * eta[None] * inverse  # eqs. G1, W1
    visible = (px - ground.camera_forward > 0.2) & (u >= 0) & (u <= columns - 1.001) & (v >= 0) & (v <= rows - 1.001)
    sampled = sample_bilinear(old, u.ravel(), v.ravel())
    intensity, gradient_u, gradient_v = (values.reshape(u.shape) for values in sampled)
    residual, scale = np.abs(intensity - target[None]), ground.robust_scale
    both = visible.all(axis=0)  # the pixels in view at every candidate: costs over one set of pixels
    if both.sum() < 50:
        return 0.0, 0.0
    huber = np.where(residual < scale, 0.5 * residual**2, scale * residual - 0.5 * scale**2)
    cost = huber[:, both].sum(axis=1)
    best = int(cost.argmin())
    distance = float(grid[best])
    if 0 < best < candidates - 1:
        curvature = cost[best - 1] - 2 * cost[best] + cost[best + 1]
        if curvature > 0:
            distance += 0.5 * (cost[best - 1] - cost[best + 1]) / curvature * (grid[1] - grid[0])
    d_py = -focal * gradient_u[best] * inverse[best]
    d_px = -(d_py * py[best] + focal * eta * gradient_v[best] * inverse[best]) * inverse[best]
    jacobian = d_px * ch + d_py * sh
    weight = scale / np.maximum(residual[best], scale) * both
    return distance, float((weight * jacobian * jacobian).sum()) / (scale / _PRIOR_DISTANCE) ** 2


def measure_span(config, images: list[np.ndarray], times: np.ndarray, poses: np.ndarray, texture: float,
                 span: int) -> list[str]:
    """Per odometry distance source: the walls over ``span`` frames (:func:`span_distance`) against the truth
    and against the odometry's own distance over the same frames."""
    odometry = _odometry(config)
    finest, turns, taken, sources = [], [], [], []
    rows = []
    for index, image in enumerate(tqdm(images, desc="odometry", leave=False)):
        dt = 0.0 if index == 0 else float(times[index] - times[index - 1])
        motion = odometry.step(grey(image), dt)
        finest.append(odometry._ground.pyramid[-1])
        turns.append(motion.yaw_rate * dt)
        taken.append(motion.forward_speed * dt)
        sources.append(motion.observed.distance if motion.observed is not None else "")
        if index < span:
            continue
        if index > span:
            finest[index - span - 1] = None  # keep the last span + 1 images only
        truth = float(np.linalg.norm(poses[index, :2] - poses[index - span, :2]))
        reach = config.odometry.max_speed * float(times[index] - times[index - span])
        turn = float(np.sum(turns[index - span + 1: index + 1]))
        distance, information = span_distance(odometry._ground, finest[index - span], finest[index], turn, reach,
                                              texture)
        rows.append((sources[index], truth, distance, information, float(np.sum(taken[index - span + 1: index + 1]))))
    sources_ = np.array([row[0] for row in rows])
    values = np.array([row[1:] for row in rows], dtype=float)
    lines = []
    for source in ("floor", "ceiling", "image", "held", "none"):
        frames = sources_ == source
        if not frames.any():
            continue
        parts = [f"{source:8} {int(frames.sum()):5d} frames"]
        for least in (1.0, *SEES[1:]):
            moving = frames & (values[:, 2] >= least) & (values[:, 0] > 0.03 * span)
            if not moving.any():
                parts.append(f"sees ≥ {least}: none")
                continue
            ratio = values[moving, 1] / values[moving, 0]
            parts.append(
                f"sees ≥ {least}: {int(moving.sum())} frames, {values[moving, 1].sum() / values[moving, 0].sum():.3f} "
                f"of the truth (10th–90th {np.percentile(ratio, 10):.2f}–{np.percentile(ratio, 90):.2f}, within 15 %: "
                f"{np.mean(np.abs(ratio - 1) < 0.15):.0%}); the odometry "
                f"{values[moving, 3].sum() / values[moving, 0].sum():.3f}"
            )
        lines.append("\n    ".join(parts))
    return lines


def synthetic(texture: float) -> str:
    """The cue on a blank floor between textured walls (tests/scenes.py), 6 m straight, 0.7 m off the centre."""
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
    from scenes import Scene, Texture, arc_path

    ground = GroundMotion(horizontal_fov=math.radians(80), camera_height=0.5, camera_forward=0.1)
    rows = []
    for half_width in (2.0, 3.0):
        scene = Scene(floor=Texture("blank", level=0.45), half_width=half_width, ceiling=None)
        path = arc_path([(6.0, 0.0)], start=(0.0, 0.7, 0.0))
        pyramids = [ground._pyramid(scene.render(x, y, yaw)) for x, y, yaw in path]
        total = sum(wall_motion(ground, a, b, (0.0, 0.0), texture, 0.1)[0] for a, b in itertools.pairwise(pyramids))
        rows.append(f"walls {half_width:.0f} m from the centre: {total:.2f} m of 6.00")
    return "synthetic, from rest: " + "; ".join(rows)


def measure(config, images: list[np.ndarray], times: np.ndarray, poses: np.ndarray, texture: float) -> list[str]:
    """Per odometry distance source: this cue's coverage and ratio to the truth, from rest and from the odometry."""
    odometry = _odometry(config)
    truth = np.r_[0.0, np.linalg.norm(np.diff(poses[:, :3], axis=0), axis=1)]
    rows = []
    for index, image in enumerate(tqdm(images, desc="odometry", leave=False)):
        dt = 0.0 if index == 0 else float(times[index] - times[index - 1])
        motion = odometry.step(grey(image), dt)
        if index == 0 or motion.observed is None:
            continue
        source = motion.observed.distance
        taken = motion.forward_speed * dt
        prior = odometry._held_speed * dt if source in ("held", "none") else taken
        yaw = motion.yaw_rate * dt
        previous, current = odometry._ceiling_previous, odometry._ground.pyramid
        alone = wall_motion(odometry._ground, previous, current, (0.0, yaw), texture, 0.1)
        added = wall_motion(odometry._ground, previous, current, (prior, yaw), texture)
        rows.append((source, truth[index], *alone, *added))
    sources = np.array([row[0] for row in rows])
    values = np.array([row[1:] for row in rows], dtype=float)
    lines = []
    for source in ("floor", "ceiling", "image", "held", "none"):
        frames = sources == source
        if not frames.any():
            continue
        parts = [f"{source:8} {int(frames.sum()):5d} frames"]
        for name, column in (("from rest", 1), ("from the odometry", 3)):
            for least in SEES:
                seen = frames & (values[:, column + 1] >= least)
                moving = seen & (values[:, 0] > 0.05)
                if not moving.any():
                    parts.append(f"{name}, sees ≥ {least}: none")
                    continue
                ratio = values[moving, column] / values[moving, 0]
                parts.append(
                    f"{name}, sees ≥ {least}: {int(seen.sum())} frames, "
                    f"{values[moving, column].sum() / values[moving, 0].sum():.2f} of the truth "
                    f"(10th–90th {np.percentile(ratio, 10):.2f}–{np.percentile(ratio, 90):.2f})"
                )
        lines.append("\n    ".join(parts))
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--worlds", nargs="+", default=["gen2:101", "gen2:104"], help="worlds to drive")
    parser.add_argument("--laps", type=int, default=2)
    parser.add_argument("--max-frames", type=int, default=4000, help="cut each drive short (0: the whole drive)")
    parser.add_argument(
        "--texture",
        type=float,
        default=0.02,
        help="image gradient (intensity in [0, 1] per pixel) that counts as texture (default 0.02)",
    )
    parser.add_argument(
        "--span",
        type=int,
        default=1,
        help="frames between the two images compared (default 1: frame to frame, Gauss–Newton from rest; above 1: "
        "the search over the distance, see the docstring)",
    )
    parser.add_argument("--preset", default="sim")
    parser.add_argument("--config", default=None, help="TOML or JSON settings over the preset")
    args = parser.parse_args(argv)
    if args.laps < 1 or args.max_frames < 0 or not args.texture > 0 or args.span < 1:
        print(
            f"--laps {args.laps} / --max-frames {args.max_frames} / --texture {args.texture} / --span {args.span}: "
            "must be at least 1 / 0 / above 0 / 1",
            file=sys.stderr,
        )
        return 2
    config = presets.get(args.preset)
    if args.config:
        config = load_config(args.config, base=config)
    print(synthetic(args.texture), flush=True)
    for world in args.worlds:
        recorded = record(world, args.laps, args.max_frames or None).frames
        images = [frame.image for frame in recorded]
        times, poses = np.array([frame.time for frame in recorded]), np.array([frame.truth.pose for frame in recorded])
        if args.span > 1:
            lines = measure_span(config, images, times, poses, args.texture, args.span)
        else:
            lines = measure(config, images, times, poses, args.texture)
        print(world + ":\n  " + "\n  ".join(lines), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
