"""The adaptive finite-element model (fem3d.adaptive): exact transfer of fields to the refined
mesh, energies of a transferred state, the marking rule and its damage-onset density, the
replay of a refinement, and the predictor-corrector evolution against its banded twin."""

from __future__ import annotations

import numpy as np
import pytest

from fem3d.adaptive import Transfer, mark, near_damage, onset_density, refine_pass
from fem3d.damage import P1Damage
from fem3d.refine import cell_sizes
from fem3d.scene import AdaptOptions
from tests.fem3d.meshes import small_mesh
from thinfilm.discretization import Refinement, prolong
from thinfilm.solvers.boxqp import solve_box_qp


def refined_chain(mesh, n, seed=0):
    """An adaptive model's refinement of ``mesh`` by ``n`` random passes, through
    :func:`fem3d.adaptive.refine_pass` (no model needed): ``(mesh, refinement)``."""
    rng = np.random.default_rng(seed)
    refinement = Refinement.initial(mesh.n_nodes)
    for _ in range(n):
        marked = np.sort(rng.choice(mesh.n_cells, size=max(1, mesh.n_cells // 5), replace=False))
        mesh, refinement, _ = refine_pass(mesh, refinement, marked)
    return mesh, refinement


@pytest.mark.parametrize("dim", [2, 3])
def test_transfer_is_exact_for_p1_fields(dim):
    """New vertices are midpoints: an affine field stays the same function, and any P1 field's
    values at the old vertices are kept bit for bit, its interpolant unchanged (checked at
    the new vertices against the coarse field evaluated there)."""
    first = small_mesh(dim)
    mesh, refinement = refined_chain(first, 4)
    transfer = Transfer(refinement, first.n_nodes, dim)
    A = np.arange(1.0, 1.0 + dim * dim).reshape(dim, dim) / 7.0
    affine = lambda x: x @ A.T + 0.3   # noqa: E731
    u = transfer.u(affine(first.points).ravel())
    np.testing.assert_allclose(u.reshape(-1, dim), affine(mesh.points), rtol=0, atol=1e-13)
    rng = np.random.default_rng(1)
    alpha0 = rng.random(first.n_nodes)
    alpha = transfer.alpha(alpha0)
    np.testing.assert_array_equal(alpha[: first.n_nodes], alpha0)
    assert np.all(alpha >= 0.0) and np.all(alpha <= 1.0)
    # bounds node by node: lower <= alpha before, so after
    lower0 = alpha0 * rng.random(first.n_nodes)
    assert np.all(transfer.alpha(lower0) <= alpha)
    # the transfer through two calls equals one call, bit for bit (what a resumed run does)
    middle, refinement_1 = refined_chain(first, 2)
    step = Transfer(refinement_1, first.n_nodes, dim).alpha(alpha0)
    np.testing.assert_array_equal(prolong(step, refinement, middle.n_nodes), alpha)


@pytest.mark.parametrize("dim", [2, 3])
def test_energies_of_a_transferred_state(dim):
    """The AT1 surface energy (the gradient term exact, the lumped linear term exact for P1)
    and the elastic energy of an undamaged state carry over to round-off; with damage the
    elastic energy changes, by the vertex quadrature of the degradation
    (docs/adaptivity.md#transfer)."""
    from fem3d.elasticity import Elasticity

    first = small_mesh(dim)
    mesh, refinement = refined_chain(first, 3)
    transfer = Transfer(refinement, first.n_nodes, dim)
    rng = np.random.default_rng(2)
    alpha0 = 0.5 * rng.random(first.n_nodes)
    u0 = rng.standard_normal(first.n_nodes * dim) * 1e-3
    coarse, fine = (P1Damage(m, 1.3, 0.2, at=1) for m in (first, mesh))
    assert fine.surface_energy(transfer.alpha(alpha0)) == pytest.approx(coarse.surface_energy(alpha0), rel=1e-12)
    el = [Elasticity(m, 10.0, 0.25, constrained=np.array([0])) for m in (first, mesh)]
    zero = (np.zeros(first.n_nodes), np.zeros(mesh.n_nodes))
    assert el[1].elastic_energy(transfer.u(u0), zero[1]) == pytest.approx(el[0].elastic_energy(u0, zero[0]),
                                                                         rel=1e-12)
    damaged = el[1].elastic_energy(transfer.u(u0), transfer.alpha(alpha0)), el[0].elastic_energy(u0, alpha0)
    assert damaged[0] != pytest.approx(damaged[1], rel=1e-12)   # the vertex rule of g is not exact


@pytest.mark.parametrize("at", [1, 2])
def test_onset_density_of_the_homogeneous_bar(at):
    """AT1: a uniform density below :func:`onset_density` leaves the damage at 0, above it
    damages. AT2: the homogeneous stress (1 - alpha(psi))^2 sqrt(2 E psi) peaks there."""
    Gc, eps = 0.8, 0.1
    psi_c = onset_density(at, Gc, eps)
    if at == 1:
        mesh = small_mesh(2, jitter=0.0)
        op = P1Damage(mesh, Gc, eps, at=1)
        for factor, damaged in ((0.98, False), (1.02, True)):
            # the nodal energy of a uniform density psi: e = 2 psi omega (model.damage_problem)
            A, b = op.problem(2.0 * factor * psi_c * op.omega)
            a = solve_box_qp(A, b, np.zeros(mesh.n_nodes), 1.0, rtol=1e-12).a
            assert (a.max() > 1e-8) == damaged
    else:
        # homogeneous AT2: alpha = psi / (psi + Gc / (2 eps)); stress ~ (1 - alpha)^2 sqrt(psi)
        psi = np.linspace(0.2, 3.0, 200001) * psi_c
        stress = (Gc / (2 * eps) / (psi + Gc / (2 * eps))) ** 2 * np.sqrt(psi)
        assert psi[np.argmax(stress)] == pytest.approx(psi_c, rel=1e-4)


def test_marking_rule():
    options = AdaptOptions(h_min=0.1, h_max=1.0, alpha=0.05, energy=0.5, buffer=0.0)
    sizes = np.array([1.0, 1.0, 0.1, 1.0, 1.0, 0.5])
    alpha = np.array([0.06, 0.0, 0.9, 0.0, 0.9, 0.0])
    density = np.array([0.0, 0.3, 9.0, 0.03, 0.0, 0.6])
    damageable = np.array([True, True, True, True, False, True])
    onset, eps = 1.0, 0.5
    # 0: damaged; 1: 0.3 x (1 / 0.5) >= 0.5; 2: at h_min; 3: 0.03 x 2 < 0.5; 4: held; 5: 0.6 x 1
    np.testing.assert_array_equal(mark(sizes, alpha, density, damageable, options, onset, eps),
                                  [True, True, False, False, False, True])


def test_near_damage():
    mesh = small_mesh(2, jitter=0.0)
    alpha = np.zeros(mesh.n_nodes)
    alpha[0] = 1.0
    buffer = 0.3
    near = near_damage(mesh.points, mesh.cells, alpha, 0.5, buffer)
    centroids = mesh.points[mesh.cells].mean(axis=1)
    distance = np.linalg.norm(centroids - mesh.points[0], axis=1)
    np.testing.assert_array_equal(near, distance <= buffer + cell_sizes(mesh.points, mesh.cells))
    assert not near_damage(mesh.points, mesh.cells, alpha, 1.5, buffer).any()


def test_transfer_when_a_pass_halves_an_edge_it_made():
    """A bisection can cut an edge made earlier in the same pass (a child whose longest edge
    is new): the new vertex's parent is then a vertex of that pass, and the transfer must
    compute it after its parent (a per-pass vectorized sum would read it unset)."""
    from tests.fem3d.meshes import tri_mesh

    mesh = tri_mesh(5, 5, jitter=0.45, seed=2)
    rng = np.random.default_rng(2)
    refinement = Refinement.initial(mesh.n_nodes)
    first = mesh
    for _ in range(4):
        marked = np.sort(rng.choice(mesh.n_cells, size=max(1, mesh.n_cells // 3), replace=False))
        mesh, refinement, _ = refine_pass(mesh, refinement, marked)
    new = refinement.parents[first.n_nodes:]
    own = np.arange(first.n_nodes, mesh.n_nodes)
    passes = np.searchsorted(refinement.pass_nodes, own, side="right")
    assert np.any(new.max(axis=1) >= refinement.pass_nodes[passes - 1])   # the case occurs here
    affine = 2.0 * first.points[:, 0] - 0.7 * first.points[:, 1] + 0.1
    np.testing.assert_allclose(prolong(affine, refinement, first.n_nodes),
                               2.0 * mesh.points[:, 0] - 0.7 * mesh.points[:, 1] + 0.1, rtol=0, atol=1e-14)
