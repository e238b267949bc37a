"""Relaxation of the experience map: the poses that best agree with the links between experiences.

Two solvers of the same sum of squared link errors (NeuroSLAM eq. 25's):
:func:`relax_passes` takes the paper's passes (each experience moved by a fraction of its links' errors),
:func:`solve_least_squares` its least-squares minimum directly (Gauss–Newton on the sparse link graph).
Both are pure: poses and links in, poses out; :class:`~neuroslam.experience_map.ExperienceMap` keeps the
map and decides when to call them (``ExperienceMapConfig.relaxation``).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from .geometry import wrap

__all__ = ["relax_passes", "solve_least_squares"]

SETTLED = 1e-4  # m or rad: relaxation stops once no experience moves more than this in a pass
LEAST_SQUARES_ITERATIONS = 3  # Gauss–Newton iterations at most per call; an unfinished solve goes on next call
LEAST_SQUARES_SETTLED = 1e-3  # m or rad: the solve stops once no experience moves more than this
LEAST_SQUARES_HALVINGS = 20  # step halvings tried before a Gauss–Newton step counts as no descent
# halvings of a NeuroSLAM eq. 25 pass that would raise the total link error before the map counts as settled
PASS_HALVINGS = 20


def solve_least_squares(poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, link_poses: np.ndarray,
                        weights: np.ndarray) -> tuple[np.ndarray, bool]:
    """The least-squares map of NeuroSLAM eq. 25's link errors, found by Gauss–Newton on the sparse link graph.

    NeuroSLAM eq. 25 moves every experience by a fraction of its links' errors per pass, reducing the sum of
    squared link errors (x, y, z in metres, yaw in radians, all weighted 1). Along a loop of n
    experiences it needs of the order of n² passes to spread a loop's error (a 1,500-experience lap
    keeps almost all of it after thousands of passes), so a map relaxed by passes still has the
    shape of the odometry; and its passes settle short of the minimum, because they ignore how a
    source's yaw moves its target. Here that sum is minimised directly, each link's squared errors
    times its weight (``closure_weight`` for a loop closure's link, whose target the robot may have
    passed up to a metre away; 1 for a driven link, accurate to centimetres): residuals

        r_xy = p_source + distance · (cos, sin)(yaw_source + heading) − p_target,
        r_z = z_source + height − z_target,   r_yaw = wrap(yaw_source + facing − yaw_target),

    linearised (including the dependence of r_xy on the source's yaw), and the normal equations
    solved by a sparse LU, the first experience held fixed. One call runs at most
    ``LEAST_SQUARES_ITERATIONS`` iterations, each step halved until the total error does not rise (so a
    solve never increases it, even where a false closure makes the links disagree grossly); a solve that
    has not converged (no experience moving more than 1 mm) goes on at the next call, so no frame waits
    for a long solve.

    Args:
        poses: (n, 4) the experiences' poses (m, rad); the first is held fixed.
        sources, targets: (L,) each link's experiences (indices into ``poses``).
        link_poses: (L, 4) each link's distance (m), heading (rad, from the source's yaw), facing (rad,
            the target's yaw relative to the source's) and height change (m).
        weights: (L,) each link's weight.

    Returns (poses (n, 4) after the iterations, settled: whether the solve converged).
    """
    n = len(poses)
    distance, heading, facing, height = link_poses.T
    count = len(sources)
    root_weight = np.sqrt(weights)
    tiled_weight = np.tile(root_weight, 10)  # one per Jacobian entry below
    rows = np.arange(count)
    ones = np.ones(count)

    def residual_at(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        direction = poses[sources, 3] + heading
        cos, sin = distance * np.cos(direction), distance * np.sin(direction)
        return np.concatenate([
            (poses[sources, 0] + cos - poses[targets, 0]) * root_weight,
            (poses[sources, 1] + sin - poses[targets, 1]) * root_weight,
            (poses[sources, 2] + height - poses[targets, 2]) * root_weight,
            wrap(poses[sources, 3] + facing - poses[targets, 3]) * root_weight]), cos, sin

    residual, cos, sin = residual_at(poses)
    cost = float(residual @ residual)
    for _ in range(LEAST_SQUARES_ITERATIONS):
        # Jacobian: residual block a (x, y, z, yaw) against the source's and target's variables
        jacobian_rows = np.concatenate([rows, rows, rows, rows + count, rows + count, rows + count,
                                        rows + 2 * count, rows + 2 * count, rows + 3 * count, rows + 3 * count])
        columns = np.concatenate([4 * sources, 4 * targets, 4 * sources + 3, 4 * sources + 1, 4 * targets + 1,
                                  4 * sources + 3, 4 * sources + 2, 4 * targets + 2, 4 * sources + 3,
                                  4 * targets + 3])
        values = np.concatenate([ones, -ones, -sin, ones, -ones, cos, ones, -ones, ones, -ones]) * tiled_weight
        # the first experience stays where it is: its columns leave the system (a stiff prior on it
        # instead would make the normal equations too ill-conditioned to solve on long chains)
        jacobian = scipy.sparse.csc_matrix((values, (jacobian_rows, columns)), shape=(4 * count, 4 * n))[:, 4:]
        normal = (jacobian.T @ jacobian).tocsc()
        factor = scipy.sparse.linalg.splu(normal)  # COLAMD ordering: about 2x faster than spsolve's here
        step = factor.solve(-(jacobian.T @ residual)).reshape(n - 1, 4)
        # backtracking: a full step can overshoot where the links disagree grossly (the yaw coupling is
        # far from linear), so the step is halved until the total squared link error does not rise
        scale = 1.0
        for _halving in range(LEAST_SQUARES_HALVINGS):
            trial = poses.copy()
            trial[1:] += scale * step
            trial[:, 3] = wrap(trial[:, 3])
            trial_residual, trial_cos, trial_sin = residual_at(trial)
            trial_cost = float(trial_residual @ trial_residual)
            if trial_cost <= cost:
                break
            scale /= 2
        else:  # no descent along the Gauss–Newton direction: a minimum, up to round-off
            return poses, True
        poses, residual, cos, sin, cost = trial, trial_residual, trial_cos, trial_sin, trial_cost
        if len(step) == 0 or np.abs(step).max() < LEAST_SQUARES_SETTLED:  # the full step, not a halved one
            return poses, True
    return poses, False


def relax_passes(poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, link_poses: np.ndarray,
                 degree: np.ndarray, correction: float, passes: int) -> tuple[np.ndarray, bool]:
    """NeuroSLAM eq. 25 over all links at once, ``passes`` times.

    Once a pass moves no experience by more than ``SETTLED`` (m or rad) the map counts as settled: the
    experience map then skips further passes until a loop closure adds an inconsistent link (a link made
    from the odometry to a new experience agrees with the poses by construction). The passes ignore how a source's
    yaw moves its target, so near where they settle a full pass can raise the total squared link error (by
    up to ~1 % on noisy loops): such a pass is halved until it does not (at most ``PASS_HALVINGS`` times);
    where no part of it helps, the pass is taken with the yaw coupling (the error's gradient, scaled as
    NeuroSLAM eq. 25 scales it), which always helps unless the map is at a minimum. So relaxation never
    increases the error; passes that lower it are the paper's, unchanged.

    Args:
        poses: (n, 4) the experiences' poses (m, rad). sources, targets, link_poses: as in
            :func:`solve_least_squares`. degree: (n,) links per experience. correction: NeuroSLAM eq. 25's
            correction rate (``ExperienceMapConfig.correction``). passes: at most this many.

    Returns (poses (n, 4) after the passes, settled).
    """
    distance, heading, facing, height = (np.ascontiguousarray(column) for column in link_poses.T)
    n = len(poses)
    scale = correction / np.maximum(degree, 1) / 2
    # one contiguous array per axis: gathers and scatters over 1-D arrays are several times faster
    x, y, z, yaw = (np.ascontiguousarray(poses[:, axis]) for axis in range(4))

    def link_errors(x, y, z, yaw) -> tuple[tuple[np.ndarray, ...], float]:
        source_yaw = yaw[sources]
        direction = source_yaw + heading
        errors = (
            x[sources] + distance * np.cos(direction) - x[targets],
            y[sources] + distance * np.sin(direction) - y[targets],
            z[sources] + height - z[targets],
            wrap(source_yaw + facing - yaw[targets]),
        )
        return errors, sum(float(error @ error) for error in errors)

    def pass_steps(errors) -> list[np.ndarray]:
        return [(np.bincount(targets, error, n) - np.bincount(sources, error, n)) * scale for error in errors]

    def with_coupling(steps, yaw, errors) -> list[np.ndarray]:
        # NeuroSLAM eq. 25's steps plus, in the source's yaw, how turning it moves the link's far end: a positively
        # scaled negative gradient of the total error, so a small enough step always lowers it
        direction = yaw[sources] + heading
        turning = errors[1] * distance * np.cos(direction) - errors[0] * distance * np.sin(direction)
        return [*steps[:3], steps[3] - np.bincount(sources, turning, n) * scale]

    def halved(steps, total):
        """The largest of the step, its half, its quarter, ... that does not raise the total error."""
        fraction = 1.0
        for _halving in range(PASS_HALVINGS):
            trial = [values + fraction * step for values, step in zip((x, y, z, yaw), steps, strict=True)]
            trial[3] = wrap(trial[3])
            trial_errors, trial_total = link_errors(*trial)
            if trial_total <= total:
                return trial, trial_errors, trial_total
            fraction /= 2
        return None

    errors, total = link_errors(x, y, z, yaw)
    settled = False
    for _ in range(passes):
        # the paper's pass; if no part of it lowers the total error (it ignores how a source's yaw moves its
        # target), the pass with that coupling, which does unless the map is at a minimum
        steps = pass_steps(errors)
        accepted = halved(steps, total)
        if accepted is None:
            steps = with_coupling(steps, yaw, errors)
            accepted = halved(steps, total)
        if accepted is None:  # a minimum, up to round-off
            settled = True
            break
        (x, y, z, yaw), errors, total = accepted
        if max(float(np.abs(step).max()) for step in steps) < SETTLED:  # the full pass, not a halved one
            settled = True
            break
    return np.column_stack([x, y, z, yaw]), settled
