"""Recorded image sequences: a folder of frames plus optional ground truth, read as a frame stream.

A dataset folder holds PNG or JPEG frames, taken in natural order (``frame2`` before ``frame10``), and
optionally ground truth in TUM format (``t x y z qx qy qz qw``, which also gives the frames' times) or in
the NeuroSLAM CSV format (``frame,x,y,z,rx,ry,rz``, angles in radians, no header), and optionally a
description ``dataset.json`` (:func:`read_description`: where it was recorded and the floor heights, so that a
replay is scored per floor as the drive was). ``neuroslam record`` writes such folders (frames in
``frames/``, ``groundtruth.tum``, ``wheel_odometry.tum``, ``dataset.json``).
"""

from __future__ import annotations

import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import NeuroSLAMError
from .geometry import wrap

__all__ = ["DESCRIPTION_FILE", "DatasetDescription", "DatasetError", "GroundTruth", "check_frame_sizes",
           "check_levels", "list_frames", "load_frame", "read_description", "read_groundtruth", "write_description"]

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
DESCRIPTION_FILE = "dataset.json"


class DatasetError(NeuroSLAMError, ValueError):
    """A dataset folder, frame or ground-truth file cannot be used."""


@dataclass(frozen=True)
class GroundTruth:
    """Ground truth of a sequence: positions (N × 3, m), yaw (N, rad) and, from TUM files, times (N, s)."""

    positions: np.ndarray
    yaw: np.ndarray
    times: np.ndarray | None

    @property
    def poses(self) -> np.ndarray:
        """(N, 4) x, y, z, yaw."""
        return np.column_stack([self.positions, self.yaw])


@dataclass(frozen=True)
class DatasetDescription:
    """What a dataset's ``dataset.json`` says: the world and route it was recorded on (names, or None) and
    the heights of its floors (m, increasing, or None), by which the ground truth's frames get their floor."""

    world: str | None = None
    route: str | None = None
    levels: tuple[float, ...] | None = None


def check_levels(levels, name: str = "levels") -> tuple[float, ...]:
    """Floor heights (m) as a tuple: at least one, finite and strictly increasing.

    Raises:
        DatasetError: naming ``name`` and the value.
    """
    try:
        values = tuple(float(level) for level in levels)
    except (TypeError, ValueError):
        raise DatasetError(f"{name}={levels!r}: must be a list of floor heights in metres") from None
    if not values or not all(math.isfinite(v) for v in values) or any(b <= a for a, b in itertools.pairwise(values)):
        raise DatasetError(f"{name}={list(values)!r}: must be one or more finite heights (m), strictly increasing")
    return values


def read_description(folder: str | Path) -> DatasetDescription:
    """The ``dataset.json`` of a dataset folder (a JSON object with optional ``world`` and ``route`` names and
    ``levels``, floor heights in m); an empty description when there is none.

    Raises:
        DatasetError: the file exists but is unreadable, not a JSON object, or has a field of the wrong type.
    """
    path = Path(folder) / DESCRIPTION_FILE
    if not path.is_file():
        return DatasetDescription()
    try:
        content = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DatasetError(f"dataset description {str(path)!r}: not readable JSON ({error})") from None
    if not isinstance(content, dict):
        raise DatasetError(f"dataset description {str(path)!r}: must be a JSON object")
    for key in ("world", "route"):
        if content.get(key) is not None and not isinstance(content[key], str):
            raise DatasetError(f"dataset description {str(path)!r}: {key}={content[key]!r} must be a name")
    levels = content.get("levels")
    if levels is not None:
        if not isinstance(levels, list):
            raise DatasetError(f"dataset description {str(path)!r}: levels={levels!r} must be a list of heights (m)")
        try:
            levels = check_levels(levels)
        except DatasetError as error:
            raise DatasetError(f"dataset description {str(path)!r}: {error}") from None
    return DatasetDescription(content.get("world"), content.get("route"), levels)


def write_description(folder: str | Path, description: DatasetDescription) -> Path:
    """Write ``folder/dataset.json``; returns its path."""
    path = Path(folder) / DESCRIPTION_FILE
    content = {"world": description.world, "route": description.route,
               "levels": None if description.levels is None else list(description.levels)}
    path.write_text(json.dumps(content, indent=2) + "\n")
    return path


def _natural_key(path: Path) -> list:
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", path.name)]


def list_frames(folder: str | Path) -> list[Path]:
    """The image files of ``folder`` (or of its ``frames/`` subfolder) in natural order."""
    folder = Path(folder)
    if not folder.is_dir():
        raise DatasetError(f"frames folder {str(folder)!r}: not a readable folder")
    if (folder / "frames").is_dir():
        folder = folder / "frames"
    try:
        frames = [p for p in folder.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES and p.is_file()]
    except OSError as error:
        raise DatasetError(f"frames folder {str(folder)!r}: cannot list it ({error.strerror})") from None
    if not frames:
        raise DatasetError(f"frames folder {str(folder)!r}: no PNG or JPEG images in it")
    return sorted(frames, key=_natural_key)


def check_frame_sizes(paths: list[Path]) -> tuple[int, int]:
    """The (width, height) in pixels shared by every frame, read from the file headers only.

    Raises:
        DatasetError: naming the first frame that is unreadable or whose size differs from the first's.
    """
    from PIL import Image, UnidentifiedImageError

    size = None
    for path in paths:
        try:
            with Image.open(path) as image:
                current = image.size
        except (OSError, UnidentifiedImageError) as error:
            raise DatasetError(f"frame {str(path)!r}: not a readable image ({error})") from None
        if size is None:
            size = current
        elif current != size:
            raise DatasetError(f"frame {str(path)!r}: {current[0]}x{current[1]} pixels, but the first frame "
                               f"{str(paths[0])!r} is {size[0]}x{size[1]}")
    if size is None:
        raise DatasetError("no frames to check")
    return size


def load_frame(path: Path) -> np.ndarray:
    """An image as HxWx3 uint8 RGB (grey images are kept HxW).

    8-bit images are decoded by OpenCV (about 1.5× Pillow's speed on the testbed's PNG frames); any other
    (16-bit or 32-bit grey, unusual modes) by Pillow, converted to 8 bits as Pillow converts them."""
    import cv2
    from PIL import Image, UnidentifiedImageError

    image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if image is not None and image.dtype == np.uint8:
        if image.ndim == 2:
            return image
        if image.shape[2] == 3:
            return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
        if image.shape[2] == 4:
            return cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
    try:
        with Image.open(path) as image:
            image = image.convert("L" if image.mode in ("L", "I;16", "I") else "RGB")
            return np.asarray(image, dtype=np.uint8)
    except (OSError, UnidentifiedImageError) as error:
        raise DatasetError(f"frame {str(path)!r}: not a readable image ({error})") from None


def read_groundtruth(path: str | Path) -> GroundTruth:
    """Read TUM (8 columns, whitespace) or NeuroSLAM CSV (7 columns, commas) ground truth."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as error:
        raise DatasetError(f"ground truth {str(path)!r}: cannot read it ({error})") from None
    rows = [line for line in text.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise DatasetError(f"ground truth {str(path)!r}: no rows")
    comma = "," in rows[0]
    fields = [row.split(",") if comma else row.split() for row in rows]
    widths = {len(row) for row in fields}
    if len(widths) > 1:
        line = next(i for i, row in enumerate(fields) if len(row) != len(fields[0])) + 1
        raise DatasetError(f"ground truth {str(path)!r}: rows have different numbers of columns (data row {line})")
    try:
        table = np.array([[float(v) for v in row] for row in fields])
    except ValueError:
        raise DatasetError(f"ground truth {str(path)!r}: rows must be numbers") from None
    finite = np.isfinite(table).all(axis=1)
    if not finite.all():
        line = int(np.flatnonzero(~finite)[0]) + 1
        raise DatasetError(f"ground truth {str(path)!r}: NaN or infinity in data row {line}")
    if table.shape[1] == 8 and len(table) > 1 and not np.all(np.diff(table[:, 0]) > 0):
        line = int(np.flatnonzero(np.diff(table[:, 0]) <= 0)[0]) + 2
        raise DatasetError(f"ground truth {str(path)!r}: TUM times must increase (data row {line}: "
                           f"{float(table[line - 1, 0])!r} after {float(table[line - 2, 0])!r})")
    if table.shape[1] == 8:
        qx, qy, qz, qw = table[:, 4], table[:, 5], table[:, 6], table[:, 7]
        yaw = np.arctan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy**2 + qz**2))
        return GroundTruth(table[:, 1:4], yaw, table[:, 0])
    if table.shape[1] == 7:
        return GroundTruth(table[:, 1:4], wrap(table[:, 6]), None)
    raise DatasetError(
        f"ground truth {str(path)!r}: {table.shape[1]} columns; expected 8 (TUM: t x y z qx qy qz qw) "
        "or 7 (CSV: frame,x,y,z,rx,ry,rz)"
    )


def frame_times(count: int, groundtruth: GroundTruth | None, rate: float) -> np.ndarray:
    """Times of ``count`` frames: the ground truth's TUM times when it has one per frame, else ``rate`` Hz."""
    if groundtruth is not None and groundtruth.times is not None:
        return groundtruth.times
    if not math.isfinite(rate) or rate <= 0:
        raise DatasetError(f"rate={rate!r}: must be a positive number of frames per second")
    return np.arange(count) / rate
