"""The shared damage operator (:mod:`thinfilm.damage`) on its own: ``A`` and ``b`` against the
energy and its finite differences on an arbitrary graph Laplacian, fixed nodes, thickness,
the nodal split of the surface energy, the argument checks, and the 1D optimal profiles of
AT1 and AT2, whose discrete surface energies have closed forms that tend to the toughness at
second order.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.damage import DamageOperator, c_m
from thinfilm.solvers.boxqp import solve_box_qp


def graph_laplacian(n, seed=0):
    """A random weighted graph Laplacian on ``n`` nodes (a path plus random chords, positive
    weights), sorted CSR, and random positive nodal measures."""
    rng = np.random.default_rng(seed)
    pairs = [(i, i + 1) for i in range(n - 1)] + [tuple(sorted(rng.choice(n, 2, replace=False))) for _ in range(n)]
    i, j = np.array(sorted(set(pairs))).T
    w = rng.uniform(0.5, 2.0, i.size)
    off = sp.coo_matrix((np.concatenate([-w, -w]), (np.concatenate([i, j]), np.concatenate([j, i]))), shape=(n, n))
    L = (off - sp.diags(np.asarray(off.sum(axis=1)).ravel())).tocsr()
    L.sort_indices()
    return L, rng.uniform(0.2, 1.0, n)


def energy(alpha, e, L, omega, toughness, eta, at, T, k_res=1e-3):
    """The total energy at fixed displacement, ``1/2 sum g(alpha) e + S_h(alpha)``, term by term."""
    g = (1.0 - alpha) ** 2 + k_res
    cs = toughness / (4.0 * (2.0 / 3.0 if at == 1 else 0.5))
    return 0.5 * g @ e + cs * T * (omega @ alpha**at / eta + eta * alpha @ (L @ alpha))


def test_normalization():
    assert c_m(1) == 2.0 / 3.0 and c_m(2) == 0.5
    for at in (0, 3, True, 1.5):
        with pytest.raises(ValueError, match="at"):
            c_m(at)


@pytest.mark.parametrize("T", [1.0, 0.35])
@pytest.mark.parametrize("at", [1, 2])
def test_problem_is_the_energy_and_its_derivatives(at, T):
    """``E(a) = 1/2 a.A.a - b.a + const``; ``A a - b`` and ``A`` are the gradient and Hessian of
    the energy by central differences (exact up to round-off: the energy is quadratic)."""
    n, toughness, eta = 30, 1.7, 0.23
    L, omega = graph_laplacian(n)
    rng = np.random.default_rng(1)
    e = rng.uniform(0.0, 3.0, n)
    op = DamageOperator(L, omega, toughness, eta, at=at, thickness=T)
    A, b = op.problem(e)
    const = energy(np.zeros(n), e, L, omega, toughness, eta, at, T)
    assert abs(A - A.T).max() == 0.0 and A.has_sorted_indices
    for _ in range(3):
        a = rng.random(n)
        E = energy(a, e, L, omega, toughness, eta, at, T)
        assert 0.5 * a @ (A @ a) - b @ a + const == pytest.approx(E, rel=1e-13)
        assert op.surface_energy(a) == pytest.approx(energy(a, 0 * e, L, omega, toughness, eta, at, T), rel=1e-13)
        assert op.surface_density(a).sum() == pytest.approx(op.surface_energy(a), rel=1e-13)
        h = 1e-4
        basis = np.eye(n)
        grad = np.array([(energy(a + h * v, e, L, omega, toughness, eta, at, T)
                          - energy(a - h * v, e, L, omega, toughness, eta, at, T)) / (2 * h) for v in basis])
        np.testing.assert_allclose(A @ a - b, grad, rtol=0, atol=1e-8 * np.abs(grad).max())
    hess = np.array([[(energy(h * (u + v), e, L, omega, toughness, eta, at, T)
                       - energy(h * (u - v), e, L, omega, toughness, eta, at, T)
                       - energy(h * (v - u), e, L, omega, toughness, eta, at, T)
                       + energy(-h * (u + v), e, L, omega, toughness, eta, at, T)) / (4 * h * h)
                      for v in basis] for u in basis])
    np.testing.assert_allclose(A.toarray(), hess, rtol=0, atol=1e-6 * np.abs(hess).max())
    # only the diagonal depends on e, rewritten in place
    A1 = A.copy()
    A2, b2 = op.problem(2.0 * e)
    assert A2 is A
    np.testing.assert_allclose((A2 - A1).toarray(), np.diag(e), rtol=0, atol=1e-15 * np.abs(e).max())
    np.testing.assert_allclose(b2 - b, e, rtol=0, atol=1e-15 * np.abs(e).max())


@pytest.mark.parametrize("at", [1, 2])
def test_fixed_nodes_are_decoupled(at):
    """Fixed rows and columns hold only ``A_ii = 1`` (``b_i = -1``); for damage that is 0 there
    the quadratic form is the energy's change; the bounded minimizer is 0 there."""
    n, T = 40, 2.5
    L, omega = graph_laplacian(n, seed=3)
    fixed = np.arange(1, n, 3)
    rng = np.random.default_rng(4)
    e = rng.uniform(20.0, 40.0, n)  # damage everywhere it may
    op = DamageOperator(L, omega, 1.1, 0.3, at=at, thickness=T, fixed_nodes=fixed)
    A, b = op.problem(e)
    for i in fixed:
        row = A.getrow(i)
        assert row.nnz == 1 and row.indices[0] == i and row.data[0] == 1.0 and A.getcol(i).nnz == 1
    np.testing.assert_array_equal(b[fixed], -1.0)
    assert A.has_sorted_indices and abs(A - A.T).max() == 0.0
    zero = np.zeros(n)
    for _ in range(3):
        a = rng.random(n)
        a[fixed] = 0.0
        change = energy(a, e, L, omega, 1.1, 0.3, at, T) - energy(zero, e, L, omega, 1.1, 0.3, at, T)
        assert 0.5 * a @ (A @ a) - b @ a == pytest.approx(change, rel=1e-12)
    res = solve_box_qp(A, b, lower=0.0, upper=1.0, rtol=1e-12)
    assert np.all(res.a[fixed] == 0.0)
    assert np.all(res.a[np.setdiff1d(np.arange(n), fixed)] > 0.0)
    assert op.fixed_nodes.tolist() == fixed.tolist() and not op.fixed_nodes.flags.writeable


def test_argument_checks():
    L, omega = graph_laplacian(6)
    with pytest.raises(ValueError, match="CSR"):
        DamageOperator(L.tocsc(), omega, 1.0, 0.1)
    unsorted = sp.csr_matrix((L.data[::-1].copy(), L.indices[::-1].copy(), L.indptr), shape=L.shape)
    unsorted.has_sorted_indices = False
    with pytest.raises(ValueError, match="sorted"):
        DamageOperator(unsorted, omega, 1.0, 0.1)
    no_diagonal = sp.csr_matrix(L - sp.diags(L.diagonal()))
    no_diagonal.eliminate_zeros()
    with pytest.raises(ValueError, match="diagonal"):
        DamageOperator(no_diagonal, omega, 1.0, 0.1)
    with pytest.raises(ValueError, match="omega"):
        DamageOperator(L, -omega, 1.0, 0.1)
    with pytest.raises(ValueError, match="omega"):
        DamageOperator(L, omega[:-1], 1.0, 0.1)
    for kwargs, key in [({"toughness": 0.0}, "toughness"), ({"eta": -1.0}, "eta"), ({"thickness": 0.0}, "thickness"),
                        ({"at": 3}, "at"), ({"fixed_nodes": [3, 1]}, "sorted"), ({"fixed_nodes": [6]}, "outside")]:
        args = {"toughness": 1.0, "eta": 0.1} | kwargs
        with pytest.raises(ValueError, match=key):
            DamageOperator(L, omega, **args)
    op = DamageOperator(L, omega, 1.0, 0.1)
    with pytest.raises(ValueError, match="e has shape"):
        op.problem(np.zeros(5))
    with pytest.raises(ValueError, match="alpha has shape"):
        op.surface_energy(np.zeros(7))
    assert op.n_nodes == 6 and op.fixed_nodes.size == 0 and not op.omega.flags.writeable


def profile_energy(at, ratio, eta=0.1, toughness=1.3, half_width=None):
    """The surface energy over the toughness of the optimal discrete profile across a crack
    point at x = 0 on a uniform 1D grid of spacing ``h = eta / ratio`` (``alpha = 1`` held at
    x = 0, no elastic energy), its damage and its nodes."""
    half_width = half_width or (4.0 if at == 1 else 16.0) * eta
    h = eta / ratio
    n = 2 * int(round(half_width / h)) + 1
    x = np.linspace(-half_width, half_width, n)
    stencil = sp.diags([-np.ones(n - 1), np.r_[1.0, 2.0 * np.ones(n - 2), 1.0], -np.ones(n - 1)], [-1, 0, 1]) / h
    L = sp.csr_matrix(stencil)
    L.sort_indices()
    omega = np.full(n, h)
    omega[[0, -1]] = h / 2
    op = DamageOperator(L, omega, toughness, eta, at=at)
    A, b = op.problem(np.zeros(n))
    crack = np.abs(x) < 1e-9 * h
    if at == 1:
        a = solve_box_qp(A, b, lower=np.where(crack, 1.0, 0.0), upper=1.0, rtol=1e-12).a
    else:  # no bound is active off the crack (the profile is positive): one linear solve
        free = ~crack
        a = np.ones(n)
        a[free] = spla.spsolve(A[free][:, free].tocsc(), b[free] - A[free][:, crack] @ a[crack])
    return op.surface_energy(a) / toughness, a, x


@pytest.mark.parametrize("at", [1, 2])
def test_optimal_profile_costs_the_toughness(at):
    """The discrete 1D minimizer with ``alpha(0) = 1`` costs ``Gc (1 + O(h^2))``.

    AT1 (``N = 2 eta / h`` an integer): the sampled profile ``(1 - |x| / (2 eta))^2`` is the
    discrete minimizer (its second difference ``h^2 / (2 eta^2)`` balances the local term on
    the free nodes, where it is positive) and ``S / Gc = 1 + h^2 / (32 eta^2)``.
    AT2 (an unbounded line): the minimizer is ``r^|k|`` at node ``k``,
    ``r + 1/r = 2 + h^2 / eta^2``, and ``S / Gc = sqrt(1 + h^2 / (4 eta^2))``, from
    ``S = cs (A a)_0`` (``A a = 0`` on the free nodes). The domain, 16 eta on each side, cuts
    the tail at ``exp(-16)``: the closed form holds to 1e-12.
    Both fall at order 2 in ``h``, with constants 1/32 and 1/8."""
    ratios = np.array([2.5, 5.0, 10.0, 20.0])  # eta / h
    excess = []
    for r in ratios:
        ratio_energy, a, x = profile_energy(at, r)
        q = 1.0 / r  # h / eta
        closed = 1.0 + q * q / 32.0 if at == 1 else math.sqrt(1.0 + q * q / 4.0)
        assert ratio_energy == pytest.approx(closed, rel=1e-11, abs=0)
        if at == 1:
            d = np.abs(x) / 0.1
            np.testing.assert_allclose(a, np.where(d < 2.0, (1.0 - d / 2.0) ** 2, 0.0), atol=1e-10)
        else:
            rr = 1.0 + q * q / 2.0 - math.sqrt(q * q + q**4 / 4.0)
            k = np.rint(np.abs(x) * r / 0.1)
            np.testing.assert_allclose(a, rr**k, rtol=0, atol=1e-6)  # the cut tail: exp(-16)
        excess.append(ratio_energy - 1.0)
    h = 1.0 / ratios
    order, log_constant = np.polyfit(np.log(h), np.log(excess), 1)
    assert order == pytest.approx(2.0, abs=0.02)
    assert math.exp(log_constant) == pytest.approx(1.0 / 32.0 if at == 1 else 1.0 / 8.0, rel=0.02)
    # on the finest grid the profile costs the toughness within 1e-4 (AT1) or 4e-4 (AT2)
    assert abs(excess[-1]) < (1e-4 if at == 1 else 4e-4)
