"""neuroslam sweep: world lists and grids are parsed and checked; drives run as Ray tasks into results.csv,
a re-run skips the drives already ok, and a failing drive is a row that does not stop the others."""

import csv
import json
import re

import pytest

import sim
from neuroslam import InvalidParameterError
from neuroslam.lab.cli import main
from neuroslam.lab.sweep import expand_worlds, flatten, parse_grid


def test_world_lists_expand_ranges_and_commas():
    assert expand_worlds(["carpark,gen:3-5", "my.xml"]) == ["carpark", "gen:3", "gen:4", "gen:5", "my.xml"]
    assert expand_worlds(["gen1:7-8"]) == ["gen1:7", "gen1:8"]  # a generator version's seeds
    with pytest.raises(InvalidParameterError, match="A <= B"):
        expand_worlds(["gen:5-3"])


def test_grids_are_every_combination_of_valid_values():
    grid = parse_grid(["local_view.threshold=0.05,0.07", "experience_map.loop_closure=code,confirmed"])
    assert len(grid) == 4 and (("local_view.threshold", 0.07), ("experience_map.loop_closure", "code")) in grid
    assert parse_grid([]) == [()]
    with pytest.raises(InvalidParameterError, match=r"local_view\.treshold"):
        parse_grid(["local_view.treshold=0.05"])  # a misspelt field fails before any drive starts
    with pytest.raises(InvalidParameterError, match=r"local_view\.threshold"):
        parse_grid(["local_view.threshold=-1"])
    with pytest.raises(InvalidParameterError, match="FIELD=V1,V2"):
        parse_grid(["local_view.threshold"])


def test_metrics_flatten_with_dots():
    assert flatten({"a": {"b": 1, "c": {"d": 2}}, "e": [1, 2]}) == {"a.b": 1, "a.c.d": 2, "e": "[1, 2]"}


def test_a_sweep_on_local_ray_writes_rows_skips_done_drives_and_survives_a_failure(tmp_path, capsys):
    pytest.importorskip("ray")
    out = tmp_path / "sweep"
    # a world of one's own: its row keeps the path asked for (its metrics name it by the file's stem)
    world = sim.load_world("gen:4")
    mine = tmp_path / "mine.xml"
    mine.write_text(world.xml)
    (tmp_path / "mine.routes.json").write_text(json.dumps(
        {"levels": list(world.levels), "routes": {"main": {"waypoints": world.route().waypoints.tolist()}}}))
    arguments = ["sweep", "--worlds", "gen:2,nowhere", "gen:3", str(mine), "--max-frames", "20", "--workers", "2",
                 "--out", str(out)]
    assert main(arguments) == 1  # one drive failed
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert sorted((row["world"], row["status"]) for row in rows) == [(str(mine), "ok"), ("gen:2", "ok"),
                                                                     ("gen:3", "ok"), ("nowhere", "failed")]
    failed = next(row for row in rows if row["status"] == "failed")
    assert "not a built-in world" in failed["error"] and "\n" not in failed["error"]
    for row in rows:
        if row["status"] == "ok":
            folder = re.sub(r"[^A-Za-z0-9._=-]+", "_", row["world"])
            metrics = json.loads((out / "drives" / f"{folder}-seed0" / "metrics.json").read_text())
            assert float(row["ate_rmse_m.slam"]) == pytest.approx(metrics["ate_rmse_m"]["slam"])
            assert int(row["frames"]) == 20
    written = {path: path.stat().st_mtime_ns for path in (out / "drives").rglob("metrics.json")}
    # the same sweep again, without the failing world: nothing left to run
    assert main(["sweep", "--worlds", "gen:2", "gen:3", str(mine), "--max-frames", "20", "--out", str(out)]) == 0
    assert {path: path.stat().st_mtime_ns for path in (out / "drives").rglob("metrics.json")} == written
    assert "gen:2" in capsys.readouterr().out
