"""Mirror symmetries of the grid (thinfilm.plate.symmetry) and the plate model restricted to
symmetric fields: the orbits, the Galerkin reduction ``P^T K P`` against an explicit ``P``,
the reduced u-solve against the full one, a whole ring step against the unreduced model,
and the scene checks that refuse a symmetry the scene does not have."""

import json

import numpy as np
import pytest
import scipy.sparse as sp

from thinfilm.engine import AltMinOptions, Engine, StepRecord
from thinfilm.plate.grid import Grid
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.scene import SceneError, parse_scene
from thinfilm.plate.symmetry import GridSymmetry

from tests.helpers import CASES, load_case



def with_symmetry(name, group, overrides=None):
    """The case file ``cases/<name>.toml`` with ``[domain] symmetry = group`` and ``overrides``."""
    return load_case(name, {"domain.symmetry": group, **(overrides or {})})


def explicit_P(sym):
    """The (n_nodes, n_orbits) 0/1 matrix of "node k lies in orbit o"."""
    n = sym.orbit.size
    return sp.csr_matrix((np.ones(n), (np.arange(n), sym.orbit)), shape=(n, sym.n_orbits))


@pytest.mark.parametrize("cells, group, expected", [
    # (n + 1)^2 nodes, n + 1 = 2m even: D4 orbits are the m (m + 1) / 2 nodes of an eighth.
    (5, "d4", 3 * 4 // 2),
    # n + 1 = 2m + 1 odd: the same with the centre lines, (m + 1)(m + 2) / 2.
    (6, "d4", 4 * 5 // 2),
    (5, "d2", 9),           # 3 x 3 quarter
    (6, "d2", 16),          # 4 x 4 quarter, centre lines included
    (5, "mirror_x", 3 * 6),
    (5, "mirror_y", 3 * 6),
])
def test_orbits_partition_the_nodes(cells, group, expected):
    grid = Grid.rectangle(-1.0, 1.0, cells, -1.0, 1.0, cells)
    sym = GridSymmetry(grid, group)
    assert sym.n_orbits == expected
    # each orbit has as many nodes as its representative has distinct images
    images = np.array([p[sym.representative] for p in sym.permutations])
    assert np.array_equal(sym.orbit_size, [len(set(column)) for column in images.T])
    # every node of an orbit is an image of its representative, and nothing else is
    for p in sym.permutations:
        assert np.array_equal(sym.orbit[p], sym.orbit)


def test_average_is_the_projection_onto_symmetric_fields():
    grid = Grid.rectangle(-1.0, 1.0, 9, -1.0, 1.0, 9)
    sym = GridSymmetry(grid, "d4")
    rng = np.random.default_rng(1)
    x = rng.random(grid.n_nodes)
    a = sym.average(x)
    assert sym.asymmetry(x) > 0.1
    assert np.array_equal(sym.average(a), a)                 # a projection
    # the orthogonal projection: x - a is orthogonal to every symmetric field
    P = explicit_P(sym)
    assert np.max(np.abs(P.T @ (x - a))) < 1e-12
    m = sym.maximum(x)
    assert np.array_equal(m, np.maximum.reduce([x[p] for p in sym.permutations]))
    assert np.array_equal(sym.expand(sym.restrict(a)), a)


def test_reduced_matrix_is_P_transpose_K_P():
    grid = Grid.rectangle(-1.0, 1.0, 8, -1.0, 1.0, 8)
    n = grid.n_nodes
    rng = np.random.default_rng(2)
    K = sp.random(n, n, density=0.05, random_state=3, format="csr")
    K = (K + K.T + sp.identity(n)).tocsr()
    for group in ("mirror_x", "d2", "d4"):
        sym = GridSymmetry(grid, group)
        P = explicit_P(sym)
        expected = (P.T @ K @ P).toarray()
        assert np.max(np.abs(sym.reduce_matrix(K).toarray() - expected)) < 1e-12
        K2 = K.copy()
        K2.data = rng.random(K2.nnz)         # same pattern, new values: the cached map
        assert np.max(np.abs(sym.reduce_matrix(K2).toarray() - (P.T @ K2 @ P).toarray())) < 1e-12
        f = rng.random(n)
        assert np.max(np.abs(sym.reduce_vector(f) - P.T @ f)) < 1e-12
        # a new pattern after a cached one: the map must be rebuilt, not reused
        K3 = (K + sp.random(n, n, density=0.02, random_state=4, format="csr")).tocsr()
        K3 = (K3 + K3.T).tocsr()
        assert np.max(np.abs(sym.reduce_matrix(K3).toarray() - (P.T @ K3 @ P).toarray())) < 1e-12


@pytest.mark.parametrize("linear", ["direct", "amg"])
def test_reduced_u_solve_equals_the_full_solve(linear):
    # Symmetric damage and load: the minimizer over all u is symmetric, so the Galerkin
    # restriction to symmetric u must return it to round-off (AMG: to its tolerance).
    full = make_model_of(with_symmetry("indentation", "none", {"domain.cells": [60, 60], "solver.linear": linear}))
    reduced = make_model_of(with_symmetry("indentation", "d4", {"domain.cells": [60, 60], "solver.linear": linear}))
    assert reduced.symmetry.n_orbits == 31 * 32 // 2
    x, y = full.grid.coordinates
    r = np.hypot(x, y)
    alpha = np.clip(1.0 - np.abs(r - 0.2) / 0.02, 0.0, 1.0) + 0.5 * np.exp(-((x - 0.1) ** 2 + y ** 2) / 1e-3)
    alpha = np.clip(reduced.symmetry.average(alpha), 0.0, 1.0)   # a ring with four spots
    u_full = full.solve_u(alpha, 0.4, None, 1e-12)
    u_red = reduced.solve_u(alpha, 0.4, None, 1e-12)
    scale = np.max(np.abs(u_full))
    assert np.max(np.abs(u_red - u_full)) < 1e-9 * scale
    assert reduced.energies(u_red, alpha, 0.4) == pytest.approx(full.energies(u_full, alpha, 0.4), rel=1e-10)


def make_model_of(scene):
    return make_model(scene, build_grid(scene.domain))


def film_scene(load, x, y, cells, group, extra=""):
    """A small plate scene (2D if ``y`` is given) with ``[domain] symmetry = group``."""
    y_line = "" if y is None else f"y = {list(y)}\n"
    return parse_scene(f"""
[model]
kind = "plate"
winkler = 1e4
toughness = 0.05
eta_dx = 2
[domain]
x = {list(x)}
{y_line}cells = {cells}
symmetry = "{group}"
[load]
kind = "{load}"
{"radius = 0.3" if load == "indenter" else ""}
t_max = 1.0
steps = 2
{extra}""", source="film.toml")


@pytest.mark.parametrize("load, x, y, cells, group", [
    ("indenter", (-0.5, 0.5), (-0.5, 0.5), [10, 10], "d4"),      # odd node count: nodes on the mirror lines
    ("indenter", (-0.5, 0.5), (-0.5, 0.5), [11, 11], "d4"),      # even: orbits pair across them
    ("bending", (-0.5, 0.5), (-0.3, 0.3), [10, 7], "d2"),
    ("bending", (-0.5, 0.5), (-0.3, 0.3), [11, 6], "d2"),
    ("bending", (-0.5, 0.5), None, 20, "mirror_x"),
    ("bending", (-0.5, 0.5), None, 21, "mirror_x"),
    ("cantilever", (0.0, 1.0), (-0.1, 0.1), [12, 5], "mirror_y"),  # clamped at x = 0
    ("cantilever", (0.0, 1.0), (-0.1, 0.1), [12, 6], "mirror_y"),
])
def test_plate_operator_is_invariant_and_the_restriction_is_exact(load, x, y, cells, group):
    # K(alpha) commutes with every mirror when alpha does (free-edge closures, twist term and
    # clamping included), so the restricted u-solve returns the full one.
    model = make_model_of(film_scene(load, x, y, cells, group))
    full = make_model_of(film_scene(load, x, y, cells, "none"))
    sym = model.symmetry
    alpha = 0.9 * sym.average(np.random.default_rng(5).random(model.n_alpha))
    K = full.plate.matrix(alpha)
    scale = abs(K).max()
    for p in sym.permutations[1:]:
        assert abs(K[p][:, p] - K).max() < 1e-12 * scale
    u_full = full.solve_u(alpha, 1.0, None, 1e-12)
    u_red = model.solve_u(alpha, 1.0, None, 1e-12)
    assert np.max(np.abs(u_red - u_full)) < 1e-10 * np.max(np.abs(u_full))


def test_search_and_backtracking_keep_the_restriction():
    # A 1D film with the nucleation search and backtracking, restricted to even fields: every
    # step's damage is symmetric and irreversible, and the film cracks.
    scene = load_case("fig2_5", {"domain.cells": 200, "domain.symmetry": "mirror_x", "load.steps": 40})
    model = make_model_of(scene)
    engine = Engine.from_options(model, scene.solver)
    t = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    _, states = engine.run(t)
    alphas = np.array([s.alpha for s in states])
    assert all(model.symmetry.asymmetry(a) == 0.0 for a in alphas)
    assert np.all(np.diff(alphas, axis=0) >= 0.0)
    assert alphas[-1].max() > 0.99


def test_asymmetric_initial_damage_is_raised_to_its_orbit_maximum():
    # Engine.run with an initial damage that is not symmetric: the bound of the first step is
    # its orbit maximum, so that no asymmetric alpha reaches the restricted u-solve.
    model = make_model_of(with_symmetry("indentation", "d4", {"domain.cells": [40, 40]}))
    seen = []
    solve_u = model.solve_u
    model.solve_u = lambda alpha, *args: seen.append(model.symmetry.asymmetry(alpha)) or solve_u(alpha, *args)
    alpha0 = np.zeros(model.n_alpha)
    alpha0[5] = 0.5
    _, states = Engine(model).run([0.0, 0.1], alpha_initial=alpha0)
    assert seen and max(seen) == 0.0
    assert np.all(states[-1].alpha >= alpha0) and model.symmetry.asymmetry(states[-1].alpha) == 0.0


def test_symmetric_ring_step_follows_the_unreduced_one():
    # The ring step of the indenter from alpha = 0 on 100^2: in exact arithmetic alternate
    # minimization stays symmetric, so the restricted model must take the same iterations to
    # the same ring and energy (the unreduced one drifts from symmetry only by round-off).
    runs = {}
    for group in ("none", "d4"):
        model = make_model_of(with_symmetry("indentation", group, {"domain.cells": [100, 100], "model.eta": 0.016}))
        engine = Engine(model, AltMinOptions(tol=1e-4, acceleration="overrelax", omega=4.0))
        record = StepRecord(6, 0.3)
        zero = np.zeros(model.n_alpha)
        runs[group] = record, engine.alternate_minimization(0.3, zero, zero, None, record, 6), model
    (rec_full, full, _), (rec_red, red, model) = runs["none"], runs["d4"]
    assert rec_red.iterations == rec_full.iterations
    assert model.symmetry.asymmetry(red.alpha) == 0.0
    assert full.alpha.max() > 0.99                          # a crack formed
    assert np.max(np.abs(red.alpha - full.alpha)) < 1e-6
    assert red.total == pytest.approx(full.total, rel=1e-9)


def test_trial_cracks_come_with_their_mirror_images():
    model = make_model_of(with_symmetry("indentation", "d4", {"domain.cells": [40, 40]}))
    sym = model.symmetry
    u = model.solve_u(np.zeros(model.n_alpha), 0.3, None, 1e-10)
    nodes = model.candidates(u, np.zeros(model.n_alpha), 0.3)
    assert len({int(sym.orbit[k]) for k in nodes}) == len(nodes)
    trials = model.trial_states(u, np.zeros(model.n_alpha), 0.3)
    assert trials and all(sym.asymmetry(a) == 0.0 for a in trials)


@pytest.mark.parametrize("name, group, overrides, key, words", [
    ("indentation", "d4", {"domain.cells": [320, 300]}, "domain.symmetry", "square"),
    ("indentation", "d4", {"domain.y": [-0.4, 0.3]}, "domain.symmetry", "square"),
    ("indentation", "rotation", {}, "domain.symmetry", '"none", "mirror_x"'),
])
def test_scene_refuses_a_symmetry_of_another_grid(name, group, overrides, key, words):
    with pytest.raises(SceneError) as err:
        with_symmetry(name, group, overrides)
    assert err.value.key == key and words in str(err.value)


def test_symmetry_the_load_or_clamp_does_not_have_is_refused():
    # The cantilever is clamped at x = 0: mirroring x would clamp x = 1 as well.
    scene = with_symmetry("cantilever_6e6", "mirror_x", {"domain.cells": [40, 4]})
    with pytest.raises(SceneError) as err:
        make_model_of(scene)
    assert err.value.key == "domain.symmetry" and "clamped edges (x0)" in str(err.value)
    # Mirroring y is a symmetry of the cantilever's grid, clamp and load.
    mirrored = make_model_of(with_symmetry("cantilever_6e6", "mirror_y", {"domain.cells": [40, 4]}))
    assert mirrored.symmetry.n_orbits == 41 * 3
    # An indenter off the centre of the domain is not invariant under its mirrors.
    scene = with_symmetry("indentation", "d2", {"domain.cells": [40, 40], "domain.x": [-0.4, 0.5],
                                                "domain.y": [-0.4, 0.5]})
    with pytest.raises(SceneError) as err:
        make_model_of(scene)
    assert err.value.key == "domain.symmetry" and "not invariant" in str(err.value)


def test_command_line_refuses_a_symmetry_in_one_line_and_writes_nothing(tmp_path, capsys):
    from thinfilm.cli import main

    scene = tmp_path / "off_centre.toml"
    scene.write_text((CASES / "indentation.toml").read_text())
    overrides = {"domain.x": [-0.4, 0.5], "domain.y": [-0.4, 0.5], "domain.cells": [40, 40], "domain.symmetry": "d2"}
    assert main(["run", str(scene)] + [f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "domain.symmetry" in err[0] and "not invariant" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["off_centre.toml"]
