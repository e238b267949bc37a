"""Regenerate the built-in world files: ``python -m sim.arenas [DIRECTORY]`` (default: ./worlds)."""

import sys
from pathlib import Path

from . import BUILTIN_BUILDERS, write_world

directory = Path(sys.argv[1] if len(sys.argv) > 1 else "worlds")
for build in BUILTIN_BUILDERS.values():
    print(write_world(build(), directory))
