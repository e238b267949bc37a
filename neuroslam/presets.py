"""Named parameter sets: the paper's three datasets (Tables 5–9) and ``sim``, tuned for the testbed.

``get("sim")`` is the default camera of the testbed (160×120, 80° horizontal field of view).
``synper``, ``synpan`` and ``carpark`` carry the paper's network parameters (Tables 5, 6, 8) and its
fields of view and crop regions (Tables 7, 9, converted from pixels to fractions of the image); the
paper's template and experience thresholds are in its own score units, which differ from this
implementation's, so those use values calibrated for this implementation's scores.
"""

from __future__ import annotations

import difflib
import math
from pathlib import Path

from .config import (
    Config,
    ExperienceMapConfig,
    GridCellConfig,
    HeadDirectionConfig,
    LocalViewConfig,
    Region,
    VisualOdometryConfig,
    load_config,
)
from .errors import InvalidParameterError

__all__ = ["get", "names", "resolve"]


def _paper_grid(global_inhibition: float, view_injection: float) -> GridCellConfig:
    """Table 5: 36³ cells of 1 m."""
    return GridCellConfig(size=(36, 36, 36), cell_size=(1.0, 1.0, 1.0), global_inhibition=global_inhibition,
                          view_injection=view_injection)


def _profile_odometry(**regions: Region) -> VisualOdometryConfig:
    """The paper's intensity-profile odometry (NeuroSLAM eqs. 27–30), with the gains measured on the testbed's car park
    (speed 14.6 m per unit of profile difference, yaw 0.9 of the geometric value), and the paper's height
    (NeuroSLAM eqs. 31–32)."""
    return VisualOdometryConfig(planar_motion="profile", height_model="profile", speed_scale=14.6, yaw_scale=0.9,
                                **regions)


def _paper_map(correction: float, relaxation_passes: int) -> ExperienceMapConfig:
    """The paper's experience map: NeuroSLAM eq. 25's passes, loops closed by NeuroSLAM eq. 22's code match alone,
    and a link from a re-entered experience starting where the codes place the robot (eq. 22)."""
    return ExperienceMapConfig(correction=correction, relaxation_passes=relaxation_passes, relaxation="passes",
                               loop_closure="code", structure_weight=0.0, view_heading_weight=0.0,
                               blind_speed_error=0.0, reentry_links_driven=False)


def _sim() -> Config:
    """The testbed's camera (160×120, 80°): the defaults of :class:`~neuroslam.config.Config`."""
    return Config()


def _synper() -> Config:
    # 160 × 120 perspective images; crops of Table 9: columns 16:145, rows 31:90 (rotation, translation)
    crop = Region(30 / 120, 90 / 120, 15 / 160, 145 / 160)
    return Config(
        horizontal_fov=math.radians(81.5), vertical_fov=math.radians(70.0),
        odometry=_profile_odometry(rotation_region=crop, translation_region=crop,
                                   height_region=Region(10 / 120, 110 / 120, 10 / 160, 150 / 160)),
        grid_cells=_paper_grid(0.0002, 0.1),
        head_direction=HeadDirectionConfig(inhibition_variance=3.0, global_inhibition=0.0002, view_injection=0.001),
        experience_map=_paper_map(correction=0.5, relaxation_passes=5),
    )


def _synpan() -> Config:
    # 480 × 200 panoramic strips; crops of Table 9: columns 181:300, rows 51:150
    crop = Region(50 / 200, 150 / 200, 180 / 480, 300 / 480)
    return Config(
        horizontal_fov=2 * math.pi, vertical_fov=math.radians(50.0), panoramic=True,
        odometry=_profile_odometry(rotation_region=Region(50 / 200, 150 / 200, 0.0, 1.0), translation_region=crop,
                                   height_region=crop),
        local_view=LocalViewConfig(thumbnail=(20, 48), max_column_shift=23),
        grid_cells=_paper_grid(0.00025, 0.1),
        head_direction=HeadDirectionConfig(inhibition_variance=3.1, global_inhibition=0.0003, view_injection=0.01),
        experience_map=_paper_map(correction=0.005, relaxation_passes=1),
    )


def _carpark() -> Config:
    # 480 × 270 perspective images, whole frame (Table 9)
    return Config(
        horizontal_fov=math.radians(75.0), vertical_fov=math.radians(60.0),
        odometry=_profile_odometry(),
        local_view=LocalViewConfig(thumbnail=(27, 48)),
        grid_cells=_paper_grid(0.0002, 0.1),
        head_direction=HeadDirectionConfig(inhibition_variance=3.1, global_inhibition=0.0002, view_injection=0.1),
        experience_map=_paper_map(correction=0.5, relaxation_passes=5),
    )


_PRESETS = {"sim": _sim, "synper": _synper, "synpan": _synpan, "carpark": _carpark}


def names() -> list[str]:
    """Names of the presets."""
    return list(_PRESETS)


def get(name: str) -> Config:
    """The preset called ``name`` (a fresh, immutable :class:`~neuroslam.config.Config`)."""
    if name not in _PRESETS:
        close = difflib.get_close_matches(str(name), names(), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise InvalidParameterError("preset", name, f"unknown preset{hint}; known: {', '.join(names())}")
    return _PRESETS[name]()


def resolve(config: Config | str | Path | None) -> Config:
    """A :class:`Config` from what a user may pass for one: ``None`` (the defaults), a ``Config`` (itself), a
    TOML or JSON file's path, or a preset's name. Raises :class:`InvalidParameterError` naming ``config``
    for anything else, and the errors of :func:`get` and :func:`~neuroslam.config.load_config`."""
    if config is None:
        return Config()
    if isinstance(config, Config):
        return config
    if isinstance(config, str | Path):
        text = str(config)
        if text.endswith((".toml", ".json")) or Path(text).is_file():
            return load_config(text)
        return get(text)
    raise InvalidParameterError("config", type(config).__name__, "must be a Config, a preset name or a file path")
