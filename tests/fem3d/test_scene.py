"""``kind = "fem"`` scenes: what they read, and the one-line refusals of bad input."""

from __future__ import annotations

import numpy as np
import pytest

from tests.helpers import CASES, ROOT, load_case
from thinfilm.scene import SceneError, load_scene, parse_scene

SCENE = """\
[model]
kind = "fem"
dim = 2
E = 1000.0
nu = 0.3
Gc = 0.01
eps = 0.5
thickness = 2.0
undamaged = ["gray"]
[geometry]
kind = "lpanel"
[mesh]
h = 5.0
h_coarse = 25.0
check_eps = false   # eps = h / 10: a scene about reading, not resolution
[load]
t_max = 0.1
steps = 4
fixed = ["bottom"]
[load.displacement.load]
y = 1.0
"""


def test_a_scene_reads_into_its_parts():
    scene = parse_scene(SCENE)
    m = scene.model
    assert (m.dim, m.E, m.nu, m.Gc, m.eps, m.k_res, m.at, m.plane, m.thickness) == (
        2, 1000.0, 0.3, 0.01, 0.5, 1e-6, 1, "stress", 2.0)
    assert m.undamaged == ("gray",) and scene.geometry.kind == "lpanel"
    assert scene.load.fixed == ("bottom",) and scene.load.displacement == (("load", 1, 1.0),)
    assert scene.load.loaded == ("load",) and scene.load.proportional
    assert (scene.mesh.h, scene.mesh.h_coarse) == (5.0, 25.0)
    assert dict(scene.geometry.options) == {}   # model.dim reaches lpanel when it is meshed


def test_the_cohesive_law_reads_its_keys():
    m = parse_scene(SCENE.replace("nu = 0.3", 'nu = 0.3\nlaw = "czm"\nft = 2.7\nsoftening = "cornelissen"')).model
    assert (m.law, m.ft, m.softening, m.at) == ("czm", 2.7, "cornelissen", 0)
    law = m.damage_law()
    assert (law.E, law.Gc, law.ft, law.eta, law.softening) == (1000.0, 0.01, 2.7, 0.5, "cornelissen")
    assert parse_scene(SCENE.replace("nu = 0.3", 'nu = 0.3\nlaw = "at2"')).model.at == 2
    assert parse_scene(SCENE).model.law == "at1"


def test_explicit_loads():
    scene = parse_scene(SCENE.replace("t_max = 0.1\nsteps = 4", "t = [0.0, 0.05, 0.08, 0.1]"))
    assert scene.load.values == (0.0, 0.05, 0.08, 0.1) and scene.load.t_max == 0.1 and scene.load.steps == 3


@pytest.mark.parametrize("change, message", [
    (("dim = 2", "dim = 4"), "model.dim = 4: must be 2 or 3"),
    (("nu = 0.3", "nu = 0.5"), "model.nu = 0.5: must be in (-1, 0.5)"),
    (("eps = 0.5", "eps = -1.0"), "model.eps = -1.0: must be a positive number"),
    (("thickness = 2.0", 'thickness = 2.0\nplane = "membrane"'), 'model.plane = "membrane": must be one of "stress"'),
    (("dim = 2", "dim = 3"), "model.thickness = 2.0: is for 2D runs only"),
    (('kind = "lpanel"', 'kind = "lpanel"\nconfiguration = "I"'), 'geometry.configuration = "I": is not a key of'),
    (('kind = "lpanel"', 'kind = "beam"'), 'geometry.kind = "beam": must be one of "lpanel"'),
    (('kind = "lpanel"', 'kind = "lpanel"\nrefine = [0, 1]'), "geometry.refine = [0, 1]: must be a list of 4"),
    (("h_coarse = 25.0", "h_coarse = 1.0"), "mesh.h_coarse = 1.0: must be >= mesh.h = 5"),
    (("t_max = 0.1\nsteps = 4", "t = [0.1, 0.2]"), "load.t = [0.1, 0.2]: must be a list of at least two loads"),
    (('fixed = ["bottom"]', "fixed = [1]"), "load.fixed = [1]: must be a list of group names"),
    (("[load.displacement.load]\ny = 1.0", "[load.displacement.load]\nw = 1.0"), "load.displacement.load.w: unknown key"),
    (('fixed = ["bottom"]\n[load.displacement.load]\ny = 1.0', ""), "load.fixed: give load.fixed or"),
    (("y = 1.0", "y = 0.0"), "load: nothing loads the solid"),
    (("[load]", "[solver]\nbacktrack = \"sometimes\"\n[load]"), 'solver.backtrack = "sometimes": must be one of'),
    (("h = 5.0", "h = 5.0\nh_min = 1.0"), "mesh.h_min = 1.0: is read only with mesh.adapt = true"),
    (("h = 5.0", "adapt = true\nh = 5.0\nh_min = 1.0"), "mesh.h_min = 1.0: and mesh.h are the same size"),
    (("h = 5.0", 'adapt = true\nh = 5.0\nadapt_alpha = 1.5'), "mesh.adapt_alpha = 1.5: must be in (0, 1]"),
    (("h = 5.0", "adapt = true\nh = 5.0\nadapt_energy = 0"), "mesh.adapt_energy = 0: must be a positive number"),
    (("h_coarse = 25.0", "h_coarse = 1.0\nadapt = true"), "mesh.h_coarse = 1.0: must be >= the smallest size, 5"),
    (("nu = 0.3", 'nu = 0.3\nlaw = "czm"'), "model.ft: missing"),
    (("nu = 0.3", 'nu = 0.3\nlaw = "czm"\nft = -2.7'), "model.ft = -2.7: must be a positive number"),
    (("nu = 0.3", 'nu = 0.3\nlaw = "czm"\nft = 2.7\nsoftening = "bilinear"'), 'model.softening = "bilinear": must be'),
    (("nu = 0.3", 'nu = 0.3\nft = 2.7'), 'model.ft = 2.7: is a key of the cohesive law (law = "czm") only'),
    (("nu = 0.3", 'nu = 0.3\nlaw = "at2"\nat = 2'), 'model.at = 2: is the law\'s older spelling'),
    (("nu = 0.3", 'nu = 0.3\nlaw = "AT1"'), 'model.law = "AT1": must be one of "at1"'),
])
def test_bad_input_names_the_key(change, message):
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE.replace(*change), source="x.toml")
    assert message in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("name", ["lpanel", "lpanel_fine", "lpanel_3d", "lpanel_czm", "three_point_bending_I",
                                  "three_point_bending_II"])
def test_the_case_files_are_valid(name):
    scene = load_case(name)
    assert scene.kind == "fem"
    if scene.reference:
        assert (CASES / "winkler_lpanel_series_a.csv").samefile(scene.reference)


def test_buffers_soften_their_region_and_keep_it_sound():
    # the region near the load as a buffer 1000 times softer than the panel: its cells carry
    # E_b / E, its nodes are held sound, and the panel gets more compliant
    from fem3d.kind import build_mesh, build_model

    scene = parse_scene(SCENE.replace('undamaged = ["gray"]', 'undamaged = ["gray"]\nbuffers = {near_load = 1.0}'),
                        source="x.toml")
    assert scene.model.buffers == (("near_load", 1.0),)
    mesh = build_mesh(scene)
    model = build_model(scene, mesh)
    soft = mesh.cell_groups["near_load"]
    assert np.all(model.elasticity.modulus[soft] == 1e-3) and np.sum(model.elasticity.modulus != 1.0) == soft.size
    assert np.all(np.isin(mesh.nodes_of("near_load"), model.damage.fixed_nodes))
    plain = build_model(parse_scene(SCENE, source="x.toml"), mesh)
    alpha = np.zeros(mesh.n_nodes)
    forces = [m.forces(m.solve_u(alpha, 0.1, None, 1e-10), alpha, 0.1)["load"] for m in (model, plain)]
    assert 0.0 < forces[0] < 0.5 * forces[1]


@pytest.mark.parametrize("value, message", [
    ("{near_load = -1.0}", "model.buffers.near_load = -1.0: must be a positive number"),
    ("2.0", "model.buffers = 2.0: must be a table [model.buffers]"),
])
def test_bad_buffers_name_the_key(value, message):
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE.replace('undamaged = ["gray"]', f"buffers = {value}"), source="x.toml")
    assert message in str(err.value)


def test_a_buffer_region_missing_from_the_mesh_is_refused():
    from fem3d.kind import build_mesh, build_model

    scene = parse_scene(SCENE.replace('undamaged = ["gray"]', "buffers = {top_layer = 1.0}"), source="x.toml")
    with pytest.raises(SceneError) as err:
        build_model(scene, build_mesh(scene))
    assert 'model.buffers.top_layer = "top_layer": no region of that name in the mesh' in str(err.value)


def test_a_constant_load_is_held_while_the_other_grows():
    from fem3d.kind import build_mesh, build_model

    text = SCENE + "[load.constant.force.load]\nx = 500.0\n"
    scene = parse_scene(text, source="x.toml")
    assert scene.load.constant_force == (("load", (500.0, 0.0)),) and not scene.load.proportional
    assert parse_scene(SCENE, source="x.toml").load.proportional
    model = build_model(scene, build_mesh(scene))
    assert not model.proportional
    f = model.loads.force_at(0.3)
    assert f[0::2].sum() == pytest.approx(500.0) and f[1::2].sum() == 0.0
    # recorded with the run: its energy release rate is not computed ((4.16) needs a proportional load)
    from fem3d.kind import KIND

    assert KIND.parameters(scene)["proportional"] is False
    # backtracking is allowed with a constant part (the engine's exact test)
    backtracking = parse_scene(text.replace("[load]", '[solver]\nbacktrack = "standard"\n[load]'), source="x.toml")
    assert backtracking.solver.backtrack.kind == "standard" and backtracking.solver.backtrack.test == "exact"


def test_a_bad_constant_load_names_the_key():
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE + "[load.constant.pressure]\nx = 1.0\n", source="x.toml")
    assert "load.constant.pressure: unknown key" in str(err.value)


def test_an_adaptive_mesh_reads_its_sizes_and_thresholds():
    adaptive = SCENE.replace("h = 5.0\nh_coarse = 25.0", "adapt = true\nh_min = 2.0\nh_max = 20.0\nadapt_alpha = 0.1")
    a = parse_scene(adaptive).mesh
    assert (a.h, a.h_coarse) == (2.0, 20.0)
    assert (a.adapt.h_min, a.adapt.h_max, a.adapt.alpha, a.adapt.energy, a.adapt.buffer) == (2.0, 20.0, 0.1, 0.5, 0.0)
    # a banded scene made adaptive keeps its sizes; defaults from eps
    banded = parse_scene(SCENE.replace("[mesh]", "[mesh]\nadapt = true")).mesh.adapt
    assert (banded.h_min, banded.h_max) == (5.0, 25.0)
    bare = parse_scene(SCENE.replace("h = 5.0\nh_coarse = 25.0", "adapt = true\nadapt_buffer = 1.5")).mesh.adapt
    assert (bare.h_min, bare.h_max, bare.buffer) == (0.1, 2.0, 1.5)   # eps / 5, 4 eps
    assert parse_scene(SCENE).mesh.adapt is None
    case = load_case("lpanel", {"mesh.adapt": True}).mesh.adapt
    assert (case.h_min, case.h_max) == (0.625, 12.5)
    # a mesh file is the first mesh: h_max its own largest element, measured
    own = load_scene(ROOT / "examples" / "own_mesh" / "notched_plate.toml", overrides={"mesh.adapt": True}).mesh
    assert own.measured and own.adapt.h_max == own.h_coarse > own.adapt.h_min == pytest.approx(0.02)   # eps / 5


def test_an_adaptive_mesh_needs_p1():
    text = SCENE.replace("[mesh]", "[mesh]\nadapt = true").replace("eps = 0.5", 'eps = 0.5\nelement = "P2"')
    with pytest.raises(SceneError, match='model.element = "P2": mesh.adapt = true needs "P1"'):
        parse_scene(text, source="x.toml")
