"""The experience map's section: matching, loop closure and relaxation."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .checks import non_negative, number, positive, require
from .options import LOOP_CLOSURES, RELAXATIONS, LoopClosure, Relaxation

__all__ = ["ExperienceMapConfig"]


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
        confirmation_blind: a loop closure, or a merge with another session's map, may be confirmed on a frame
            whose distance nothing observed (``held`` or ``none``, :class:`~neuroslam.vision.motion.Observed`).
            False (the default): neither is. A
            forward camera recognises a place from a few metres before it, and where the floor shows too little
            to measure the distance, the view is mostly walls and far scene, which change little along the path:
            measured on recorded two-lap drives of four benchmark worlds (gen3:102, 125, 132, 139), the
            closures confirmed on blind frames re-entered experiences made 0.19–1.59 m (median per world) and
            up to 3.45 m from the robot's true place, against 0.07–0.11 m and at most 0.61 m on seen frames
            (2.02 m once), and six of the seven false closures (over 2 m) were blind (docs/generalization.md,
            the twentieth step). The frames after the stretch, where the floor is seen again, confirm it. A
            merge moves the whole partial map by where the robot stands, so the same holds for it.
            Only a source that says what it observed is ever blind (not wheels, not the paper's profile
            odometry).
        confirmation_laid_apart: two confirmed places one pass laid more than ``2 * confirmation_tolerance``
            apart (by its odometer, within the window's travel) are rivals however close the map has since put
            them (:func:`~neuroslam.loop_closure.confirm_place`'s ``odometers``). On the camera benchmark it
            changed one world of 43, gen3:130, whose false closure was such a pair (the map held them 0.25 m
            apart, the odometry had laid them 2.3 m apart): gone; the other 42 the same to the digit
            (docs/generalization.md, the twenty-sixth step). False: the rule before it.
        confirmation_rival_spread: in ``confirmation_tolerance``: a confirmed place with another place the window
            confirms as well farther than this from it, in the map or by one pass's odometer (with
            ``confirmation_laid_apart``), is not confirmed (:func:`~neuroslam.loop_closure.confirm_place`'s
            ``rival_spread``). 2 (the rule before): two places are distinct from twice the tolerance, as in the
            view rule. 1 (the default): only where every place the window explains as well lies within the
            tolerance each frame is held to; between 1 and 2 tolerances the better fit is a guess, and its error
            reaches the 2 m at which the benchmark calls a closure false (gen3:130's and gen3:137's near-miss
            closures, 2.02–2.06 m, were the worse fit of two confirmed places 1.86–1.89 m apart;
            docs/generalization.md, the thirty-fourth step). With the wheels every benchmark world still meets
            every target at 1 (the thirty-sixth step).
        confirmation_along_path: where no place is confirmed, try eq. M8: a place known across the path but not
            along it (:func:`~neuroslam.loop_closure.confirm_place`'s ``along_path``). On a blank floor a view
            is seen along many metres; the confirmation above counts it as no evidence (it cannot say where
            along the path the robot is), and a world whose views are mostly such confirms almost nothing
            (gen3:103: 1,781 of 2,133 tested windows of its second lap fail for that alone, one loop closure in
            two laps). Such a window still says where the robot is across the path and which way it faces; the
            experience made next is linked to the winning place by a link that is free along the place's
            heading (eq. M5's row across, with the weight of a loop closure), and the robot's codes are not
            moved. Only where the current view's match pins its column shift (as for eq. M6: the link holds the
            robot's yaw to the place's plus the view's): on gen3:137 11 of 557 such links were more than 10°
            off without it, none with it. Not counted as a loop closure. False: off; on the benchmark's 13
            largely blind worlds it made gen3:132 a catastrophe (7 links joined look-alike corridors up to 35 m
            apart, which the rule it relaxes keeps out) and gen3:136 worse (docs/generalization.md, the
            thirty-ninth step).
        confirmation_local_reach: judge whether a window frame's view says where the robot is per hypothesis,
            near where that hypothesis maps the frame (within ``2 * confirmation_tolerance`` plus
            ``confirmation_drift`` per metre of the frame's distance from the current one), as a merge with
            another session's map does (:func:`~neuroslam.loop_closure.confirm_place`'s ``local_reach``), instead
            of over everything within the search radius. The radius grows by ``confirmation_drift`` per metre
            driven since the last closure, and a view seen twice within it (a corridor of large tiles that looks
            alike every 8 m) is then no evidence for any place: measured on a recorded two-lap drive of gen3:204,
            the second lap's ground level matched lap one's views on 99 % of its frames for 130 m and confirmed
            nothing, 18–20 of 20 window frames agreeing but 7–17 of them voided by views repeated 6–11 m apart
            within the radius; with the option that replay closes the loop (SLAM ATE 2.15 -> 1.72 m), and the
            twenty unseen seeds gain (every target 11 -> 12). Alone it closes loops falsely (urban's repeated
            facades 9, gen3:217 3: the radius-wide rule was what kept look-alikes metres apart from confirming
            each other; docs/generalization.md, the forty-fifth step); with ``confirmation_rival_shifts`` and
            ``confirmation_pinned_yaw`` it is the default (True; the forty-ninth step). False: the radius-wide
            rule (the fourteenth step's "each hypothesis's own places" was the same rule).
        confirmation_rival_shifts: the rival test over every place the window explains, not only the current
            view's places (:func:`~neuroslam.loop_closure.rival_shift_support`): a place is not confirmed where a
            copy of it shifted by more than the rival spread has as many window frames agreeing, the copy within
            the search radius of the estimate or no farther from the place than the place from the estimate.
            Urban's first false closure with ``confirmation_local_reach`` (11.9 m off, a straight window under a
            33 m radius) had a copy 3.8 m on with its full 16 frames, its 1,362 true closures one with 6 at most;
            gen3:116's (5 m off, the place 16.4 m from the estimate) a copy 5 m on with 20 (the forty-seventh
            step). True (the default, from the forty-ninth step); False: the rival test over the current
            view's places only.
        confirmation_rival_odds: with ``confirmation_rival_shifts``, a shifted copy of a confirmed place is a rival
            by how likely a place the robot's estimate makes it against the place, not by whether it lies within
            reach (:func:`~neuroslam.loop_closure.confirm_place`'s ``rival_odds``): the search radius taken as the
            estimate's 2σ bound, a copy refuses the place where the place is less than this many times as likely.
            0 (the default): the reach rule.
        closure_window_pose: where a loop closure puts the robot. True: on its confirmed place moved by where
            the confirmation window's frames say the robot is against it
            (:func:`~neuroslam.loop_closure.confirm_place`'s ``offset``: the median over the agreeing frames, each
            placed by its own view), always; the robot's codes are moved there. On the 43 benchmark worlds, camera
            only, better by more than 5 cm on 20 and worse on 6; with the wheels better on 30 and worse on 5, the
            worst 2.00 → 1.66 m; but the hand-written angled car park goes 0.83 → 3.07 m camera only (its
            odometry 1.82 m) and 2.85 → 2.94 m with the wheels (eq. M4 on its 60° bays; without it 0.79 and
            0.75 m): not the default (the fifty-sixth step of docs/generalization.md). False (the default): on
            the place, with the codes moved only where they lie farther from it than ``threshold`` (about 2 m or
            10° with the ``sim`` preset), and otherwise kept, the robot's own drifted estimate near the place
            giving the closure's offset.
        reentry_keeps_pose: where the robot is when it re-enters an experience without closing a loop (eq. 22's
            match on an experience linked to the current one: the robot follows the map). True: where it was in
            the map, its pose re-expressed against the experience (the odometry since the last experience goes on
            from there). False (the default): where the difference of the codes puts it
            (:meth:`~neuroslam.experience_map.ExperienceMap._offset`), which, with ``reentry_links_driven`` off,
            the link the robot drives next from that experience then carries (0.3 m off in the median where a
            second session follows the first's map, against 0.007 m for a link from an experience the robot
            made). On the 43 benchmark worlds, camera only,
            the median SLAM ATE 1.16 → 0.89 m, better by more than 5 cm on 16 and worse on 7 (gen3:102 0.99 →
            1.34 m), no target count changed; multisession 3 → 4 of 5; with the wheels 0.60 / 1.21 / 2.00 →
            0.58 / 0.94 / 1.22 m (median / p90 / worst), 43 of 43; but a robot that follows a map a loop closure
            has bent leaves it (the synthetic square's second lap 2.0 m from its first, ``tests/test_slam.py``):
            not the default (docs/generalization.md, the fifty-ninth and sixtieth steps; ``reentry_links_driven``
            keeps its links without that).
        reentry_links_driven: with ``reentry_keeps_pose`` off, a re-entry still puts the robot where the codes
            say (its estimate, and the frames' places in the map), but the next link from the experience (to a
            new experience, or a loop closure) carries the driven path: the odometry since the last experience
            made or closed onto, re-expressed against each experience re-entered on the way through the map's
            poses (:attr:`~neuroslam.experience_map.ExperienceMap.driven`). The links lose the code-read place
            as with ``reentry_keeps_pose``, while a robot following a map that a loop closure bent stays on it
            (with ``reentry_keeps_pose`` on two laps of a synthetic square it parts from its first lap by 2 m in
            the median, ``tests/test_slam.py``). True (the default; the paper presets keep it off): on the 43
            benchmark worlds camera only 1.16 / 4.31 / 15.00 → 0.90 / 4.27 / 15.00 m (median / p90 / worst), 33
            of 43 as before; on twenty unseen seeds every target 12 → 13 of 20, gen3:215's 34 false closures
            gone; multisession 3 → 4 of 5 within 1.25 × one session's; with the wheels 0.60 / 1.21 /
            2.00 → 0.59 / 1.02 / 1.21 m, 43 of 43
            (docs/generalization.md, the sixtieth and sixty-first steps). False: the link starts at the
            code-read place.
        confirmation_pinned_yaw: a loop closure turns the robot onto its place by the view's yaw relative to its
            template only where the view's match pins that yaw (eq. M6's rule: its difference below half its
            template's column contrast); elsewhere the robot keeps the odometry's heading, and the hypotheses
            map the window by it. On gen1:2 with ``confirmation_local_reach`` the closures whose view did not
            pin its yaw erred by up to 5.0° in heading, those that did by 2.2° at most (the forty-eighth step).
            True (the default, from the forty-ninth step); False: every closure takes the view's yaw.
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
        structure_weight: weight of eq. M4's residual (rad²) per experience that saw the floor's straight
            lines, relative to a driven link's yaw error; 0 leaves the lines out (the paper's map). Eq. M4
            (:mod:`neuroslam.relaxation`) holds the map's heading to the lines' direction, modulo 90°, where
            no loop closes; only with ``relaxation = "least-squares"``. 0.01: the lines' orientation scatters
            by about 2° a frame (35 mrad, :mod:`neuroslam.vision.structure`) and a driven link's yaw by about 8
            mrad (the testbed's wheels over half a metre), (8 / 35)² ≈ 0.05 for independent errors; but a
            misread stretch (a wall's foot taken for a floor line) lasts tens of frames, about five experiences
            at one every half metre, which share one error, so each counts a fifth.
        structure_tolerance: rad, the Cauchy scale of eq. M4: an orientation this far from the map's counts
            half (a wall's foot or a ramp's edge read as a floor line). 2°, the lines' per-frame scatter.
        structure_families: the most directions of lines (modulo 90°) eq. M4 holds the map to
            (:func:`~neuroslam.relaxation.structure_axes`): each experience is held to the nearest, and a further
            direction counts only where its readings hold half the first's support. 1: one direction and its
            perpendicular, as eq. M4 was first written. 2 (the default) holds a building laid along two
            directions, a wing turned against the main block or bays painted at an angle to the lanes (measured in
            docs/generalization.md, the fifty-seventh and fifty-eighth steps: the 43 camera only and with the
            wheels as with 1, the hand-written car park with the wheels 2.85 → 0.48 m); each direction beyond is
            one more chance for a drifted stretch of a blind map to be held to its own drift.
        view_heading_weight: weight of eq. M6's residual (rad²) per experience made on a familiar view, relative
            to a driven link's yaw error; 0 leaves it out (the paper's map). Eq. M6 (:mod:`neuroslam.relaxation`)
            holds the experience's yaw to the yaw the view was learned at plus the view's relative yaw (the
            view cells' column shift): a view seen again tells the heading even where it cannot tell the place
            along the path (a blank floor, where no loop closes). Only with ``relaxation = "least-squares"``.
            0.05: the shift is whole thumbnail columns (5° with the ``sim`` camera), a uniform error of 1.4°
            (25 mrad) 1σ, against a driven link's 8 mrad, (8 / 25)² ≈ 0.1 for independent errors; consecutive
            experiences made on one view share its shift, about two each, so each counts a half.
        view_heading_tolerance: rad, the Cauchy scale of eq. M6, on how far an experience's residual lies from
            the median of its neighbours' (the :data:`~neuroslam.relaxation.VIEW_HEADING_NEIGHBOURS` made
            nearest it): the map's heading drifts slowly along a path, so neighbours share their
            residual, and a view that matched a look-alike elsewhere (facing another way) departs from it.
            5°: one column of the view's shift.
        view_heading_difference: the largest view-cell match difference (``local_view.threshold``'s measure)
            of a view whose heading counts for eq. M6: 0.15, half the view cells' threshold. On two recorded
            two-lap drives of generated worlds (docs/generalization.md, the thirty-eighth step), matches
            within it kept 45 % of the views whose heading was right within 10° and 1–5 % of those that were
            not (look-alikes 20–25 m away, facing another way).
        structure_interval: m driven between the solves eq. M4 (or eq. M6) starts (a loop closure starts its own). 10 m:
            the wheels' heading walks about 1.7° in that distance (9.1 mrad per root metre, docs/testbed.md),
            within ``structure_tolerance``, so the new experiences' lines are not yet weighed down as misread.
        blind_speed_error: m/s, how wrong a distance nothing observed may be per second (1σ): a link weighs
            its length by its weight × s² / (s² + (this × its seconds blind)²), s = ``link_length_error``, and its
            direction by its weight (eq. M5 of :mod:`neuroslam.relaxation`): a loop closure stretches the
            stretches nobody measured instead of bending the loop. 0: every length alike (the paper's map).
            0.6 m/s: the testbed drives at about 1 m/s; a held speed is off by about 40 %, a blind frame past
            ``odometry.blind_hold`` by 100 % (docs/generalization.md, the twelfth step), about three to one, a
            root mean square of 0.6. Scale it with your robot's speed. Only with ``relaxation =
            "least-squares"``; a source that does not say what it observed (wheels, the paper's profile
            odometry) is never blind.
        link_length_error: m, 1σ of a link's length where its distance was seen: 0.03 m, the root mean square
            forward error of the links under 0.35 s on 31 benchmark worlds (`benchmarks/link_errors.py` on eq.
            M4's run, whose links did not yet say whether they were blind). Labelled, eq. M5's run gives 0.014 m
            for the seen ones, and 0.73–0.85 m/s for ``blind_speed_error``; both defaults weigh a blind link's
            length more than those would, and were not re-run at the measured values.
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
    confirmation_blind: bool = False
    confirmation_laid_apart: bool = True
    confirmation_rival_spread: float = 1.0
    confirmation_along_path: bool = False
    confirmation_local_reach: bool = True
    confirmation_rival_shifts: bool = True
    confirmation_pinned_yaw: bool = True
    confirmation_rival_odds: float = 0.0
    closure_window_pose: bool = False
    reentry_keeps_pose: bool = False
    reentry_links_driven: bool = True
    confirmation_tolerance: float = 1.0
    confirmation_age: float = 30.0
    confirmation_drift: float = 0.1
    confirmation_climb_error: float = 0.3
    closure_weight: float = 0.1
    structure_weight: float = 0.01
    structure_tolerance: float = math.radians(2.0)
    structure_families: int = 2
    structure_interval: float = 10.0
    view_heading_weight: float = 0.0
    view_heading_tolerance: float = math.radians(5.0)
    view_heading_difference: float = 0.15
    blind_speed_error: float = 0.6
    link_length_error: float = 0.03

    def __post_init__(self) -> None:
        self.validate()

    def validate(self, path: str = "experience_map") -> None:
        non_negative(path, view_weight=self.view_weight, grid_weight=self.grid_weight,
                      direction_weight=self.direction_weight)
        positive(path, threshold=self.threshold)
        require(f"{path}.correction", self.correction, number(self.correction) and 0 < self.correction <= 1,
                 "must be in (0, 1]")
        for name in ("relaxation_passes", "idle_passes"):
            value = getattr(self, name)
            require(f"{path}.{name}", value, isinstance(value, int) and 0 <= value <= 1000,
                     "must be an integer from 0 to 1000")
        require(f"{path}.relaxation", self.relaxation, self.relaxation in RELAXATIONS,
                 f"must be one of {', '.join(RELAXATIONS)}")
        require(f"{path}.loop_closure", self.loop_closure, self.loop_closure in LOOP_CLOSURES,
                 f"must be one of {', '.join(LOOP_CLOSURES)}")
        window = self.confirmation_window
        require(f"{path}.confirmation_window", window, isinstance(window, int) and 1 <= window <= 1000,
                 "must be an integer from 1 to 1000")
        matches = self.confirmation_matches
        require(f"{path}.confirmation_matches", matches,
                 isinstance(matches, int) and 1 <= matches <= (window if isinstance(window, int) else 1000),
                 "must be an integer from 1 to confirmation_window")
        require(f"{path}.confirmation_laid_apart", self.confirmation_laid_apart,
                 isinstance(self.confirmation_laid_apart, bool), "must be true or false")
        require(f"{path}.confirmation_blind", self.confirmation_blind, isinstance(self.confirmation_blind, bool),
                 "must be true or false")
        require(f"{path}.confirmation_along_path", self.confirmation_along_path,
                isinstance(self.confirmation_along_path, bool), "must be true or false")
        require(f"{path}.confirmation_local_reach", self.confirmation_local_reach,
                isinstance(self.confirmation_local_reach, bool), "must be true or false")
        require(f"{path}.confirmation_rival_shifts", self.confirmation_rival_shifts,
                isinstance(self.confirmation_rival_shifts, bool), "must be true or false")
        require(f"{path}.confirmation_pinned_yaw", self.confirmation_pinned_yaw,
                isinstance(self.confirmation_pinned_yaw, bool), "must be true or false")
        require(f"{path}.closure_window_pose", self.closure_window_pose,
                isinstance(self.closure_window_pose, bool), "must be true or false")
        require(f"{path}.reentry_keeps_pose", self.reentry_keeps_pose,
                isinstance(self.reentry_keeps_pose, bool), "must be true or false")
        require(f"{path}.reentry_links_driven", self.reentry_links_driven,
                isinstance(self.reentry_links_driven, bool), "must be true or false")
        require(f"{path}.structure_families", self.structure_families,
                isinstance(self.structure_families, int) and not isinstance(self.structure_families, bool)
                and 1 <= self.structure_families <= 4, "must be an integer from 1 to 4")
        views = self.confirmation_views
        require(f"{path}.confirmation_views", views,
                 isinstance(views, int) and not isinstance(views, bool) and 1 <= views <= 100,
                 "must be an integer from 1 to 100")
        require(f"{path}.confirmation_rival_spread", self.confirmation_rival_spread,
                 number(self.confirmation_rival_spread) and 0 < self.confirmation_rival_spread <= 2,
                 "must be in (0, 2]")
        positive(path, confirmation_tolerance=self.confirmation_tolerance, closure_weight=self.closure_weight,
                 structure_tolerance=self.structure_tolerance, structure_interval=self.structure_interval,
                 view_heading_tolerance=self.view_heading_tolerance)
        non_negative(path, view_heading_weight=self.view_heading_weight,
                     view_heading_difference=self.view_heading_difference)
        non_negative(path, structure_weight=self.structure_weight, confirmation_age=self.confirmation_age,
                     confirmation_drift=self.confirmation_drift, confirmation_climb_error=self.confirmation_climb_error,
                     confirmation_spacing=self.confirmation_spacing, confirmation_turn=self.confirmation_turn)
        non_negative(path, blind_speed_error=self.blind_speed_error)
        require(f"{path}.confirmation_rival_odds", self.confirmation_rival_odds,
                number(self.confirmation_rival_odds) and (self.confirmation_rival_odds == 0
                                                          or self.confirmation_rival_odds > 1),
                "must be 0 (off) or above 1")
        positive(path, link_length_error=self.link_length_error)
