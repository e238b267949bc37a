"""The map file: everything a NeuroSLAM session needs to continue, in one file.

Format (version 1): a ZIP archive (stored, not compressed; the ``.npz`` layout numpy uses) holding

- ``header.json``: ``{"format": "neuroslam-map", "version": 1, "library": "0.1.0", "config": {...},
  "arrays": {name: {"shape": [...], "dtype": "<f8"}, ...}, "metadata": {...}}``: the configuration as
  :meth:`~neuroslam.config.Config.to_dict` writes it, and a manifest of every array;
- one ``NAME.npy`` per array (numpy's ``.npy`` format, no pickles): the state of every part of the
  pipeline under dotted names (``grid_cells.activity``, ``experience_map.poses``, ...; see
  :meth:`neuroslam.NeuroSLAM.state_dict`), and the caller's extra per-map arrays under ``extra.NAME``
  (e.g. the ground-truth position of every experience, which the command line stores for scoring).

Writes are atomic: the archive is written to a temporary file beside the target, flushed to disk, and
renamed over the target, so a crash mid-save leaves the previous file intact. Reads check everything
before anything is built: the ZIP structure and each member's CRC-32 (truncated or altered bytes), the
format name (a foreign ``.npz`` or JSON), the version (a newer file is refused, never guessed at), and
that every array in the manifest is present with the stated shape and dtype.
"""

from __future__ import annotations

import io
import json
import os
import tempfile
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from .errors import NeuroSLAMError
from .files import publish

__all__ = ["FORMAT", "FORMAT_VERSION", "MapFileError", "read_map", "write_map"]

FORMAT = "neuroslam-map"
FORMAT_VERSION = 1
HEADER = "header.json"


class MapFileError(NeuroSLAMError, ValueError):
    """A map file cannot be read or written; nothing was changed.

    Attributes:
        path: the file.
        reason: what is wrong with it.
    """

    def __init__(self, path: str | Path, reason: str):
        self.path = str(path)
        self.reason = reason
        super().__init__(f"map file {self.path!r}: {reason}")


def _member(name: str) -> zipfile.ZipInfo:
    """A stored member dated 1980-01-01 (ZIP's epoch), so the same map gives a byte-identical file."""
    info = zipfile.ZipInfo(name, date_time=(1980, 1, 1, 0, 0, 0))
    info.compress_type = zipfile.ZIP_STORED
    info.external_attr = 0o644 << 16
    return info


def write_map(path: str | Path, header: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Write ``arrays`` and ``header`` (plus the format, version and manifest) atomically to ``path``.

    Returns the path written. Raises :class:`MapFileError` when the target's folder does not exist or
    cannot be written; the previous file at ``path``, if any, is then untouched.
    """
    path = Path(path)
    if path.is_dir():
        raise MapFileError(path, "is a directory, expected a file path")
    folder = path.parent if str(path.parent) else Path(".")
    if not folder.is_dir():
        raise MapFileError(path, f"folder {str(folder)!r} does not exist")
    manifest = {}
    for name, array in arrays.items():
        array = np.asarray(array)
        if array.dtype == object:
            raise MapFileError(path, f"array {name!r} holds Python objects, which the format does not store")
        manifest[name] = {"shape": list(array.shape), "dtype": array.dtype.str}
    full_header = {"format": FORMAT, "version": FORMAT_VERSION, **header, "arrays": manifest}
    try:
        handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=folder)
    except OSError as error:
        raise MapFileError(path, f"cannot write in {str(folder)!r} ({error.strerror})") from None
    try:
        with os.fdopen(handle, "wb") as file:
            with zipfile.ZipFile(file, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as archive:
                archive.writestr(_member(HEADER), json.dumps(full_header, indent=1, sort_keys=True))
                for name, array in arrays.items():
                    with archive.open(_member(f"{name}.npy"), "w", force_zip64=True) as member:
                        np.lib.format.write_array(member, np.asarray(array, order="C"), allow_pickle=False)
            file.flush()
            os.fsync(file.fileno())
        publish(temporary, path)  # mkstemp's 0600 would make the map private
    except BaseException as error:
        Path(temporary).unlink(missing_ok=True)
        if isinstance(error, OSError):
            raise MapFileError(path, f"cannot write ({error.strerror or error})") from None
        raise
    try:  # make the rename itself durable
        directory = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(directory)
        finally:
            os.close(directory)
    except OSError:
        pass
    return path


def read_map(path: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Read and check a map file: (header, arrays). Raises :class:`MapFileError` saying what is wrong."""
    path = Path(path)
    if path.is_dir():
        raise MapFileError(path, "is a directory, expected a map file (a run's folder holds it as map.npz)")
    if not path.exists():
        raise MapFileError(path, "does not exist")
    try:
        with zipfile.ZipFile(path) as archive:
            names = set(archive.namelist())
            if HEADER not in names:
                raise MapFileError(path, f"not a neuroslam map (no {HEADER}; a foreign .npz?)")
            try:
                header = json.loads(archive.read(HEADER).decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError) as error:
                raise MapFileError(path, f"{HEADER} is not valid JSON ({error})") from None
            _check_header(path, header)
            arrays = {}
            for name, spec in header["arrays"].items():
                member = f"{name}.npy"
                if member not in names:
                    raise MapFileError(path, f"array {name!r} listed in the header is missing")
                data = archive.read(member)  # checks the member's CRC-32
                try:
                    array = np.lib.format.read_array(io.BytesIO(data), allow_pickle=False)
                except (ValueError, OSError, EOFError) as error:
                    raise MapFileError(path, f"array {name!r} is unreadable ({error})") from None
                if list(array.shape) != list(spec["shape"]) or array.dtype.str != spec["dtype"]:
                    raise MapFileError(path, f"array {name!r} is {array.dtype.str} {list(array.shape)}, "
                                             f"the header says {spec['dtype']} {spec['shape']}")
                arrays[name] = array
    except zipfile.BadZipFile as error:
        raise MapFileError(path, f"not a readable map (truncated or corrupted: {error})") from None
    except OSError as error:
        raise MapFileError(path, f"cannot read ({error.strerror or error})") from None
    return header, arrays


def _check_header(path: Path, header: Any) -> None:
    if not isinstance(header, dict) or header.get("format") != FORMAT:
        found = header.get("format") if isinstance(header, dict) else type(header).__name__
        raise MapFileError(path, f"not a neuroslam map (format {found!r}, expected {FORMAT!r})")
    version = header.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version < 1:
        raise MapFileError(path, f"invalid format version {version!r}")
    if version > FORMAT_VERSION:
        raise MapFileError(path, f"format version {version} is newer than this neuroslam reads ({FORMAT_VERSION}); "
                                 "upgrade neuroslam to load it")
    arrays = header.get("arrays")
    if not isinstance(arrays, dict) or not all(
            isinstance(spec, dict) and isinstance(spec.get("shape"), list) and isinstance(spec.get("dtype"), str)
            for spec in arrays.values()):
        raise MapFileError(path, "the header's array manifest is malformed")
    if not isinstance(header.get("config"), dict):
        raise MapFileError(path, "the header has no configuration")
