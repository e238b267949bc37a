"""Shared fixtures. Importing ``sim`` first selects headless EGL rendering before mujoco loads."""

import sim  # noqa: F401

BUILTIN_WORLDS = ["carpark", "urban", "building"]
GENERATED_WORLDS = ["gen:0", "gen:4", "gen:7"]  # gen:4 has three levels
