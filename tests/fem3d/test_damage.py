"""The AT damage operator on P1 (:mod:`fem3d.damage` on :mod:`thinfilm.damage`): the Laplacian
and lumped measure against scikit-fem, the damage problem against a direct evaluation of the
energy, fixed nodes, the AT1 onset stress, and the surface energy of a crack against its
closed form on structured meshes.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import skfem
from skfem.models.poisson import laplace, mass

from fem3d import kernels
from fem3d.damage import P1Damage
from fem3d.elasticity import Elasticity
from tests.fem3d.checks import fitted_order, rel_diff
from tests.fem3d.meshes import small_mesh, to_skfem, tri_mesh
from tests.fem3d.solves import solve
from thinfilm.solvers.boxqp import solve_box_qp

E, NU = 3.0, 0.3


@pytest.mark.parametrize("dim", [2, 3])
def test_laplacian_and_lumped_measure(dim):
    """``L`` is scikit-fem's P1 Laplacian, ``omega`` the row sums of its P1 mass matrix; the
    kernels agree with their references."""
    mesh = small_mesh(dim)
    op = P1Damage(mesh, 1.0, 0.1)
    basis = skfem.Basis(to_skfem(mesh), skfem.ElementTriP1() if dim == 2 else skfem.ElementTetP1())
    assert rel_diff(op.L, skfem.asm(laplace, basis)) < 1e-12
    np.testing.assert_allclose(op.omega, np.asarray(skfem.asm(mass, basis).sum(axis=1)).ravel(), rtol=1e-13)
    grads, measure = kernels.cell_geometry(mesh.points, mesh.cells)
    assert rel_diff(op.L, kernels.laplacian_reference(grads, measure, mesh.cells, mesh.n_nodes)) < 1e-14
    np.testing.assert_allclose(op.omega, kernels.lumped_measure_reference(measure, mesh.cells, mesh.n_nodes),
                               rtol=1e-14)
    assert op.L.has_sorted_indices and abs(op.L - op.L.T).max() == 0.0
    assert np.abs(op.L @ np.ones(mesh.n_nodes)).max() < 1e-13 * abs(op.L).max()


@pytest.mark.parametrize("at", [1, 2])
@pytest.mark.parametrize("dim", [2, 3])
def test_problem_is_the_energy(dim, at):
    """``E(u, a) - E(u, 0) = 1/2 a.A.a - b.a`` for random ``u`` and ``a`` (0 on the fixed
    nodes), with ``E = P + S`` evaluated directly; the bulk part is ``sum_i c_i g(a_i)``."""
    mesh = small_mesh(dim)
    T = 1.6 if dim == 2 else 1.0
    rng = np.random.default_rng(7)
    fixed = np.sort(rng.choice(mesh.n_nodes, size=mesh.n_nodes // 5, replace=False))
    el = Elasticity(mesh, E, NU, thickness=T, k_res=1e-3)
    op = P1Damage(mesh, 0.7, 0.15, at=at, thickness=T, fixed_nodes=fixed)
    u = rng.standard_normal(el.n_dofs)
    c = el.nodal_energy(u)
    A, b = op.problem(2.0 * c)  # the damage problem's nodal energy e = 2 c

    def energy(a):
        return el.elastic_energy(u, a) + op.surface_energy(a)

    zero = np.zeros(mesh.n_nodes)
    for _ in range(3):
        a = rng.random(mesh.n_nodes)
        a[fixed] = 0.0
        assert energy(a) - energy(zero) == pytest.approx(0.5 * a @ (A @ a) - b @ a, rel=1e-12)
        assert el.elastic_energy(u, a) == pytest.approx(c @ ((1.0 - a) ** 2 + el.k_res), rel=1e-13)
    # the surface energy's closed form pieces
    a = rng.random(mesh.n_nodes)
    cs = 0.7 / (4.0 * (2.0 / 3.0 if at == 1 else 0.5))
    assert op.surface_energy(a) == pytest.approx(cs * T * (op.omega @ a**at / 0.15 + 0.15 * a @ (op.L @ a)), rel=1e-14)
    # the same object, rewritten, at the next call
    A2, _ = op.problem(2.0 * c)
    assert A2 is A


def test_fixed_nodes_are_decoupled_and_held_at_zero():
    mesh = small_mesh(2)
    fixed = np.arange(0, mesh.n_nodes, 4)
    op = P1Damage(mesh, 1.0, 0.2, fixed_nodes=fixed)
    c = np.full(mesh.n_nodes, 50.0)  # far above the damage threshold everywhere
    A, b = op.problem(2.0 * c)
    for i in fixed:
        row = A.getrow(i)
        assert row.nnz == 1 and row.indices[0] == i and row.data[0] == 1.0
        assert A.getcol(i).nnz == 1
    np.testing.assert_array_equal(b[fixed], -1.0)
    assert A.has_sorted_indices and abs(A - A.T).max() == 0.0
    res = solve_box_qp(A, b, lower=0.0, upper=1.0)
    assert np.all(res.a[fixed] == 0.0)
    free = np.setdiff1d(np.arange(mesh.n_nodes), fixed)
    assert np.all(res.a[free] > 0.0)
    with pytest.raises(ValueError, match="sorted"):
        P1Damage(mesh, 1.0, 0.2, fixed_nodes=fixed[::-1])
    with pytest.raises(ValueError, match="at"):
        P1Damage(mesh, 1.0, 0.2, at=3)


@pytest.mark.parametrize("k_res", [0.0, 1e-2])
def test_at1_onset_stress(k_res):
    """A strip in homogeneous uniaxial stress (plane stress), AT1: damage stays 0 below
    ``sigma_c = sqrt(3 Gc E / (8 eps))`` and is ``1 - (sigma_c/sigma)^2`` everywhere above.

    Exact on any mesh: P1 holds the uniform strain exactly, so ``psi`` is the same in every
    cell and ``c_i = T psi omega_i``; the AT1 local term is ``(3 Gc T / (8 eps)) omega_i``, so
    ``b = 2 c - (3 Gc T / (8 eps)) omega = T (2 psi - 3 Gc / (8 eps)) omega`` has one sign at
    every node, and ``L 1 = 0`` makes the uniform field ``a = 1 - 3 Gc / (16 eps psi)`` solve
    ``A a = b``. ``g'(0) = -2`` whatever
    ``k_res``: the threshold does not depend on it."""
    lx, ly, T, Gc, eps = 4.0, 1.0, 0.5, 0.8, 0.15
    mesh = tri_mesh(16, 5, lx, ly, jitter=0.3)
    left = np.flatnonzero(mesh.points[:, 0] == 0.0)
    right = np.flatnonzero(mesh.points[:, 0] == lx)
    con = np.unique(np.concatenate([left * 2, right * 2, [1]]))  # node 0 = (0, 0) held in y
    el = Elasticity(mesh, E, NU, plane="stress", thickness=T, k_res=k_res, constrained=con)
    op = P1Damage(mesh, Gc, eps, at=1, thickness=T)
    sigma_c = math.sqrt(3.0 * Gc * E / (8.0 * eps))
    for s in (1.0 - 1e-3, 1.0 + 1e-3):
        delta = s * sigma_c / E * lx  # undamaged stress C e = s sigma_c (g(0) = 1 + k_res scales neither psi nor c)
        u = solve(el, np.zeros(mesh.n_nodes), np.where(np.isin(con, right * 2), delta, 0.0))
        np.testing.assert_allclose(el.stress(u)[:, 0], s * sigma_c, rtol=1e-10)
        A, b = op.problem(2.0 * el.nodal_energy(u))
        a = solve_box_qp(A, b, lower=0.0, upper=1.0, rtol=1e-12).a
        if s < 1:
            assert np.all(a == 0.0)
        else:
            np.testing.assert_allclose(a, 1.0 - 1.0 / s**2, rtol=1e-8)


def crack_excess(ratio, lines, eps=0.1, H=0.3, T=2.0, Gc=1.3):
    """``S / (Gc T H) - 1`` for AT1 with ``c = 0`` and ``alpha = 1`` held on ``lines`` adjacent
    vertical lines of nodes (the first at x = 0) across a strip ``[-4 eps, 4 eps] x [0, H]``
    of cell size ``h = eps / ratio``."""
    h = eps / ratio
    nx = int(round(8 * ratio))
    mesh = tri_mesh(nx, 3, 8 * eps, H, x0=-4 * eps)
    op = P1Damage(mesh, Gc, eps, at=1, thickness=T)
    A, b = op.problem(np.zeros(mesh.n_nodes))
    x = mesh.points[:, 0]
    crack = np.zeros(mesh.n_nodes, dtype=bool)
    for k in range(lines):
        crack |= np.abs(x - k * h) < 1e-9 * h
    lower = np.where(crack, 1.0, 0.0)
    res = solve_box_qp(A, b, lower=lower, upper=1.0, rtol=1e-12)
    return op.surface_energy(res.a) / (Gc * T * H) - 1.0, res.a, x


@pytest.mark.parametrize("lines", [1, 2], ids=["one-line", "one-element-band"])
def test_crack_surface_energy(lines):
    """The surface energy of a straight crack along a mesh line tends to ``Gc T length``.

    On these meshes (every interior node in six right triangles) ``L`` is the 5-point
    Laplacian and ``omega`` the trapezoidal weights, so for a field constant in y the problem is
    the 1D lumped P1 one. With ``N = 2 eps / h`` an integer, the sampled optimal profile
    ``(1 - |x|/(2 eps))^2`` satisfies its KKT conditions exactly (second difference
    ``h^2 / (2 eps^2)`` on the free nodes, positive gradient where it reaches 0), and summing
    it gives ``S / (Gc T H) = 1 + h^2 / (32 eps^2)``: order 2, constant 1/32, when the crack is
    one line of nodes. A crack that opens ``u`` needs ``alpha = 1`` on two adjacent lines (a
    band one element wide), which adds ``(3/8) h / eps`` (the band's share of
    ``Int alpha / eps``): ``1 + 3h/(8 eps) + h^2/(32 eps^2)``, the literature's first-order
    excess of AT1 on P1."""
    ratios = np.array([2.5, 5.0, 10.0])  # eps / h
    excess = []
    for r in ratios:
        ex, a, x = crack_excess(r, lines)
        excess.append(ex)
        h = 1.0 / r  # in units of eps
        closed = h**2 / 32.0 + (3.0 * h / 8.0 if lines == 2 else 0.0)
        assert ex == pytest.approx(closed, rel=1e-9)
        # the discrete minimizer is the sampled profile
        d = np.maximum(np.abs(x / 0.1 - (0.5 / r if lines == 2 else 0.0)) - (0.5 / r if lines == 2 else 0.0), 0.0)
        np.testing.assert_allclose(a, np.where(d < 2.0, (1.0 - d / 2.0) ** 2, 0.0), atol=1e-10)
    h = 1.0 / ratios
    closed = h**2 / 32.0 + (3.0 * h / 8.0 if lines == 2 else 0.0)
    order = fitted_order(h, np.array(excess))
    constant = float(np.exp(np.mean(np.log(excess) - order * np.log(h))))
    if lines == 1:
        assert order == pytest.approx(2.0, abs=1e-6) and constant == pytest.approx(1.0 / 32.0, rel=1e-6)
    else:
        # the fit of 3h/8 + h^2/32 over h/eps = 0.1-0.4: order 1 + (its local slope
        # 1 + h/(12 + h) at these h), constant a little above 3/8
        p_closed = fitted_order(h, closed)
        assert order == pytest.approx(p_closed, abs=1e-6) and 1.0 < order < 1.1
        assert constant == pytest.approx(float(np.exp(np.mean(np.log(closed) - p_closed * np.log(h)))), rel=1e-6)
        assert 3.0 / 8.0 < constant < 0.42
