r"""The second-order information of the finite-element energy: the cross block ``d2E/du dalpha``.

With the switch of a split frozen at ``u``'s own (:mod:`fem3d.split`), the elastic energy is

    P(u, alpha) = sum_e gbar_e(alpha) P_e^+(u) + P^-(u) - f(t).u,
    P_e^+(u) = 1/2 u_e.K_e^+.u_e = T |e| sum_q w_q psi_plus(e_q(u)),

``gbar_e = 1/(d+1) sum_{i in e} g(alpha_i)`` (:func:`fem3d.kernels.cell_degradation`),
``g(a) = (1 - a)^2 + k_res``, and ``K_e^+`` the stiffness of the degraded part at the cell's
quadrature points (``docs/model.md#second-order-information``). So

    d2P / du dalpha_i = sum_{e ni i} g'(alpha_i) / (d + 1) K_e^+ u_e,

``g'(a) = -2 (1 - a)`` (a law's own ``g'`` for the cohesive law). The cell forces ``F_e = K_e^+ u_e`` are
``F_e[k, a] = T |e| sum_q w_q sigma^+_q[a, b] G_qk[b]`` (``G_qk`` the gradient of local basis
function ``k`` at point ``q``, ``sigma^+ = lam^+ tr(e) I + 2 mu^+ e`` with the degraded part's
Lame parameters ``(lam^+, mu^+)``, the coefficient of ``gbar`` in
:func:`fem3d.split.effective_lame`), and the block is the sparse product ``R V diag(g')``:
``R`` (dofs x cells) holds the cell forces, ``V`` (cells x vertices) the means' weights
``1/(d+1)``. Without a split ``psi_plus`` is the whole density; with ``"amor"`` (4.11) or
``"positive"`` (4.12) the energy is piecewise quadratic in ``u`` and this is its Hessian away
from the switch surfaces (``tr e = 0`` at a point), where it is not defined.

NumPy and scipy.sparse, no Numba: the assembly is a few array passes and one sparse product
(0.5 s for P1 tetrahedra on 104k vertices, 0.3 s for P2 on 133k nodes, less than or about
the stiffness matrix's own assembly: docs/model.md#second-order-information).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from fem3d import split as splits

__all__ = ["cell_forces", "cross_block"]

# Voigt index of the tensor component (a, b), tensor shear components
_VOIGT = {2: np.array([[0, 2], [2, 1]]), 3: np.array([[0, 5, 4], [5, 1, 3], [4, 3, 2]])}


def cell_forces(elasticity, u, tension=None) -> np.ndarray:
    """The forces ``F_e = K_e^+ u_e`` of the degraded part of each cell, undegraded.

    Parameters
    ----------
    elasticity : fem3d.elasticity.Elasticity
    u : ndarray, shape (n_dofs,)
        The full displacement.
    tension : ndarray of bool, optional
        The split's switch at every point (shape ``space.point_shape``); None: every point
        in tension (the whole density).

    Returns
    -------
    ndarray, shape (n_cells, nl, d)
        Force (per local node and component), each cell's modulus and the thickness included.
    """
    el, space = elasticity, elasticity.space
    d, n_q = el.dim, space.n_q
    n_cells = space.n_cells
    ones = np.ones(space.point_shape)
    lam1, mu1 = splits.effective_lame(ones, tension, el.lam, el.mu, d, el.split)
    lam0, mu0 = splits.effective_lame(0.0 * ones, tension, el.lam, el.mu, d, el.split)
    modulus = space.at_points(el.modulus)
    lam_p = ((lam1 - lam0) * modulus).reshape(n_cells, n_q)
    mu_p = ((mu1 - mu0) * modulus).reshape(n_cells, n_q)
    e = el.strain(u).reshape(n_cells, n_q, -1)
    voigt = e[..., _VOIGT[d]]                                  # (n_cells, n_q, d, d)
    trace = np.trace(voigt, axis1=2, axis2=3)
    sigma = 2.0 * mu_p[..., None, None] * voigt + (lam_p * trace)[..., None, None] * np.eye(d)
    G = space.basis_gradients                                  # (n_cells, n_q, nl, d)
    F = np.einsum("cqab,cqkb,q->cka", sigma, G, space.weights)
    return F * (el.thickness * el.measure)[:, None, None]


def cross_block(elasticity, u, alpha, tension=None, fixed_nodes=None) -> sp.csr_matrix:
    """``d2P/du_free dalpha`` (module docstring).

    Parameters
    ----------
    elasticity : fem3d.elasticity.Elasticity
    u : ndarray, shape (n_dofs,)
    alpha : ndarray, shape (n_vertices,)
    tension : ndarray of bool, optional
        The frozen switch (see :func:`cell_forces`).
    fixed_nodes : ndarray of int, optional
        Damage nodes held at 0, decoupled from the displacement: their columns are zero (the
        damage problem's rows there are the identity, :mod:`thinfilm.damage`).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n_free, n_vertices)
        Force per unit damage.
    """
    el, space, mesh = elasticity, elasticity.space, elasticity.mesh
    d = el.dim
    F = cell_forces(el, u, tension)
    n_cells, nl = space.cells.shape
    dofs = (space.cells[:, :, None] * d + np.arange(d)).reshape(n_cells, -1)
    cell_index = np.repeat(np.arange(n_cells), nl * d)
    R = sp.csr_matrix((F.ravel(), (dofs.ravel(), cell_index)), shape=(el.n_dofs, n_cells))[el.free]
    nv = mesh.cells.shape[1]
    V = sp.csr_matrix((np.full(mesh.cells.size, 1.0 / nv), (np.repeat(np.arange(n_cells), nv), mesh.cells.ravel())),
                      shape=(n_cells, mesh.n_nodes))
    dg = el.degradation_slope(alpha)
    if fixed_nodes is not None and len(fixed_nodes):
        dg = dg.copy()
        dg[fixed_nodes] = 0.0
    return (R @ V @ sp.diags(dg)).tocsr()
