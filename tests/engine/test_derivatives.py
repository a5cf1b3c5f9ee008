"""The 1D bar's EnergyDerivatives hook (examples/bar/model.py) against finite differences."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from examples.bar.model import Bar
from tests.derivatives_check import check_energy_derivatives, interior_damage


def test_bar_gradient_and_hessian_blocks_match_finite_differences():
    bar = Bar(n=20, E=2.0, Gc=1.5, ell=0.1)
    rng = np.random.default_rng(3)
    t = 0.7
    u = bar.u_from_free(t * bar.x[1:-1] + 0.05 * rng.standard_normal(bar.n - 1), t)
    alpha = interior_damage(rng, bar.n_alpha)
    check_energy_derivatives(bar, u, alpha, t)


def test_bar_blocks_are_the_u_and_damage_problems():
    bar = Bar(n=20)
    rng = np.random.default_rng(4)
    t = 0.4
    alpha = interior_damage(rng, bar.n_alpha)
    u = bar.solve_u(alpha, t)
    K_uu, K_ua, K_aa = bar.hessian_blocks(u, alpha, t)
    A, b = bar.damage_problem(u, t)
    assert (K_aa != A).nnz == 0
    g_u, g_a = bar.energy_gradient(u, alpha, t)
    np.testing.assert_array_equal(g_a, A @ alpha - b)
    # K_uu is the matrix solve_u solves: Newton's step from u_free = 0 lands on its solution
    r0, _ = bar.energy_gradient(bar.u_from_free(np.zeros(bar.n - 1), t), alpha, t)
    np.testing.assert_allclose(bar.u_from_free(spla.spsolve(K_uu.tocsc(), -r0), t), u, rtol=1e-12, atol=1e-14)
    assert np.linalg.norm(g_u) < 1e-9 * np.linalg.norm(r0)
    assert sp.issparse(K_ua) and K_ua.shape == (bar.n - 1, bar.n + 1)
