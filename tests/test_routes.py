"""Route sidecars: the documented format is read, malformed files are refused with a clear message."""

import json

import numpy as np
import pytest

import sim
from sim.world import parse_routes


def test_route_geometry():
    square = {"waypoints": [[0, 0, 0], [4, 0, 0], [4, 3, 0]], "loop": True}
    routes, levels = parse_routes({"routes": {"square": square}})
    route = routes["square"]
    assert route.length == pytest.approx(12.0)
    np.testing.assert_allclose(route.point_at(5.0), [4, 1, 0])
    np.testing.assert_allclose(route.point_at(12.0 + 2.0), [2, 0, 0])  # loops wrap around
    assert route.start_yaw == pytest.approx(0.0)
    assert levels == (0.0,)


@pytest.mark.parametrize("data, message", [
    ([], "non-empty 'routes'"),
    ({"routes": {}}, "non-empty 'routes'"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0]]}}}, "at least two waypoints"),
    ({"routes": {"a": {"waypoints": [[0, 0], [1, 1]]}}}, "shape"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0], ["x", 1, 0]]}}}, "numbers"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0], [float("nan"), 1, 0]]}}}, "NaN"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0], [0, 0, 0]]}}}, "identical"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0], [1, 0, 0]], "loop": "yes"}}}, "loop"),
    ({"routes": {"a": {"waypoints": [[0, 0, 0], [1, 0, 0]]}}, "levels": "high"}, "levels"),
])
def test_malformed_routes_are_refused(data, message):
    with pytest.raises(sim.RouteError, match=message):
        parse_routes(data)


def test_bad_route_files_name_the_file(tmp_path):
    (tmp_path / "w.xml").write_text("<mujoco/>")
    (tmp_path / "w.routes.json").write_text("{not json")
    with pytest.raises(sim.RouteError, match="invalid JSON") as error:
        sim.load_world(tmp_path / "w.xml")
    assert "w.routes.json" in str(error.value)
    (tmp_path / "w.routes.json").unlink()
    with pytest.raises(sim.RouteError, match="no route file"):
        sim.load_world(tmp_path / "w.xml")


def test_unknown_route_name():
    with pytest.raises(sim.RouteError, match="'nope'"):
        sim.load_world("carpark").route("nope")


def test_routes_file_overrides_sidecar(tmp_path):
    path = tmp_path / "r.json"
    path.write_text(json.dumps({"routes": {"short": {"waypoints": [[-14, -12.5, 0], [0, -12.5, 0]], "loop": False}}}))
    world = sim.load_world("carpark", routes=path)
    assert list(world.routes) == ["short"]
    assert world.levels == (0.0,)
