"""Numba kernels of the elasticity and damage operators (:mod:`fem3d.elasticity`,
:mod:`fem3d.damage`), with their NumPy/scipy references (``*_reference``).

Arrays and scalars in, no validation (the operators call these with the right dtypes:
C-contiguous float64 arrays, int64 indices, int32 position tables). The discrete energy is
defined in :mod:`fem3d.elasticity` and :mod:`fem3d.damage`; the elements (their nodes,
quadrature and basis gradients) in :mod:`fem3d.elements`.

Conventions shared by every kernel
----------------------------------
- ``points`` (n_nodes, d), ``cells`` (n_cells, d + 1); ``d`` = 2 (triangles) or 3 (tetrahedra).
- ``grads`` (n_cells, d + 1, d): the gradients of the P1 basis functions of each cell's
  vertices, in the order of ``cells``; ``measure`` (n_cells,): areas or volumes.
- Displacement dofs: ``node * d + component``, over the element's nodes. ``free_index``
  (n_dofs,) maps a dof to its row in the free block (``-1`` if constrained), ``con_index``
  (n_dofs,) to its position among the constrained dofs (``-1`` if free); both increase with
  the dof.
- Elements (:mod:`fem3d.elements`): ``element_cells`` (n_cells, nl), each cell's ``nl``
  displacement nodes; a quadrature rule of ``n_q`` points with ``weights`` (n_q,) summing to 1
  (fractions of the cell's measure); ``basis`` (n_cells, n_q, nl, d), the gradient of each
  local basis function at each point (1 / length); ``lam``, ``mu`` (n_cells, n_q), the
  effective Lame parameters at the points (degradation, split and modulus included). The
  element stiffness between dof ``(k, a)`` (local node ``k``, component ``a``) and ``(m, b)``,
  with ``G_qk`` the gradient of basis function ``k`` at point ``q`` (``C e(phi_ka) : e(phi_mb)``)::

      K_e[ka, mb] = T |e| sum_q w_q (lam_q G_qk[a] G_qm[b] + mu_q (G_qk[b] G_qm[a] + delta_ab G_qk . G_qm))

  :func:`stiffness_values` and :func:`boundary_product` form it per cell through two
  symmetric ``nl d x nl d`` products (:func:`_element_parts`), so that ``(ka, mb)`` and
  ``(mb, ka)`` are equal bit for bit: the matrix is symmetric.
- P1 fast path (:func:`p1_stiffness_values`, :func:`p1_boundary_product`, :func:`p1_strain`,
  :func:`p1_energy_density`): one point per cell, ``basis = grads``, the entries formed directly as
  ``w lam (g_k[a] g_m[b]) + w mu (g_k[b] g_m[a]) + delta_ab w mu g_k . g_m`` (the same
  operations for ``(ka, mb)`` and ``(mb, ka)``: symmetric bit for bit), faster than the
  generic kernels on P1 (docs/speed.md#the-element-kernels).
- CSR patterns are built once (:func:`node_graph`, :func:`free_pattern`); the value kernels
  write into ``data`` through positions found once per mesh (:func:`cell_offsets`).
- Sums run serially in index order (reproducible; no fastmath).

Position lookup
---------------
Every free row of node ``i`` has the same columns (the free dofs of ``i``'s neighbours, in
increasing order), so the position of ``(ka, mb)`` is ``indptr[row(ka)] + offset(i, j) +
(number of free components of j before b)``, where ``offset(i, j)`` depends on the node pair
only. :func:`cell_offsets` stores it per cell and node pair (int32, ``nl^2`` per cell), in
place of a binary search in each row (docs/speed.md#the-element-kernels).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit

__all__ = [
    "cell_geometry", "cell_geometry_reference",
    "node_graph", "node_graph_reference",
    "free_pattern", "free_pattern_reference", "cell_offsets",
    "cell_degradation", "cell_degradation_reference",
    "stiffness_values", "p1_stiffness_values", "stiffness_reference",
    "boundary_product", "p1_boundary_product",
    "point_strain", "p1_strain", "point_strain_reference",
    "energy_density", "p1_energy_density", "energy_density_reference",
    "nodal_energy", "nodal_energy_reference",
    "laplacian_values", "laplacian_reference",
    "lumped_measure", "lumped_measure_reference",
    "elasticity_matrix_voigt",
]


# ------------------------------------------------------------------------------------------
# geometry and patterns
# ------------------------------------------------------------------------------------------
@njit(cache=True)
def cell_geometry(points, cells):
    """Gradients of the P1 basis functions and measures of every cell.

    With ``J`` the matrix whose columns are the edges ``x_k - x_0`` (k = 1..d), the
    barycentric coordinate ``lambda_k`` (k >= 1) has gradient row ``k - 1`` of ``J^-1``, and
    ``grad lambda_0 = -sum_k grad lambda_k``; ``|e| = |det J| / d!``.

    Returns
    -------
    grads : ndarray, shape (n_cells, d + 1, d)
    measure : ndarray, shape (n_cells,)
        Unsigned areas (d = 2) or volumes (d = 3); 0 for a degenerate cell (whose
        gradients are then not finite).
    """
    n_cells = cells.shape[0]
    d = points.shape[1]
    grads = np.empty((n_cells, d + 1, d), dtype=np.float64)
    measure = np.empty(n_cells, dtype=np.float64)
    for e in range(n_cells):
        p0 = cells[e, 0]
        if d == 2:
            p1, p2 = cells[e, 1], cells[e, 2]
            j00 = points[p1, 0] - points[p0, 0]
            j10 = points[p1, 1] - points[p0, 1]
            j01 = points[p2, 0] - points[p0, 0]
            j11 = points[p2, 1] - points[p0, 1]
            det = j00 * j11 - j01 * j10
            inv = 1.0 / det
            grads[e, 1, 0] = j11 * inv
            grads[e, 1, 1] = -j01 * inv
            grads[e, 2, 0] = -j10 * inv
            grads[e, 2, 1] = j00 * inv
            measure[e] = 0.5 * abs(det)
        else:
            p1, p2, p3 = cells[e, 1], cells[e, 2], cells[e, 3]
            ax = points[p1, 0] - points[p0, 0]
            ay = points[p1, 1] - points[p0, 1]
            az = points[p1, 2] - points[p0, 2]
            bx = points[p2, 0] - points[p0, 0]
            by = points[p2, 1] - points[p0, 1]
            bz = points[p2, 2] - points[p0, 2]
            cx = points[p3, 0] - points[p0, 0]
            cy = points[p3, 1] - points[p0, 1]
            cz = points[p3, 2] - points[p0, 2]
            # rows of J^-1: (b x c, c x a, a x b) / det, det = a . (b x c)
            bcx, bcy, bcz = by * cz - bz * cy, bz * cx - bx * cz, bx * cy - by * cx
            cax, cay, caz = cy * az - cz * ay, cz * ax - cx * az, cx * ay - cy * ax
            abx, aby, abz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            det = ax * bcx + ay * bcy + az * bcz
            inv = 1.0 / det
            grads[e, 1, 0], grads[e, 1, 1], grads[e, 1, 2] = bcx * inv, bcy * inv, bcz * inv
            grads[e, 2, 0], grads[e, 2, 1], grads[e, 2, 2] = cax * inv, cay * inv, caz * inv
            grads[e, 3, 0], grads[e, 3, 1], grads[e, 3, 2] = abx * inv, aby * inv, abz * inv
            measure[e] = abs(det) / 6.0
        for k in range(d):
            s = 0.0
            for v in range(1, d + 1):
                s += grads[e, v, k]
            grads[e, 0, k] = -s
    return grads, measure


def cell_geometry_reference(points, cells):
    """NumPy reference of :func:`cell_geometry` (batched ``numpy.linalg.inv``)."""
    d = points.shape[1]
    edges = points[cells[:, 1:]] - points[cells[:, :1]]  # (n, d, d): row k = x_{k+1} - x_0
    J = np.transpose(edges, (0, 2, 1))  # columns = edges
    inv = np.linalg.inv(J)  # row k = grad lambda_{k+1}
    grads = np.concatenate([-inv.sum(axis=1, keepdims=True), inv], axis=1)
    measure = np.abs(np.linalg.det(J)) / (2.0 if d == 2 else 6.0)
    return grads, measure


@njit(cache=True)
def node_graph(cells, n_nodes):
    """CSR pattern of the node adjacency (two nodes are adjacent if a cell has both; every
    node of a cell is adjacent to itself), column indices sorted in each row.

    Returns
    -------
    indptr : ndarray of int64, shape (n_nodes + 1,)
    indices : ndarray of int64
        A node of no cell has an empty row.
    """
    n_cells, nv = cells.shape
    # node -> cells incidence
    inc_ptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for e in range(n_cells):
        for k in range(nv):
            inc_ptr[cells[e, k] + 1] += 1
    for i in range(n_nodes):
        inc_ptr[i + 1] += inc_ptr[i]
    fill = inc_ptr[:-1].copy()
    inc = np.empty(inc_ptr[n_nodes], dtype=np.int64)
    for e in range(n_cells):
        for k in range(nv):
            i = cells[e, k]
            inc[fill[i]] = e
            fill[i] += 1
    marker = np.full(n_nodes, -1, dtype=np.int64)
    indptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for i in range(n_nodes):
        count = 0
        for p in range(inc_ptr[i], inc_ptr[i + 1]):
            e = inc[p]
            for k in range(nv):
                j = cells[e, k]
                if marker[j] != i:
                    marker[j] = i
                    count += 1
        indptr[i + 1] = indptr[i] + count
    indices = np.empty(indptr[n_nodes], dtype=np.int64)
    marker[:] = -1
    for i in range(n_nodes):
        q = indptr[i]
        for p in range(inc_ptr[i], inc_ptr[i + 1]):
            e = inc[p]
            for k in range(nv):
                j = cells[e, k]
                if marker[j] != i:
                    marker[j] = i
                    indices[q] = j
                    q += 1
        indices[indptr[i]:indptr[i + 1]].sort()
    return indptr, indices


def node_graph_reference(cells, n_nodes):
    """scipy reference of :func:`node_graph`: ``(indptr, indices)`` of the summed incidence
    products (a CSR with sorted indices, duplicates summed)."""
    nv = cells.shape[1]
    rows = np.repeat(cells, nv, axis=1).ravel()
    cols = np.tile(cells, (1, nv)).ravel()
    G = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n_nodes, n_nodes))
    G.sum_duplicates()
    G.sort_indices()
    return G.indptr.astype(np.int64), G.indices.astype(np.int64)


@njit(cache=True)
def free_pattern(node_indptr, node_indices, free_index, d, n_free):
    """CSR pattern of the free-dof block ``K_ff`` and each node-graph entry's column offset.

    Row ``free_index[i d + a]`` holds the free dofs of ``i``'s neighbours, increasing.

    Returns
    -------
    indptr : ndarray of int64, shape (n_free + 1,)
    indices : ndarray of int32
        Free-dof column indices, sorted in each row.
    entry_offset : ndarray of int64, shape (node nnz,)
        For the node-graph entry ``(i, j)``: the position, within any free row of node
        ``i``, of the first free dof of node ``j`` (-1 if ``j`` has no free dof).
    """
    n_nodes = node_indptr.size - 1
    nfree = np.zeros(n_nodes, dtype=np.int64)
    for i in range(n_nodes):
        for a in range(d):
            if free_index[i * d + a] >= 0:
                nfree[i] += 1
    entry_offset = np.empty(node_indices.size, dtype=np.int64)
    row_len = np.zeros(n_nodes, dtype=np.int64)
    for i in range(n_nodes):
        s = 0
        for p in range(node_indptr[i], node_indptr[i + 1]):
            j = node_indices[p]
            entry_offset[p] = s if nfree[j] > 0 else -1
            s += nfree[j]
        row_len[i] = s
    indptr = np.zeros(n_free + 1, dtype=np.int64)
    for i in range(n_nodes):
        for a in range(d):
            r = free_index[i * d + a]
            if r >= 0:
                indptr[r + 1] = row_len[i]
    for r in range(n_free):
        indptr[r + 1] += indptr[r]
    indices = np.empty(indptr[n_free], dtype=np.int32)
    for i in range(n_nodes):
        for a in range(d):
            r = free_index[i * d + a]
            if r < 0:
                continue
            q = indptr[r]
            for p in range(node_indptr[i], node_indptr[i + 1]):
                j = node_indices[p]
                for b in range(d):
                    c = free_index[j * d + b]
                    if c >= 0:
                        indices[q] = c
                        q += 1
    return indptr, indices, entry_offset


def free_pattern_reference(node_indptr, node_indices, free, d):
    """scipy reference of :func:`free_pattern`'s ``(indptr, indices)``: the node graph with
    each entry expanded to a ``d x d`` block, restricted to the free dofs ``free`` (increasing)."""
    n_nodes = node_indptr.size - 1
    G = sp.csr_matrix((np.ones(node_indices.size), node_indices, node_indptr), shape=(n_nodes, n_nodes))
    K = sp.kron(G, np.ones((d, d))).tocsr()[free][:, free]
    K.sort_indices()
    return K.indptr.astype(np.int64), K.indices.astype(np.int64)


@njit(cache=True)
def _find(indices, lo, hi, key):
    """Position of ``key`` in the sorted ``indices[lo:hi]`` (binary search; -1 if absent)."""
    while lo < hi:
        mid = (lo + hi) >> 1
        v = indices[mid]
        if v < key:
            lo = mid + 1
        elif v > key:
            hi = mid
        else:
            return mid
    return -1


@njit(cache=True)
def cell_offsets(cells, node_indptr, node_indices, entry_offset):
    """Per cell and pair ``(k, l)`` of its nodes: ``entry_offset`` of the node pair
    ``(cells[e, k], cells[e, l])`` (see :func:`free_pattern`), int32, shape (n_cells, nl, nl)
    (``cells`` (n_cells, nl): the mesh's cells, or an element's cells of its nodes)."""
    n_cells, nv = cells.shape
    out = np.empty((n_cells, nv, nv), dtype=np.int32)
    for e in range(n_cells):
        for k in range(nv):
            i = cells[e, k]
            for m in range(nv):
                p = _find(node_indices, node_indptr[i], node_indptr[i + 1], cells[e, m])
                out[e, k, m] = entry_offset[p]
    return out


# ------------------------------------------------------------------------------------------
# elasticity
# ------------------------------------------------------------------------------------------
@njit(cache=True)
def cell_degradation(alpha, cells, k_res):
    """``gbar_e = 1/(d+1) sum_{i in e} ((1 - alpha_i)^2 + k_res)``, shape (n_cells,)."""
    n_cells, nv = cells.shape
    out = np.empty(n_cells, dtype=np.float64)
    for e in range(n_cells):
        s = 0.0
        for k in range(nv):
            c = 1.0 - alpha[cells[e, k]]
            s += c * c
        out[e] = s / nv + k_res
    return out


def cell_degradation_reference(alpha, cells, k_res):
    """NumPy reference of :func:`cell_degradation`."""
    return ((1.0 - alpha) ** 2 + k_res)[cells].mean(axis=1)


@njit(cache=True)
def _gram(grads, e, gg):
    """``gg[k, l] = grads[e, k] . grads[e, l]``."""
    nv, d = grads.shape[1], grads.shape[2]
    for k in range(nv):
        for m in range(nv):
            s = 0.0
            for c in range(d):
                s += grads[e, k, c] * grads[e, m, c]
            gg[k, m] = s


@njit(cache=True)
def _element_parts(basis, measure, weights, e, lam, mu, thickness, A, M, Tr):
    """The parts of cell ``e``'s element stiffness (module docstring), written into ``A``,
    ``M`` (nl d, nl d) and ``Tr`` (nl, nl): with ``X_q(k d + a) = G_qk[a]``,
    ``A[i, j] = sum_q T |e| w_q lam_q X_qi X_qj``, ``M`` the same with ``mu``, and
    ``Tr[k, m] = sum_c M[kc, mc]``, so that::

        K_e[ka, mb] = A[ka, mb] + M[kb, ma] + delta_ab Tr[k, m]

    ``A`` and ``M`` are summed on their upper triangle and mirrored, so ``K_e`` is symmetric
    bit for bit."""
    n_q, nl, d = basis.shape[1], basis.shape[2], basis.shape[3]
    n = nl * d
    X = basis[e].reshape(n_q, n)
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
def stiffness_values(basis, measure, weights, cells, lam, mu, thickness, free_index, indptr, offsets, data):
    """Write the values of ``K_ff = sum_e K_e`` (module docstring) into ``data``.

    Parameters
    ----------
    basis : ndarray, shape (n_cells, n_q, nl, d)
        Basis gradients at the quadrature points.
    measure : ndarray, shape (n_cells,)
    weights : ndarray, shape (n_q,)
    cells : ndarray of int64, shape (n_cells, nl)
        The element's cells (its nodes).
    lam, mu : ndarray, shape (n_cells, n_q)
        Effective Lame parameters at the points.
    thickness : float
    free_index : ndarray of int64, shape (n_dofs,)
    indptr : ndarray of int64, shape (n_free + 1,)
        The pattern of :func:`free_pattern` on the element's node graph.
    offsets : ndarray of int32, shape (n_cells, nl, nl)
        :func:`cell_offsets` of the element's cells.
    data : ndarray, shape (nnz,)
        Overwritten.
    """
    n_cells, nl = cells.shape
    n_q, d = basis.shape[1], basis.shape[3]
    data[:] = 0.0
    A = np.empty((nl * d, nl * d), dtype=np.float64)
    M = np.empty((nl * d, nl * d), dtype=np.float64)
    Tr = np.empty((nl, nl), dtype=np.float64)
    for e in range(n_cells):
        _element_parts(basis, measure, weights, e, lam, mu, thickness, A, M, Tr)
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


@njit(cache=True)
def p1_stiffness_values(grads, measure, cells, lam, mu, thickness, free_index, indptr, offsets, data):
    """:func:`stiffness_values` of the P1 element (fast path, module docstring): ``grads``
    (n_cells, d + 1, d) the basis gradients, ``lam``, ``mu`` shape (n_cells,), ``offsets``
    (n_cells, d + 1, d + 1); the other arguments as there."""
    n_cells, nv, d = grads.shape
    data[:] = 0.0
    gg = np.empty((nv, nv), dtype=np.float64)
    for e in range(n_cells):
        w = thickness * measure[e]
        wl = w * lam[e]
        wm = w * mu[e]
        _gram(grads, e, gg)
        for k in range(nv):
            i = cells[e, k]
            for a in range(d):
                r = free_index[i * d + a]
                if r < 0:
                    continue
                base = indptr[r]
                gia = grads[e, k, a]
                for m in range(nv):
                    off = offsets[e, k, m]
                    if off < 0:
                        continue
                    j = cells[e, m]
                    p = base + off
                    gja = grads[e, m, a]
                    for b in range(d):
                        if free_index[j * d + b] < 0:
                            continue
                        v = wl * (gia * grads[e, m, b]) + wm * (grads[e, k, b] * gja)
                        if a == b:
                            v += wm * gg[k, m]
                        data[p] += v
                        p += 1


def elasticity_matrix_voigt(lam, mu, d):
    """Isotropic elasticity in Voigt form with engineering shear strains: 3x3 in 2D
    (xx, yy, xy), 6x6 in 3D (xx, yy, zz, yz, xz, xy)."""
    n = 3 if d == 2 else 6
    D = np.zeros((n, n))
    D[:d, :d] = lam
    D[np.arange(d), np.arange(d)] = lam + 2.0 * mu
    D[np.arange(d, n), np.arange(d, n)] = mu
    return D


def _voigt_B(basis):
    """Strain-displacement matrices ``B`` (n, 3 or 6, d nl), engineering shear, from basis
    gradients (n, nl, d) (a cell's, or a point's)."""
    n, nv, d = basis.shape
    B = np.zeros((n, 3 if d == 2 else 6, d * nv))
    for k in range(nv):
        gx, gy = basis[:, k, 0], basis[:, k, 1]
        if d == 2:
            B[:, 0, 2 * k] = gx
            B[:, 1, 2 * k + 1] = gy
            B[:, 2, 2 * k] = gy
            B[:, 2, 2 * k + 1] = gx
        else:
            gz = basis[:, k, 2]
            c = 3 * k
            B[:, 0, c] = gx
            B[:, 1, c + 1] = gy
            B[:, 2, c + 2] = gz
            B[:, 3, c + 1], B[:, 3, c + 2] = gz, gy  # yz
            B[:, 4, c], B[:, 4, c + 2] = gz, gx  # xz
            B[:, 5, c], B[:, 5, c + 1] = gy, gx  # xy
    return B


def stiffness_reference(basis, measure, weights, cells, lam, mu, thickness):
    """scipy reference: the full ``K`` (all dofs, CSR) from the Voigt element matrices
    ``T |e| sum_q w_q B_q^T D_q B_q`` (``D_q`` of ``lam``, ``mu`` at the point, shape
    (n_cells, n_q) or, with one point, (n_cells,)); restrict it to the free dofs to compare
    with :func:`stiffness_values` or :func:`p1_stiffness_values` (``basis = grads[:, None]``,
    ``weights = [1]``)."""
    n, n_q, nl, d = basis.shape
    B = _voigt_B(basis.reshape(n * n_q, nl, d)).reshape(n, n_q, 3 if d == 2 else 6, nl * d)
    D_lam = elasticity_matrix_voigt(1.0, 0.0, d)
    D_mu = elasticity_matrix_voigt(0.0, 1.0, d)
    W = thickness * measure[:, None] * np.asarray(weights)[None, :]
    lam, mu = np.reshape(lam, (n, n_q)), np.reshape(mu, (n, n_q))
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
def boundary_product(basis, measure, weights, cells, cell_list, lam, mu, thickness, row_index, col_index, x, sign,
                     out):
    """``out[row_index[i]] += sign (K_e x)_i``, summed over the cells of ``cell_list``: a block
    of ``K`` times a vector, where only the cells touching a constrained dof contribute.

    ``row_index`` and ``col_index`` (n_dofs,) map a dof to its row of ``out`` and its entry of
    ``x`` (``-1``: skipped). The two uses (:mod:`fem3d.elasticity`): the right-hand side
    ``out -= K_fd u_d`` (rows ``free_index``, columns ``con_index``, ``x = u_d``, ``sign =
    -1``) and the reactions ``out += (K u)_d`` (rows ``con_index``, every column, ``x = u``,
    ``sign = +1``). ``cell_list``: the cells with a constrained dof (the others have no
    ``K_fd`` or ``K_dd`` entry). The other arguments as in :func:`stiffness_values`.
    """
    nl = cells.shape[1]
    n_q, d = basis.shape[1], basis.shape[3]
    A = np.empty((nl * d, nl * d), dtype=np.float64)
    M = np.empty((nl * d, nl * d), dtype=np.float64)
    Tr = np.empty((nl, nl), dtype=np.float64)
    for t in range(cell_list.size):
        e = cell_list[t]
        _element_parts(basis, measure, weights, e, lam, mu, thickness, A, M, Tr)
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
def p1_boundary_product(grads, measure, cells, cell_list, lam, mu, thickness, row_index, col_index, x, sign, out):
    """:func:`boundary_product` of the P1 element (fast path): ``grads`` (n_cells, d + 1, d),
    ``lam``, ``mu`` shape (n_cells,); the other arguments as there."""
    nv, d = grads.shape[1], grads.shape[2]
    gg = np.empty((nv, nv), dtype=np.float64)
    for q in range(cell_list.size):
        e = cell_list[q]
        w = thickness * measure[e]
        le, me = lam[e], mu[e]
        _gram(grads, e, gg)
        for k in range(nv):
            i = cells[e, k]
            for a in range(d):
                r = row_index[i * d + a]
                if r < 0:
                    continue
                gia = grads[e, k, a]
                s = 0.0
                for m in range(nv):
                    j = cells[e, m]
                    gja = grads[e, m, a]
                    for b in range(d):
                        c = col_index[j * d + b]
                        if c < 0:
                            continue
                        v = le * (gia * grads[e, m, b]) + me * (grads[e, k, b] * gja)
                        if a == b:
                            v += me * gg[k, m]
                        s += v * x[c]
                out[r] += sign * (w * s)


@njit(cache=True)
def _displacement_gradient(basis, cells, u, e, q, H):
    """``H[a, b] = du_a/dx_b`` at point ``q`` of cell ``e``, written into ``H`` (d, d)."""
    nl, d = basis.shape[2], basis.shape[3]
    H[:, :] = 0.0
    for k in range(nl):
        i = cells[e, k]
        for a in range(d):
            ua = u[i * d + a]
            for b in range(d):
                H[a, b] += ua * basis[e, q, k, b]


@njit(cache=True)
def point_strain(basis, cells, u):
    """The strain at every point in Voigt order with *tensor* shear components: 2D
    ``(e_xx, e_yy, e_xy)``, 3D ``(e_xx, e_yy, e_zz, e_yz, e_xz, e_xy)``; shape
    (n_cells, n_q, 3 or 6).

    Parameters
    ----------
    basis : ndarray, shape (n_cells, n_q, nl, d)
    cells : ndarray of int64, shape (n_cells, nl)
    u : ndarray, shape (n_dofs,)
    """
    n_cells, n_q, nl, d = basis.shape
    out = np.empty((n_cells, n_q, 3 if d == 2 else 6), dtype=np.float64)
    H = np.empty((d, d), dtype=np.float64)
    for e in range(n_cells):
        for q in range(n_q):
            _displacement_gradient(basis, cells, u, e, q, H)
            if d == 2:
                out[e, q, 0], out[e, q, 1], out[e, q, 2] = H[0, 0], H[1, 1], 0.5 * (H[0, 1] + H[1, 0])
            else:
                out[e, q, 0], out[e, q, 1], out[e, q, 2] = H[0, 0], H[1, 1], H[2, 2]
                out[e, q, 3] = 0.5 * (H[1, 2] + H[2, 1])
                out[e, q, 4] = 0.5 * (H[0, 2] + H[2, 0])
                out[e, q, 5] = 0.5 * (H[0, 1] + H[1, 0])
    return out


def point_strain_reference(basis, cells, u):
    """NumPy reference of :func:`point_strain`."""
    d = basis.shape[3]
    ue = u.reshape(-1, d)[cells]  # (n, nl, d)
    H = np.einsum("eka,eqkb->eqab", ue, basis)
    e = 0.5 * (H + np.swapaxes(H, 2, 3))
    if d == 2:
        return np.stack([e[..., 0, 0], e[..., 1, 1], e[..., 0, 1]], axis=-1)
    return np.stack([e[..., 0, 0], e[..., 1, 1], e[..., 2, 2], e[..., 1, 2], e[..., 0, 2], e[..., 0, 1]], axis=-1)


@njit(cache=True)
def energy_density(basis, cells, u, lam, mu):
    """``psi = 1/2 e:C:e = lam/2 tr(e)^2 + mu e:e`` at every point (undamaged), shape (n_cells, n_q)."""
    n_cells, n_q, nl, d = basis.shape
    out = np.empty((n_cells, n_q), dtype=np.float64)
    H = np.empty((d, d), dtype=np.float64)
    for e in range(n_cells):
        for q in range(n_q):
            _displacement_gradient(basis, cells, u, e, q, H)
            tr = 0.0
            ee = 0.0
            for a in range(d):
                tr += H[a, a]
                for b in range(d):
                    s = 0.5 * (H[a, b] + H[b, a])
                    ee += s * s
            out[e, q] = 0.5 * lam * tr * tr + mu * ee
    return out


def energy_density_reference(basis, cells, u, lam, mu):
    """NumPy reference of :func:`energy_density`: ``1/2 eps_v . D . eps_v`` with the Voigt
    ``D`` and engineering shears."""
    d = basis.shape[3]
    e = point_strain_reference(basis, cells, u)
    e[..., d:] *= 2.0
    D = elasticity_matrix_voigt(lam, mu, d)
    return 0.5 * np.einsum("eqi,ij,eqj->eq", e, D, e)


@njit(cache=True)
def _cell_gradient(grads, cells, u, e, G):
    """``G[a, b] = du_a/dx_b`` on P1 cell ``e`` (constant), written into ``G`` (d, d)."""
    nv, d = grads.shape[1], grads.shape[2]
    G[:, :] = 0.0
    for k in range(nv):
        i = cells[e, k]
        for a in range(d):
            ua = u[i * d + a]
            for b in range(d):
                G[a, b] += ua * grads[e, k, b]


@njit(cache=True)
def p1_strain(grads, cells, u):
    """:func:`point_strain` of the P1 element (fast path): the strain of each cell, shape
    (n_cells, 3 or 6), from ``grads`` (n_cells, d + 1, d); the same operations as
    :func:`point_strain` on ``grads[:, None]``."""
    n_cells, nv, d = grads.shape
    out = np.zeros((n_cells, 3 if d == 2 else 6), dtype=np.float64)
    G = np.empty((d, d), dtype=np.float64)  # displacement gradient du_a/dx_b
    for e in range(n_cells):
        _cell_gradient(grads, cells, u, e, G)
        if d == 2:
            out[e, 0], out[e, 1], out[e, 2] = G[0, 0], G[1, 1], 0.5 * (G[0, 1] + G[1, 0])
        else:
            out[e, 0], out[e, 1], out[e, 2] = G[0, 0], G[1, 1], G[2, 2]
            out[e, 3] = 0.5 * (G[1, 2] + G[2, 1])
            out[e, 4] = 0.5 * (G[0, 2] + G[2, 0])
            out[e, 5] = 0.5 * (G[0, 1] + G[1, 0])
    return out


@njit(cache=True)
def p1_energy_density(grads, cells, u, lam, mu):
    """:func:`energy_density` of the P1 element (fast path): shape (n_cells,), from ``grads``
    (n_cells, d + 1, d)."""
    n_cells, nv, d = grads.shape
    out = np.empty(n_cells, dtype=np.float64)
    G = np.empty((d, d), dtype=np.float64)
    for e in range(n_cells):
        _cell_gradient(grads, cells, u, e, G)
        tr = 0.0
        ee = 0.0
        for a in range(d):
            tr += G[a, a]
            for b in range(d):
                s = 0.5 * (G[a, b] + G[b, a])
                ee += s * s
        out[e] = 0.5 * lam * tr * tr + mu * ee
    return out


@njit(cache=True)
def nodal_energy(psi, measure, cells, thickness, out):
    """``out_i = thickness sum_{e ni i} |e| psi_e / (d + 1)`` (``out`` overwritten; ``cells``
    the mesh's, ``psi`` (n_cells,) each cell's mean density)."""
    n_cells, nv = cells.shape
    out[:] = 0.0
    for e in range(n_cells):
        v = thickness * measure[e] * psi[e] / nv
        for k in range(nv):
            out[cells[e, k]] += v


def nodal_energy_reference(psi, measure, cells, thickness, n_nodes):
    """NumPy reference of :func:`nodal_energy` (``numpy.bincount``)."""
    nv = cells.shape[1]
    return np.bincount(cells.ravel(), weights=np.repeat(thickness * measure * psi / nv, nv), minlength=n_nodes)


# ------------------------------------------------------------------------------------------
# damage
# ------------------------------------------------------------------------------------------
@njit(cache=True)
def laplacian_values(grads, measure, cells, indptr, indices, data):
    """Write the P1 stiffness matrix ``L_ij = sum_e |e| grad psi_i . grad psi_j`` into the
    node-graph pattern (``data`` overwritten; binary search in the sorted rows)."""
    n_cells, nv, d = grads.shape
    data[:] = 0.0
    gg = np.empty((nv, nv), dtype=np.float64)
    for e in range(n_cells):
        _gram(grads, e, gg)
        for k in range(nv):
            i = cells[e, k]
            for m in range(nv):
                p = _find(indices, indptr[i], indptr[i + 1], cells[e, m])
                data[p] += measure[e] * gg[k, m]


def laplacian_reference(grads, measure, cells, n_nodes):
    """scipy reference of :func:`laplacian_values`: the full matrix (CSR, duplicates summed)."""
    nv = cells.shape[1]
    Le = np.einsum("e,ekc,emc->ekm", measure, grads, grads)
    rows = np.repeat(cells, nv, axis=1).ravel()
    cols = np.tile(cells, (1, nv)).ravel()
    L = sp.csr_matrix((Le.ravel(), (rows, cols)), shape=(n_nodes, n_nodes))
    L.sum_duplicates()
    return L


@njit(cache=True)
def lumped_measure(measure, cells, n_nodes):
    """``m_i = sum_{e ni i} |e| / (d + 1)``, shape (n_nodes,)."""
    n_cells, nv = cells.shape
    out = np.zeros(n_nodes, dtype=np.float64)
    for e in range(n_cells):
        v = measure[e] / nv
        for k in range(nv):
            out[cells[e, k]] += v
    return out


def lumped_measure_reference(measure, cells, n_nodes):
    """NumPy reference of :func:`lumped_measure`."""
    nv = cells.shape[1]
    return np.bincount(cells.ravel(), weights=np.repeat(measure / nv, nv), minlength=n_nodes)
