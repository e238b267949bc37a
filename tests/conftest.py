"""Shared fixtures. Importing ``sim`` first selects headless EGL rendering before mujoco loads."""

from pathlib import Path

import sim  # noqa: F401

BUILTIN_WORLDS = ["carpark", "urban", "building"]
GENERATED_WORLDS = ["gen:0", "gen:4", "gen:7"]  # gen:4 has three levels
# MJCF files written by hand for the generalization benchmark (benchmarks/worlds/README.md)
HANDWRITTEN_WORLDS = sorted(str(path) for path in (Path(__file__).resolve().parent.parent / "benchmarks" / "worlds")
                            .glob("*.xml"))
