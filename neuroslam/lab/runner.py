"""One runner: NeuroSLAM over a frame stream, with everything a run leaves behind.

:func:`run` feeds a :class:`~neuroslam.lab.frames.FrameStream` to a :class:`~neuroslam.slam.NeuroSLAM`, one
frame at a time, and keeps the run's history in a :class:`Run` (as RatInABox keeps an agent's): per frame
the time, the truth where known, the online estimate, the odometry's pose, the active template and
experience and what the camera observed; the loop closures and merges with the truth of the places they
joined; the timings. :meth:`Run.metrics` is the one construction of ``metrics.json``, :meth:`Run.write`
writes every output file of a run, and the ``plot_*`` methods draw it. ``neuroslam drive``, ``run`` and
``sweep`` are this runner on a :class:`~neuroslam.lab.frames.DriveStream` or
:class:`~neuroslam.lab.frames.FolderStream`::

    import sim
    from neuroslam import NeuroSLAM
    from neuroslam.lab.frames import DriveStream
    from neuroslam.lab.runner import run

    result = run(DriveStream(sim.ScriptedDrive("carpark", laps=1)), NeuroSLAM("sim"))
    print(result.metrics()["ate_rmse_m"]); result.write("runs/carpark")
"""

from __future__ import annotations

import json
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..evaluation import false_along_path_mask, observation_shares, run_metrics
from ..slam import MAP_FILE, NeuroSLAM
from ..tum import write_tum, yaw_quaternion
from .frames import Frame, FrameStream, SelfMotionSource

if TYPE_CHECKING:
    from ..estimate import Estimate
    from .recording import RunRecorder

__all__ = ["ExperienceTruth", "Run", "load_sessions", "run"]

logger = logging.getLogger(__name__)


class ExperienceTruth:
    """The ground truth of every experience, across sessions: this session's from its frames, the loaded
    maps' from the truth saved with them (``experience_truth`` and ``experience_levels`` in the map file;
    NaN and -1 when a map was saved without ground truth). An experience is identified by (session,
    creation time), which survives merges and fusions.

    Args:
        slam: the SLAM whose map is looked up.
        loaded_poses, loaded_levels: (K, 4) and (K,), in the order of the experiences the SLAM already holds
            (None: unknown, NaN and -1).
        from_maps: the session continues loaded maps (``metrics.json`` then reports merges); None: whenever
            the SLAM already holds experiences.
    """

    def __init__(self, slam: NeuroSLAM, loaded_poses: np.ndarray | None = None,
                 loaded_levels: np.ndarray | None = None, *, from_maps: bool | None = None):
        self.slam = slam
        themap = slam.experience_map
        loaded_poses = np.full((themap.size, 4), np.nan) if loaded_poses is None else loaded_poses
        loaded_levels = np.full(themap.size, -1) if loaded_levels is None else loaded_levels
        from_maps = themap.size > 0 if from_maps is None else from_maps
        self.loaded = {(int(session), float(time)): (np.asarray(pose, dtype=float), int(level))
                       for session, time, pose, level in zip(themap.sessions, themap.creation_times, loaded_poses,
                                                             loaded_levels, strict=True)}
        self.from_maps = from_maps
        self.times: list[float] = []
        self.poses: list[np.ndarray] = []
        self.levels: list[int] = []

    def add_frame(self, time: float, pose: np.ndarray | None, level: int = -1) -> None:
        """This session's next frame: its time (s), true pose (None if unknown) and level."""
        self.times.append(time)
        self.poses.append(np.full(4, np.nan) if pose is None else np.asarray(pose, dtype=float))
        self.levels.append(level)

    def of(self, experiences) -> tuple[np.ndarray, np.ndarray]:
        """(K, 4) true poses (m, rad) and (K,) true levels where the given experiences were made."""
        themap = self.slam.experience_map
        poses, levels = [], []
        for experience in np.asarray(experiences, dtype=int).reshape(-1):
            session, time = int(themap.sessions[experience]), float(themap.creation_times[experience])
            if session == themap.session and self.times:
                frame = min(int(np.searchsorted(self.times, time)), len(self.times) - 1)
                pose, level = self.poses[frame], self.levels[frame]
            else:
                pose, level = self.loaded.get((session, time), (np.full(4, np.nan), -1))
            poses.append(pose)
            levels.append(level)
        return np.array(poses).reshape(-1, 4), np.array(levels, dtype=int)


def load_sessions(paths) -> tuple[NeuroSLAM, ExperienceTruth]:
    """The maps of earlier sessions (map files or run folders), joined into one SLAM, with the truth saved
    with them. The caller begins the new session (:meth:`NeuroSLAM.begin_session`)."""
    slam, poses, levels = None, [], []
    for path in paths:
        loaded = NeuroSLAM.load(path)
        size = loaded.experience_map.size
        poses.append(loaded.map_extra.get("experience_truth", np.full((size, 4), np.nan)))
        levels.append(loaded.map_extra.get("experience_levels", np.full(size, -1)))
        if slam is None:
            slam = loaded
        else:
            slam.add_map(loaded)
    if slam is None:
        raise ValueError("load_sessions: no map given")
    return slam, ExperienceTruth(slam, np.concatenate(poses), np.concatenate(levels), from_maps=True)


@dataclass
class Run:
    """The history of one run of NeuroSLAM over a frame stream (what :func:`run` returns).

    Attributes:
        stream: the frame stream. slam: the SLAM after the run. odometry: the odometry mode.
        times: (N,) s. truths: per frame, the :class:`~neuroslam.lab.frames.Truth` or None.
        wheels: per frame, the :class:`~neuroslam.lab.frames.Wheels` or None.
        online: (N, 4) the estimate as it was at each frame (m, rad). self_motion: (N, 4) the odometry's
            pose, integrated without the map. estimate: (N, 4) every frame in the final map
            (:meth:`NeuroSLAM.trajectory`), the trajectory SLAM evaluations score.
        active: (N, 2) the active template and experience ids. observed: per frame, what the camera observed
            (:class:`~neuroslam.vision.odometry.Observed`, or None).
        closures, merges: (frame, true position (3,), true level) of the place each loop closure re-entered
            and each merge joined. book: the truth of every experience.
        slam_seconds: s in self-motion and :meth:`NeuroSLAM.step`. elapsed: s for the whole loop.
        interrupted: the run stopped early (Ctrl-C); the history holds the frames done.
    """

    stream: FrameStream
    slam: NeuroSLAM
    odometry: str
    book: ExperienceTruth
    times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    truths: list = field(default_factory=list)
    wheels: list = field(default_factory=list)
    online: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    self_motion: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    estimate: np.ndarray = field(default_factory=lambda: np.zeros((0, 4)))
    active: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=int))
    observed: list = field(default_factory=list)
    closures: list = field(default_factory=list)
    merges: list = field(default_factory=list)
    slam_seconds: float = 0.0
    elapsed: float = 0.0
    interrupted: bool = False

    @property
    def frames(self) -> int:
        """Frames run."""
        return len(self.times)

    @property
    def truth(self) -> np.ndarray | None:
        """(N, 4) true poses (m, rad), or None unless every frame has one."""
        if not self.truths or any(truth is None for truth in self.truths):
            return None
        return np.array([truth.pose for truth in self.truths])

    @property
    def true_levels(self) -> np.ndarray | None:
        """(N,) true level indices, or None unless every frame has one."""
        if self.truth is None or any(truth.level < 0 for truth in self.truths):
            return None
        return np.array([truth.level for truth in self.truths])

    @property
    def title(self) -> str:
        """The figure title: the stream and the odometry mode."""
        return f"{getattr(self.stream, 'title', self.stream.name)}: {self.odometry} odometry"

    def _event_arguments(self) -> dict:
        """The map, loop-closure and merge arguments of :func:`~neuroslam.evaluation.run_metrics`. The map
        scored is the robot's (after merges, the merged map); loaded maps it never met are separate maps in
        frames of their own, so they are left out (``map_components`` in metrics.json counts them)."""
        themap = self.slam.experience_map
        mine = np.flatnonzero(themap.components == themap.component)
        experience_truth, experience_levels = self.book.of(mine)

        def columns(events: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            return (np.array([frame for frame, _, _ in events], dtype=int),
                    np.array([pose for _, pose, _ in events]).reshape(-1, 3),
                    np.array([level for _, _, level in events], dtype=int))

        closure_frames, closure_truth, closure_levels = columns(self.closures)
        arguments = {"experience_positions": themap.poses[mine, :3], "experience_truth": experience_truth[:, :3],
                     "experience_levels": experience_levels, "closure_frames": closure_frames,
                     "closure_truth": closure_truth, "closure_levels": closure_levels}
        if self.book.from_maps:
            arguments["merge_frames"], arguments["merge_truth"], arguments["merge_levels"] = columns(self.merges)
        return arguments

    def _along_path_metrics(self) -> dict[str, int]:
        """``along_path_closures``: eq. M8's links in the robot's map (a place known across the path, not along
        it; not loop closures), and ``false_along_path_closures``: those whose two experiences were made more
        than 2 m apart across the place's true heading or in height, or on different levels
        (:func:`~neuroslam.evaluation.false_along_path_mask`)."""
        themap = self.slam.experience_map
        mine = themap.components[themap.links[:, 0]] == themap.component if len(themap.links) else np.zeros(0, bool)
        along = np.flatnonzero(np.isinf(themap.link_blind_times) & mine)
        places, place_levels = self.book.of(themap.links[along, 0])
        linked, levels = self.book.of(themap.links[along, 1])
        floors = None if self.stream.levels is None else np.array(self.stream.levels, dtype=float)
        false = false_along_path_mask(places, linked[:, :3], place_levels, levels, floors=floors)
        return {"along_path_closures": int(len(along)), "false_along_path_closures": int(np.count_nonzero(false))}

    def metrics(self) -> dict[str, Any]:
        """``metrics.json``: the source, the path driven, the map's size, the accuracy against the truth
        where known (:func:`~neuroslam.evaluation.run_metrics`), what the camera observed
        (:func:`~neuroslam.evaluation.observation_shares`) and the milliseconds a frame by stage."""
        truth, true_levels = self.truth, self.true_levels
        levels = self.stream.levels
        themap = self.slam.experience_map
        positions = None if truth is None else truth[:, :3]
        metrics: dict[str, Any] = {
            **self.stream.describe(), "frames": self.frames, **self.stream.summary(),
            "distance_m": float(np.sum(np.linalg.norm(np.diff(positions, axis=0), axis=1)))
            if positions is not None else None,
            "levels": None if levels is None else list(levels),
            "levels_visited": None if true_levels is None else sorted({int(level) for level in true_levels}),
            "height_range_m": [float(positions[:, 2].min()), float(positions[:, 2].max())]
            if positions is not None else None,
            "odometry": self.odometry, "templates": self.slam.local_view.count, "experiences": themap.size,
            "map_components": len(np.unique(themap.components)),
        }
        if truth is not None:
            metrics.update(run_metrics(
                truth=truth, true_levels=true_levels, levels=None if levels is None else np.array(levels),
                estimate=self.estimate, odometry=self.self_motion, online_estimate=self.online,
                **self._event_arguments()))
            if self.slam.config.experience_map.confirmation_along_path:  # eq. M8's links, judged as closures are
                metrics.update(self._along_path_metrics())
        else:
            metrics["loop_closures"] = themap.loop_closures
            if self.book.from_maps:
                metrics.update(merges=len(self.slam.merges), merge_frames=[frame for frame, _ in self.slam.merges])
        metrics.update(observation_shares(self.observed))
        frames = max(self.frames, 1)
        metrics["ms_per_frame"] = {
            "slam": 1000 * self.slam_seconds / frames,
            **{stage: None if seconds is None else 1000 * seconds / frames
               for stage, seconds in self.stream.timings().items()},
            "total": 1000 * self.elapsed / frames,
        }
        if self.interrupted:
            metrics["interrupted"] = True
        return metrics

    def write(self, out: str | Path) -> list[Path]:
        """Every output file of the run into ``out`` (created if missing); returns their paths.

        ``groundtruth.tum`` and ``wheel_odometry.tum`` where every frame has the truth or the wheels;
        ``slam.tum`` (every frame in the final map), ``slam_online.tum`` (the estimate at each frame),
        ``odometry.tum`` (the self-motion integrated without the map), ``experiences.tum`` (the final map),
        ``map.npz`` (the whole state, with each experience's truth), ``metrics.json`` and ``report.png``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        written = []
        times = self.times
        if self.truth is not None:
            write_tum(out / "groundtruth.tum", times, self.truth[:, :3],
                      np.array([truth.quaternion for truth in self.truths]))
            written.append(out / "groundtruth.tum")
        if self.wheels and all(wheels is not None for wheels in self.wheels):
            write_tum(out / "wheel_odometry.tum", times, np.array([[w.x, w.y, 0.0] for w in self.wheels]),
                      yaw_quaternion(np.array([w.yaw for w in self.wheels])))
            written.append(out / "wheel_odometry.tum")
        for name, poses in (("slam", self.estimate), ("slam_online", self.online), ("odometry", self.self_motion)):
            write_tum(out / f"{name}.tum", times, poses[:, :3], yaw_quaternion(poses[:, 3]))
            written.append(out / f"{name}.tum")
        themap = self.slam.experience_map
        write_tum(out / "experiences.tum", themap.creation_times, themap.poses[:, :3],
                  yaw_quaternion(themap.poses[:, 3]))
        poses, levels = self.book.of(np.arange(themap.size))
        self.slam.save(out / MAP_FILE, extra={"experience_truth": poses, "experience_levels": levels},
                       metadata=self.stream.map_metadata())
        metrics = self.metrics()  # once: the figure's headline reads the same numbers
        (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
        self.plot_report(out / "report.png", metrics=metrics)
        return [*written, out / "experiences.tum", out / MAP_FILE, out / "metrics.json", out / "report.png"]

    def plot_report(self, path: str | Path | None = None, *, metrics: dict[str, Any] | None = None):
        """The run at a glance (:func:`~neuroslam.lab.plots.plot_report`); returns ``(figure, axes)``.
        ``metrics``: :meth:`metrics` if the caller has it already (it is not computed again)."""
        from .plots import plot_report

        themap = self.slam.experience_map
        return plot_report(truth=self.truth, odometry=self.self_motion, estimate=self.estimate,
                           experiences=themap.poses,
                           experience_frames=np.searchsorted(self.times, themap.creation_times),
                           links=themap.links, template_ids=self.active[:, 0], experience_ids=self.active[:, 1],
                           times=self.times, title=self.title, headline=self.headline(metrics),
                           closure_frames=np.array([frame for frame, _, _ in self.closures], dtype=int),
                           true_levels=self.true_levels, path=path)

    def headline(self, metrics: dict[str, Any] | None = None) -> str:
        """The run's headline numbers in one line (the report figure's subtitle), from ``metrics`` (default:
        :meth:`metrics`)."""
        metrics = self.metrics() if metrics is None else metrics

        def metres(value) -> str:
            return "n/a" if value is None else f"{value:.2f} m"

        parts = [f"{metrics['frames']} frames"]
        if metrics.get("distance_m") is not None:
            parts.append(f"{metrics['distance_m']:.0f} m")
        if "ate_rmse_m" in metrics:
            parts.append(f"SLAM ATE {metres(metrics['ate_rmse_m']['slam'])} "
                         f"(odometry {metres(metrics['ate_rmse_m']['odometry'])})")
        closures = f"{metrics['loop_closures']} loop closures"
        if "false_loop_closures" in metrics:
            closures += f" ({metrics['false_loop_closures']} false)"
        parts += [closures, f"{metrics['experiences']} experiences"]
        if metrics.get("level_accuracy") is not None:
            parts.append(f"level accuracy {metrics['level_accuracy']:.2f}")
        return " · ".join(parts)


def _note_events(run: Run, estimate, frame: int) -> None:
    """Keep a frame's loop closure or merge with the ground truth of the experience it joined (looked up now:
    a later merge may renumber the experiences)."""
    for happened, events in ((estimate.loop_closure, run.closures), (estimate.merged, run.merges)):
        if happened:
            poses, levels = run.book.of([estimate.experience_id])
            events.append((frame, poses[0, :3], levels[0]))
    if estimate.merged:  # the loop closures the merge found among the frames before it, scored at their frames
        for earlier, experience in run.slam.closures_before_merge:
            poses, levels = run.book.of([experience])
            run.closures.append((earlier, poses[0, :3], levels[0]))


def run(stream: FrameStream, slam: NeuroSLAM, *, odometry: str = "visual", book: ExperienceTruth | None = None,
        recorder: RunRecorder | None = None, progress: bool = True,
        on_frame: Callable[[Frame, Estimate, NeuroSLAM], None] | None = None) -> Run:
    """NeuroSLAM over every frame of ``stream``; the run's history.

    Args:
        stream: the frames (:mod:`neuroslam.lab.frames`). slam: the SLAM (a fresh one, or one that loaded
            maps and began a session). odometry: ``visual``, ``wheel`` or ``visual-inertial``
            (:class:`~neuroslam.lab.frames.SelfMotionSource`).
        book: the loaded maps' truth (:func:`load_sessions`), or None for a first session.
        recorder: a :class:`~neuroslam.lab.recording.RunRecorder` to log each frame to, or None.
        progress: show a progress bar (tqdm) in the stream's unit.
        on_frame: ``on_frame(frame, estimate, slam)`` after each frame's step, for what the history does not
            keep (a measurement's own bookkeeping); its time counts in ``elapsed``, not in ``slam_seconds``.

    Ctrl-C stops the run after the frame in progress: the history keeps the frames done and
    :attr:`Run.interrupted` is set.
    """
    source = SelfMotionSource(odometry, slam)
    result = Run(stream, slam, odometry, book if book is not None else ExperienceTruth(slam))
    times, truths, wheels, online, self_motion, active, observed = [], [], [], [], [], [], []
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=int(stream.total), unit=stream.unit, desc=stream.name)
    started = time.perf_counter()
    frame: Frame
    try:
        for frame in stream:
            slam_started = time.perf_counter()
            motion = source(frame)
            estimate = slam.step(frame.image, frame.time, odometry=motion)
            result.slam_seconds += time.perf_counter() - slam_started
            times.append(frame.time)
            truths.append(frame.truth)
            wheels.append(frame.wheels)
            truth = frame.truth
            result.book.add_frame(frame.time, None if truth is None else truth.pose,
                                  -1 if truth is None else truth.level)
            online.append(estimate.pose)
            active.append((estimate.template_id, estimate.experience_id))
            observed.append(estimate.self_motion.observed)
            _note_events(result, estimate, len(times) - 1)
            self_motion.append(slam.odometry_pose)
            if recorder is not None:
                recorder.log_frame(frame.time, frame.image, slam, estimate, None if truth is None else truth.pose)
            if on_frame is not None:
                on_frame(frame, estimate, slam)
            if bar is not None:
                bar.update(min(int(frame.progress), bar.total) - bar.n)
    except KeyboardInterrupt:
        result.interrupted = True
        logger.warning("interrupted after %d frames", len(times))
    finally:
        if bar is not None:
            bar.close()
        if recorder is not None:
            recorder.close()
    result.elapsed = time.perf_counter() - started
    result.times = np.array(times, dtype=float)
    result.truths, result.wheels, result.observed = truths, wheels, observed
    result.online = np.array(online, dtype=float).reshape(-1, 4)
    result.self_motion = np.array(self_motion, dtype=float).reshape(-1, 4)
    result.active = np.array(active, dtype=int).reshape(-1, 2)
    result.estimate = slam.trajectory()
    return result
