"""Energies of the discrete thin-film model and the quadratic alpha-problem.

The discrete energy ``E_h(u, alpha) = P_h(u, alpha, w) + S_h(alpha)`` is defined in
:mod:`thinfilm.plate.operators` (formulas at interior nodes, free and clamped edges, corners).
These functions evaluate it; they take the operator objects of that module, which hold the
grid, the parameters and the boundary conditions.

Units: non-dimensional (``docs/model.md#continuous-energy``); lengths in units of L, energies per the scaling of (2.14).
Values of ``u`` on clamped nodes are ignored (taken as 0).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from thinfilm.plate.kernels import stencil as kernels

__all__ = [
    "elastic_energies",
    "elastic_energy",
    "bending_density",
    "surface_energy",
    "total_energy",
    "load_force",
    "nodal_energy",
    "damage_problem",
    "damage_problem_constant",
]


def elastic_energies(plate, u, alpha, w) -> tuple[float, float]:
    """Bending and foundation energies ``(1/2 Int g W(D^2 u), winkler/2 Int (u - w)^2)``.

    Parameters
    ----------
    plate : PlateOperator
    u, alpha, w : ndarray, shape (n_nodes,)
        Displacement, damage, substrate displacement ``w_t`` at the nodes.

    Returns
    -------
    bending, foundation : float
    """
    grid = plate.grid
    u = grid.nodal("u", u)
    w = grid.nodal("w", w)
    g = plate.degradation(alpha)
    bending, foundation = kernels.plate_energy(
        u, g, w, grid.nx, grid.ny, grid.hx, grid.hy, plate.nu, plate.winkler, plate.clamped_flags
    )
    return float(bending), float(foundation)


def elastic_energy(plate, u, alpha, w) -> float:
    """Elastic energy ``P_h(u, alpha, w)`` = bending + foundation (see :func:`elastic_energies`)."""
    bending, foundation = elastic_energies(plate, u, alpha, w)
    return bending + foundation


def bending_density(plate, u) -> np.ndarray:
    """Lumped undamaged bending energy ``e`` at the nodes, shape ``(n_nodes,)``.

    ``e_n = omega_n Q_n + 1/4 sum_{cells c around n} hx hy 2 (1 - nu) d_c^2`` (weights included,
    so ``e`` is an energy, not a density), such that the bending energy at any damage is
    ``1/2 sum_n g(alpha_n) e_n``. This is the diagonal of the alpha-problem.
    """
    grid = plate.grid
    u = grid.nodal("u", u)
    e = np.empty(grid.n_nodes, dtype=np.float64)
    kernels.bending_density(u, grid.nx, grid.ny, grid.hx, grid.hy, plate.nu, plate.clamped_flags, e)
    return e


def surface_energy(damage, alpha) -> float:
    """Ambrosio-Tortorelli surface energy ``S_h(alpha)``.

    ``docs/model.md#the-discrete-damage-problem`` on the grid's node weights and edge
    Laplacian (:mod:`thinfilm.plate.operators`): for a uniform film by the grid's stencil
    kernel, which needs no matrix product; for a film of varying toughness (each node's local
    term takes its factor, each edge's gradient term the mean of its nodes') as the sum of
    :meth:`thinfilm.damage.DamageOperator.surface_density`, so that :func:`nodal_energy`
    sums to it.
    """
    grid = damage.grid
    alpha = grid.nodal("alpha", alpha)
    if damage.toughness_factor is None:
        return float(
            kernels.surface_energy(alpha, grid.nx, grid.ny, grid.hx, grid.hy, damage.eta, damage.toughness, damage.at)
        )
    # A film of varying toughness: the same sums with the factor in each term.
    return float(damage.surface_density(alpha).sum())


def total_energy(plate, damage, u, alpha, w) -> float:
    """``E_h(u, alpha) = P_h(u, alpha, w) + S_h(alpha)``."""
    return elastic_energy(plate, u, alpha, w) + surface_energy(damage, alpha)


def load_force(plate, u, w, dw) -> float:
    """The force conjugate to the load parameter: ``dE_h/dt`` at fixed ``u`` and ``alpha``.

    Only the foundation term depends on ``t`` (through ``w = w_t``), so

        F_t = dE_h/dt = -winkler sum_n omega_n (u_n - w_n) dw_n/dt,

    the foundation's traction ``winkler (u - w)`` on the substrate times the substrate's
    velocity, summed over the grid with the node weights (clamped nodes count with ``u = 0``,
    as in the energy). At a minimizer ``u`` it is also the derivative of the minimized energy
    at fixed ``alpha`` (envelope theorem), so that ``F_t dt`` is the work the load does on the
    film: positive when loading stores energy.

    Parameters
    ----------
    plate : PlateOperator
    u, w, dw : ndarray, shape (n_nodes,)
        Displacement, substrate displacement ``w_t`` and its rate ``dw_t/dt`` at the nodes.

    Returns
    -------
    float
        Non-dimensional energy per unit of ``t``.
    """
    grid = plate.grid
    u = np.array(grid.nodal("u", u))
    u[plate.clamped_nodes] = 0.0  # the energy ignores stored values there
    traction = plate.winkler * grid.weights * (u - grid.nodal("w", w))
    return 0.0 - float(traction @ grid.nodal("w", dw))  # 0.0 -: no -0.0 at t = 0


def nodal_energy(plate, damage, u, alpha, w) -> np.ndarray:
    """The total energy ``E_h(u, alpha)`` split over the nodes, shape ``(n_nodes,)``.

    Node ``n`` takes ``1/2 g_n e_n`` (its lumped bending energy, twist shared by the four
    cells around it, see :func:`bending_density`), its foundation term
    ``winkler/2 omega_n (u_n - w_n)^2`` and its surface terms
    (:meth:`thinfilm.damage.DamageOperator.surface_density`, with the toughness factors of an
    imperfect film). The entries sum to
    :func:`total_energy` (to round-off); summed over a region they give the energy there,
    exact up to the stencils that straddle its boundary.

    Parameters
    ----------
    plate : PlateOperator
    damage : thinfilm.plate.operators.GridDamage
    u, alpha, w : ndarray, shape (n_nodes,)
        Displacement, damage and substrate displacement ``w_t`` at the nodes.
    """
    grid = plate.grid
    u = np.array(grid.nodal("u", u))
    u[plate.clamped_nodes] = 0.0  # the energy ignores stored values there
    alpha = grid.nodal("alpha", alpha)
    w = grid.nodal("w", w)
    foundation = 0.5 * plate.winkler * grid.weights * (u - w) ** 2
    return 0.5 * plate.degradation(alpha) * bending_density(plate, u) + foundation + damage.surface_density(alpha)


def damage_problem(plate, damage, u) -> tuple[sp.csr_matrix, np.ndarray]:
    """The alpha-problem at fixed ``u``: ``(A, b)`` with
    ``E_h(u, alpha) = 1/2 alpha.A.alpha - b.alpha + const`` for every ``alpha``.

    :meth:`thinfilm.damage.DamageOperator.problem` for the nodal energy ``e`` of
    :func:`bending_density` (``docs/model.md#the-discrete-damage-problem``).
    The bound constraints (irreversibility, ``alpha <= 1``) are the damage solver's.

    Returns
    -------
    A : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
        Owned by ``damage``; its diagonal is rewritten in place by the next call.
    b : ndarray, shape (n_nodes,)
    """
    return damage.problem(bending_density(plate, u))


def damage_problem_constant(plate, u, w) -> float:
    """The ``const`` of :func:`damage_problem`: ``1/2 (1 + k_res) sum_n e_n`` + foundation."""
    grid = plate.grid
    e = bending_density(plate, u)
    _, foundation = elastic_energies(plate, u, np.zeros(grid.n_nodes), w)
    return 0.5 * (1.0 + plate.k_res) * float(np.sum(e)) + foundation
