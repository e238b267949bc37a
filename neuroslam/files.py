"""Writing files safely: written in full under a temporary name, then moved into place."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["publish"]


def publish(temporary: str | Path, path: str | Path) -> None:
    """Move a finished temporary file onto ``path`` (atomically, on one file system) with the permissions a
    newly created file gets under the process's umask (0644 under the usual 022): ``tempfile.mkstemp``
    creates files readable by their owner only, which would make trajectories and maps private."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(temporary, 0o666 & ~umask)
    os.replace(temporary, path)
