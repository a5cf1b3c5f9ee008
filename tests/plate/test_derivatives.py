"""PlateModel's EnergyDerivatives hook (thinfilm/plate/derivatives.py) against finite
differences: 1D and 2D grids, free and clamped edges, AT1 and AT2, an imperfect film; and
restricted to symmetric fields (every mirror group, with and without clamped edges), whose
blocks are also compared with ``P^T`` of the unrestricted model's."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from tests.derivatives_check import check_energy_derivatives, interior_damage
from tests.helpers import load_case
from thinfilm.plate.grid import Grid
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.model import PlateModel
from thinfilm.plate.symmetry import GridSymmetry
from thinfilm.solvers.linear import make_solver


def random_state(model, seed=0):
    rng = np.random.default_rng(seed)
    u = model.u_from_free(rng.standard_normal(model.plate.free_nodes.size), 0.0)
    return u, interior_damage(rng, model.n_alpha)


def direct_model(grid, clamped=(), at=1, factor=None):
    w1 = np.random.default_rng(5).standard_normal(grid.n_nodes)
    model = PlateModel(grid, 0.3, 40.0, 1e-6, 0.1, 0.05, at, lambda t: t * w1, True, None, clamped=clamped,
                       toughness_factor=factor)
    model.linear_solver = make_solver("direct", model.plate.matrix(np.zeros(grid.n_nodes)))
    return model


@pytest.mark.parametrize("case, overrides", [
    ("fig2_5", {"domain.cells": 24}),
    ("fig2_7", {"domain.cells": [14, 6]}),
    ("indentation", {"domain.cells": [10, 9]}),
])
def test_case_models_match_finite_differences(case, overrides):
    scene = load_case(case, overrides)
    model = make_model(scene, build_grid(scene.domain))
    u, alpha = random_state(model)
    scale = float(np.max(np.abs(model.load(1.0)))) or 1.0
    check_energy_derivatives(model, scale * u, alpha, 0.8)


@pytest.mark.parametrize("grid, clamped, at", [
    (Grid.line(0.0, 1.0, 16), ("x0",), 2),
    (Grid.line(0.0, 1.0, 16), ("x0", "x1"), 1),
    (Grid.rectangle(0.0, 1.0, 9, 0.0, 0.7, 8), ("x0",), 1),
    (Grid.rectangle(0.0, 1.0, 8, 0.0, 0.7, 7), ("x0", "y1"), 2),
    (Grid.rectangle(0.0, 1.0, 7, 0.0, 0.7, 6), (), 2),
])
def test_clamped_edges_and_at2_match_finite_differences(grid, clamped, at):
    factor = np.random.default_rng(6).uniform(0.7, 1.3, grid.n_nodes)
    model = direct_model(grid, clamped, at, factor)
    u, alpha = random_state(model, seed=1)
    check_energy_derivatives(model, u, alpha, 0.6)


@pytest.mark.parametrize("grid, clamped", [(Grid.line(0.0, 1.0, 12), ("x1",)),
                                           (Grid.rectangle(0.0, 1.0, 6, 0.0, 1.0, 5), ("y0",))])
def test_blocks_are_the_u_matrix_and_the_damage_problem(grid, clamped):
    model = direct_model(grid, clamped)
    u, alpha = random_state(model, seed=2)
    K_uu, K_ua, K_aa = model.hessian_blocks(u, alpha, 0.5)
    free = model.plate.free_nodes
    K = model.plate.matrix(alpha)
    assert abs(K_uu - K[free][:, free]).max() == 0.0
    A, b = model.damage_problem(u, 0.5)
    assert abs(K_aa - A).max() == 0.0
    g_u, g_a = model.energy_gradient(u, alpha, 0.5)
    np.testing.assert_array_equal(g_a, A @ alpha - b)
    # the u-gradient vanishes at solve_u's displacement
    u_star = model.solve_u(alpha, 0.5, None, None)
    g_star, _ = model.energy_gradient(u_star, alpha, 0.5)
    assert np.linalg.norm(g_star) < 1e-9 * np.linalg.norm(g_u)
    # the cross block's columns are g'(alpha_n) M_n u: summed against g'(alpha)^-1 ones they
    # give the bending part of K(alpha = 0) u without the foundation, sum_n M_n u
    total = K_ua @ (1.0 / (-2.0 * (1.0 - alpha)))
    np.testing.assert_allclose(total, model.plate.apply_bending(np.ones(grid.n_nodes), u)[free], rtol=1e-12,
                               atol=1e-12 * np.abs(total).max())


def symmetric_state(model, seed=0):
    """A symmetric state of a model with a symmetry: ``u_from_free`` of random orbit values and
    the orbit average of a random interior damage."""
    rng = np.random.default_rng(seed)
    u = model.u_from_free(rng.standard_normal(model.free_u(np.zeros(model.n_alpha)).size), 0.0)
    alpha = model.symmetry.average(interior_damage(rng, model.n_alpha))
    assert model.symmetry.asymmetry(u) == 0.0 and model.symmetry.asymmetry(alpha) == 0.0
    return u, alpha


def symmetric_direct_model(grid, group, clamped=(), at=1):
    """:func:`direct_model` restricted to the fields of ``group``, with a symmetric load and
    toughness factor, its solver made for the reduced matrix."""
    symmetry = GridSymmetry(grid, group)
    rng = np.random.default_rng(5)
    w1 = symmetry.average(rng.standard_normal(grid.n_nodes))
    factor = symmetry.average(rng.uniform(0.7, 1.3, grid.n_nodes))
    model = PlateModel(grid, 0.3, 40.0, 1e-6, 0.1, 0.05, at, lambda t: t * w1, True, None, clamped=clamped,
                       toughness_factor=factor, symmetry=symmetry)
    model.linear_solver = make_solver("direct", model.reduced_matrix(np.zeros(grid.n_nodes)))
    return model


#: Case files restricted to each group on small grids (odd and even node counts), and one
#: with a clamped edge its mirror keeps.
SYMMETRIC_CASES = [
    ("fig2_5", {"domain.cells": 24, "domain.symmetry": "mirror_x"}),
    ("fig2_5", {"domain.cells": 25, "domain.symmetry": "mirror_x", "model.at": 2}),
    ("indentation_full_d4", {"domain.cells": [10, 10], "solver.coarse": None}),
    ("indentation_full_d4", {"domain.cells": [11, 11], "solver.coarse": None, "model.at": 2}),
    ("indentation", {"domain.cells": [10, 9], "domain.symmetry": "d2"}),
    ("indentation", {"domain.cells": [9, 10], "domain.symmetry": "mirror_x", "model.at": 2}),
    ("indentation", {"domain.cells": [10, 9], "domain.symmetry": "mirror_y"}),
    ("cantilever_6e6", {"domain.cells": [12, 6], "domain.symmetry": "mirror_y"}),
]


@pytest.mark.parametrize("case, overrides", SYMMETRIC_CASES)
def test_symmetric_case_models_match_finite_differences(case, overrides):
    scene = load_case(case, overrides)
    model = make_model(scene, build_grid(scene.domain))
    assert model.symmetry is not None
    u, alpha = symmetric_state(model)
    scale = float(np.max(np.abs(model.load(1.0)))) or 1.0
    check_energy_derivatives(model, scale * u, alpha, 0.8)


@pytest.mark.parametrize("grid, group, clamped, at", [
    (Grid.line(-0.5, 0.5, 16), "mirror_x", ("x0", "x1"), 2),
    (Grid.line(-0.5, 0.5, 15), "mirror_x", ("x0", "x1"), 1),
    (Grid.rectangle(-0.5, 0.5, 8, -0.5, 0.5, 8), "d4", ("x0", "x1", "y0", "y1"), 1),
    (Grid.rectangle(-0.5, 0.5, 9, -0.4, 0.4, 7), "d2", ("y0", "y1"), 2),
    (Grid.rectangle(-0.5, 0.5, 9, -0.4, 0.4, 6), "mirror_y", ("x0",), 1),
])
def test_symmetric_clamped_films_match_finite_differences(grid, group, clamped, at):
    model = symmetric_direct_model(grid, group, clamped, at)
    u, alpha = symmetric_state(model, seed=1)
    assert np.all(u[model.plate.clamped_nodes] == 0.0)
    check_energy_derivatives(model, u, alpha, 0.6)


@pytest.mark.parametrize("grid, group, clamped", [
    (Grid.line(-0.5, 0.5, 12), "mirror_x", ("x0", "x1")),
    (Grid.line(-0.5, 0.5, 13), "mirror_x", ()),
    (Grid.rectangle(-0.5, 0.5, 7, -0.5, 0.5, 7), "d4", ()),
    (Grid.rectangle(-0.5, 0.5, 8, -0.5, 0.5, 8), "d4", ("x0", "x1", "y0", "y1")),
    (Grid.rectangle(-0.5, 0.5, 8, -0.3, 0.3, 5), "d2", ("x0", "x1")),
    (Grid.rectangle(-0.5, 0.5, 7, -0.3, 0.3, 6), "mirror_x", ("y1",)),
    (Grid.rectangle(-0.5, 0.5, 7, -0.3, 0.3, 6), "mirror_y", ("x1",)),
])
def test_symmetric_blocks_are_the_restriction_of_the_full_ones(grid, group, clamped):
    model = symmetric_direct_model(grid, group, clamped)
    sym = model.symmetry
    full = PlateModel(grid, 0.3, 40.0, 1e-6, 0.1, 0.05, 1, model.load, True, None, clamped=clamped,
                      toughness_factor=model.damage.toughness_factor)
    u, alpha = symmetric_state(model, seed=2)
    t = 0.5
    v = model.free_u(u)
    # the free reduced dofs are the orbits of free nodes: one value per orbit, clamped orbits 0
    free_orbits = np.unique(sym.orbit[model.plate.free_nodes])
    assert v.size == free_orbits.size
    assert np.array_equal(sym.restrict(u)[free_orbits], v)
    # P_f, the (n_free, n_free_orbits) 0/1 matrix of "free node k lies in free orbit o"
    position = np.searchsorted(free_orbits, sym.orbit[full.plate.free_nodes])
    P = sp.csr_matrix((np.ones(position.size), (np.arange(position.size), position)),
                      shape=(position.size, free_orbits.size))
    np.testing.assert_array_equal(full.free_u(u), P @ v)

    g_u, g_a = model.energy_gradient(u, alpha, t)
    G_u, G_a = full.energy_gradient(u, alpha, t)
    np.testing.assert_allclose(g_u, P.T @ G_u, rtol=0, atol=1e-13 * np.abs(G_u).max())
    np.testing.assert_array_equal(g_a, G_a)

    K_uu, K_ua, K_aa = model.hessian_blocks(u, alpha, t)
    F_uu, F_ua, F_aa = full.hessian_blocks(u, alpha, t)
    # K_uu is the matrix solve_u factorizes, on the free orbits
    reduced = model.reduced_matrix(alpha)
    assert abs(K_uu - reduced[free_orbits][:, free_orbits]).max() == 0.0
    if clamped:
        # the clamped orbits are decoupled from the free ones in it (solve_u holds them at 0)
        clamped_orbits = np.setdiff1d(np.arange(sym.n_orbits), free_orbits)
        assert abs(reduced[clamped_orbits][:, free_orbits]).sum() == 0.0
    for mine, theirs in ((K_uu, P.T @ F_uu @ P), (K_ua, P.T @ F_ua)):
        assert abs(mine - theirs).max() <= 1e-13 * abs(theirs).max()
    assert abs(K_aa - F_aa).max() == 0.0
    A, b = model.damage_problem(u, t)
    assert abs(K_aa - A).max() == 0.0
    np.testing.assert_array_equal(g_a, A @ alpha - b)

    # the u-gradient vanishes at solve_u's displacement, which is the full model's minimizer
    u_star = model.solve_u(alpha, t, None, None)
    g_star, _ = model.energy_gradient(u_star, alpha, t)
    assert np.linalg.norm(g_star) < 1e-9 * np.linalg.norm(g_u)
    G_star, _ = full.energy_gradient(u_star, alpha, t)
    assert np.linalg.norm(G_star) < 1e-9 * np.linalg.norm(G_u)
    np.testing.assert_array_equal(model.u_from_free(model.free_u(u_star), t), u_star)


def test_a_symmetry_that_mixes_clamped_and_free_nodes_is_refused():
    # Built directly (a scene refuses it first): mirroring x would clamp x = 1 as well.
    grid = Grid.rectangle(-0.5, 0.5, 6, -0.5, 0.5, 6)
    w1 = np.zeros(grid.n_nodes)
    model = PlateModel(grid, 0.3, 40.0, 1e-6, 0.1, 0.05, 1, lambda t: t * w1, True, None, clamped=("x0",),
                       symmetry=GridSymmetry(grid, "mirror_x"))
    with pytest.raises(ValueError, match="not mapped onto themselves"):
        model.hessian_blocks(np.zeros(grid.n_nodes), np.zeros(grid.n_nodes), 0.1)
