"""Test meshes of P1 finite elements, shared by the ``fem3d`` tests.

Structured triangulations with diagonals alternating from row to row (every interior node has
six triangles) and Kuhn tetrahedralizations (six tetrahedra per cube around its main
diagonal), optionally with the interior nodes jittered; the small jittered mesh most tests
start from; and a mesh as scikit-fem's, for the tests that compare with it.
"""

from __future__ import annotations

from itertools import permutations

import numpy as np
import skfem

from fem3d.mesh import Mesh


def tri_mesh(nx, ny, lx=1.0, ly=1.0, x0=0.0, y0=0.0, jitter=0.0, seed=0):
    """``nx * ny`` rectangles of ``[x0, x0 + lx] x [y0, y0 + ly]``, two triangles each, the
    diagonal direction alternating from row to row; interior nodes moved by up to
    ``jitter / 2`` cell sizes in each direction."""
    x = x0 + np.linspace(0.0, lx, nx + 1)
    y = y0 + np.linspace(0.0, ly, ny + 1)
    X, Y = np.meshgrid(x, y)
    points = np.column_stack([X.ravel(), Y.ravel()])
    i, j = (a.ravel() for a in np.meshgrid(np.arange(nx), np.arange(ny)))
    bl = j * (nx + 1) + i
    br, tl = bl + 1, bl + nx + 1
    tr = tl + 1
    up = (j % 2 == 0)[:, None]
    t1 = np.where(up, np.column_stack([bl, br, tr]), np.column_stack([bl, br, tl]))
    t2 = np.where(up, np.column_stack([bl, tr, tl]), np.column_stack([br, tr, tl]))
    cells = np.stack([t1, t2], axis=1).reshape(-1, 3)
    return _jittered(points, cells, np.array([lx / nx, ly / ny]), jitter, seed)


def tet_mesh(n, lengths=(1.0, 1.0, 1.0), jitter=0.0, seed=0):
    """Kuhn tetrahedralization of ``n[0] x n[1] x n[2]`` boxes of ``[0, lengths]``: each box
    split into the six tetrahedra ``0 -> e_p -> e_p + e_q -> (1, 1, 1)``."""
    n = np.broadcast_to(np.asarray(n), (3,))
    axes = [np.linspace(0.0, lengths[k], n[k] + 1) for k in range(3)]
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(order="F"), Y.ravel(order="F"), Z.ravel(order="F")])

    def node(i, j, k):
        return i + (n[0] + 1) * (j + (n[1] + 1) * k)

    i, j, k = (a.ravel(order="F") for a in np.meshgrid(*(np.arange(m) for m in n), indexing="ij"))
    cells = []
    for perm in permutations(range(3)):
        v = np.zeros(3, dtype=int)
        verts = [node(i, j, k)]
        for p in perm:
            v[p] += 1
            verts.append(node(i + v[0], j + v[1], k + v[2]))
        cells.append(np.column_stack(verts))
    cells = np.stack(cells, axis=1).reshape(-1, 4)
    h = np.asarray(lengths) / n
    return _jittered(points, cells, h, jitter, seed)


def _jittered(points, cells, h, jitter, seed):
    if jitter:
        lo, hi = points.min(axis=0), points.max(axis=0)
        interior = np.all((points > lo + 1e-12) & (points < hi - 1e-12), axis=1)
        rng = np.random.default_rng(seed)
        points = points.copy()
        points[interior] += jitter * h * (rng.random((interior.sum(), points.shape[1])) - 0.5)
    # positive orientation, as fem3d.mesh.Mesh promises
    edges = points[cells[:, 1:]] - points[cells[:, :1]]
    neg = np.linalg.det(edges) < 0
    cells = cells.copy()
    cells[neg, 1], cells[neg, 2] = cells[neg, 2].copy(), cells[neg, 1].copy()
    edges = points[cells[:, 1:]] - points[cells[:, :1]]
    assert np.all(np.linalg.det(edges) > 0)
    return Mesh(points, cells)


def small_mesh(dim, jitter=0.3):
    return tri_mesh(6, 5, 1.2, 0.9, jitter=jitter) if dim == 2 else tet_mesh((3, 3, 2), (1.0, 0.8, 0.7), jitter=jitter)


def to_skfem(mesh):
    cls = skfem.MeshTri if mesh.dim == 2 else skfem.MeshTet
    return cls(mesh.points.T.copy(), mesh.cells.T.copy())


def boundary_nodes(mesh):
    """Nodes on the faces of the mesh's bounding box."""
    lo, hi = mesh.points.min(axis=0), mesh.points.max(axis=0)
    tol = 1e-12 * float(np.ptp(mesh.points, axis=0).max())
    return np.flatnonzero(np.any((mesh.points < lo + tol) | (mesh.points > hi - tol), axis=1))


def node_dofs(nodes, dim, components=None):
    comps = range(dim) if components is None else components
    return np.sort(np.concatenate([np.asarray(nodes) * dim + a for a in comps]))
