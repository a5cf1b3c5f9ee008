"""Checks shared by the ``fem3d`` tests: of meshes (orientation, boundary, measures, groups),
of matrices (relative difference), of nodal forces (resultant force and moment), and of
convergence (the fitted order of an error).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp


# --- meshes --------------------------------------------------------------------------------------

def signed_measures(mesh):
    """Signed areas (2D) or volumes (3D) of the cells."""
    edges = mesh.points[mesh.cells[:, 1:]] - mesh.points[mesh.cells[:, :1]]
    return np.linalg.det(edges) / math.factorial(mesh.dim)


def edge_lengths(mesh):
    """Lengths of every cell's edges, shape (n_cells, number of edges of a cell)."""
    k = mesh.dim + 1
    pairs = [(i, j) for i in range(k) for j in range(i + 1, k)]
    p = mesh.points[mesh.cells]
    return np.stack([np.linalg.norm(p[:, i] - p[:, j], axis=1) for i, j in pairs], axis=1)


def boundary_facets(mesh):
    """The facets (sorted vertex tuples) that belong to one cell only."""
    k = mesh.dim + 1
    faces = np.concatenate([np.delete(mesh.cells, i, axis=1) for i in range(k)])
    faces, counts = np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)
    return {tuple(f) for f in faces[counts == 1]}


def facet_measures(mesh, facets):
    """Lengths (2D) or areas (3D) of ``facets``."""
    p = mesh.points[facets]
    if mesh.dim == 2:
        return np.linalg.norm(p[:, 1] - p[:, 0], axis=1)
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def check_common(mesh):
    """Positive orientation, every node in a cell, every facet group on the boundary."""
    assert mesh.points.shape[1] == mesh.dim
    assert np.all(signed_measures(mesh) > 0.0)
    assert np.array_equal(np.unique(mesh.cells), np.arange(mesh.n_nodes))
    boundary = boundary_facets(mesh)
    for name, facets in mesh.facet_groups.items():
        assert facets.shape[1] == mesh.dim and len(facets) > 0, name
        assert {tuple(f) for f in np.sort(facets, axis=1)} <= boundary, name


# --- matrices, forces and convergence ------------------------------------------------------------

def rel_diff(A, B):
    A = A.toarray() if sp.issparse(A) else np.asarray(A)
    B = B.toarray() if sp.issparse(B) else np.asarray(B)
    return float(np.abs(A - B).max() / np.abs(B).max())


def force_and_moment(points, dim, dofs, r):
    """Resultant force and moment (about the origin) of nodal forces ``r`` on ``dofs``."""
    F = np.zeros((points.shape[0], dim))
    F.reshape(-1)[dofs] = r
    if dim == 2:
        return F.sum(axis=0), np.array([np.sum(points[:, 0] * F[:, 1] - points[:, 1] * F[:, 0])])
    return F.sum(axis=0), np.cross(points, F).sum(axis=0)


def fitted_order(h, err):
    return float(np.polyfit(np.log(h), np.log(err), 1)[0])
