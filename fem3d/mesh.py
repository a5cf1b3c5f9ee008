"""A simplicial mesh with named regions and boundaries: the object every part of the
finite-element model is built on.

Triangles in 2D, tetrahedra in 3D (P1: the nodes are the vertices). Named groups come from the
geometry's physical groups (:mod:`fem3d.specimens`) or from a ``.msh`` file:

* ``cell_groups``: regions, as cell indices (e.g. ``"gray"``, the coarse region where damage
  is held at 0);
* ``facet_groups``: boundaries, as facets (segments in 2D, triangles in 3D) given by their
  vertices (e.g. ``"bottom"``, where the panel is clamped);
* ``node_groups``: named points (e.g. a load point), as node indices.

Lengths are in the scene's unit (mm for the dissertation's concrete panels).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["Mesh", "mesh_geometry"]


@dataclass(frozen=True, eq=False)
class Mesh:
    """Vertices, cells and named groups.

    Attributes
    ----------
    points : ndarray, shape (n_nodes, dim), float64
        Vertex coordinates.
    cells : ndarray, shape (n_cells, dim + 1), int64
        Vertex indices of each triangle or tetrahedron, positively oriented (positive
        signed area or volume).
    cell_groups : dict of str -> ndarray of int64
        Named regions: indices into ``cells``.
    facet_groups : dict of str -> ndarray, shape (k, dim), int64
        Named boundaries: the vertex indices of each facet.
    node_groups : dict of str -> ndarray of int64
        Named points: node indices.
    """

    points: np.ndarray
    cells: np.ndarray
    cell_groups: dict = field(default_factory=dict)
    facet_groups: dict = field(default_factory=dict)
    node_groups: dict = field(default_factory=dict)

    def __post_init__(self):
        points = np.ascontiguousarray(self.points, dtype=np.float64)
        cells = np.ascontiguousarray(self.cells, dtype=np.int64)
        if points.ndim != 2 or points.shape[1] not in (2, 3):
            raise ValueError(f"points must have shape (n, 2) or (n, 3), got {points.shape}")
        if cells.ndim != 2 or cells.shape[1] != points.shape[1] + 1:
            raise ValueError(f"cells must have shape (m, {points.shape[1] + 1}) for a {points.shape[1]}D mesh,"
                             f" got {cells.shape}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "cells", cells)

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])

    @property
    def n_nodes(self) -> int:
        return int(self.points.shape[0])

    @property
    def n_cells(self) -> int:
        return int(self.cells.shape[0])

    def group_names(self):
        """Every group name, by kind: ``{"cells": [...], "facets": [...], "nodes": [...]}``."""
        return {"cells": sorted(self.cell_groups), "facets": sorted(self.facet_groups),
                "nodes": sorted(self.node_groups)}

    def nodes_of(self, name) -> np.ndarray:
        """The nodes of group ``name`` (a region's, a boundary's or a point group's), sorted.

        Raises
        ------
        KeyError
            If no group has that name (the message lists them).
        """
        if name in self.facet_groups:
            return np.unique(self.facet_groups[name])
        if name in self.node_groups:
            return np.unique(self.node_groups[name])
        if name in self.cell_groups:
            return np.unique(self.cells[self.cell_groups[name]])
        raise KeyError(f"no group {name!r} in the mesh (groups: {self.group_names()})")

    def description(self):
        """The mesh as results files, XDMF and plots see it
        (:class:`thinfilm.discretization.SimplexMesh`)."""
        from thinfilm.discretization import SimplexMesh

        return SimplexMesh(self.points, self.cells)


def mesh_geometry(mesh: Mesh):
    """``(grads, measure)`` of the mesh's cells (:func:`fem3d.kernels.cell_geometry`: the P1
    basis gradients, shape (n_cells, d + 1, d), and the areas or volumes, shape (n_cells,)),
    after checking that no cell is degenerate and every node belongs to a cell.

    Raises
    ------
    TypeError
        If ``mesh`` is no :class:`Mesh`.
    ValueError
        Naming the first degenerate cell or the first node of no cell.
    """
    from fem3d import kernels   # Numba: loaded with the operators, not with the mesh

    if not isinstance(mesh, Mesh):
        raise TypeError(f"mesh = {mesh!r} must be a fem3d.mesh.Mesh")
    grads, measure = kernels.cell_geometry(mesh.points, mesh.cells)
    bad = np.flatnonzero(~(measure > 0) | ~np.isfinite(measure))
    if bad.size:
        raise ValueError(f"{bad.size} degenerate cell(s) (zero area or volume), the first: cell {bad[0]}"
                         f" with vertices {mesh.cells[bad[0]].tolist()}")
    used = np.zeros(mesh.n_nodes, dtype=bool)
    used[mesh.cells.ravel()] = True
    if not used.all():
        orphans = np.flatnonzero(~used)
        raise ValueError(f"{orphans.size} node(s) belong to no cell (their unknowns would be undetermined),"
                         f" the first: node {orphans[0]}")
    return grads, measure
