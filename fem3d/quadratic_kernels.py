"""Numba kernels of the P2 elasticity (:mod:`fem3d.quadratic_elasticity`), with their NumPy/scipy
references (``*_reference``).

Arrays and scalars in, no validation (the operator calls these with C-contiguous float64
arrays, int64 indices, int32 position tables).

Conventions (beyond those of :mod:`fem3d.kernels`, whose patterns and position tables these
kernels share: :func:`fem3d.kernels.node_graph`, :func:`~fem3d.kernels.free_pattern` and
:func:`~fem3d.kernels.cell_offsets` applied to the P2 cells)
-------------------------------------------------------------------------------------------
- ``cells`` (n_cells, nl): each cell's P2 nodes, its ``d + 1`` vertices then its edges'
  midpoints in the order of ``local_edges`` (nl = 6 triangles, 10 tetrahedra;
  :mod:`fem3d.quadratic`); ``grads`` (n_cells, d + 1, d) and ``measure`` (n_cells,) the P1
  ones (:func:`fem3d.kernels.cell_geometry`).
- ``bary`` (n_q, d + 1), ``weights`` (n_q,): a quadrature rule in barycentric coordinates,
  weights summing to 1 (:data:`fem3d.quadratic.STIFFNESS_RULES`).
- ``lam``, ``mu`` (n_cells, n_q): the effective Lame parameters at each quadrature point
  (degradation, split and modulus included). Element stiffness between dof ``(k, a)`` and
  ``(m, b)``, with ``G_qk`` the gradient of local basis function ``k`` at point ``q``::

      K_e[ka, mb] = T |e| sum_q w_q (lam_q G_qk[a] G_qm[b] + mu_q (G_qk[b] G_qm[a] + delta_ab G_qk . G_qm))

  formed per cell from the basis gradients at the points (computed on the fly) through two
  symmetric ``nl d x nl d`` products (:func:`_element_parts`), so that ``(ka, mb)`` and
  ``(mb, ka)`` are equal bit for bit: the matrix is symmetric.
- Sums run serially in index order (reproducible; no fastmath).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

from fem3d import kernels
from fem3d.kernels import elasticity_matrix_voigt

__all__ = [
    "basis_gradients", "basis_gradients_reference",
    "stiffness_values", "stiffness_reference",
    "boundary_product",
    "point_strain", "point_strain_reference",
]


@njit(cache=True)
def _gradients(grads, e, bary, local_edges, G):
    """``G[q, k, c]``: gradient of local basis function ``k`` of cell ``e`` at point ``q``."""
    n_q, nv = bary.shape
    d = grads.shape[2]
    for q in range(n_q):
        for k in range(nv):
            f = 4.0 * bary[q, k] - 1.0
            for c in range(d):
                G[q, k, c] = f * grads[e, k, c]
        for s in range(local_edges.shape[0]):
            k, m = local_edges[s, 0], local_edges[s, 1]
            lk, lm = 4.0 * bary[q, k], 4.0 * bary[q, m]
            for c in range(d):
                G[q, nv + s, c] = lk * grads[e, m, c] + lm * grads[e, k, c]


@njit(cache=True)
def basis_gradients(grads, bary, local_edges):
    """The P2 basis gradients of every cell at every point, shape (n_cells, n_q, nl, d)."""
    n_cells, nv, d = grads.shape
    nl = nv + local_edges.shape[0]
    out = np.empty((n_cells, bary.shape[0], nl, d), dtype=np.float64)
    for e in range(n_cells):
        _gradients(grads, e, bary, local_edges, out[e])
    return out


def basis_gradients_reference(grads, bary, local_edges):
    """NumPy reference of :func:`basis_gradients` (the product rule on ``l_k (2 l_k - 1)`` and
    ``4 l_k l_m``)."""
    vertex = np.einsum("qk,ekc->eqkc", 4.0 * bary - 1.0, grads)
    k, m = local_edges[:, 0], local_edges[:, 1]
    edge = 4.0 * (np.einsum("qs,esc->eqsc", bary[:, k], grads[:, m])
                  + np.einsum("qs,esc->eqsc", bary[:, m], grads[:, k]))
    return np.concatenate([vertex, edge], axis=2)


@njit(cache=True)
def _element_parts(grads, measure, e, bary, weights, local_edges, lam, mu, thickness, G, A, M, Tr):
    """The parts of cell ``e``'s element stiffness (module docstring): with
    ``X_q(k d + a) = G_qk[a]`` (the basis gradients, written into ``G``),
    ``A[i, j] = sum_q T |e| w_q lam_q X_qi X_qj``, ``M`` the same with ``mu``, and
    ``Tr[k, m] = sum_c M[kc, mc]``, so that::

        K_e[ka, mb] = A[ka, mb] + M[kb, ma] + delta_ab Tr[k, m]

    ``A`` and ``M`` are summed on their upper triangle and mirrored, so ``K_e`` is symmetric
    bit for bit."""
    n_q, nl, d = G.shape
    n = nl * d
    _gradients(grads, e, bary, local_edges, G)
    X = G.reshape(n_q, n)
    A[:, :] = 0.0
    M[:, :] = 0.0
    for q in range(n_q):
        w = thickness * measure[e] * weights[q]
        wl = w * lam[e, q]
        wm = w * mu[e, q]
        for i in range(n):
            xl = wl * X[q, i]
            xm = wm * X[q, i]
            for j in range(i, n):
                A[i, j] += xl * X[q, j]
                M[i, j] += xm * X[q, j]
    for i in range(n):
        for j in range(i + 1, n):
            A[j, i] = A[i, j]
            M[j, i] = M[i, j]
    for k in range(nl):
        for m in range(nl):
            t = 0.0
            for c in range(d):
                t += M[k * d + c, m * d + c]
            Tr[k, m] = t


@njit(cache=True)
def stiffness_values(grads, measure, cells, local_edges, bary, weights, lam, mu, thickness, free_index, indptr,
                     offsets, data):
    """Write the values of ``K_ff`` (module docstring) into ``data``.

    Parameters
    ----------
    lam, mu : ndarray, shape (n_cells, n_q)
        Effective Lame parameters at the quadrature points.
    free_index : ndarray of int64, shape (n_dofs,)
    indptr : ndarray of int64, shape (n_free + 1,)
        The pattern of :func:`fem3d.kernels.free_pattern` on the P2 node graph.
    offsets : ndarray of int32, shape (n_cells, nl, nl)
        :func:`fem3d.kernels.cell_offsets` of the P2 cells.
    data : ndarray, shape (nnz,)
        Overwritten.
    """
    n_cells, nl = cells.shape
    d = grads.shape[2]
    n_q = bary.shape[0]
    data[:] = 0.0
    G = np.empty((n_q, nl, d), dtype=np.float64)
    A = np.empty((nl * d, nl * d), dtype=np.float64)
    M = np.empty((nl * d, nl * d), dtype=np.float64)
    Tr = np.empty((nl, nl), dtype=np.float64)
    for e in range(n_cells):
        _element_parts(grads, measure, e, bary, weights, local_edges, lam, mu, thickness, G, A, M, Tr)
        for k in range(nl):
            i = cells[e, k]
            for a in range(d):
                r = free_index[i * d + a]
                if r < 0:
                    continue
                base = indptr[r]
                for m in range(nl):
                    off = offsets[e, k, m]
                    if off < 0:
                        continue
                    j = cells[e, m]
                    p = base + off
                    for b in range(d):
                        if free_index[j * d + b] < 0:
                            continue
                        v = A[k * d + a, m * d + b] + M[k * d + b, m * d + a]
                        if a == b:
                            v += Tr[k, m]
                        data[p] += v
                        p += 1


def _voigt_B(G):
    """Strain-displacement matrices (engineering shear) at every point, shape
    (n_cells, n_q, 3 or 6, nl d), from basis gradients ``G`` (n_cells, n_q, nl, d): P1's
    :func:`fem3d.kernels._voigt_B` of each point as a cell of its own."""
    n, n_q, nl, d = G.shape
    B = kernels._voigt_B(G.reshape(n * n_q, nl, d))
    return B.reshape(n, n_q, B.shape[1], B.shape[2])


def stiffness_reference(grads, measure, cells, local_edges, bary, weights, lam, mu, thickness):
    """scipy reference: the full ``K`` (all dofs, CSR) from the Voigt element matrices
    ``T |e| sum_q w_q B_q^T D_q B_q``; restrict it to the free dofs to compare with
    :func:`stiffness_values`."""
    n, nl = cells.shape
    d = grads.shape[2]
    B = _voigt_B(basis_gradients_reference(grads, bary, local_edges))
    D_lam = elasticity_matrix_voigt(1.0, 0.0, d)
    D_mu = elasticity_matrix_voigt(0.0, 1.0, d)
    W = thickness * measure[:, None] * weights[None, :]
    Ke = (np.einsum("eq,eqki,kl,eqlj->eij", W * lam, B, D_lam, B)
          + np.einsum("eq,eqki,kl,eqlj->eij", W * mu, B, D_mu, B))
    dofs = (cells[:, :, None] * d + np.arange(d)).reshape(n, nl * d)
    rows = np.repeat(dofs, nl * d, axis=1).ravel()
    cols = np.tile(dofs, (1, nl * d)).ravel()
    n_dofs = d * (int(cells.max()) + 1)
    K = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(n_dofs, n_dofs))
    K.sum_duplicates()
    return K


@njit(cache=True)
def boundary_product(grads, measure, cells, local_edges, bary, weights, cell_list, lam, mu, thickness, row_index,
                     col_index, x, sign, out):
    """``out[row_index[i]] += sign (K_e x)_i`` summed over the cells of ``cell_list``, as
    :func:`fem3d.kernels.boundary_product` (the right-hand side ``-K_fd u_d`` and the
    reactions ``(K u)_d``), with the P2 element stiffness of the module docstring."""
    nl = cells.shape[1]
    d = grads.shape[2]
    n_q = bary.shape[0]
    G = np.empty((n_q, nl, d), dtype=np.float64)
    A = np.empty((nl * d, nl * d), dtype=np.float64)
    M = np.empty((nl * d, nl * d), dtype=np.float64)
    Tr = np.empty((nl, nl), dtype=np.float64)
    for t in range(cell_list.size):
        e = cell_list[t]
        _element_parts(grads, measure, e, bary, weights, local_edges, lam, mu, thickness, G, A, M, Tr)
        for k in range(nl):
            i = cells[e, k]
            for a in range(d):
                r = row_index[i * d + a]
                if r < 0:
                    continue
                s = 0.0
                for m in range(nl):
                    j = cells[e, m]
                    for b in range(d):
                        c = col_index[j * d + b]
                        if c < 0:
                            continue
                        v = A[k * d + a, m * d + b] + M[k * d + b, m * d + a]
                        if a == b:
                            v += Tr[k, m]
                        s += v * x[c]
                out[r] += sign * s


@njit(cache=True)
def point_strain(grads, cells, local_edges, bary, u):
    """The strain at every quadrature point in Voigt order with *tensor* shear components:
    2D ``(e_xx, e_yy, e_xy)``, 3D ``(e_xx, e_yy, e_zz, e_yz, e_xz, e_xy)``; shape
    (n_cells, n_q, 3 or 6)."""
    n_cells, nl = cells.shape
    d = grads.shape[2]
    n_q = bary.shape[0]
    out = np.empty((n_cells, n_q, 3 if d == 2 else 6), dtype=np.float64)
    G = np.empty((n_q, nl, d), dtype=np.float64)
    H = np.empty((d, d), dtype=np.float64)  # displacement gradient du_a/dx_b
    for e in range(n_cells):
        _gradients(grads, e, bary, local_edges, G)
        for q in range(n_q):
            H[:, :] = 0.0
            for k in range(nl):
                i = cells[e, k]
                for a in range(d):
                    ua = u[i * d + a]
                    for b in range(d):
                        H[a, b] += ua * G[q, k, b]
            if d == 2:
                out[e, q, 0], out[e, q, 1], out[e, q, 2] = H[0, 0], H[1, 1], 0.5 * (H[0, 1] + H[1, 0])
            else:
                out[e, q, 0], out[e, q, 1], out[e, q, 2] = H[0, 0], H[1, 1], H[2, 2]
                out[e, q, 3] = 0.5 * (H[1, 2] + H[2, 1])
                out[e, q, 4] = 0.5 * (H[0, 2] + H[2, 0])
                out[e, q, 5] = 0.5 * (H[0, 1] + H[1, 0])
    return out


def point_strain_reference(grads, cells, local_edges, bary, u):
    """NumPy reference of :func:`point_strain`."""
    d = grads.shape[2]
    G = basis_gradients_reference(grads, bary, local_edges)
    ue = u.reshape(-1, d)[cells]  # (n, nl, d)
    H = np.einsum("eka,eqkb->eqab", ue, G)
    e = 0.5 * (H + np.swapaxes(H, 2, 3))
    if d == 2:
        return np.stack([e[..., 0, 0], e[..., 1, 1], e[..., 0, 1]], axis=-1)
    return np.stack([e[..., 0, 0], e[..., 1, 1], e[..., 2, 2], e[..., 1, 2], e[..., 0, 2], e[..., 0, 1]], axis=-1)
