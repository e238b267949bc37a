"""Parameters of NeuroSLAM as frozen dataclasses, with validation and loading from dicts and files.

Every section validates itself on construction and names the offending field (``grid_cells.size``).
Units: metres, seconds and radians at the boundary; cells only inside the networks. Defaults are the
``sim`` preset (the testbed's 160×120, 80° camera); :mod:`neuroslam.presets` holds the paper's tables.

Why the ``sim`` defaults are what they are, and what each changed on the benchmark: ``docs/configuration.md``.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, get_args

from .errors import InvalidParameterError

__all__ = [
    "Config", "ExperienceMapConfig", "GridCellConfig", "GridNetworkConfig", "HeadDirectionConfig", "LocalViewConfig",
    "Region", "VisualOdometryConfig", "load_config",
]


def _number(value: object) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


# the options: each a Literal type (what a field may hold) and its values
Relaxation = Literal["passes", "least-squares"]
Integrator = Literal["odometry", "grid-network"]
LoopClosure = Literal["code", "confirmed"]
PlanarMotion = Literal["profile", "ground"]
HeightModel = Literal["profile", "transitions"]
Shift = Literal["fourier", "linear"]
RELAXATIONS: tuple[str, ...] = get_args(Relaxation)
INTEGRATORS: tuple[str, ...] = get_args(Integrator)
LOOP_CLOSURES: tuple[str, ...] = get_args(LoopClosure)
PLANAR_MOTIONS: tuple[str, ...] = get_args(PlanarMotion)
HEIGHT_MODELS: tuple[str, ...] = get_args(HeightModel)
SHIFTS: tuple[str, ...] = get_args(Shift)


def _require(path: str, value: object, ok: bool, reason: str) -> None:
    if not ok:
        raise InvalidParameterError(path, value, reason)


def _positive(section: str, **values: object) -> None:
    for name, value in values.items():
        _require(f"{section}.{name}", value, _number(value) and value > 0, "must be a positive number")


def _non_negative(section: str, **values: object) -> None:
    for name, value in values.items():
        _require(f"{section}.{name}", value, _number(value) and value >= 0, "must be a number >= 0")


def _odd_width(section: str, name: str, value: object, limit: int) -> None:
    _require(f"{section}.{name}", value, isinstance(value, int) and not isinstance(value, bool)
             and value >= 1 and value % 2 == 1 and value <= limit,
             f"must be an odd number of cells from 1 to {limit} (odd, so a resting packet cannot drift)")


def _cells(section: str, name: str, value: object, dimensions: int) -> None:
    ok = (isinstance(value, tuple) and len(value) == dimensions
          and all(isinstance(v, int) and not isinstance(v, bool) and 4 <= v <= 512 for v in value))
    _require(f"{section}.{name}", value, ok, f"must be {dimensions} integers from 4 to 512 (cells)")


def _validate_network(path: str, section: Any) -> None:
    """The attractor-network fields the grid-cell and head-direction sections share."""
    size = min(section.size)
    _odd_width(path, "excitation_width", section.excitation_width, size)
    _odd_width(path, "inhibition_width", section.inhibition_width, size)
    _positive(path, excitation_variance=section.excitation_variance, inhibition_variance=section.inhibition_variance)
    _non_negative(path, global_inhibition=section.global_inhibition, view_injection=section.view_injection)
    _require(f"{path}.inhibition_scale", section.inhibition_scale, _number(section.inhibition_scale)
             and 0 <= section.inhibition_scale < 1, "must be in [0, 1)")
    _require(f"{path}.shift", section.shift, section.shift in SHIFTS, "must be 'fourier' or 'linear'")
    _require(f"{path}.readout_radius", section.readout_radius, isinstance(section.readout_radius, int)
             and 1 <= section.readout_radius < size // 2, "must be an integer from 1 to size/2 - 1")


@dataclass(frozen=True)
class Region:
    """A crop of the image as fractions of its height (top, bottom) and width (left, right)."""

    top: float = 0.0
    bottom: float = 1.0
    left: float = 0.0
    right: float = 1.0

    def validate(self, path: str) -> None:
        for name in ("top", "bottom", "left", "right"):
            value = getattr(self, name)
            _require(f"{path}.{name}", value, _number(value) and 0 <= value <= 1, "must be a fraction in [0, 1]")
        _require(f"{path}.bottom", self.bottom, self.bottom > self.top, "must be greater than top")
        _require(f"{path}.right", self.right, self.right > self.left, "must be greater than left")


@dataclass(frozen=True)
class VisualOdometryConfig:
    """Visual odometry from scanline intensity profiles ("aidvo", NeuroSLAM eqs. 27–32).

    Attributes:
        rotation_region: crop whose column profile gives the yaw rate (NeuroSLAM eqs. 27–29).
        translation_region: crop whose profile difference gives the speed (NeuroSLAM eq. 30).
        height_region: crop whose row profile gives pitch changes (NeuroSLAM eqs. 31–32).
        profile_width: columns the rotation/translation profiles are resampled to.
        max_column_shift: largest profile shift searched, as a fraction of the profile width.
        max_row_shift: largest row shift searched, as a fraction of the height region's rows.
        planar_motion: where speed and yaw come from: ``profile`` (the paper's NeuroSLAM eqs. 27–30: profile shift and
            difference) or ``ground`` (direct alignment of the floor under a ground-plane model, eqs. G1–G3
            of :mod:`neuroslam.vision.ground_motion`: metric from the camera height, independent of the
            scenery; pinhole cameras only).
        camera_height: the camera's height above the floor, m (for ``ground``).
        camera_forward: the camera's distance ahead of the robot's turning axis, m (for ``ground``).
        speed_scale: gain on the speed: metres per frame per unit of mean absolute profile difference (mu
            of NeuroSLAM eq. 30) for ``profile``, a correction near 1 for ``ground``.
        max_speed: speed clip, m/s (v_max of NeuroSLAM eq. 30). max_yaw_rate: yaw-rate clip, rad/s.
        max_climb_rate: climb-rate clip, m/s (v_max^h).
        height_model: how the pitch (and so the climb, speed × sin pitch) is followed: ``profile``
            (NeuroSLAM eqs. 31–32: the height region's row shift integrated frame after frame, with the leak, bias
            and gain below) or ``transitions`` (level floors joined by ramps: the rotation between frames by direct
            alignment, eqs. R1–R2, and pitch changes taken only as whole transitions, eq. R3, of
            :mod:`neuroslam.vision.pitch`; pinhole cameras only).
        pitch_leak: rate at which the integrated pitch relaxes to level, 1/s (``profile``).
        pitch_flow_bias: apparent pitch change per metre driven on level ground, rad/m (calibration, ``profile``).
        climb_scale: gain on the climb rate speed × sin(pitch) (calibration, ``profile``).
        transition_rate: pitch change per second above which a frame belongs to a ramp's foot or top, rad/s
            (``transitions``; a transition of 10° over the robot's length at 1 m/s turns at about 30°/s).
        transition_min: smallest pitch change taken as a transition, rad (``transitions``).
        max_slope: steepest slope driven; a transition leaving the pitch steeper is refused, rad (``transitions``).
        level_snap: a pitch this close to level after a transition is level, rad (``transitions``).
        yaw_scale: gain on the yaw rate from the column shift (calibration; 1 = geometric).
        near_floor_row: for ``ground``, the yaw solved again on the floor below this fraction of half the
            image height under the centre (eq. G4 of :mod:`neuroslam.vision.ground_motion`: walls close
            beside the path reach into the far floor rows and bias the yaw); 0 turns it off. At 0.5 (the
            default) the building's straight corridors read -1.6 to +2.2 degrees of turn instead of -11 to
            +7 (see the README's accuracy section).
        floor_half_width: for ``ground``, the floor region's half width beside the path, m (eq. G5 of
            :mod:`neuroslam.vision.ground_motion`); 0 (the default) takes the whole floor below the horizon.
            Walls standing beside the path reach into the far floor rows and, where the floor has few marks,
            bias the yaw one way (the inner wall of a ring). At 1 m (the lane the robot drives in, about twice
            its width; the rows up to 1.2 m ahead keep their whole width) the bias goes, but so does much of the
            yaw's information: over the generalization benchmark (generator version 1, 43 worlds, 2 laps) the
            odometry's ATE fell on 30 worlds and level accuracy >= 0.95 rose from 37 to 42 worlds (the SLAM ATE's
            90th percentile 5.19 -> 4.32 m), yet the SLAM ATE rose on 20 (the car park 0.27 -> 0.50 m: its yaw
            error over 100 frames 0.55 -> 0.71 degrees rms, a bias the loop closures removed traded for noise
            they cannot), and the worlds meeting every target fell from 24 to 12. Off until the lane is used
            only where the walls outweigh it (docs/generalization.md).
        floor_min_information: for ``ground``, the floor's information on the distance (eq. G3's Σ w J_d²) below
            which the floor does not see the distance, as a multiple of the prior's weight. 0.3, measured on the
            testbed (the README's accuracy section): it leaves every textured floor alone. 1.0, where the
            measurement outweighs the constant-velocity prior, handed a quarter of urban's frames to the
            fallbacks, which read them worse (the ceiling cue on facades: 0.65 of the distance, against the
            floor's 0.99 on the same frames; the benchmark's urban SLAM ATE 0.54 -> 3.96 m).
        floor_aperture: rad; for ``ground``, that information counts only the floor (and ceiling) pixels whose
            image gradient lies more than this from perpendicular to the image motion of a forward step (eq. G6
            of :mod:`neuroslam.vision.ground_motion`): an edge along the path (a wall's foot, a ramp's side)
            does not change as the robot drives along it, and counted, it held a blank ramp's distance at a
            tenth of the truth. 0 (the default) counts every pixel; 10 degrees (0.1745) is twice the measured
            direction error of a rendered, blurred edge, where a texture whose gradients point every way loses
            about 0.2 % of its information. Off by default: over the camera benchmark it lowers the SLAM ATE's
            median 4.73 -> 4.01 m and raises level accuracy >= 0.95 from 32 to 36 worlds, but it turns urban's
            closed loop (SLAM ATE 0.64 -> 1.06 m against the odometry's 1.60 m) through which loop closures
            its map makes, not through its odometry (5 mm); docs/generalization.md, tenth step.
        min_image_information: with ``ground`` and ``transitions``, the whole image's information on the yaw
            (eq. R2 of :mod:`neuroslam.vision.pitch`, Σ w J², intensity² per rad²) per pixel of the height
            region below which the image does not see the yaw (nor the pitch: a height transition commits only
            where one of its frames sees it, eq. R3), and the odometry says it is blind. 0.2 is five times what
            sensor noise of 5 grey levels alone gives a uniform image (0.04: noise must never count as seeing),
            and a twentieth of what any texture across the image gives (1–4).
        blind_hold: seconds the last observed speed is held where nothing observes the distance, before it is
            taken as 0 (a turn rate is never held: where nothing sees the yaw there is no turn). 10: as long as
            the scales of the ceiling and the upper image are remembered (``scale_memory``), the robot's motion
            is taken to go on as last seen. (2 s dropped the building's blank stretches to 0 for 55 frames a
            lap, 5.5 m; its SLAM ATE 2.09 m against 1.60 m with 10 s.)
        scale_memory: seconds over which the metric scale of the upper image's expansion (walls, ceiling) is
            learnt from the floor's distance, to be carried where the floor shows none (a time constant).
        floor_yaw_tolerance: with ``ground`` and ``transitions``, the largest disagreement between the floor's
            yaw change (eqs. G3–G4) and the whole image's (eq. R2) for which the floor's solution is taken, rad
            per frame; beyond it the floor's solution is a wrong minimum (a ramp's shading, a far line
            slipping a pixel) and the frame's motion comes from the other cues, as where the floor sees
            nothing. 1 degree: the two agree within 0.4–0.7 degrees on 99 % of frames on floors where both
            work (car park, urban, the building), so this is about five times their spread and rejects only
            gross failures (on a sparsely marked ramp, single frames read 3–13 degrees of turn while driving
            straight). The ceiling's solution (the distance over a blank floor) is refused by the same bound
            against the yaw taken.
        manhattan: with ``ground``, the heading follows the orientation of the floor's or the ceiling's straight
            edges, modulo 90 degrees (eqs. M1–M3 of :mod:`neuroslam.vision.structure`): buildings, car parks and
            streets are built along two perpendicular directions, and their lines, unlike the odometry's
            heading, do not drift. Where a world's lines are not perpendicular, or there are none, it does
            nothing (the consistency and strength tests below). Off by default: it removes the heading's drift
            but not its wander (where a wall's edges in the floor rows are read as the floor's lines, for
            seconds at a time), and the car park's SLAM ATE got worse with it (docs/generalization.md, ninth
            step).
        manhattan_strength: the least share of a plane's edge energy along two perpendicular directions (R of
            eq. M2) for a frame's line orientation to count. 0.5: most of the edges lie along the lines.
        manhattan_spread: rad; the heading is turned only while the last ``manhattan_window`` counted frames
            agree on where the lines lie: the median absolute deviation of their innovations (eq. M3) at most
            this. 3 degrees: a little over the per-frame scatter of eq. M2 on the generated worlds (80 % of
            counted frames within 2 degrees of the true orientation on gen2:107, 45 % on blank-floored gen2:101),
            so a run of misread frames (a wall's vertical edges taken for floor lines) does not turn it.
        manhattan_window: counted frames over which the innovation's median is taken (eq. M3); the first such
            window fixes the lines' reference orientation. 50: five seconds at 10 frames a second, longer than
            the runs of misread frames seen.
        manhattan_rate: 1/s, eq. M3's rate: the heading moves this share of the median innovation per second
            (a time constant of 5 s at 0.2, the window's length). The odometry's own drift is a few hundredths of
            a degree a frame, which a slow correction removes; a fast one would pass on the per-frame scatter.
        manhattan_first_row: eq. M1's plane pixels start this far from the image centre (below it for the floor,
            above it for the ceiling), as a fraction of half the image height.
    """

    rotation_region: Region = Region(0.0, 1.0, 0.0, 1.0)
    translation_region: Region = Region(0.5, 1.0, 0.0, 1.0)
    height_region: Region = Region(0.2, 0.8, 0.1, 0.9)
    profile_width: int = 160
    max_column_shift: float = 0.2
    max_row_shift: float = 0.2
    planar_motion: PlanarMotion = "ground"
    camera_height: float = 0.5
    camera_forward: float = 0.1
    speed_scale: float = 1.0
    max_speed: float = 2.5
    max_yaw_rate: float = 2.5
    max_climb_rate: float = 0.6
    pitch_leak: float = 0.01
    pitch_flow_bias: float = 0.012
    climb_scale: float = 0.4
    yaw_scale: float = 1.0
    height_model: HeightModel = "transitions"
    transition_rate: float = math.radians(10.0)
    transition_min: float = math.radians(3.0)
    max_slope: float = math.radians(15.0)
    level_snap: float = math.radians(4.0)
    near_floor_row: float = 0.5
    floor_half_width: float = 0.0
    floor_min_information: float = 0.3
    floor_aperture: float = 0.0
    min_image_information: float = 0.2
    blind_hold: float = 10.0
    scale_memory: float = 10.0
    floor_yaw_tolerance: float = math.radians(1.0)
    manhattan: bool = False
    manhattan_strength: float = 0.5
    manhattan_spread: float = math.radians(3.0)
    manhattan_window: int = 50
    manhattan_rate: float = 0.2
    manhattan_first_row: float = 0.3

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "odometry") -> None:
        for name in ("rotation_region", "translation_region", "height_region"):
            region = getattr(self, name)
            _require(f"{path}.{name}", region, isinstance(region, Region), "must be a Region")
            region.validate(f"{path}.{name}")
        _require(f"{path}.profile_width", self.profile_width, isinstance(self.profile_width, int)
                 and 8 <= self.profile_width <= 4096, "must be an integer from 8 to 4096 columns")
        for name in ("max_column_shift", "max_row_shift"):
            value = getattr(self, name)
            _require(f"{path}.{name}", value, _number(value) and 0 < value < 0.5, "must be a fraction in (0, 0.5)")
        _positive(path, speed_scale=self.speed_scale, max_speed=self.max_speed, max_yaw_rate=self.max_yaw_rate,
                  max_climb_rate=self.max_climb_rate, climb_scale=self.climb_scale, yaw_scale=self.yaw_scale)
        _non_negative(path, pitch_leak=self.pitch_leak)
        _require(f"{path}.planar_motion", self.planar_motion, self.planar_motion in PLANAR_MOTIONS,
                 "must be 'profile' or 'ground'")
        _require(f"{path}.camera_forward", self.camera_forward, _number(self.camera_forward)
                 and abs(self.camera_forward) < 10, "must be a distance in metres")
        _positive(path, camera_height=self.camera_height)
        _require(f"{path}.pitch_flow_bias", self.pitch_flow_bias, _number(self.pitch_flow_bias),
                 "must be a number (rad/m)")
        _require(f"{path}.height_model", self.height_model, self.height_model in HEIGHT_MODELS,
                 "must be 'profile' or 'transitions'")
        _positive(path, transition_rate=self.transition_rate, transition_min=self.transition_min)
        _require(f"{path}.max_slope", self.max_slope, _number(self.max_slope) and 0 < self.max_slope < math.pi / 2,
                 "must be an angle in (0, pi/2) rad")
        _require(f"{path}.near_floor_row", self.near_floor_row,
                 _number(self.near_floor_row) and (self.near_floor_row == 0 or 0.3 < self.near_floor_row < 1),
                 "must be 0 (off) or a fraction in (0.3, 1) of half the image height")
        _require(f"{path}.level_snap", self.level_snap,
                 _number(self.level_snap) and 0 <= self.level_snap < self.max_slope,
                 "must be an angle from 0 to max_slope, rad")
        _non_negative(path, min_image_information=self.min_image_information, blind_hold=self.blind_hold,
                      floor_min_information=self.floor_min_information, floor_half_width=self.floor_half_width)
        _positive(path, scale_memory=self.scale_memory, floor_yaw_tolerance=self.floor_yaw_tolerance)
        _require(f"{path}.floor_aperture", self.floor_aperture,
                 _number(self.floor_aperture) and 0 <= self.floor_aperture < math.pi / 2,
                 "must be an angle in [0, pi/2) rad")
        _require(f"{path}.manhattan", self.manhattan, isinstance(self.manhattan, bool), "must be true or false")
        _require(f"{path}.manhattan_strength", self.manhattan_strength,
                 _number(self.manhattan_strength) and 0 < self.manhattan_strength <= 1, "must be a share in (0, 1]")
        _require(f"{path}.manhattan_spread", self.manhattan_spread,
                 _number(self.manhattan_spread) and 0 < self.manhattan_spread < math.pi / 4,
                 "must be an angle in (0, pi/4) rad")
        _require(f"{path}.manhattan_window", self.manhattan_window,
                 isinstance(self.manhattan_window, int) and not isinstance(self.manhattan_window, bool)
                 and self.manhattan_window >= 2, "must be a whole number of frames, 2 or more")
        _positive(path, manhattan_rate=self.manhattan_rate)
        _require(f"{path}.manhattan_first_row", self.manhattan_first_row,
                 _number(self.manhattan_first_row) and 0 <= self.manhattan_first_row < 1,
                 "must be a fraction in [0, 1) of half the image height")


@dataclass(frozen=True)
class LocalViewConfig:
    """Local view cells: patch-normalised thumbnails matched by shifted mean absolute difference.

    Attributes:
        region: crop of the image the thumbnail is taken from.
        thumbnail: (rows, columns) of the thumbnail.
        patch_size: side of the patch normalisation window, pixels (NeuroSLAM eq. 26), odd.
        max_row_shift, max_column_shift: shifts tried when matching, thumbnail pixels.
        threshold: largest mean absolute difference (of patch-normalised values) that still matches.
        candidates: templates pre-selected cheaply before the exact shifted comparison.
    """

    region: Region = Region(0.0, 1.0, 0.0, 1.0)
    thumbnail: tuple[int, int] = (12, 16)
    patch_size: int = 5
    max_row_shift: int = 2
    max_column_shift: int = 4
    threshold: float = 0.3
    candidates: int = 24

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "local_view") -> None:
        _require(f"{path}.region", self.region, isinstance(self.region, Region), "must be a Region")
        self.region.validate(f"{path}.region")
        ok = (isinstance(self.thumbnail, tuple) and len(self.thumbnail) == 2
              and all(isinstance(v, int) and 4 <= v <= 256 for v in self.thumbnail))
        _require(f"{path}.thumbnail", self.thumbnail, ok, "must be (rows, columns), integers from 4 to 256")
        _odd_width(path, "patch_size", self.patch_size, 31)
        for name, limit in (("max_row_shift", self.thumbnail[0] // 2), ("max_column_shift", self.thumbnail[1] // 2)):
            value = getattr(self, name)
            _require(f"{path}.{name}", value, isinstance(value, int) and 0 <= value < max(limit, 1),
                     f"must be an integer from 0 to {max(limit, 1) - 1} pixels")
        _positive(path, threshold=self.threshold)
        _require(f"{path}.candidates", self.candidates, isinstance(self.candidates, int) and self.candidates >= 1,
                 "must be a positive integer")


@dataclass(frozen=True)
class GridCellConfig:
    """3D grid cells (NeuroSLAM eqs. 1–11).

    Attributes:
        size: cells along (x, y, z). cell_size: metres per cell along (x, y, z).
        excitation_width, excitation_variance: Gaussian excitatory kernel (NeuroSLAM eq. 1), cells and cells².
        inhibition_width, inhibition_variance: Gaussian inhibitory kernel (NeuroSLAM eq. 4).
        inhibition_scale: weight of the local inhibition (1 in the paper, which is unstable; see
            :mod:`neuroslam.cells.attractor`).
        global_inhibition: phi of NeuroSLAM eq. 4, subtracted from every cell each frame.
        view_injection: delta of NeuroSLAM eq. 11, strength of local view calibration.
        readout_radius: half-width of the window of the circular-mean read-out, cells.
        shift: path integration by an exact phase ramp (``fourier``) or the paper's blend (``linear``).
    """

    size: tuple[int, int, int] = (48, 48, 16)
    cell_size: tuple[float, float, float] = (2.0, 2.0, 1.0)
    excitation_width: int = 7
    excitation_variance: float = 1.5
    inhibition_width: int = 5
    inhibition_variance: float = 2.0
    inhibition_scale: float = 0.7
    global_inhibition: float = 0.0002
    view_injection: float = 0.005
    readout_radius: int = 4
    shift: Shift = "fourier"

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "grid_cells") -> None:
        _cells(path, "size", self.size, 3)
        ok = isinstance(self.cell_size, tuple) and len(self.cell_size) == 3 and all(
            _number(v) and v > 0 for v in self.cell_size)
        _require(f"{path}.cell_size", self.cell_size, ok, "must be three positive lengths in metres")
        _validate_network(path, self)


@dataclass(frozen=True)
class HeadDirectionConfig:
    """Multilayered head-direction cells (NeuroSLAM eqs. 12–20): yaw × height.

    Attributes:
        size: cells along (yaw, height). height_cell_size: metres per height cell.
        The yaw cell size is 2 pi / size[0] radians. Other fields as in :class:`GridCellConfig`.
        The paper's 8-cell excitatory width is even, which makes a resting packet drift; 9 is used,
        and the read-out window is ±6 cells (the paper's ±5 cuts the packet and biases the read-out).
    """

    size: tuple[int, int] = (36, 36)
    height_cell_size: float = 1.0
    excitation_width: int = 9
    excitation_variance: float = 1.9
    inhibition_width: int = 5
    inhibition_variance: float = 3.0
    inhibition_scale: float = 0.7
    global_inhibition: float = 0.0002
    view_injection: float = 0.005
    readout_radius: int = 6
    shift: Shift = "fourier"

    @property
    def yaw_cell_size(self) -> float:
        """Radians per yaw cell."""
        return 2 * math.pi / self.size[0]

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "head_direction") -> None:
        _cells(path, "size", self.size, 2)
        _positive(path, height_cell_size=self.height_cell_size)
        _validate_network(path, self)


@dataclass(frozen=True)
class GridNetworkConfig:
    """The Burak–Fiete periodic grid-cell network (grid-network paper, grid-network eqs. 1–5, Tables I–II).

    Attributes:
        size: n, neurons along each side of the n × n sheet (a torus).
        time_constant: tau of grid-network eq. 1, ms. time_step: the Euler step of grid-network eq. 1, ms.
        excitation_scale: alpha of grid-network eq. 3. lattice_period: the lambda with beta = 3 / lambda² of
            grid-network eq. 3, neurons.
        surround_ratio: gamma / beta of grid-network eq. 3 (1.05).
        weight_shift: l of grid-network eq. 2, neurons: each neuron's outgoing weights shifted along its
            preferred direction.
        velocity_gain: eta of grid-network eq. 4.
        velocity_scale: the velocity input of grid-network eq. 4 per m/s of the robot's speed; the pattern flows
            linearly with its input (0.36 neurons per step per unit of eta × v) only while eta × this × speed stays
            below about 0.04 (measured: beyond it the lattice deforms), so the default keeps 2 m/s there.
        steps_per_frame: Euler steps of grid-network eq. 1 per camera frame (the accuracy/speed trade-off:
            ``benchmarks/grid_network.py``).
        search_radius: Delta of Table I, neurons: the read-out looks for the shift within ±Delta.
        settle_steps: steps at rest from a random start before use, so that the lattice forms.
        seed: of that random start.
        calibration_directions: headings at which the settled lattice's flow direction is measured once
            against its input, to correct the read-out (0: no correction).
    """

    size: int = 128
    time_constant: float = 5.0
    time_step: float = 0.5
    excitation_scale: float = 1.0
    lattice_period: float = 18.0
    surround_ratio: float = 1.05
    weight_shift: float = 2.0
    velocity_gain: float = 2.0
    velocity_scale: float = 0.01
    steps_per_frame: int = 10
    search_radius: int = 9
    settle_steps: int = 2000
    seed: int = 0
    calibration_directions: int = 24

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "grid_network") -> None:
        _require(f"{path}.size", self.size, isinstance(self.size, int) and not isinstance(self.size, bool)
                 and 16 <= self.size <= 1024, "must be an integer from 16 to 1024 (neurons)")
        _positive(path, time_constant=self.time_constant, time_step=self.time_step,
                  excitation_scale=self.excitation_scale, lattice_period=self.lattice_period,
                  surround_ratio=self.surround_ratio, velocity_scale=self.velocity_scale)
        _non_negative(path, weight_shift=self.weight_shift, velocity_gain=self.velocity_gain)
        _require(f"{path}.time_step", self.time_step, self.time_step <= self.time_constant,
                 "must not exceed time_constant (the Euler step of grid-network eq. 1 would overshoot)")
        for name, low in (("steps_per_frame", 1), ("search_radius", 1), ("settle_steps", 0),
                          ("calibration_directions", 0)):
            value = getattr(self, name)
            _require(f"{path}.{name}", value, isinstance(value, int) and not isinstance(value, bool)
                     and low <= value <= 100_000, f"must be an integer from {low} to 100000")
        _require(f"{path}.search_radius", self.search_radius, self.search_radius < self.size // 2,
                 "must be below half the sheet")
        _require(f"{path}.seed", self.seed, isinstance(self.seed, int) and not isinstance(self.seed, bool),
                 "must be an integer")


@dataclass(frozen=True)
class ExperienceMapConfig:
    """Multilayered experience map (NeuroSLAM eqs. 21–25).

    Attributes:
        view_weight, grid_weight, direction_weight: mu^lv, mu^gc, mu^hdc of NeuroSLAM eq. 22; the grid and
            direction distances are in cells, the view term is 1 for a different template.
        threshold: S_max of NeuroSLAM eq. 22; a score above it for every experience creates a new one.
        correction: psi of NeuroSLAM eq. 25, per relaxation pass (scaled by each experience's number of links).
        relaxation_passes: passes of NeuroSLAM eq. 25 after a loop closure.
        idle_passes: passes of NeuroSLAM eq. 25 on frames without a loop closure.
        relaxation: ``passes`` (the paper: ``relaxation_passes`` / ``idle_passes`` of NeuroSLAM eq. 25 per frame)
            or ``least-squares`` (the minimum of the link errors those passes reduce, solved directly after
            each loop closure; see :meth:`neuroslam.experience_map.ExperienceMap._solve`).
        loop_closure: ``code`` (the paper: re-entering any experience whose conjunctive code matches,
            NeuroSLAM eq. 22, closes a loop) or ``confirmed`` (the rule of the grid-network paper, section III: a
            loop closes only when more than ``confirmation_matches - 1`` of the last
            ``confirmation_window`` frames matched familiar views consistently, i.e. at old experiences
            laid out as the odometry of those frames says, within ``confirmation_tolerance`` metres;
            a confirmed place also moves both networks' packets to its codes).
        confirmation_window, confirmation_matches: frames looked back, and how many must agree. The
            paper's rule is 10 and 7 with ``confirmation_spacing`` 0; the ``sim`` defaults (20 and 16,
            one frame per metre) look back 20 m, because a view there stays the same over a metre or two.
        confirmation_spacing: m; 0 counts every frame (the paper), a distance keeps one frame per that
            much travel in the window, so a view seen for many frames counts once per spacing.
        confirmation_turn: rad; turning on the spot (on a path curving tighter than 0.5 m, the robot's half
            length) keeps one frame per this much turn too, so a robot turning in place at a place it knows
            confirms it without travelling. 5°: the 16 agreeing frames then span 80°, the testbed camera's
            field of view, over which every part of the view has changed. 0: travel alone counts.
        confirmation_views: templates that count as a window frame's view: its best match and the next
            ones within the match threshold (1: the best alone, the paper). A place seen again a little
            off its first path often matches another place's template slightly better than its own
            (measured on urban's second lap, repeated facades: the best match was at the right place for
            88 % of the frames, one of the matches within the threshold for 98.6 %). With the best alone,
            the 16 of 20 agreeing frames came and went, and whether a loop closed depended on the noise
            (urban: SLAM ATE 1.59–1.87 m over three runs with imperceptible noise; with 2, 0.79–0.81 m).
            The others only add evidence: hypotheses come from the best match, and whether a view is
            uninformative from its best match's spread.
        confirmation_tolerance: m, how far a frame's matched experience may lie from where the
            hypothesis puts it. confirmation_age: s, experiences younger than this are not a revisit.
        confirmation_drift: m per m driven since the last loop closure: a hypothesis must lie within
            ``confirmation_tolerance`` plus this times that distance of the current estimate.
        confirmation_climb_error: m of height per m driven: the same for heights (the visual odometry's
            height drifts faster than its position), and how far the window's heights may disagree.
        closure_weight: weight of a loop-closure link's squared errors in the least-squares map, relative to
            a link made by driving (1: all alike). A closure puts the robot on a remembered experience
            that it may pass up to ``confirmation_tolerance`` away from; a link driven between two
            experiences is accurate to centimetres.
    """

    view_weight: float = 10.0
    grid_weight: float = 1.0
    direction_weight: float = 1.0
    threshold: float = 1.0
    correction: float = 0.5
    relaxation_passes: int = 5
    idle_passes: int = 1
    relaxation: Relaxation = "least-squares"
    loop_closure: LoopClosure = "confirmed"
    confirmation_window: int = 20
    confirmation_matches: int = 16
    confirmation_spacing: float = 1.0
    confirmation_turn: float = math.radians(5.0)
    confirmation_views: int = 2
    confirmation_tolerance: float = 1.0
    confirmation_age: float = 30.0
    confirmation_drift: float = 0.1
    confirmation_climb_error: float = 0.3
    closure_weight: float = 0.1

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "experience_map") -> None:
        _non_negative(path, view_weight=self.view_weight, grid_weight=self.grid_weight,
                      direction_weight=self.direction_weight)
        _positive(path, threshold=self.threshold)
        _require(f"{path}.correction", self.correction, _number(self.correction) and 0 < self.correction <= 1,
                 "must be in (0, 1]")
        for name in ("relaxation_passes", "idle_passes"):
            value = getattr(self, name)
            _require(f"{path}.{name}", value, isinstance(value, int) and 0 <= value <= 1000,
                     "must be an integer from 0 to 1000")
        _require(f"{path}.relaxation", self.relaxation, self.relaxation in RELAXATIONS,
                 f"must be one of {', '.join(RELAXATIONS)}")
        _require(f"{path}.loop_closure", self.loop_closure, self.loop_closure in LOOP_CLOSURES,
                 f"must be one of {', '.join(LOOP_CLOSURES)}")
        window = self.confirmation_window
        _require(f"{path}.confirmation_window", window, isinstance(window, int) and 1 <= window <= 1000,
                 "must be an integer from 1 to 1000")
        matches = self.confirmation_matches
        _require(f"{path}.confirmation_matches", matches,
                 isinstance(matches, int) and 1 <= matches <= (window if isinstance(window, int) else 1000),
                 "must be an integer from 1 to confirmation_window")
        views = self.confirmation_views
        _require(f"{path}.confirmation_views", views,
                 isinstance(views, int) and not isinstance(views, bool) and 1 <= views <= 100,
                 "must be an integer from 1 to 100")
        _positive(path, confirmation_tolerance=self.confirmation_tolerance, closure_weight=self.closure_weight)
        _non_negative(path, confirmation_age=self.confirmation_age, confirmation_drift=self.confirmation_drift,
                      confirmation_climb_error=self.confirmation_climb_error,
                      confirmation_spacing=self.confirmation_spacing, confirmation_turn=self.confirmation_turn)


@dataclass(frozen=True)
class Config:
    """All NeuroSLAM parameters.

    Attributes:
        horizontal_fov: the camera's horizontal field of view, rad (2 pi for a panorama).
        vertical_fov: the camera's vertical field of view, rad.
        panoramic: True when image columns wrap around (a 360-degree strip).
        integrator: how the odometric displacement that links experiences is integrated: ``odometry``
            (the self-motion directly, as the paper) or ``grid-network`` (through the Burak–Fiete network
            of the grid-network paper, ``grid_network``; :mod:`neuroslam.cells.grid_network`).
    """

    horizontal_fov: float = math.radians(80.0)
    vertical_fov: float = 2 * math.atan(math.tan(math.radians(40.0)) * 0.75)
    panoramic: bool = False
    integrator: Integrator = "odometry"
    odometry: VisualOdometryConfig = field(default_factory=VisualOdometryConfig)
    local_view: LocalViewConfig = field(default_factory=LocalViewConfig)
    grid_cells: GridCellConfig = field(default_factory=GridCellConfig)
    head_direction: HeadDirectionConfig = field(default_factory=HeadDirectionConfig)
    experience_map: ExperienceMapConfig = field(default_factory=ExperienceMapConfig)
    grid_network: GridNetworkConfig = field(default_factory=GridNetworkConfig)

    def __post_init__(self) -> None:
        _require("horizontal_fov", self.horizontal_fov, _number(self.horizontal_fov)
                 and 0 < self.horizontal_fov <= 2 * math.pi + 1e-9, "must be in (0, 2 pi] radians")
        _require("vertical_fov", self.vertical_fov, _number(self.vertical_fov) and 0 < self.vertical_fov < math.pi,
                 "must be in (0, pi) radians")
        _require("panoramic", self.panoramic, isinstance(self.panoramic, bool), "must be true or false")
        _require("integrator", self.integrator, self.integrator in INTEGRATORS,
                 f"must be one of {', '.join(INTEGRATORS)}")
        if self.panoramic and isinstance(self.odometry, VisualOdometryConfig):
            _require("odometry.planar_motion", self.odometry.planar_motion, self.odometry.planar_motion == "profile",
                     "must be 'profile' for a panoramic camera (the ground-plane model needs a pinhole camera)")
        for name, kind in _SECTIONS.items():
            section = getattr(self, name)
            _require(name, section, isinstance(section, kind), f"must be a {kind.__name__}")
            section.validate(name)

    def replace(self, **changes: Any) -> Config:
        """A copy with some top-level fields or whole sections replaced."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_dict(cls, data: dict[str, Any], *, base: Config | None = None) -> Config:
        """Build a config from nested plain data (as read from TOML or JSON) over ``base`` (defaults).

        Unknown keys are refused with the closest known name suggested.
        """
        base = base or cls()
        if not isinstance(data, dict):
            raise InvalidParameterError("config", type(data).__name__, "must be a table of settings")
        return _merge(base, data, "")

    def to_dict(self) -> dict[str, Any]:
        """Nested plain data (tuples as lists), the inverse of :meth:`from_dict`."""
        return json.loads(json.dumps(dataclasses.asdict(self)))


_SECTIONS = {
    "odometry": VisualOdometryConfig, "local_view": LocalViewConfig, "grid_cells": GridCellConfig,
    "head_direction": HeadDirectionConfig, "experience_map": ExperienceMapConfig, "grid_network": GridNetworkConfig,
}


def _merge(base: Any, data: dict[str, Any], prefix: str) -> Any:
    fields = {f.name: f for f in dataclasses.fields(base)}
    changes: dict[str, Any] = {}
    for key, value in data.items():
        path = f"{prefix}{key}"
        if key not in fields:
            close = difflib.get_close_matches(str(key), list(fields), n=1)
            hint = f" (did you mean {prefix + close[0]!r}?)" if close else f"; known: {', '.join(fields)}"
            raise InvalidParameterError(path, value, f"unknown setting{hint}")
        current = getattr(base, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise InvalidParameterError(path, value, "must be a table of settings")
            changes[key] = _merge(current, value, f"{path}.")
        elif isinstance(current, tuple):
            if not isinstance(value, (list, tuple)):
                raise InvalidParameterError(path, value, f"must be a list of {len(current)} values")
            changes[key] = tuple(value)
        else:
            changes[key] = value
    return dataclasses.replace(base, **changes)  # every section validates itself on construction


def load_config(path: str | Path, *, base: Config | None = None) -> Config:
    """Read a TOML (``.toml``) or JSON (``.json``) file of settings over ``base`` (default: the defaults)."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise InvalidParameterError("config", str(path), f"cannot read ({error.strerror})") from None
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as error:
        raise InvalidParameterError("config", str(path), f"not valid {path.suffix or 'TOML'} ({error})") from None
    return Config.from_dict(data, base=base)
