"""Every world compiles and simulates a second without MuJoCo warnings (Menagerie-style), the shipped
files match their builders, and the generator is deterministic per seed."""

import json
import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import BUILTIN_WORLDS, GENERATED_WORLDS, HANDWRITTEN_WORLDS

import sim
from sim.arenas import BUILTIN_BUILDERS, Rect, generated, routes_json, subtract_rectangles
from sim.simulation import HIGH_SHADOW_SIZE, Simulation
from sim.world import _worlds_directory


@pytest.mark.parametrize("name", BUILTIN_WORLDS + GENERATED_WORLDS + ["gen:11", "gen:12"] + HANDWRITTEN_WORLDS)
def test_world_compiles_and_simulates_one_second_without_warnings(name):
    world = sim.load_world(name)
    with Simulation(world) as simulation:
        simulation.set_command(0.5, 0.2)
        simulation.step(1.0)
        assert simulation.warnings() == {}
        assert simulation.time == pytest.approx(1.0)
        truth = simulation.ground_truth()
        assert np.all(np.isfinite(truth.pose))
        assert abs(truth.position[2] - world.levels[0]) < 0.05  # resting on the ground floor


def test_builtin_worlds_are_listed():
    assert sim.builtin_worlds() == sorted(BUILTIN_WORLDS)


@pytest.mark.parametrize("name", BUILTIN_WORLDS)
def test_shipped_files_match_their_builders(name):
    source = BUILTIN_BUILDERS[name]()
    directory = _worlds_directory()
    assert (directory / f"{name}.xml").read_text() == source.xml, "run: python -m sim.arenas worlds"
    assert (directory / f"{name}.routes.json").read_text() == routes_json(source)


def _ramp_slopes(xml: str) -> list[float]:
    slopes = []
    for geom in ET.fromstring(xml).iter("geom"):
        if geom.get("name", "").startswith("ramp"):
            _w, x, y, _z = map(float, geom.get("quat").split())
            # angle between the ramp's surface normal (local z) and the world's z
            normal_z = 1 - 2 * (x * x + y * y)
            slopes.append(math.degrees(math.acos(max(-1.0, min(1.0, normal_z)))))
    return slopes


@pytest.mark.parametrize("name", BUILTIN_WORLDS + GENERATED_WORLDS + HANDWRITTEN_WORLDS)
def test_worlds_have_several_levels_joined_by_gentle_ramps(name):
    world = sim.load_world(name)
    xml = world.xml if world.xml is not None else world.path.read_text()
    slopes = _ramp_slopes(xml)
    assert len(world.levels) >= 2
    assert len(slopes) >= len(world.levels) - 1
    assert all(0 < s <= 12.0 for s in slopes), slopes
    # every route starts on a floor, the main route on the ground floor; its waypoints touch every level
    # (others may stay on one: the car park's ground-floor loops for multisession experiments)
    for route in world.routes.values():
        assert route.waypoints[0, 2] in world.levels
    assert world.routes["main"].waypoints[0, 2] == world.levels[0]
    main = world.routes["main"]
    assert set(np.unique(world.level_of(main.waypoints[:, 2]))) == set(range(len(world.levels)))


def test_the_benchmark_has_hand_written_worlds():
    assert [Path(name).stem for name in HANDWRITTEN_WORLDS] == ["angled_carpark", "dim_gallery", "terrace_garden",
                                                                     "turned_wing"]


def _distance_to_route(points: np.ndarray, waypoints: np.ndarray) -> np.ndarray:
    """Each point's horizontal distance (m) to the closed polyline through ``waypoints``."""
    starts, ends = waypoints[:, :2], np.roll(waypoints[:, :2], -1, axis=0)
    along = ends - starts
    share = np.clip(np.einsum("psk,sk->ps", points[:, None, :2] - starts[None], along) / (along**2).sum(1), 0, 1)
    nearest = starts[None] + share[..., None] * along[None]
    return np.linalg.norm(points[:, None, :2] - nearest, axis=2).min(axis=1)


@pytest.mark.parametrize("name", HANDWRITTEN_WORLDS)
def test_a_hand_written_world_is_driven_a_whole_lap_on_every_level(name):
    drive = sim.ScriptedDrive(name, laps=1, render=False)
    positions = np.array([frame.ground_truth.position for frame in drive])
    assert drive.laps_completed == 1
    # the pure pursuit cuts these 18-90 degree corners by under 0.2 m; a bump against a tree, a column or a
    # railing pushes the robot farther off, and a fall off a ramp's side far more
    assert _distance_to_route(positions, drive.route.waypoints).max() < 0.5
    for level in drive.world.levels:
        assert np.min(np.abs(positions[:, 2] - level)) < 0.05  # it stood on every floor


@pytest.mark.parametrize("name", BUILTIN_WORLDS)
def test_surfaces_have_their_own_textures(name):
    root = ET.fromstring(sim.load_world(name).path.read_text())
    textures = [t for t in root.iter("texture") if t.get("type") == "2d"]
    signatures = {(t.get("builtin"), t.get("rgb1"), t.get("mark")) for t in textures}
    assert len(textures) >= 40
    assert len(signatures) >= 0.9 * len(textures)  # nearly every surface looks different


def test_generator_is_deterministic_and_differs_between_seeds():
    assert generated(5).xml == generated(5).xml
    assert generated(5).routes == generated(5).routes
    assert generated(5).xml != generated(6).xml
    layouts = {json.dumps(generated(s).routes["levels"]) for s in range(8)}
    assert len(layouts) >= 6


def test_subtract_rectangles_covers_exactly_the_area_outside_the_holes():
    outer = Rect(-10, 10, -5, 5)
    holes = [Rect(6, 10, -3, 3), Rect(-2, 0, -1, 4)]
    pieces = subtract_rectangles(outer, holes)
    area = sum((r.x1 - r.x0) * (r.y1 - r.y0) for r in pieces)
    assert area == pytest.approx(20 * 10 - 4 * 6 - 2 * 5)
    assert not any(p.overlaps(h) for p in pieces for h in holes)
    assert not any(a.overlaps(b) for i, a in enumerate(pieces) for b in pieces[i + 1:])


@pytest.mark.parametrize("bad, message", [
    ("nowhere", "not a built-in world"),
    ("gen:abc", "integer seed"),
    ("gen:-3", "non-negative"),
    ("/no/such/world.xml", "does not exist"),
])
def test_unknown_worlds_are_refused_with_the_name(bad, message):
    with pytest.raises(sim.WorldError, match=message) as error:
        sim.load_world(bad)
    assert repr(bad) in str(error.value)


def test_user_world_gets_the_robot_added(tmp_path):
    xml = """<mujoco><worldbody><light pos="0 0 5" dir="0 0 -1" directional="true"/>
      <geom name="ground" type="plane" size="20 20 0.1" rgba=".5 .5 .5 1"/>
      <geom name="deck" type="box" size="5 2 0.1" pos="0 10 2.9"/>
      <geom name="ramp" type="box" size="7.5 2 0.1" pos="-12 10 1.4" euler="0 -0.2 0"/></worldbody></mujoco>"""
    (tmp_path / "mine.xml").write_text(xml)
    (tmp_path / "mine.routes.json").write_text(json.dumps(
        {"routes": {"loop": {"waypoints": [[0, 0, 0], [5, 0, 0], [5, 5, 0]], "loop": True}}}))
    world = sim.load_world(tmp_path / "mine.xml")
    assert world.levels == (0.0,)
    with Simulation(world) as simulation:
        simulation.step(0.5)
        assert simulation.warnings() == {}
        assert simulation.model.body("robot/") is not None
        assert simulation.render().shape == (120, 160, 3)


def test_mjcf_that_does_not_compile_is_reported(tmp_path):
    (tmp_path / "broken.xml").write_text("<mujoco><worldbody><geom type='box' size='1'/></worldbody></mujoco>")
    (tmp_path / "broken.routes.json").write_text('{"routes": {"a": {"waypoints": [[0,0,0],[1,0,0]]}}}')
    with pytest.raises(sim.WorldError, match="broken"):
        Simulation(sim.load_world(tmp_path / "broken.xml"))


def test_visual_profiles():
    world = sim.load_world("carpark")
    images = {}
    for quality in ("fast", "high"):
        with Simulation(world, quality=quality) as simulation:
            assert simulation.model.vis.quality.shadowsize == (0 if quality == "fast" else HIGH_SHADOW_SIZE)
            assert bool(simulation.model.light_castshadow.all()) == (quality == "high")
            images[quality] = simulation.render()
    assert np.mean(np.abs(images["fast"].astype(int) - images["high"].astype(int))) > 1.0
    with pytest.raises(sim.InvalidParameterError, match="quality"):
        Simulation(world, quality="ultra")


def test_fast_profile_draws_planes_on_a_coarse_grid_with_the_same_frames(monkeypatch):
    import mujoco

    import sim.simulation as simulation_module

    world = sim.load_world("gen3:133")  # its ground plane: 400 m across, a 1 m render grid
    start = (-9.9, 0.0, 6.08, math.pi)  # on the open top deck, the land at the horizon in view
    images, spacings, fast = {}, {}, simulation_module.FAST_PLANE_GRID_CELLS
    for cells in (fast, 10**9):  # 10**9 cells: the world's own grid
        monkeypatch.setattr(simulation_module, "FAST_PLANE_GRID_CELLS", cells)
        with Simulation(world, start=start) as simulation:
            ground = simulation.model.geom("ground0")
            spacings[cells] = float(ground.size[2])
            images[cells] = simulation.render(noise=False)
            ground.pos[2] = -1000.0  # the land out of sight: the frame must change, or the test shows nothing
            mujoco.mj_forward(simulation.model, simulation.data)
            assert np.any(simulation.render(noise=False) != images[cells])
    assert spacings == {fast: 400.0 / fast, 10**9: 1.0}
    # the lights are directional: per-vertex lighting is the same on any grid of a flat plane
    np.testing.assert_array_equal(images[fast], images[10**9])
    with Simulation(world, quality="high") as simulation:
        assert simulation.model.geom("ground0").size[2] == 1.0

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><geom name='infinite' type='plane' size='0 0 0.05'/>"
        "<geom name='finite' type='plane' size='5 2 0.01'/><geom name='coarse' type='plane' size='5 5 3'/>"
        "</worldbody></mujoco>")
    simulation_module.coarsen_plane_grids(model, 20)
    assert [float(model.geom(name).size[2]) for name in ("infinite", "finite", "coarse")] == \
        pytest.approx([0.05, 0.5, 3.0])


@pytest.mark.parametrize("world, camera", [("carpark", sim.CameraConfig()),
                                           ("urban", sim.CameraConfig(width=256, height=64, panoramic=True))])
def test_fast_profile_leaves_out_geoms_outside_the_view_with_the_same_frames(world, camera):
    import itertools

    import mujoco

    drive = sim.ScriptedDrive(world, camera=camera, max_frames=200)
    simulation = drive.simulation
    views = [simulation.model.camera(f"robot/view{view}").id for view in range(len(camera.view_yaws))]
    every_geom = mujoco.Renderer(simulation.model, camera.height, camera.view_width)
    with drive:
        for _ in itertools.islice(drive, 0, 180, 30):  # a pose every 3 s along the route
            image = simulation.render(noise=False)
            drawn = []
            for view in views:
                every_geom.update_scene(simulation.data, camera=view)
                drawn.append(every_geom.render())
            # the last view's scenes: the simulation's left geoms out, and drew the same pixels
            assert simulation._renderer.scene.ngeom < every_geom.scene.ngeom
            np.testing.assert_array_equal(image, np.concatenate(drawn, axis=1))
    every_geom.close()


def test_geoms_outside_view():
    from sim.simulation import geoms_outside_view, view_frustum_normals

    normals = view_frustum_normals(90.0, 1.0)  # 45° half-angles both ways
    camera_matrix = np.eye(3).ravel()  # at the origin looking along -z
    positions = np.array([[0, 0, -5], [0, 0, 5], [7, 0, -5], [5.5, 0, -5], [0, 5.5, -5], [0, -7, -5], [0, 0, 5]])
    radii = np.array([1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0])
    # ahead; behind; 2 m beyond the right edge (1.41 m from its plane); touching the right and top edges;
    # beyond the bottom; a zero radius (an unbounded plane) behind
    assert geoms_outside_view(positions, radii, np.zeros(3), camera_matrix, normals).tolist() == \
        [False, True, True, False, False, True, False]
    # its columns the camera's axes in the world: x = -y, y = +z (up), z = -x: looking along +x
    turned = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]).ravel()
    assert geoms_outside_view(np.array([[5.0, 0, 0], [-5.0, 0, 0]]), np.ones(2), np.zeros(3), turned,
                              normals).tolist() == [False, True]


@pytest.mark.parametrize("seed, digest", [(0, "2b6271ce38489216"), (5, "61aa8c1daad186d3"), (101, "f2f1d391e96642e8")])
def test_generator_version_1_stays_byte_for_byte_what_gen_seed_was(seed, digest):
    # the digests of gen:SEED's MJCF as the generator wrote it before version 2 (commit 9df86ae): a
    # researcher's gen1:SEED is the world their results were measured on
    import hashlib

    assert hashlib.sha256(generated(seed, 1).xml.encode()).hexdigest()[:16] == digest
    assert sim.load_world(f"gen1:{seed}").xml == generated(seed, 1).xml


@pytest.mark.parametrize("seed, digest", [(0, "52d352af7fe40084"), (7, "57362bccab9fb789"), (101, "2c35b039875bc7ec"),
                                         (128, "91fa0c917a18fd0d")])
def test_generator_version_2_stays_byte_for_byte(seed, digest):
    # the digests of gen2:SEED's MJCF before version 3 (commit 0794100): the worlds the generalization
    # benchmark's generator-2 runs were measured on
    import hashlib

    assert hashlib.sha256(generated(seed, 2).xml.encode()).hexdigest()[:16] == digest


def test_gen_seed_is_the_latest_version_and_versions_are_named():
    from sim.arenas import GENERATOR_VERSION

    assert sim.load_world("gen:7").xml == sim.load_world(f"gen{GENERATOR_VERSION}:7").xml == generated(7).xml
    assert len({sim.load_world(f"gen{version}:7").xml for version in (1, 2, 3)}) == 3
    with pytest.raises(sim.WorldError, match="no generator version 9") as error:
        sim.load_world("gen9:1")
    assert "'gen9:1'" in str(error.value)
    with pytest.raises(sim.WorldError, match="'gen1:' must be followed by an integer seed"):
        sim.load_world("gen1:x")
    with pytest.raises(ValueError, match="version=4"):
        generated(1, 4)
    for seed in (-1, 1.5, True):
        with pytest.raises(ValueError, match=f"seed={seed!r}"):
            generated(seed)


def _geoms(xml: str) -> list[ET.Element]:
    return list(ET.fromstring(xml).iter("geom"))


def test_generator_version_2_draws_the_documented_distribution():
    # over 120 seeds every documented kind appears (sim.arenas.storeys._generated_2): 2-4 levels, 5-12 degree
    # ramps, the four floor styles, roofs, parapets, open decks with land to the horizon and partial decks,
    # corridors (rooms) and halls, dim and bright light
    counts, slopes, styles, tops, brightness, corridors = set(), [], set(), set(), [], set()
    for seed in range(120):
        source = generated(seed, 2)
        root = ET.fromstring(source.xml)
        counts.add(len(source.routes["levels"]))
        slopes += _ramp_slopes(source.xml)
        for texture in root.iter("texture"):  # WorldBuilder.floor_material names its textures KIND_STYLE_N
            kind, _, rest = texture.get("name", "").partition("_")
            style = rest.rpartition("_")[0]
            if kind in ("floor", "ramp") and style:
                styles.add(style)
                mark, builtin = texture.get("mark"), texture.get("builtin")
                assert {"blank": builtin == "flat" and mark == "none" and texture.get("rgb1") == texture.get("rgb2"),
                        "low-contrast": builtin in ("checker", "gradient") and mark == "random",
                        "large-tiled": builtin == "flat" and mark == "edge",
                        "well-marked": builtin == "checker" and mark == "random"}[style], texture.attrib
        names = {geom.get("name", "") for geom in root.iter("geom")}
        land = any(name.startswith("ground") for name in names)
        deck = any(name.startswith("deck") for name in names)
        walls = [geom for geom in root.iter("geom") if geom.get("name", "").startswith("wall")]
        roof = any(float(g.get("pos").split()[2]) > source.routes["levels"][-1] + 3 for g in root.iter("geom")
                   if g.get("name", "").startswith("floor"))
        tops.add("deck" if deck else "open" if land else "roof" if roof else "parapet")
        assert not deck or land  # a partial deck stands over an open top level
        # room walls stand inside the ring lanes (the ramps' walls lie outside them): a corridor level; an
        # obstacle: a hall
        lanes = np.array(source.routes["routes"]["main"]["waypoints"])
        inner_x, inner_y = np.abs(lanes[:, 0]).max() - 5.5, np.abs(lanes[:, 1]).max() - 0.5
        corridors.update(
            {"corridor" for g in walls if abs(float(g.get("pos").split()[0])) < inner_x
             and abs(float(g.get("pos").split()[1])) < inner_y}
            | {"hall" for name in names if name.startswith("obstacle")})
        brightness.append(float(root.find("visual/headlight").get("ambient").split()[0]) / 0.35)
    assert counts == {2, 3, 4}
    assert 5.0 <= min(slopes) < 6.0 and 11.0 < max(slopes) <= 12.0
    assert styles == {"blank", "low-contrast", "large-tiled", "well-marked"}
    assert tops == {"roof", "parapet", "open", "deck"}
    assert min(brightness) < 0.55 and max(brightness) > 1.2
    assert corridors == {"corridor", "hall"}


def _visible_coplanar_faces(xml: str) -> list[tuple[str, str, float]]:
    """Pairs of box faces of different materials lying in one plane, facing the same way and overlapping where
    nothing covers them (a point 5 mm in front of the overlap outside every box, above every ground plane, and
    above and within the ground floor's slab ``floor0``: a generated world's footprint, outside and under which
    no camera goes): (geom, geom, overlapping area in m²). Such faces flicker in a rendered image ("z-fighting")."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    boxes = [g for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX]
    centres, rotations = data.geom_xpos[boxes], data.geom_xmat[boxes].reshape(-1, 3, 3)
    halves = model.geom_size[boxes]
    planes = [data.geom_xpos[g][2] for g in range(model.ngeom) if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_PLANE]
    ground_floor = model.geom("floor0").id  # a generated world's footprint, and its lowest floor at z = 0
    footprint_centre, footprint_half = data.geom_xpos[ground_floor][:2], model.geom_size[ground_floor][:2]
    faces = []  # (box index, normal, offset, centre, (axis, half) x 2)
    for index in range(len(boxes)):
        for axis in range(3):
            for sign in (-1.0, 1.0):
                normal = sign * rotations[index][:, axis]
                centre = centres[index] + normal * halves[index][axis]
                sides = [(rotations[index][:, a], halves[index][a]) for a in range(3) if a != axis]
                faces.append((index, normal, float(normal @ centre), centre, sides))
    normals = np.array([face[1] for face in faces])
    offsets = np.array([face[2] for face in faces])
    grid = (np.arange(8) + 0.5) / 8 * 2 - 1
    found = []
    for i, (index, normal, offset, centre, ((a1, h1), (b1, k1))) in enumerate(faces):
        same = (normals[i + 1:] @ normal > 1 - 1e-9) & (np.abs(offsets[i + 1:] - offset) < 1e-6)
        for j in np.flatnonzero(same) + i + 1:
            other, _, _, other_centre, ((a2, h2), (b2, k2)) = faces[j]
            if other == index or model.geom_matid[boxes[index]] == model.geom_matid[boxes[other]]:
                continue
            points = (centre + grid[:, None, None] * h1 * a1 + grid[None, :, None] * k1 * b1).reshape(-1, 3)
            relative = points - other_centre
            shared = points[(np.abs(relative @ a2) <= h2 + 1e-9) & (np.abs(relative @ b2) <= k2 + 1e-9)]
            if not len(shared):
                continue
            front = shared + 0.005 * normal
            local = np.einsum("bji,pbj->pbi", rotations, front[:, None, :] - centres[None])
            covered = np.all(np.abs(local) <= halves[None], axis=2).any(axis=1)
            covered |= (front[:, 2:3] < np.array(planes)[None, :]).any(axis=1)  # under a ground plane
            inside = np.all(np.abs(front[:, :2] - footprint_centre) <= footprint_half, axis=1)
            covered |= (front[:, 2] < 0.0) | ~inside  # under the ground floor (level 0) or outside the footprint
            if not covered.all():
                area = (~covered).mean() * len(shared) / len(points) * 4 * h1 * k1
                found.append((model.geom(boxes[index]).name, model.geom(boxes[other]).name, round(float(area), 3)))
    return found


@pytest.mark.parametrize("seed", [0, 3, 7, 101, 103, 128])
def test_generated_worlds_have_no_coplanar_faces_of_different_materials(seed):
    # version 3 (WorldBuilder's coplanar_free): a ramp's side wall standing in a level's outer wall, and a
    # wall's top in the floor above it, were two faces in one place that flicker from frame to frame in the
    # camera's images; version 2 had them (the check below finds them), version 3 must not
    assert _visible_coplanar_faces(generated(seed).xml) == []
    assert _visible_coplanar_faces(generated(seed, 2).xml) != []
