"""Configuration: presets, files, and clear errors for unknown keys, wrong types and bad ranges."""

import json

import pytest

from neuroslam import Config, InvalidParameterError, load_config, presets


def test_presets_exist_and_differ():
    assert presets.names() == ["sim", "synper", "synpan", "carpark"]
    assert presets.get("synpan").panoramic and not presets.get("sim").panoramic
    assert presets.get("synper").head_direction.view_injection == 0.001  # Table 6
    with pytest.raises(InvalidParameterError, match="did you mean 'synpan'"):
        presets.get("synpn")


def test_paper_presets_keep_the_papers_experience_map():
    """The paper presets close loops by eq. 22's code match and lay a re-entered experience's link from the place
    the codes read; the ``sim`` preset lays it along the driven path (the sixty-first step)."""
    assert presets.get("sim").experience_map.reentry_links_driven
    for name in ("synper", "synpan", "carpark"):
        experience_map = presets.get(name).experience_map
        assert experience_map.loop_closure == "code", name
        assert not experience_map.reentry_links_driven, name
        assert not experience_map.reentry_keeps_pose, name


@pytest.mark.parametrize("data, field, text", [
    ({"grid_cell": {}}, "grid_cell", "did you mean 'grid_cells'"),
    ({"experience_map": {"thresold": 1}}, "experience_map.thresold", "did you mean 'experience_map.threshold'"),
    ({"grid_cells": {"size": [36, 36]}}, "grid_cells.size", "3 integers"),
    ({"grid_cells": {"cell_size": [1, 0, 1]}}, "grid_cells.cell_size", "positive"),
    ({"grid_cells": {"size": [0, 36, 36]}}, "grid_cells.size", "from 4 to 512"),
    ({"local_view": {"threshold": -1}}, "local_view.threshold", "positive"),
    ({"local_view": {"threshold": "low"}}, "local_view.threshold", "positive"),
    ({"local_view": {"noise_floor": -1.0}}, "local_view.noise_floor", ">= 0"),
    ({"local_view": {"noise_floor": float("nan")}}, "local_view.noise_floor", ">= 0"),
    ({"odometry": {"height_region": {"top": 0.9, "bottom": 0.5}}}, "odometry.height_region.bottom", "greater"),
    ({"experience_map": {"correction": 2}}, "experience_map.correction", "(0, 1]"),
    ({"horizontal_fov": -1}, "horizontal_fov", "radians"),
    ({"odometry": {"near_floor_row": 0.2}}, "odometry.near_floor_row", "0 (off) or a fraction in (0.3, 1)"),
    ({"odometry": {"near_floor_row": 1.0}}, "odometry.near_floor_row", "0 (off) or a fraction in (0.3, 1)"),
    ({"odometry": {"near_floor_row": "near"}}, "odometry.near_floor_row", "0 (off) or a fraction in (0.3, 1)"),
    ({"odometry": {"slope_half_width": -1.0}}, "odometry.slope_half_width", ">= 0"),
    ({"odometry": {"slope_near_floor": 1}}, "odometry.slope_near_floor", "true or false"),
    ({"odometry": {"floor_aperture": 1.6}}, "odometry.floor_aperture", "[0, pi/2)"),
    ({"odometry": {"floor_aperture": -0.1}}, "odometry.floor_aperture", "[0, pi/2)"),
    ({"odometry": {"manhattan": "yes"}}, "odometry.manhattan", "true or false"),
    ({"odometry": {"manhattan_strength": 0.0}}, "odometry.manhattan_strength", "(0, 1]"),
    ({"odometry": {"manhattan_spread": 0.9}}, "odometry.manhattan_spread", "(0, pi/4)"),
    ({"odometry": {"manhattan_window": 1}}, "odometry.manhattan_window", "2 or more"),
    ({"odometry": {"manhattan_window": 5.0}}, "odometry.manhattan_window", "2 or more"),
    ({"odometry": {"working_width": 16}}, "odometry.working_width", "from 32 to 4096"),
    ({"odometry": {"working_width": 160.0}}, "odometry.working_width", "whole number of columns"),
    ({"odometry": {"manhattan_rate": 0}}, "odometry.manhattan_rate", "positive"),
    ({"odometry": {"floor_shared_information": 1}}, "odometry.floor_shared_information", "true, false or"),
    ({"odometry": {"floor_shared_information": "auto"}}, "odometry.floor_shared_information", "true, false or"),
    ({"odometry": {"manhattan_first_row": 1.0}}, "odometry.manhattan_first_row", "[0, 1)"),
    ({"odometry": {"manhattan_first_row": -0.1}}, "odometry.manhattan_first_row", "[0, 1)"),
    ({"experience_map": {"relaxation": "gauss"}}, "experience_map.relaxation", "passes, least-squares"),
    ({"experience_map": {"loop_closure": "seq"}}, "experience_map.loop_closure", "code, confirmed"),
    ({"experience_map": {"confirmation_window": 10, "confirmation_matches": 11}},
     "experience_map.confirmation_matches", "from 1 to confirmation_window"),
    ({"experience_map": {"confirmation_tolerance": 0}}, "experience_map.confirmation_tolerance", "positive"),
    ({"experience_map": {"confirmation_views": 0}}, "experience_map.confirmation_views", "from 1 to 100"),
    ({"experience_map": {"confirmation_rival_spread": 0}}, "experience_map.confirmation_rival_spread", "(0, 2]"),
    ({"experience_map": {"confirmation_rival_spread": 2.5}}, "experience_map.confirmation_rival_spread", "(0, 2]"),
    ({"experience_map": {"confirmation_drift": -0.1}}, "experience_map.confirmation_drift", ">= 0"),
    ({"experience_map": {"reentry_keeps_pose": "yes"}}, "experience_map.reentry_keeps_pose", "true or false"),
    ({"experience_map": {"reentry_links_driven": 1}}, "experience_map.reentry_links_driven", "true or false"),
    ({"integrator": "pose-cells"}, "integrator", "odometry, grid-network"),
    ({"grid_network": {"size": 8}}, "grid_network.size", "from 16 to 1024"),
    ({"grid_network": {"time_step": 10}}, "grid_network.time_step", "time_constant"),
    ({"grid_network": {"steps_per_frame": 0}}, "grid_network.steps_per_frame", "from 1"),
    ({"grid_network": {"search_radius": 64}}, "grid_network.search_radius", "half the sheet"),
    ({"grid_network": {"lattice_period": -18}}, "grid_network.lattice_period", "positive"),
    ({"grid_network": {"steps_perframe": 10}}, "grid_network.steps_perframe",
     "did you mean 'grid_network.steps_per_frame'"),
])
def test_bad_settings_name_the_field(data, field, text):
    with pytest.raises(InvalidParameterError) as error:
        Config.from_dict(data)
    assert error.value.field == field
    assert text in str(error.value)


def test_no_near_floor_leaves_eq_g9_off():
    # eq. G9 (on by default) reads eq. G4's near floor on a slope; with no near floor (near_floor_row 0, eq. G4
    # off) there is none to read, and the odometry builds with the whole floor on slopes too
    from neuroslam.vision.odometry import VisualOdometry

    config = Config.from_dict({"odometry": {"near_floor_row": 0.0}})
    assert config.odometry.slope_near_floor
    assert not VisualOdometry(config.odometry)._ground.slope_near_floor


def test_files_round_trip(tmp_path):
    config = Config.from_dict({"grid_cells": {"size": [20, 20, 10]}, "experience_map": {"threshold": 2.5}})
    (tmp_path / "c.json").write_text(json.dumps(config.to_dict()))
    assert load_config(tmp_path / "c.json") == config
    (tmp_path / "c.toml").write_text("[grid_cells]\nsize = [20, 20, 10]\n[experience_map]\nthreshold = 2.5\n")
    assert load_config(tmp_path / "c.toml") == config
    (tmp_path / "bad.toml").write_text("[grid_cells\n")
    with pytest.raises(InvalidParameterError, match="not valid"):
        load_config(tmp_path / "bad.toml")
