"""The vision sections of the configuration: image regions, visual odometry, local view cells."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .checks import non_negative, number, odd_width, positive, require
from .options import HEIGHT_MODELS, PLANAR_MOTIONS, HeightModel, PlanarMotion

__all__ = ["LocalViewConfig", "Region", "VisualOdometryConfig"]


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
            require(f"{path}.{name}", value, number(value) and 0 <= value <= 1, "must be a fraction in [0, 1]")
        require(f"{path}.bottom", self.bottom, self.bottom > self.top, "must be greater than top")
        require(f"{path}.right", self.right, self.right > self.left, "must be greater than left")


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
        slope_half_width: for ``ground`` with ``transitions``, eq. G4's near floor's half width beside the path
            while the pitch held is a slope (at least ``transition_min``), m (eq. G7 of
            :mod:`neuroslam.vision.ground_motion`): a ramp's side wall close beside its lane enters the near
            floor's outer corner and turns the yaw (the generator's ramp lanes run 1.3 m from a wall on the right
            both ways, and the ramps turned the odometry counter-clockwise on 61 of 63 two-lap drives, a median
            +26.7 degrees a drive). 1 m (the default; eq. G5's lane, the robot's path and its half width's
            margin) halves that (30.3 -> 14.2 degrees a drive on twenty unseen seeds) and over the benchmark's
            43 worlds and those 20 takes the SLAM ATE's 90th percentile 8.80 -> 5.23 m, the median 1.24 -> 1.23
            m, within 5 m and the odometry 54 -> 56, level accuracy 57 -> 58; "halves" 44 -> 42 (the forty-sixth
            and forty-seventh steps of docs/generalization.md). 0 keeps the whole near floor. With
            ``slope_near_floor`` the lane bounds eq. G9's region as well (before 8835008 it did nothing there,
            eq. G4 being skipped on slopes).
        slope_near_floor: for ``ground`` with ``transitions``, eq. G3's floor region is eq. G4's near floor while the
            pitch held is a slope (eq. G9 of :mod:`neuroslam.vision.ground_motion`; nothing where ``near_floor_row``
            is 0): a ramp's far floor reads its distance short (a hand-written car park's ramps 0.882 of their
            length, 0.995 on the near floor), and a ramp's length places one level against the other. On (the
            default, with ``held_direction`` on and ``ceiling_on_slopes`` off, from the forty-fourth step of
            docs/generalization.md): on a faint ramp the near floor sees the distance on fewer frames and the
            speed is held there, and alone (the forty-third step) it made two catastrophes on ten unseen worlds,
            where the speed held was backward or the ceiling over the ramp was read instead.
        floor_min_information: for ``ground``, the floor's information on the distance (eq. G3's Σ w J_d²) below
            which the floor does not see the distance, as a multiple of the prior's weight. 0.3, measured on the
            testbed (the README's accuracy section): it leaves every textured floor alone. 1.0, where the
            measurement outweighs the constant-velocity prior, handed a quarter of urban's frames to the
            fallbacks, which read them worse (the ceiling cue on facades: 0.65 of the distance, against the
            floor's 0.99 on the same frames; the benchmark's urban SLAM ATE 0.54 -> 3.96 m).
        floor_shared_information: for ``ground``, the floor's (and ceiling's) information on the distance is eq. G8's,
            Σ w J_d J'_d, J'_d the same derivative from the current image's gradients at the floor pixel: the
            part of eq. G3's information both images share. Sensor noise, which the next image does not repeat,
            adds to eq. G3's Σ w J_d² (a uniform image under 1 grey level of noise passes ``floor_min_information``,
            and the floor then reads motion at rest) but averages out of eq. G8's; a texture both images show
            gives both alike. False: eq. G3's. True: eq. G8's on every frame. ``"noisy"`` (the default): eq. G8's
            on the frames whose image has sensor noise (eq. V2 of :mod:`neuroslam.vision.local_view`, the image's
            noise estimated from the image, above half a grey level), eq. G3's elsewhere: on a clean
            render eq. G8 has only the interpolation's residual to judge by, and there it moved the benchmark's
            largely blind worlds by metres both ways (docs/generalization.md, thirty-seventh step), while under a
            camera's noise it is what keeps a blank floor blind (the fortieth step).
        floor_aperture: rad; for ``ground``, that information counts only the floor (and ceiling) pixels whose
            image gradient lies more than this from perpendicular to the image motion of a forward step (eq. G6
            of :mod:`neuroslam.vision.ground_motion`): an edge along the path (a wall's foot, a ramp's side)
            does not change as the robot drives along it, and counted, it held a blank ramp's distance at a
            tenth of the truth. 0 counts every pixel; 10 degrees (the default) is twice the measured direction
            error of a rendered, blurred edge, where a texture whose gradients point every way loses about 0.2 %
            of its information. Over the camera benchmark (43 worlds, against 0 on the same code) it lowers the
            SLAM ATE's median 4.80 -> 3.86 m and raises the worlds within 5 m and their odometry from 23 to 28
            and those with level accuracy >= 0.95 from 32 to 37, no target's count falling
            (docs/generalization.md, sixteenth step). It was off from the tenth step until then, because with
            it urban's closed loop failed its "halves" (which loop closures urban's map makes turns on
            millimetres of odometry); on today's code urban meets it either way.
        min_image_information: with ``ground`` and ``transitions``, the whole image's information on the yaw
            (eq. R2 of :mod:`neuroslam.vision.pitch`, Σ w J², intensity² per rad²) per pixel of the height
            region below which the image does not see the yaw (nor the pitch: a height transition commits only
            where one of its frames sees it, eq. R3), and the odometry says it is blind. 0.2 is five times what
            sensor noise of 5 grey levels alone gives a uniform image (0.04: noise must never count as seeing),
            and a twentieth of what any texture across the image gives (1–4).
        blind_hold: seconds the last observed speed is held where nothing observes the distance, before it is
            taken as 0 (the turn rate: ``yaw_hold``). 10: as long as
            the scales of the ceiling and the upper image are remembered (``scale_memory``), the robot's motion
            is taken to go on as last seen. (2 s dropped the building's blank stretches to 0 for 55 frames a
            lap, 5.5 m; its SLAM ATE 2.09 m against 1.60 m with 10 s.)
        blind_turn_band: with ``ground`` and ``transitions``, rad/s: the speed held where nothing observes the
            distance is the median of those observed at a turn rate (averaged over a second) within this of
            the current one (eq. R8 of :mod:`neuroslam.vision.cues`), not the last one, which is often a
            corner's; 0: the last observed speed. 0.05: twice the 99th percentile of the averaged turn rate the
            odometry reads while the robot drives straight on the development worlds (0.025 rad/s on the
            building, urban), and a tenth of a corner's (0.5–2 rad/s at the testbed's driver). The default
            since the camera benchmark judged it (docs/generalization.md, the twenty-eighth step).
        yaw_hold: with ``ground`` and ``transitions``, seconds: where nothing observes the yaw (not the floor,
            not the whole image, not the column profile), the turn rate averaged over the last second of frames
            whose yaw was observed is held for at most this long, marked ``held`` (eq. R10 of
            :meth:`neuroslam.vision.cues.CueSelectionMixin._held_turn`: a turning robot goes on turning, as
            a driving one goes on driving, ``blind_hold``); beyond it, and with 0, there is no turn. 0 (off):
            on the camera benchmark 1 s mended the blind turns of two largely blind worlds (gen3:130 4.58 →
            1.41 m) but also held the column profile's false turns (gen3:111 1.52 → 11.99 m; SLAM ATE 90th
            percentile 5.73 → 8.49 m; docs/generalization.md, the thirty-second step).
        faint_yaw_contrast: with ``ground`` and ``transitions``: where neither the floor nor the whole image
            sees the yaw (the image's information on it below ``min_image_information``), the image's yaw is
            still taken, before the column profile's, where it stands out from the yaws around it by this
            contrast (eq. R11 of :meth:`neuroslam.vision.pitch.RotationAlignment.column_yaw_contrast`: eq. R5's
            cost a few pixels of yaw away over its cost at the solution, in the median). The information per
            pixel cannot tell a faint structure from sensor noise (a uniform image under 3.5 grey levels of
            noise has as much as a faint edge); the contrast can: noise alone gives 0.95–1.12 (uniform images
            under 1–8 grey levels). 1.5 (the default), the column profile's own stand-out ratio (NeuroSLAM eq.
            28), stays clear of it. 0 (off): the column profile is the yaw's last resort. On the camera benchmark
            1.5 before the profile lowered the SLAM ATE's 90th percentile 5.73 → 4.00 m and met every target on
            32 worlds instead of 30, but two worlds gained closures 2.02–2.16 m along their lane, false by the 2 m
            bound (docs/generalization.md, the thirty-third step); after the profile and with
            ``experience_map.confirmation_rival_spread`` 1, none (the thirty-fourth step).
        faint_yaw_after_profile: with ``faint_yaw_contrast``, the column profile's yaw stays first where its
            best shift stands out, and eq. R11's is taken only on the frames nothing else saw. True (the
            default). False (the order the benchmark measured first): eq. R11 before the profile, which also
            mends the profile's false turns (a slanted edge moving up the image) but changes many more frames
            and closed loops falsely onto a lone place 2 m ahead behind a largely blind window (gen3:136, the
            thirty-fourth step).
        profile_expansion: with ``ground`` and ``transitions``: where the column profile gives the yaw (the
            last resort, where neither the floor nor the whole image's alignment sees it), its shift is found
            together with the image's expansion (eq. R9 of :func:`neuroslam.vision.profiles.profile_turn`), up
            to the fastest travel (``max_speed``) toward the nearest thing the camera sees (the floor at the
            image's lower edge). Without it a robot driving toward a wall with more structure on one side
            reads a turn (gen3:137: 20° over 5 m of straight, blank floor). Off: on the camera benchmark's
            largely blind worlds it moved SLAM ATE by metres both ways (worst 14.4 → 16.8 m over 14 worlds;
            docs/generalization.md, the twenty-ninth step, with two known defects).
        forward_evidence: with ``transitions``, the t-statistic of the whole image's expansion (eq. R4 of
            :mod:`neuroslam.vision.pitch`: eq. R1's expansion over its standard error) from which a frame on
            which nothing observes the distance still shows the robot moving in the held speed's direction: the
            speed stays held, and ``blind_hold`` counts from the last such frame (the image gives the motion's
            sign, not its size: the frame stays marked held). 0: never (the hold counts from the last observed
            distance). 10: at rest and turning in place on 2° a frame over a blank floor between textured walls
            (tests/scenes.py, with and without sensor noise of 2 grey levels) |z| stays within 6.5; driving
            there at 1 m/s it is 53–90.
        held_direction: with ``transitions`` and ``forward_evidence``: where nothing observes the distance
            and the whole image shows the robot moving (its expansion's t-statistic beyond
            ``forward_evidence``) against the direction of the speed held, the speed held becomes the median
            of the observed speeds that went the image's way (eq. R12 of
            :meth:`neuroslam.vision.cues.CueSelectionMixin._image_direction_speed`), where at least ten did.
            A held speed is one floor reading carried on, and one wrong minimum at a ramp's top (the floor not
            one plane) made it backward: gen3:133's odometry drove 21 m backwards over a blank deck while
            the image showed it driving forward, and gen3:207's held -0.2 m/s down a whole 21 m ramp. True (the
            default from the forty-fourth step of docs/generalization.md, with eq. G9); False: the speed held
            stands, only the hold's clock runs. Alone (the forty-first step) it bettered the camera benchmark's
            median and 90th percentile but turned gen3:136, a catastrophe either way, 11.19 -> 14.95 m.
        ceiling_on_slopes: with ``ground`` and ``transitions``, the ceiling's distance (eq. S1 of
            :meth:`neuroslam.vision.cues.CueSelectionMixin._observed_motion`) is read, and its height learnt, on
            slopes too (the pitch held a slope, as eq. G7). A ceiling is a plane parallel to the floor only over a
            level floor: over a ramp a level ceiling stands tilted by the slope against the camera and its
            height above the robot changes along the ramp, which eq. G1's parallel plane does not model
            (gen3:207's downhill ramp read 0.66 of its length from the ceiling). False (the default from the
            forty-fourth step of docs/generalization.md): on a slope the ceiling is neither read nor learnt from.
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
        working_width: columns; the direct alignments (eqs. G1–G4, R1–R2, M1) run on the grey image
            area-averaged to this width (rows in proportion) where it is wider, so their cost and their
            per-pixel settings (the blur, the pyramid's two levels, the columns sampled) stay those of the
            testbed's 160-pixel camera at any resolution (docs/speed.md); the profiles of NeuroSLAM eqs. 27–32
            resample the full image to ``profile_width`` as before. 0 aligns at full resolution.
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
    slope_half_width: float = 1.0
    slope_near_floor: bool = True
    floor_min_information: float = 0.3
    floor_shared_information: bool | str = "noisy"
    floor_aperture: float = 0.1745  # 10 degrees (the value the benchmark measured)
    min_image_information: float = 0.2
    blind_hold: float = 10.0
    blind_turn_band: float = 0.05
    yaw_hold: float = 0.0
    faint_yaw_contrast: float = 1.5
    faint_yaw_after_profile: bool = True
    profile_expansion: bool = False
    forward_evidence: float = 10.0
    held_direction: bool = True
    ceiling_on_slopes: bool = False
    scale_memory: float = 10.0
    floor_yaw_tolerance: float = math.radians(1.0)
    manhattan: bool = False
    manhattan_strength: float = 0.5
    manhattan_spread: float = math.radians(3.0)
    manhattan_window: int = 50
    manhattan_rate: float = 0.2
    manhattan_first_row: float = 0.3
    working_width: int = 160

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "odometry") -> None:
        for name in ("rotation_region", "translation_region", "height_region"):
            region = getattr(self, name)
            require(f"{path}.{name}", region, isinstance(region, Region), "must be a Region")
            region.validate(f"{path}.{name}")
        require(f"{path}.profile_width", self.profile_width, isinstance(self.profile_width, int)
                 and 8 <= self.profile_width <= 4096, "must be an integer from 8 to 4096 columns")
        for name in ("max_column_shift", "max_row_shift"):
            value = getattr(self, name)
            require(f"{path}.{name}", value, number(value) and 0 < value < 0.5, "must be a fraction in (0, 0.5)")
        positive(path, speed_scale=self.speed_scale, max_speed=self.max_speed, max_yaw_rate=self.max_yaw_rate,
                  max_climb_rate=self.max_climb_rate, climb_scale=self.climb_scale, yaw_scale=self.yaw_scale)
        non_negative(path, pitch_leak=self.pitch_leak)
        require(f"{path}.planar_motion", self.planar_motion, self.planar_motion in PLANAR_MOTIONS,
                 "must be 'profile' or 'ground'")
        require(f"{path}.camera_forward", self.camera_forward, number(self.camera_forward)
                 and abs(self.camera_forward) < 10, "must be a distance in metres")
        positive(path, camera_height=self.camera_height)
        require(f"{path}.pitch_flow_bias", self.pitch_flow_bias, number(self.pitch_flow_bias),
                 "must be a number (rad/m)")
        require(f"{path}.height_model", self.height_model, self.height_model in HEIGHT_MODELS,
                 "must be 'profile' or 'transitions'")
        positive(path, transition_rate=self.transition_rate, transition_min=self.transition_min)
        require(f"{path}.max_slope", self.max_slope, number(self.max_slope) and 0 < self.max_slope < math.pi / 2,
                 "must be an angle in (0, pi/2) rad")
        require(f"{path}.near_floor_row", self.near_floor_row,
                 number(self.near_floor_row) and (self.near_floor_row == 0 or 0.3 < self.near_floor_row < 1),
                 "must be 0 (off) or a fraction in (0.3, 1) of half the image height")
        require(f"{path}.level_snap", self.level_snap,
                 number(self.level_snap) and 0 <= self.level_snap < self.max_slope,
                 "must be an angle from 0 to max_slope, rad")
        non_negative(path, min_image_information=self.min_image_information, blind_hold=self.blind_hold,
                      blind_turn_band=self.blind_turn_band, yaw_hold=self.yaw_hold,
                      faint_yaw_contrast=self.faint_yaw_contrast,
                      forward_evidence=self.forward_evidence,
                      floor_min_information=self.floor_min_information, floor_half_width=self.floor_half_width,
                      slope_half_width=self.slope_half_width)
        positive(path, scale_memory=self.scale_memory, floor_yaw_tolerance=self.floor_yaw_tolerance)
        require(f"{path}.floor_aperture", self.floor_aperture,
                 number(self.floor_aperture) and 0 <= self.floor_aperture < math.pi / 2,
                 "must be an angle in [0, pi/2) rad")
        require(f"{path}.manhattan", self.manhattan, isinstance(self.manhattan, bool), "must be true or false")
        require(f"{path}.slope_near_floor", self.slope_near_floor, isinstance(self.slope_near_floor, bool),
                "must be true or false")
        require(f"{path}.faint_yaw_after_profile", self.faint_yaw_after_profile,
                isinstance(self.faint_yaw_after_profile, bool), "must be true or false")
        require(f"{path}.floor_shared_information", self.floor_shared_information,
                isinstance(self.floor_shared_information, bool) or self.floor_shared_information == "noisy",
                'must be true, false or "noisy"')
        require(f"{path}.held_direction", self.held_direction, isinstance(self.held_direction, bool),
                "must be true or false")
        require(f"{path}.ceiling_on_slopes", self.ceiling_on_slopes, isinstance(self.ceiling_on_slopes, bool),
                "must be true or false")
        require(f"{path}.profile_expansion", self.profile_expansion, isinstance(self.profile_expansion, bool),
                "must be true or false")
        require(f"{path}.manhattan_strength", self.manhattan_strength,
                 number(self.manhattan_strength) and 0 < self.manhattan_strength <= 1, "must be a share in (0, 1]")
        require(f"{path}.manhattan_spread", self.manhattan_spread,
                 number(self.manhattan_spread) and 0 < self.manhattan_spread < math.pi / 4,
                 "must be an angle in (0, pi/4) rad")
        require(f"{path}.manhattan_window", self.manhattan_window,
                 isinstance(self.manhattan_window, int) and not isinstance(self.manhattan_window, bool)
                 and self.manhattan_window >= 2, "must be a whole number of frames, 2 or more")
        positive(path, manhattan_rate=self.manhattan_rate)
        require(f"{path}.working_width", self.working_width,
                 isinstance(self.working_width, int) and not isinstance(self.working_width, bool)
                 and (self.working_width == 0 or 32 <= self.working_width <= 4096),
                 "must be 0 (full resolution) or a whole number of columns from 32 to 4096")
        require(f"{path}.manhattan_first_row", self.manhattan_first_row,
                 number(self.manhattan_first_row) and 0 <= self.manhattan_first_row < 1,
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
        noise_floor: eq. V1 of :mod:`neuroslam.vision.local_view`: a patch's contrast is counted with this many
            times the sensor noise left in a thumbnail pixel (the image's noise, eq. V2, estimated on every
            frame), so a blank patch under noise is not raised to unit contrast; 0: NeuroSLAM eq. 26 alone.
            4, the least whole number with which two views of one blank scene under noise differ by less than
            ``threshold`` (1.13 / sqrt(1 + c²) < 0.3); more would flatten faint texture a camera can still tell
            from its noise. Up to half a grey level (all rounding to 8 bits can give) the noise counts as none:
            the testbed's clean renders read at most 0.28, and eq. 26 is unchanged there.
    """

    region: Region = Region(0.0, 1.0, 0.0, 1.0)
    thumbnail: tuple[int, int] = (12, 16)
    patch_size: int = 5
    max_row_shift: int = 2
    max_column_shift: int = 4
    threshold: float = 0.3
    candidates: int = 24
    noise_floor: float = 4.0

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "local_view") -> None:
        require(f"{path}.region", self.region, isinstance(self.region, Region), "must be a Region")
        self.region.validate(f"{path}.region")
        ok = (isinstance(self.thumbnail, tuple) and len(self.thumbnail) == 2
              and all(isinstance(v, int) and 4 <= v <= 256 for v in self.thumbnail))
        require(f"{path}.thumbnail", self.thumbnail, ok, "must be (rows, columns), integers from 4 to 256")
        odd_width(path, "patch_size", self.patch_size, 31)
        for name, limit in (("max_row_shift", self.thumbnail[0] // 2), ("max_column_shift", self.thumbnail[1] // 2)):
            value = getattr(self, name)
            require(f"{path}.{name}", value, isinstance(value, int) and 0 <= value < max(limit, 1),
                     f"must be an integer from 0 to {max(limit, 1) - 1} pixels")
        positive(path, threshold=self.threshold)
        non_negative(path, noise_floor=self.noise_floor)
        require(f"{path}.candidates", self.candidates, isinstance(self.candidates, int) and self.candidates >= 1,
                 "must be a positive integer")
