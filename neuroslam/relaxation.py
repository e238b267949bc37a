"""Relaxation of the experience map: the poses that best agree with the links between experiences.

Two solvers of the same sum of squared link errors (NeuroSLAM eq. 25's):
:func:`relax_passes` takes the paper's passes (each experience moved by a fraction of its links' errors),
:func:`solve_least_squares` its least-squares minimum directly (Gauss–Newton on the sparse link graph).
Both are pure: poses and links in, poses out; :class:`~neuroslam.experience_map.ExperienceMap` keeps the
map and decides when to call them (``ExperienceMapConfig.relaxation``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse
import scipy.sparse.linalg

from .geometry import quarter_wrap, wrap

__all__ = ["StructureTerms", "ViewHeadingTerms", "relax_passes", "solve_least_squares", "structure_axes",
           "structure_axis", "view_heading_weights"]

SETTLED = 1e-4  # m or rad: relaxation stops once no experience moves more than this in a pass
LEAST_SQUARES_ITERATIONS = 3  # Gauss–Newton iterations at most per call; an unfinished solve goes on next call
LEAST_SQUARES_SETTLED = 1e-3  # m or rad: the solve stops once no experience moves more than this
LEAST_SQUARES_HALVINGS = 20  # step halvings tried before a Gauss–Newton step counts as no descent
# halvings of a NeuroSLAM eq. 25 pass that would raise the total link error before the map counts as settled
PASS_HALVINGS = 20


@dataclass(frozen=True)
class StructureTerms:
    """Heading observations against the scene's straight lines, for :func:`solve_least_squares` (eq. M4).

    Attributes:
        experiences: (m,) indices (into the solve's ``poses``) of the experiences that saw lines.
        orientations: (m,) the lines' orientation in each experience's frame when it was made, rad (phi of
            eq. M2 of :mod:`neuroslam.vision.structure`, defined modulo 90°).
        weight: the weight of each one's squared error (rad²), relative to a driven link's.
        tolerance: rad, the scale of the Cauchy weighting that makes a misread orientation count less
            (an error of ``tolerance`` counts half, of three times it a tenth).
        families: the most directions of lines the map may hold (:func:`structure_axes`); 1: one direction
            (and its perpendicular), as eq. M4 was first written.
    """

    experiences: np.ndarray
    orientations: np.ndarray
    weight: float
    tolerance: float
    families: int = 1


STRUCTURE_AXIS_ITERATIONS = 5  # reweightings of structure_axis's mean
#: structure_axes: a further direction of lines lies this many tolerances from every direction already found, where
#: their Cauchy weight has fallen to a tenth: nearer, its orientations are the found direction's scatter
STRUCTURE_FAMILY_SEPARATION = 3.0
#: structure_axes: a further direction needs this share of the first's support (the sum of its readings' Cauchy
#: weights). A direction the building is laid along is seen over a part of the path comparable to the first's, at
#: least a third of what the two hold together; a run of misread frames (a wall's foot, a ramp's edge) over a
#: stretch of it
STRUCTURE_FAMILY_SHARE = 0.5
#: eq. M6's neighbourhood: a residual is judged against the median of this many observations nearest it (in
#: the order the experiences were made): about 20 m of path where a path is driven again (an observation every
#: metre or so at the ``sim`` defaults), and a look-alike's run of up to half as many is outvoted
VIEW_HEADING_NEIGHBOURS = 20


@dataclass(frozen=True)
class ViewHeadingTerms:
    """Heading observations from familiar views, for :func:`solve_least_squares` (eq. M6).

    Each observation says that an experience's yaw is its view's reference experience's yaw plus a turn
    measured by the view cells: ``yaw[targets] = yaw[sources] + facings``.

    Attributes:
        sources: (m,) indices (into the solve's ``poses``) of the reference experiences (where the views were
            learned).
        targets: (m,) indices of the experiences made later on the same views, in the order they were made.
        facings: (m,) rad, each target's yaw relative to its source's, as the views measured it.
        weight: the weight of each one's squared error (rad²), relative to a driven link's.
        tolerance: rad, the Cauchy scale on a residual's departure from its neighbours' median
            (:func:`view_heading_weights`).
    """

    sources: np.ndarray
    targets: np.ndarray
    facings: np.ndarray
    weight: float
    tolerance: float


def view_heading_weights(residuals: np.ndarray, weight: float, tolerance: float,
                         neighbours: int = VIEW_HEADING_NEIGHBOURS) -> np.ndarray:
    """Eq. M6's weights: ``weight / (1 + (d / tolerance)²)``, d the median departure (rad) of each residual's
    neighbours from it: the ``neighbours`` observations nearest it in order (itself not counted; at the ends,
    the first or last ``neighbours``). An observation with no other counts nothing.

    The map's heading error changes slowly along a path, so a true observation's residual, however large
    before the map is solved, is its neighbours'; a view matched to a look-alike elsewhere, facing another
    way, departs from them by tens of degrees and counts little, the newest too (its neighbours are the ones
    before it). Angles: the departures are wrapped differences, so the wrap at ±π does not matter.
    """
    residuals = np.asarray(residuals, dtype=float)
    count = len(residuals)
    if count < 2:
        return np.zeros(count)
    span = min(neighbours + 1, count)  # the neighbours and the observation itself
    first = np.clip(np.arange(count) - span // 2, 0, count - span)
    window = first[:, None] + np.arange(span)
    departures = wrap(residuals[window] - residuals[:, None])
    departures[window == np.arange(count)[:, None]] = np.nan  # not itself
    departure = np.nanmedian(departures, axis=1)
    return weight / (1 + (departure / tolerance) ** 2)


def structure_axis(yaws: np.ndarray, orientations: np.ndarray, tolerance: float | None = None) -> float:
    """The lines' direction in the map frame that a set of experiences agrees on best (modulo 90°, rad): the
    circular mean of their yaw plus their lines' orientation, taken on the fourth multiple of the angle; with
    ``tolerance`` (rad), reweighted :data:`STRUCTURE_AXIS_ITERATIONS` times by eq. M4's Cauchy weights, so that
    misread lines, which all lie to one side of a wall, do not pull it."""
    directions = yaws + orientations
    axis = float(np.angle(np.mean(np.exp(4j * directions))) / 4)
    if tolerance is None:
        return axis
    for _ in range(STRUCTURE_AXIS_ITERATIONS):
        error = quarter_wrap(directions - axis)
        weight = 1 / (1 + (error / tolerance) ** 2)
        axis += float(np.angle(np.sum(weight * np.exp(4j * error))) / 4)
    return axis


def structure_axes(yaws: np.ndarray, orientations: np.ndarray, tolerance: float, families: int = 1) -> np.ndarray:
    """The directions of lines in the map frame (modulo 90°, rad) that a set of experiences holds, the strongest
    first, at most ``families`` of them.

    A building may be laid out along more than one direction: a car park's bays painted at 60° to its lanes,
    a wing turned against the main block. Eq. M2 reads each frame's lines as one direction, so the map's
    readings (yaw plus orientation) then cluster round more than one. Each direction is the strongest cluster
    of the readings farther than :data:`STRUCTURE_FAMILY_SEPARATION` tolerances from every direction found
    before it (the first: of all readings): the peak of their Cauchy density, the sum over readings of
    c(error) = 1 / (1 + (error / tolerance)²) (on bins a tenth of ``tolerance`` wide), refined by
    :data:`STRUCTURE_AXIS_ITERATIONS` means of the errors weighted by c (the Cauchy M-estimate). A circular
    mean, :func:`structure_axis`'s start, would lie between two clusters, and its refinement stop there. A
    further direction counts where its support (the sum of c over those readings) is at least
    :data:`STRUCTURE_FAMILY_SHARE` of the first's (over all readings); otherwise the search stops. With
    ``families`` 1 the one direction is :func:`structure_axis`'s, as eq. M4 was first written.
    """
    if families == 1:  # eq. M4 as first written
        return np.array([structure_axis(yaws, orientations, tolerance)])
    directions = quarter_wrap(np.asarray(yaws, dtype=float) + np.asarray(orientations, dtype=float))
    bins = max(int(round(math.pi / 2 / (tolerance / 10))), 1)
    width = math.pi / 2 / bins
    kernel_spectrum = np.fft.rfft(1 / (1 + (quarter_wrap(np.arange(bins) * width) / tolerance) ** 2))
    axes: list[float] = []
    remaining = directions
    first = 0.0
    while len(remaining):
        counts = np.bincount(np.floor((remaining + math.pi / 4) / width).astype(np.int64) % bins, minlength=bins)
        density = np.fft.irfft(np.fft.rfft(counts) * kernel_spectrum, bins)  # circular: the wrap at ±45°
        axis = -math.pi / 4 + (int(np.argmax(density)) + 0.5) * width
        for _ in range(STRUCTURE_AXIS_ITERATIONS):  # the Cauchy-weighted mean of the errors, reweighted
            error = quarter_wrap(remaining - axis)
            weight = 1 / (1 + (error / tolerance) ** 2)
            axis += float(weight @ error / weight.sum())
        support = float(np.sum(1 / (1 + (quarter_wrap(remaining - axis) / tolerance) ** 2)))
        if axes and support < STRUCTURE_FAMILY_SHARE * first:
            break
        first = first or support
        axes.append(float(quarter_wrap(axis)))
        if len(axes) == families:
            break
        nearest = np.min(np.abs(quarter_wrap(directions[:, None] - np.asarray(axes)[None, :])), axis=1)
        remaining = directions[nearest > STRUCTURE_FAMILY_SEPARATION * tolerance]
    return np.asarray(axes)


def solve_least_squares(poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, link_poses: np.ndarray,
                        weights: np.ndarray, structure: StructureTerms | None = None,
                        length_weights: np.ndarray | None = None,
                        views: ViewHeadingTerms | None = None) -> tuple[np.ndarray, bool]:
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

    linearised (including the dependence of r_xy on the source's yaw), and the normal equations (symmetric
    positive definite) solved by a sparse LU in its symmetric mode, the first experience held fixed.

    With ``length_weights`` (eq. M5, not in the NeuroSLAM paper), a link whose length is less sure than its
    direction (the camera was blind in distance on some of its frames) weighs its error along its direction of
    travel u = (cos, sin)(yaw_source + heading) by its length weight l and across it by its weight w: r_xy
    weighted by sqrt(l), plus one row across,

        r_across = sqrt(w − l) · v · (p_source − p_target),   v = (−sin, cos)(yaw_source + heading)      (M5)

    (v · u = 0, so the link's distance drops out), which makes the squared error l · along² + w · across².
    A loop closure then stretches the links whose length nobody saw, not the ones the floor measured.

    With ``structure`` (eq. M4, not in the NeuroSLAM paper), each experience that saw the floor's straight
    lines adds a residual on its yaw: buildings are built along two perpendicular directions, so the lines'
    orientation phi_i in the experience's frame plus its yaw is one direction psi of the whole map, modulo 90°,

        r_i = sqrt(w_i) · wrap_90(yaw_i + phi_i − psi_k(i)),   w_i = weight / (1 + (u_i / tolerance)²)      (M4)

    psi_k the map's directions of lines, solved with the poses (they start at :func:`structure_axes` of the
    experiences: one, as the lines of most buildings run, or up to ``structure.families`` where the readings
    cluster round more), k(i) the direction nearest experience i's reading and u_i its residual at the call's
    start (a Cauchy weighting, fixed within a call and updated at the next). The odometry's heading
    drifts; the lines' does not, so these residuals hold the map's heading where no loop closes.

    With ``views`` (eq. M6, not in the NeuroSLAM paper), each experience made on a familiar view adds a residual
    on its yaw against the yaw of the experience where the view was learned (its source s), turned by the view
    cells' relative yaw rho (NeuroSLAM's local view calibration of the head direction, eq. 11, taken into the map):

        r_k = sqrt(w_k) · wrap(yaw_s + rho_k − yaw_k),   w_k = weight / (1 + (d_k / tolerance)²)      (M6)

    d_k the departure of the residual at the call's start from its neighbours' median
    (:func:`view_heading_weights`). A view seen again says which way the robot faces even where it cannot say
    where along the path it is, so these residuals hold the heading where the loop closures are refused.

    One call runs at most ``LEAST_SQUARES_ITERATIONS`` iterations, each step halved until the total error does
    not rise (so a solve never increases it, even where a false closure makes the links disagree grossly); a
    solve that has not converged (no experience moving more than 1 mm) goes on at the next call, so no frame
    waits for a long solve.

    Args:
        poses: (n, 4) the experiences' poses (m, rad); the first is held fixed.
        sources, targets: (L,) each link's experiences (indices into ``poses``).
        link_poses: (L, 4) each link's distance (m), heading (rad, from the source's yaw), facing (rad,
            the target's yaw relative to the source's) and height change (m).
        weights: (L,) each link's weight.
        structure: eq. M4's observations, or None (then the solve is the links' alone).
        length_weights: (L,) each link's weight along its direction of travel (eq. M5), at most its weight;
            None: the same as ``weights``.
        views: eq. M6's observations, or None.

    Returns (poses (n, 4) after the iterations, settled: whether the solve converged).
    """
    n = len(poses)
    count = len(sources)
    root_weight = np.sqrt(weights)
    # eq. M5: the links whose length weighs less than their direction, each with one row across
    length_weights = weights if length_weights is None else np.minimum(length_weights, weights)
    across = np.flatnonzero(length_weights < weights)
    root_length = np.sqrt(length_weights)
    root_across = np.sqrt(weights[across] - length_weights[across])
    across_rows = 4 * count + np.arange(len(across))
    # eq. M4: psi is the last variable
    with_structure = structure is not None and len(structure.experiences) > 0
    if with_structure:
        seen, orientations = np.asarray(structure.experiences, dtype=np.int64), np.asarray(structure.orientations)
        axis = structure_axes(poses[seen, 3], orientations, structure.tolerance, structure.families)
        # each experience held to the direction nearest its reading at the call's start
        family = np.argmin(np.abs(quarter_wrap(poses[seen, 3:4] + orientations[:, None] - axis[None, :])), axis=1)
        start = quarter_wrap(poses[seen, 3] + orientations - axis[family])
        root_structure = np.sqrt(structure.weight / (1 + (start / structure.tolerance) ** 2))
        structure_rows = 4 * count + len(across) + np.arange(len(seen))
    else:
        axis, family = np.zeros(0), np.zeros(0, dtype=np.int64)
    # eq. M6: rows after eq. M4's
    with_views = views is not None and len(views.targets) > 0
    if with_views:
        view_sources = np.asarray(views.sources, dtype=np.int64)
        view_targets = np.asarray(views.targets, dtype=np.int64)
        view_facings = np.asarray(views.facings, dtype=float)
        start = wrap(poses[view_sources, 3] + view_facings - poses[view_targets, 3])
        root_views = np.sqrt(view_heading_weights(start, views.weight, views.tolerance))
        view_rows = 4 * count + len(across) + (len(seen) if with_structure else 0) + np.arange(len(view_targets))
    variables = 4 * n + len(axis)

    def residual_at(poses: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        blocks, cos, sin = _link_residuals(poses, sources, targets, link_poses, root_weight, root_length)
        direction = poses[sources[across], 3] + link_poses[across, 1]
        across_cos, across_sin = np.cos(direction), np.sin(direction)
        apart_x = poses[sources[across], 0] - poses[targets[across], 0]
        apart_y = poses[sources[across], 1] - poses[targets[across], 1]
        blocks.append((across_cos * apart_y - across_sin * apart_x) * root_across)
        if with_structure:
            blocks.append(quarter_wrap(poses[seen, 3] + orientations - axis[family]) * root_structure)
        if with_views:
            blocks.append(wrap(poses[view_sources, 3] + view_facings - poses[view_targets, 3]) * root_views)
        return np.concatenate(blocks), (cos, sin, across_cos, across_sin, apart_x, apart_y)

    def jacobian_at(parts: tuple[np.ndarray, ...]) -> scipy.sparse.csc_matrix:
        cos, sin, across_cos, across_sin, apart_x, apart_y = parts
        rows, columns, values = _link_jacobian(sources, targets, cos, sin, root_weight, root_length)
        # d r_across / d(x_s, y_s, x_t, y_t, yaw_s) = (−sin, cos, sin, −cos, −u · (p_s − p_t)) · sqrt(w − l)
        source, target = sources[across], targets[across]
        rows = [rows, np.tile(across_rows, 5)]
        columns = [columns, np.concatenate([4 * source, 4 * source + 1, 4 * target, 4 * target + 1, 4 * source + 3])]
        values = [values, np.concatenate([-across_sin, across_cos, across_sin, -across_cos,
                                          -(across_cos * apart_x + across_sin * apart_y)]) * np.tile(root_across, 5)]
        if with_structure:
            rows += [structure_rows, structure_rows]
            columns += [4 * seen + 3, 4 * n + family]
            values += [root_structure, -root_structure]
        if with_views:
            rows += [view_rows, view_rows]
            columns += [4 * view_sources + 3, 4 * view_targets + 3]
            values += [root_views, -root_views]
        # the first experience stays where it is: its columns leave the system (a stiff prior on it
        # instead would make the normal equations too ill-conditioned to solve on long chains)
        return scipy.sparse.csc_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(columns))),
                                       shape=(len(residual), variables))[:, 4:]

    residual, parts = residual_at(poses, axis)
    cost = float(residual @ residual)
    for _ in range(LEAST_SQUARES_ITERATIONS):
        jacobian = jacobian_at(parts)
        normal = (jacobian.T @ jacobian).tocsc()
        # the normal equations are symmetric positive definite: SuperLU's symmetric mode (a minimum-degree
        # ordering of the matrix's own pattern, pivots kept on the diagonal) fills in a fifth of what COLAMD's
        # column ordering with partial pivoting does and factorises 2-3x faster on a map of 1,300 experiences
        factor = scipy.sparse.linalg.splu(normal, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                          options={"SymmetricMode": True})
        full_step = factor.solve(-(jacobian.T @ residual))
        step, axis_step = full_step[: 4 * (n - 1)].reshape(n - 1, 4), full_step[4 * (n - 1):]
        # backtracking: a full step can overshoot where the links disagree grossly (the yaw coupling is
        # far from linear), so the step is halved until the total squared link error does not rise
        scale = 1.0
        for _halving in range(LEAST_SQUARES_HALVINGS):
            trial = poses.copy()
            trial[1:] += scale * step
            trial[:, 3] = wrap(trial[:, 3])
            trial_axis = axis + scale * axis_step
            trial_residual, trial_parts = residual_at(trial, trial_axis)
            trial_cost = float(trial_residual @ trial_residual)
            if trial_cost <= cost:
                break
            scale /= 2
        else:  # no descent along the Gauss–Newton direction: a minimum, up to round-off
            return poses, True
        poses, axis, residual, parts, cost = trial, trial_axis, trial_residual, trial_parts, trial_cost
        if len(full_step) == 0 or np.abs(full_step).max() < LEAST_SQUARES_SETTLED:  # the full step, not a halved one
            return poses, True
    return poses, False


def _link_residuals(poses: np.ndarray, sources: np.ndarray, targets: np.ndarray, link_poses: np.ndarray,
                    root_weight: np.ndarray,
                    root_length: np.ndarray) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
    """The links' weighted residuals (x, y, z, yaw blocks) at ``poses``, and each link's rotated distance
    (cos, sin parts) for the Jacobian. The x and y blocks weigh by ``root_length`` (eq. M5), z and yaw by
    ``root_weight``."""
    distance, heading, facing, height = link_poses.T
    direction = poses[sources, 3] + heading
    cos, sin = distance * np.cos(direction), distance * np.sin(direction)
    return [(poses[sources, 0] + cos - poses[targets, 0]) * root_length,
            (poses[sources, 1] + sin - poses[targets, 1]) * root_length,
            (poses[sources, 2] + height - poses[targets, 2]) * root_weight,
            wrap(poses[sources, 3] + facing - poses[targets, 3]) * root_weight], cos, sin


def _link_jacobian(sources: np.ndarray, targets: np.ndarray, cos: np.ndarray, sin: np.ndarray,
                   root_weight: np.ndarray, root_length: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The link residuals' Jacobian entries (rows, columns, values) over the 4 n pose variables."""
    count = len(sources)
    rows = np.arange(count)
    ones = np.ones(count)
    jacobian_rows = np.concatenate([rows, rows, rows, rows + count, rows + count, rows + count,
                                    rows + 2 * count, rows + 2 * count, rows + 3 * count, rows + 3 * count])
    columns = np.concatenate([4 * sources, 4 * targets, 4 * sources + 3, 4 * sources + 1, 4 * targets + 1,
                              4 * sources + 3, 4 * sources + 2, 4 * targets + 2, 4 * sources + 3, 4 * targets + 3])
    values = (np.concatenate([ones, -ones, -sin, ones, -ones, cos, ones, -ones, ones, -ones])
              * np.concatenate([np.tile(root_length, 6), np.tile(root_weight, 4)]))
    return jacobian_rows, columns, values


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
