"""Loads, physical units and their scene errors (cantilever, indenter, field, [material])."""

import math

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.plate.grid import Grid
from thinfilm.plate.loads import cantilever, field, indenter, indenter_displacement, indenter_rate
from thinfilm.plate.kind import resolution_warnings
from thinfilm.scene import SceneError, parse_scene
from thinfilm.plate.units import Material, toughness_from_KIC


def test_indenter_is_the_sphere_under_contact_and_flat_outside():
    R, t = 0.3, 0.4
    rc = R * math.sqrt(t * (2 - t))
    r = np.linspace(0.0, 0.5, 2001)
    w = indenter_displacement(r, np.zeros_like(r), R, t)
    assert w[0] == pytest.approx(-R * t, abs=1e-15)  # centre pressed to depth R t
    inside = r < rc
    # On the sphere: the point (r, w) is at distance R from the centre (0, R (1 - t)).
    np.testing.assert_allclose(np.hypot(r[inside], w[inside] - R * (1 - t)), R, rtol=1e-12)
    assert np.all(w[~inside] == 0.0)
    # Continuous at the contact radius: just inside it the substrate is level with the film.
    just_inside = indenter_displacement(np.array([rc * (1 - 1e-12)]), np.zeros(1), R, t)
    assert abs(just_inside[0]) < 1e-9
    grid = Grid.rectangle(-0.5, 0.5, 20, -0.5, 0.5, 20)
    load = indenter(grid, R)
    assert not load.proportional and load.clamped == ()
    assert np.all(load.w(0.0) == 0.0)


def test_cantilever_is_clamped_with_the_end_force_deflection():
    grid = Grid.rectangle(0.0, 1.0, 10, -0.05, 0.05, 2)
    load = cantilever(grid)
    assert load.proportional and load.clamped == ("x0",)
    x = grid.coordinates[0]
    np.testing.assert_allclose(load.w(2.0), 2.0 * x**2 * (3.0 - x))
    # No moment at the free end x = 1: w'' vanishes there.
    w = lambda s: s**2 * (3 - s)  # noqa: E731
    h = 1e-3
    assert abs((w(1 + h) - 2 * w(1) + w(1 - h)) / h**2) < 1e-9


def test_each_load_knows_its_rate_and_the_displacement_it_imposes():
    # The indenter: dw/dt = -R under the contact disk (the substrate follows the sphere down),
    # 0 outside; its displacement is the depth R t, the substrate's at the centre.
    R, t, dt = 0.3, 0.4, 1e-7
    r = np.linspace(0.0, 0.5, 2001)
    rate = indenter_rate(r, np.zeros_like(r), R, t)
    rc = R * math.sqrt(t * (2 - t))
    away = np.abs(r - rc) > 1e-4   # the rate jumps where the contact edge passes
    difference = (indenter_displacement(r, 0 * r, R, t + dt) - indenter_displacement(r, 0 * r, R, t - dt)) / (2 * dt)
    np.testing.assert_allclose(rate[away], difference[away], atol=1e-6)
    assert set(np.unique(rate)) == {-R, 0.0}
    grid = Grid.rectangle(-0.5, 0.5, 20, -0.5, 0.5, 20)
    load = indenter(grid, R)
    centre = np.argmin(grid.coordinates[0] ** 2 + grid.coordinates[1] ** 2)
    assert load.displacement_scale * t == pytest.approx(-load.w(t)[centre], rel=1e-12)
    np.testing.assert_array_equal(load.dw(t), indenter_rate(*grid.coordinates, R, t))
    # The cantilever: t times its tip deflection per unit t, w_1(lx) = 2 lx^3 (lx = 2 here);
    # a proportional load's rate is w(1).
    grid = Grid.rectangle(1.0, 3.0, 10, -0.05, 0.05, 2)
    load = cantilever(grid)
    assert load.displacement_scale == 16.0 and load.w(1.0)[grid.coordinates[0] == 3.0] == pytest.approx(16.0)
    np.testing.assert_array_equal(load.dw(0.7), load.w(1.0))


def test_field_load_scales_with_t():
    grid = Grid.rectangle(0.0, 1.0, 4, 0.0, 1.0, 3)
    w1 = np.arange(grid.n_nodes, dtype=float).reshape(grid.shape)
    load = field(grid, w1)
    np.testing.assert_array_equal(load.w(0.5), 0.5 * w1.ravel())


ITO = dict(E=99.8e9, nu=0.3, h=0.1e-6, Gc=toughness_from_KIC(2.2e6, 99.8e9), bond_stiffness=3e18, L=2e-6)


def test_material_groups_of_the_ito_film():
    m = Material(**ITO)
    # G~ = 12 Gc (1 - nu^2) / (E h) with Gc = K_IC^2 / E = 48.50 J/m^2: 0.0530 (docs/model.md#physical-units: of
    # order 5e-2, not the printed 5e-3).
    assert m.Gc == pytest.approx(48.497, rel=1e-4)
    assert m.G_tilde == pytest.approx(0.05303, rel=1e-3)
    assert m.toughness == pytest.approx(m.G_tilde / 0.05)


def test_groups_do_not_depend_on_the_unit_system():
    # The same film in micrometres, micronewtons: every non-dimensional group is unchanged.
    si = Material(**ITO)
    um = 1e6  # lengths in um; forces in uN (1 N = 1e6 uN): Pa -> uN/um^2 = 1e-6
    scaled = Material(E=ITO["E"] * 1e-6, nu=0.3, h=ITO["h"] * um, Gc=ITO["Gc"] * 1e6 / um,
                      bond_stiffness=ITO["bond_stiffness"] * 1e-6 / um, L=ITO["L"] * um)
    for key, value in si.groups().items():
        if key != "rigidity":
            assert scaled.groups()[key] == pytest.approx(value, rel=1e-12), key


PLATE_2D = """
[model]
kind = "plate"
{model}
eta_dx = 2.5
[domain]
x = [-0.5, 0.5]
y = [-0.5, 0.5]
cells = [20, 20]
[load]
{load}
[solver]
{solver}
"""


def scene(model='winkler = 4e6\ntoughness = 1.0', load='kind = "indenter"\nradius = 0.3\nt_max = 1.0\nsteps = 4',
          solver="", extra=""):
    return PLATE_2D.format(model=model, load=load, solver=solver) + extra


def test_material_scene_equals_the_non_dimensional_one():
    m = Material(**ITO)
    text = scene(model="", extra="[material]\n" + "\n".join(f"{k} = {v!r}" for k, v in ITO.items() if k != "Gc")
                 + f"\nK_IC = 2.2e6\n")
    s = parse_scene(text)
    assert s.model.winkler == pytest.approx(m.winkler, rel=1e-12)
    assert s.model.toughness == pytest.approx(m.toughness, rel=1e-12)
    assert s.model.nu == 0.3 and s.material.Gc == pytest.approx(m.Gc)


@pytest.mark.parametrize("text, message", [
    (scene(solver='backtrack = "standard"'),
     'solver.backtrack = "standard": backtracking needs a load proportional to t; load.kind = "indenter" is not'),
    (scene(load='kind = "indenter"\nt_max = 1.0\nsteps = 4'), "load.radius: missing (required)"),
    (scene(load='kind = "indenter"\nradius = 0.3\nt_max = 1.5\nsteps = 4'), "load.t_max = 1.5: must be <= 1"),
    (scene(load='kind = "bending"\nradius = 0.3\nt_max = 1.0\nsteps = 4'),
     'load.radius = 0.3: is not used by load.kind = "bending"'),
    (scene(load='kind = "cantilever"\nt_max = 1.0\nsteps = 4'), "domain.x = [-0.5, 0.5]: the cantilever is clamped at x = 0"),
    (scene(load='kind = "field"\nfile = "nowhere.npz"\nt_max = 1.0\nsteps = 4'), 'load.file = "nowhere.npz": no such file'),
    (scene(load='kind = "field"\nfile = "w.txt"\nt_max = 1.0\nsteps = 4'), 'load.file = "w.txt": must end in .npz, .h5 or .hdf5'),
    (scene(model="lam = 30.0", extra="[material]\nE = 1e9\nh = 1e-6\nGc = 1.0\nbond_stiffness = 1e12\nL = 1e-3\n"),
     "model.lam: not allowed with a [material] table"),
    (scene(model="", extra="[material]\nE = 1e9\nh = 1e-6\nGc = 1.0\nK_IC = 1e6\nbond_stiffness = 1e12\nL = 1e-3\n"),
     "material.Gc: give exactly one of material.Gc and material.K_IC (both are given)"),
    (scene(model="", extra="[material]\nE = -1e9\nh = 1e-6\nGc = 1.0\nbond_stiffness = 1e12\nL = 1e-3\n"),
     "material.E = -1000000000.0: must be a positive number"),
])
def test_bad_loads_and_materials_are_one_line_errors(text, message):
    with pytest.raises(SceneError) as err:
        parse_scene(text)
    assert message in str(err.value) and "\n" not in str(err.value)


def _field_scene(tmp_path, w, name="w", filename="w.npz"):
    path = tmp_path / filename
    if filename.endswith(".npz"):
        np.savez(path, **{name: w})
    else:
        with h5py.File(path, "w") as f:
            f[name] = w
    text = scene(load=f'kind = "field"\nfile = "{filename}"\nt_max = 1.0\nsteps = 4')
    scene_path = tmp_path / "field.toml"
    scene_path.write_text(text)
    return scene_path


def test_field_file_is_checked_for_shape_and_finiteness(tmp_path, capsys):
    bad_shape = _field_scene(tmp_path, np.zeros((20, 21)))
    assert main(["run", str(bad_shape), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert "array 'w' has shape (20, 21); the grid needs (21, 21)" in err and "\n" not in err
    w = np.zeros((21, 21))
    w[3, 4] = np.nan
    not_finite = _field_scene(tmp_path, w, filename="w.h5")
    assert main(["run", str(not_finite), "--quiet"]) == 2
    assert "1 non-finite values" in capsys.readouterr().err
    assert not (tmp_path / "field").exists()  # nothing written


def test_field_load_from_npz_runs(tmp_path):
    grid = Grid.rectangle(-0.5, 0.5, 20, -0.5, 0.5, 20)
    w = -0.5 * grid.coordinates[0] ** 2
    path = _field_scene(tmp_path, w.reshape(grid.shape))
    assert main(["run", str(path), "--quiet"]) == 0
    with h5py.File(tmp_path / "field" / "results.h5") as f:
        assert f["parameters"].attrs["load"] == "field"
        assert len(f["steps/t"]) == 5


def test_indenter_near_an_edge_is_warned():
    s = parse_scene(scene(load='kind = "indenter"\nradius = 0.45\nt_max = 1.0\nsteps = 4'))
    assert any("from a free edge" in w for w in resolution_warnings(s))
    s = parse_scene(scene(load='kind = "indenter"\nradius = 0.1\nt_max = 0.2\nsteps = 4'))
    assert not any("from a free edge" in w for w in resolution_warnings(s))
