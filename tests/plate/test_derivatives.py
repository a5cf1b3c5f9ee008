"""PlateModel's EnergyDerivatives hook (thinfilm/plate/derivatives.py) against finite
differences: 1D and 2D grids, free and clamped edges, AT1 and AT2, an imperfect film."""

from __future__ import annotations

import numpy as np
import pytest

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


def test_a_symmetric_film_refuses():
    grid = Grid.rectangle(-0.5, 0.5, 6, -0.5, 0.5, 6)
    w1 = np.zeros(grid.n_nodes)
    model = PlateModel(grid, 0.3, 40.0, 1e-6, 0.1, 0.05, 1, lambda t: t * w1, True, None,
                       symmetry=GridSymmetry(grid, "d2"))
    with pytest.raises(NotImplementedError, match="symmetric"):
        model.hessian_blocks(np.zeros(grid.n_nodes), np.zeros(grid.n_nodes), 0.1)
