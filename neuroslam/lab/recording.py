"""A rerun recording of a NeuroSLAM run: ``run.rrd``, written headless, opened later with ``rerun run.rrd``.

:class:`RunRecorder` logs one frame at a time into its own ``rerun.RecordingStream`` (no global state, no
viewer, no network) that streams into a file, with a default layout (a blueprint):

- ``camera``: the camera image, JPEG-compressed, every frame;
- ``world/truth`` and ``world/slam``: the ground-truth and estimated (online) trajectories, one line segment
  per frame, shown accumulated up to the time cursor; ``world/loop_closures``: a marker where each loop closed.
  The ground truth is anchored at its first pose (moved and turned so it starts at the origin facing +x, as
  the SLAM estimate does), m;
- ``map/experiences`` and ``map/links``: the experience graph (nodes and links), ``map/robot``: the estimate;
- ``cells/grid``: the most active grid cells as points coloured by activity, in cells;
  ``cells/head_direction``: the head-direction activity as an image (yaw across, height up);
- ``plots/template_id``, ``plots/experience_id`` and ``plots/position_error`` (m, after the anchoring above, no
  scale alignment) over time;
- ``events``: a text log of the loop closures.

The timeline ``time`` is the frame time (s); ``frame`` counts the frames. To keep logging cheap, the camera
image is JPEG-compressed, the per-frame images, poses and scalars are buffered and sent as columns every
``every`` frames (so a viewer reading the file as it grows lags by up to that many frames), and the heavy
things (the cell activity and the experience graph) are logged, every ``every`` frames, on loop closures and at
:meth:`close`.

rerun-sdk (0.41) is a dependency of neuroslam, imported only when a recorder is made; an environment
without it gets a clear error saying how to install it.
"""

from __future__ import annotations

import io
import logging
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InvalidParameterError, NeuroSLAMError
from ..geometry import relative

if TYPE_CHECKING:
    from ..slam import Estimate, NeuroSLAM

__all__ = ["RecordingUnavailableError", "RunRecorder"]

logger = logging.getLogger(__name__)

TRUTH_COLOUR = (90, 200, 90)
SLAM_COLOUR = (255, 140, 0)
EXPERIENCE_COLOUR = (70, 130, 255)
LINK_COLOUR = (150, 180, 255)
CURRENT_COLOUR = (255, 60, 60)


class RecordingUnavailableError(NeuroSLAMError, ImportError):
    """rerun-sdk (0.41) is not installed, so no recording can be written."""


def _rerun():
    """The ``rerun`` module, or a clear error saying how to install it."""
    try:
        import rerun
        import rerun.blueprint
    except ImportError as error:
        raise RecordingUnavailableError(
            f'recording needs rerun-sdk 0.41 ({error}); install it with: pip install "rerun-sdk>=0.41,<0.42"') from None
    version = tuple(int(part) for part in rerun.__version__.split(".")[:2] if part.isdigit())
    if version < (0, 41):
        raise RecordingUnavailableError(f'recording needs rerun-sdk 0.41, found {rerun.__version__}; install it '
                                        f'with: pip install "rerun-sdk>=0.41,<0.42"')
    return rerun


def _colour_table() -> np.ndarray:
    """(256, 3) uint8 RGB of the viridis colour map, for activities scaled to 0..255."""
    from matplotlib import colormaps

    return (colormaps["viridis"](np.linspace(0.0, 1.0, 256))[:, :3] * 255).round().astype(np.uint8)


class RunRecorder:
    """Writes a run as a rerun recording, frame by frame.

    Args:
        path: the ``.rrd`` file to write (its folder must exist); overwritten if present.
        name: the recording's name shown in the viewer (for example ``carpark/main``).
        every: frames between the logs of the cell activity and the experience graph (also logged on loop
            closures), and between the sends of the buffered images, poses and scalars.
        grid_cells: at most this many of the most active grid cells are shown (those above 1 % of the peak).
        jpeg_quality: JPEG quality of the camera images, 1–100; None stores them uncompressed.
        strict: passed to every ``log`` call (raise on bad data instead of warning); None follows rerun's
            global strict mode.

    Raises:
        RecordingUnavailableError: rerun-sdk (0.41) is not installed.
        InvalidParameterError: ``every`` is not a positive integer.

    Example::

        recorder = RunRecorder(out / "run.rrd", name="carpark")
        run(DriveStream(sim.ScriptedDrive("carpark")), slam, recorder=recorder)  # logs every frame, closes it

    (:func:`neuroslam.lab.runner.run`; by hand: ``recorder.log_frame(time, image, slam, estimate, true_pose)``
    after each ``slam.step``, then ``recorder.close()``.)
    """

    def __init__(self, path: str | Path, *, name: str = "neuroslam", every: int = 10, grid_cells: int = 400,
                 jpeg_quality: int | None = 85, strict: bool | None = None):
        if not isinstance(every, int) or every < 1:
            raise InvalidParameterError("every", every, "must be an integer of at least 1 frame")
        self.rr = rr = _rerun()
        self.path = Path(path)
        self.every = every
        self.grid_cells = grid_cells
        self.jpeg_quality = jpeg_quality
        self.strict = strict
        self.frames = 0
        self._colours = _colour_table()
        self._anchor: np.ndarray | None = None  # first true pose (x, y, z, yaw)
        self._previous_truth: np.ndarray | None = None  # last position sent, m
        self._previous_slam: np.ndarray | None = None
        # per frame: time, frame, JPEG or None, slam position, anchored true position or None, template, experience
        self._rows: list[tuple] = []
        self._heavy_logged = False  # the heavy entities are up to date with the last frame
        self._extent_logged = False
        self._slam: NeuroSLAM | None = None
        self._estimate: Estimate | None = None
        self.stream = rr.RecordingStream("neuroslam", send_properties=True)
        self.stream.save(self.path, default_blueprint=self._blueprint())
        self.stream.send_recording_name(name)
        self._log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._log("map", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._log("cells/grid", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        self._log("world/slam", rr.LineStrips3D.from_fields(colors=SLAM_COLOUR, radii=rr.Radius.ui_points(2.0)),
                  static=True)
        self._log("world/truth", rr.LineStrips3D.from_fields(colors=TRUTH_COLOUR, radii=rr.Radius.ui_points(2.0)),
                  static=True)
        if jpeg_quality is not None:
            self._log("camera", rr.EncodedImage.from_fields(media_type="image/jpeg"), static=True)
        self._log("map/robot", rr.Points3D.from_fields(colors=CURRENT_COLOUR, radii=rr.Radius.ui_points(6.0)),
                  static=True)
        for entity, label, colour in (("plots/template_id", "template id", (200, 120, 255)),
                                      ("plots/experience_id", "experience id", EXPERIENCE_COLOUR),
                                      ("plots/position_error", "position error (m)", CURRENT_COLOUR)):
            self._log(entity, rr.SeriesLines(names=label, colors=colour, widths=1.5), static=True)

    def _log(self, entity: str, data, *, static: bool = False) -> None:
        self.stream.log(entity, data, static=static, strict=self.strict)

    def _blueprint(self):
        """The default layout: camera and head direction | trajectories and experience map | grid cells, plots."""
        rrb = self.rr.blueprint
        accumulate = [rrb.VisibleTimeRange(timeline, start=rrb.TimeRangeBoundary.infinite(),
                                           end=rrb.TimeRangeBoundary.cursor_relative())
                      for timeline in ("time", "frame")]
        return rrb.Blueprint(
            rrb.Horizontal(
                rrb.Vertical(
                    rrb.Spatial2DView(origin="camera", name="camera"),
                    rrb.Spatial2DView(origin="cells/head_direction", name="head direction (yaw × height)"),
                    rrb.TextLogView(origin="events", name="events"),
                ),
                rrb.Vertical(
                    rrb.Spatial3DView(origin="world", name="trajectories (truth green, SLAM orange)",
                                      time_ranges=accumulate),
                    rrb.Spatial3DView(origin="map", name="experience map"),
                ),
                rrb.Vertical(
                    rrb.Spatial3DView(origin="cells/grid", name="grid cells"),
                    rrb.TimeSeriesView(origin="plots", contents=["/plots/template_id", "/plots/experience_id"],
                                       name="template and experience id"),
                    rrb.TimeSeriesView(origin="plots", contents="/plots/position_error", name="position error (m)"),
                ),
                column_shares=[1.0, 2.0, 1.5],
            ),
            rrb.TimePanel(timeline="time"),
            collapse_panels=True,
        )

    def log_frame(self, time: float, image: np.ndarray, slam: NeuroSLAM, estimate: Estimate,
                  truth: np.ndarray | None = None) -> None:
        """Log one frame, after ``slam.step``.

        Args:
            time: the frame's time, s.
            image: the camera image the SLAM saw, HxWx3 RGB or HxW grey, uint8 or floats in [0, 1].
            slam: the SLAM system (its cells and map are read, not changed).
            estimate: what ``slam.step`` returned for this frame.
            truth: the true pose (x, y, z, yaw) in m and rad, or None where there is no ground truth.
        """
        rr = self.rr
        self.stream.set_time("time", duration=float(time))
        self.stream.set_time("frame", sequence=self.frames)
        self._slam, self._estimate = slam, estimate
        jpeg = self._image(image)
        pose = np.asarray(estimate.pose, dtype=float)
        anchored = None if truth is None else self._anchored(np.asarray(truth, dtype=float))
        self._rows.append((float(time), self.frames, jpeg, pose[:3], None if anchored is None else anchored[:3],
                           estimate.template_id, estimate.experience_id))
        if estimate.loop_closure:
            self._log("world/loop_closures", rr.Points3D(pose[None, :3], colors=CURRENT_COLOUR,
                                                         radii=rr.Radius.ui_points(8.0)))
            self._log("events", rr.TextLog(
                f"{time:.2f} s: loop closure at experience {estimate.experience_id} (template {estimate.template_id}), "
                f"map of {slam.experience_map.size} experiences", level=rr.TextLogLevel.INFO))
        if self.frames % self.every == 0 or estimate.loop_closure:
            self._send_rows()
            self._log_heavy(slam, estimate)
        else:
            self._heavy_logged = False
        self.frames += 1

    def _image(self, image: np.ndarray) -> bytes | None:
        """The camera image as JPEG bytes to send later, or None after logging it uncompressed now."""
        from PIL import Image

        array = np.asarray(image)
        if array.dtype != np.uint8:
            array = (np.clip(array, 0.0, 1.0) * 255).round().astype(np.uint8)
        if array.ndim == 3 and array.shape[2] == 1:
            array = array[:, :, 0]
        if self.jpeg_quality is None:
            self._log("camera", self.rr.Image(array))
            return None
        buffer = io.BytesIO()  # PIL directly: about half the time of rerun's Image.compress
        Image.fromarray(array).save(buffer, format="JPEG", quality=self.jpeg_quality)
        return buffer.getvalue()

    def _send_rows(self) -> None:
        """Send the buffered per-frame images, poses and scalars as columns (one call per entity)."""
        if not self._rows:
            return
        rr = self.rr
        times, frames, jpegs, slam, truth, templates, experiences = zip(*self._rows, strict=True)
        self._rows = []
        if self.jpeg_quality is not None:
            self._columns("camera", times, frames, rr.EncodedImage.columns(blob=list(jpegs)))
        self._columns("plots/template_id", times, frames, rr.Scalars.columns(scalars=np.array(templates, float)))
        self._columns("plots/experience_id", times, frames, rr.Scalars.columns(scalars=np.array(experiences, float)))
        slam = np.array(slam)
        self._columns("map/robot", times, frames, rr.Points3D.columns(positions=slam))
        self._previous_slam = self._segments("world/slam", times, frames, slam, self._previous_slam)
        known = [index for index, position in enumerate(truth) if position is not None]
        if known:
            known_times, known_frames = [times[i] for i in known], [frames[i] for i in known]
            true = np.array([truth[i] for i in known])
            self._previous_truth = self._segments("world/truth", known_times, known_frames, true, self._previous_truth)
            error = np.linalg.norm(slam[known] - true, axis=1)
            self._columns("plots/position_error", known_times, known_frames, rr.Scalars.columns(scalars=error))

    def _columns(self, entity: str, times, frames, columns) -> None:
        indexes = [self.rr.TimeColumn("time", duration=np.array(times)),
                   self.rr.TimeColumn("frame", sequence=np.array(frames))]
        self.stream.send_columns(entity, indexes=indexes, columns=columns, strict=self.strict)

    def _segments(self, entity: str, times, frames, positions: np.ndarray, previous: np.ndarray | None) -> np.ndarray:
        """One line segment per frame, from the previous position to this one; return the last position."""
        starts = np.vstack([positions[:1] if previous is None else previous[None], positions[:-1]])
        self._columns(entity, times, frames, self.rr.LineStrips3D.columns(strips=np.stack([starts, positions], axis=1)))
        return positions[-1]

    def _anchored(self, truth: np.ndarray) -> np.ndarray:
        """A true pose in the frame of the first true pose (where the SLAM estimate starts)."""
        if self._anchor is None:
            self._anchor = truth.copy()
        return relative(self._anchor, truth)

    def _log_heavy(self, slam: NeuroSLAM, estimate: Estimate) -> None:
        """The experience graph, the grid-cell and the head-direction activity."""
        rr = self.rr
        experience_map = slam.experience_map
        if experience_map.size:
            positions = experience_map.poses[:, :3]
            colours = np.tile(np.array(EXPERIENCE_COLOUR, dtype=np.uint8), (len(positions), 1))
            if 0 <= estimate.experience_id < len(positions):
                colours[estimate.experience_id] = CURRENT_COLOUR
            self._log("map/experiences", rr.Points3D(positions, colors=colours, radii=rr.Radius.ui_points(4.0)))
            links = experience_map.links
            if len(links):
                strips = np.stack([positions[links[:, 0]], positions[links[:, 1]]], axis=1)
                self._log("map/links", rr.LineStrips3D(strips, colors=LINK_COLOUR, radii=rr.Radius.ui_points(1.0)))
        activity = np.asarray(slam.grid_cells.activity)
        flat = activity.ravel()
        peak = float(flat.max())
        if peak > 0:
            top = np.flatnonzero(flat > 0.01 * peak)  # the packet(s): usually a few hundred cells
            if len(top) > self.grid_cells:
                top = top[np.argpartition(flat[top], len(top) - self.grid_cells)[len(top) - self.grid_cells:]]
            level = flat[top] / peak
            cells = np.column_stack(np.unravel_index(top, activity.shape)).astype(np.float32)
            self._log("cells/grid", rr.Points3D(cells, colors=self._colours[(level * 255).astype(np.uint8)],
                                                radii=0.15 + 0.35 * level))
        if not self._extent_logged:
            size = np.array(activity.shape, dtype=float)
            self._log("cells/grid/extent", rr.Boxes3D(mins=[-0.5, -0.5, -0.5], sizes=[size], colors=(128, 128, 128)),
                      static=True)
            self._extent_logged = True
        direction = np.asarray(slam.head_direction.activity)  # (yaw, height)
        peak = float(direction.max())
        scaled = direction / peak if peak > 0 else direction
        picture = self._colours[(scaled.T[::-1] * 255).astype(np.uint8)]  # rows: height, top row highest
        self._log("cells/head_direction", rr.Image(np.ascontiguousarray(picture)))
        self._heavy_logged = True

    def close(self) -> None:
        """Log the final map and cell activity (if the last frame did not), then finish and close the file."""
        if self.stream is None:
            return
        self._send_rows()
        if not self._heavy_logged and self._slam is not None:
            self._log_heavy(self._slam, self._estimate)
        self.stream.flush()
        self.stream.disconnect()
        self.stream = None
        logger.info("recording of %d frames written to %s", self.frames, self.path)

    def __enter__(self) -> RunRecorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
