r"""The P2 element: quadratic displacements on a P1 mesh (6-node triangles, 10-node
tetrahedra), the damage staying P1 on the vertices.

Nodes and numbering
===================
The P2 nodes are the mesh's vertices, in the mesh's own numbering, then the midpoints of its
edges: node ``n_vertices + k`` is the midpoint of edge ``k``. Edges are numbered in the order
in which the cells first meet them (cell by cell, each cell's edges in the local order below),
so they follow the cells' order along the mesh, which keeps the assembly's memory access local.
A cell's P2 nodes are its ``d + 1`` vertices then its local edges' midpoints::

    triangle     (6 nodes):  0 1 2,  edges (0, 1) (1, 2) (0, 2)
    tetrahedron (10 nodes):  0 1 2 3, edges (0, 1) (1, 2) (0, 2) (0, 3) (1, 3) (2, 3)

(the vertex and edge order of VTK's quadratic triangle and tetrahedron). With the barycentric
coordinates ``l_k`` of the cell, the basis is ``l_k (2 l_k - 1)`` at vertex ``k`` and
``4 l_k l_m`` at the midpoint of edge ``(k, m)``; their gradients, ``(4 l_k - 1) grad l_k`` and
``4 (l_k grad l_m + l_m grad l_k)``, come from the P1 gradients
(:func:`fem3d.kernels.cell_geometry`): cells are straight-sided.

Energy (``docs/model.md#p2-displacement``)
==========================================
The strain is linear in a cell, so ``psi = e:C:e / 2`` is quadratic and the degree-2 rule of
:data:`STIFFNESS_RULES` integrates it exactly: 3 points on triangles (``(2/3, 1/6, 1/6)``
and permutations, weights 1/3), 4 on tetrahedra (``(a, b, b, b)`` and permutations,
``a = (5 + 3 sqrt 5)/20``, ``b = (5 - sqrt 5)/20``, weights 1/4). The basis gradients at
those points are stored per cell (:attr:`P2Space.basis_gradients`, ``n_q nl d`` floats: 288
bytes per triangle, 960 per tetrahedron).

Groups (:class:`P2Space`)
=========================
A region keeps its cells (its P2 nodes: all those of its cells); a boundary keeps its facets,
each with its edges' midpoints (a 3-node segment in 2D, a 6-node triangle in 3D), so its P2
nodes are its vertices and those midpoints; a group of named points keeps its vertices.
"""


from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from fem3d.elements.space import Space
from thinfilm.discretization import SimplexMesh

__all__ = ["LOCAL_EDGES", "STIFFNESS_RULES", "FACET_SHARES", "edge_numbering", "basis_values", "basis_gradients",
           "P2Space", "QuadraticMeshDescription", "SPACE"]

#: Each cell's edges as pairs of its local vertices, by dimension (module docstring).
LOCAL_EDGES = {2: np.array([(0, 1), (1, 2), (0, 2)], dtype=np.int64),
               3: np.array([(0, 1), (1, 2), (0, 2), (0, 3), (1, 3), (2, 3)], dtype=np.int64)}

_A, _B = (5.0 + 3.0 * math.sqrt(5.0)) / 20.0, (5.0 - math.sqrt(5.0)) / 20.0
#: Degree-2 rules ``(barycentric points (n_q, d + 1), weights (n_q,) summing to 1)`` by dimension.
STIFFNESS_RULES = {
    2: (np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]), np.full(3, 1 / 3)),
    3: (np.array([[_A, _B, _B, _B], [_B, _A, _B, _B], [_B, _B, _A, _B], [_B, _B, _B, _A]]), np.full(4, 0.25)),
}

#: The consistent load of a constant traction on a boundary facet, as fractions of the facet's
#: length or area given to its P2 nodes (vertices first, then the edges' midpoints): the
#: integrals of the facet's P2 basis functions. 2D 3-node segment: 1/6, 1/6, 2/3; 3D 6-node
#: triangle: 0 at the vertices, 1/3 at each midpoint.
FACET_SHARES = {2: np.array([1 / 6, 1 / 6, 2 / 3]), 3: np.array([0.0, 0.0, 0.0, 1 / 3, 1 / 3, 1 / 3])}


def basis_values(bary, dim: int) -> np.ndarray:
    """The P2 basis functions of a cell at points given by barycentric coordinates.

    Parameters
    ----------
    bary : ndarray, shape (n_points, d + 1)
    dim : {2, 3}

    Returns
    -------
    ndarray, shape (n_points, 6) in 2D, (n_points, 10) in 3D
        In the cell's P2 node order (vertices, then the local edges' midpoints).
    """
    bary = np.asarray(bary, dtype=np.float64)
    edges = LOCAL_EDGES[dim]
    return np.concatenate([bary * (2.0 * bary - 1.0), 4.0 * bary[:, edges[:, 0]] * bary[:, edges[:, 1]]], axis=1)


def basis_gradients(grads, bary, dim: int) -> np.ndarray:
    """The P2 basis gradients of every cell at barycentric points, from the P1 gradients (the
    product rule on ``l_k (2 l_k - 1)`` and ``4 l_k l_m``).

    Parameters
    ----------
    grads : ndarray, shape (n_cells, d + 1, d)
        The P1 basis gradients (:func:`fem3d.kernels.cell_geometry`), 1 / length.
    bary : ndarray, shape (n_points, d + 1)
    dim : {2, 3}

    Returns
    -------
    ndarray, shape (n_cells, n_points, 6 or 10, d)
        In the cell's P2 node order.
    """
    bary = np.asarray(bary, dtype=np.float64)
    edges = LOCAL_EDGES[dim]
    k, m = edges[:, 0], edges[:, 1]
    vertex = np.einsum("qk,ekc->eqkc", 4.0 * bary - 1.0, grads)
    edge = 4.0 * (np.einsum("qs,esc->eqsc", bary[:, k], grads[:, m])
                  + np.einsum("qs,esc->eqsc", bary[:, m], grads[:, k]))
    return np.concatenate([vertex, edge], axis=2)


def edge_numbering(cells) -> tuple[np.ndarray, np.ndarray]:
    """The edges of a mesh, numbered in the order the cells first meet them.

    Parameters
    ----------
    cells : ndarray of int, shape (n_cells, d + 1)

    Returns
    -------
    edges : ndarray of int64, shape (n_edges, 2)
        Each edge's vertices, the smaller first.
    cell_edges : ndarray of int64, shape (n_cells, 3) in 2D, (n_cells, 6) in 3D
        Each cell's edges in the local order of :data:`LOCAL_EDGES`.
    """
    cells = np.asarray(cells, dtype=np.int64)
    local = LOCAL_EDGES[cells.shape[1] - 1]
    pairs = np.sort(np.stack([cells[:, local[:, 0]], cells[:, local[:, 1]]], axis=2).reshape(-1, 2), axis=1)
    n = int(cells.max()) + 1 if cells.size else 0
    keys = pairs[:, 0] * n + pairs[:, 1]
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return pairs[first[order]], rank[inverse.ravel()].reshape(cells.shape[0], local.shape[0])


@dataclass(frozen=True, eq=False)
class QuadraticMeshDescription(SimplexMesh):
    """The mesh of a P2 run as the results file sees it: the P1 mesh (vertices and cells, on
    which the damage lives and which XDMF and the plots draw) and its edges, whose midpoints
    carry the rest of the displacement.

    ``/fields/u`` holds ``(n_vertices + n_edges) * d`` values per step: the vertices' first
    (a P1 nodal field of ``/mesh``, what XDMF shows and :meth:`thinfilm.results.reader.Results.field`
    returns), then the midpoints of ``/mesh/edges`` in order. Read back, the file's ``/mesh``
    is a plain :class:`~thinfilm.discretization.SimplexMesh` with an extra ``edges`` dataset.
    """

    edges: np.ndarray = None

    def describe(self):
        return super().describe() + f"; P2 displacement on {self.n_nodes + len(self.edges)} nodes"

    def write(self, f):
        """``/mesh`` of :class:`SimplexMesh`, with ``edges`` (n_edges, 2) and attr element = "P2"."""
        super().write(f)
        g = f[self.group]
        g.attrs["element"] = "P2"
        g["edges"] = np.asarray(self.edges, dtype=np.int64)


class P2Space(Space):
    """The P2 nodes of a P1 mesh, its 6- or 10-node cells and its groups
    (:class:`fem3d.elements.space.Space`; module docstring).

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh

    Attributes
    ----------
    mesh : Mesh
        The P1 mesh (the vertices carry the damage).
    dim, n_vertices, n_edges, n_nodes : int
        ``n_nodes = n_vertices + n_edges``.
    edges : ndarray of int64, shape (n_edges, 2)
        Vertex pairs (:func:`edge_numbering`).
    cells : ndarray of int64, shape (n_cells, 6) in 2D, (n_cells, 10) in 3D
        Each cell's P2 nodes (module docstring).
    points : ndarray, shape (n_nodes, dim)
        Node coordinates: the vertices, then the edges' midpoints.
    cell_groups, node_groups : dict
        The mesh's, unchanged.
    facet_groups : dict of str -> ndarray, shape (k, 3) in 2D, (k, 6) in 3D
        Each boundary facet's P2 nodes: its vertices, then its edges' midpoints (2D: the
        segment's; 3D: in the local edge order (0, 1), (1, 2), (0, 2) of the facet).
    facet_shares : ndarray, shape (3,) or (6,)
        :data:`FACET_SHARES` of the dimension.
    bary, weights : ndarray
        :data:`STIFFNESS_RULES` of the dimension.
    """

    name = "P2"

    def __init__(self, mesh):
        super().__init__(mesh)
        d = self.dim
        self.edges, cell_edges = edge_numbering(mesh.cells)
        self.n_edges = int(self.edges.shape[0])
        self.cells = np.ascontiguousarray(np.concatenate([mesh.cells, self.n_vertices + cell_edges], axis=1))
        midpoints = 0.5 * (mesh.points[self.edges[:, 0]] + mesh.points[self.edges[:, 1]])
        self.points = np.concatenate([mesh.points, midpoints])
        self.facet_groups = {name: self.facet_nodes(facets, name) for name, facets in mesh.facet_groups.items()}
        self.facet_shares = FACET_SHARES[d]
        self.bary, self.weights = (np.ascontiguousarray(a) for a in STIFFNESS_RULES[d])
        for a in (self.edges, self.cells, self.points):
            a.flags.writeable = False

    def edge_index(self, a, b, name="facets") -> np.ndarray:
        """The edge numbers of the vertex pairs ``(a[i], b[i])``.

        Raises
        ------
        ValueError
            If a pair is no edge of the mesh's cells (naming ``name``).
        """
        a, b = np.asarray(a, dtype=np.int64), np.asarray(b, dtype=np.int64)
        n = self.n_vertices
        keys = np.minimum(a, b) * n + np.maximum(a, b)
        edge_keys = self.edges[:, 0] * n + self.edges[:, 1]
        order = np.argsort(edge_keys)
        sorted_keys = edge_keys[order]
        pos = np.clip(np.searchsorted(sorted_keys, keys), 0, order.size - 1)
        bad = np.flatnonzero(sorted_keys[pos] != keys) if order.size else np.arange(keys.size)
        if bad.size:
            k = bad[0]
            raise ValueError(f"{name}: the segment ({int(a.ravel()[k])}, {int(b.ravel()[k])}) is no edge of the"
                             " mesh's cells")
        return order[pos]

    def facet_nodes(self, facets, name="facets") -> np.ndarray:
        """The P2 nodes of boundary facets given by their vertices.

        Parameters
        ----------
        facets : ndarray of int, shape (k, d)
            Segments (2D) or triangles (3D).

        Returns
        -------
        ndarray of int64, shape (k, 3) in 2D, (k, 6) in 3D
            The vertices, then the midpoints of the facet's edges ((0, 1) in 2D; (0, 1),
            (1, 2), (0, 2) in 3D).
        """
        facets = np.asarray(facets, dtype=np.int64).reshape(-1, self.dim)
        local = np.array([(0, 1)]) if self.dim == 2 else LOCAL_EDGES[2]
        mid = self.n_vertices + self.edge_index(facets[:, local[:, 0]], facets[:, local[:, 1]], name)
        return np.concatenate([facets, mid.reshape(facets.shape[0], -1)], axis=1)

    def facet_load(self, facets, area, name="facets"):
        """Each facet's P2 nodes (k, 3 or 6) and ``area`` times :data:`FACET_SHARES` (the
        integrals of the facet's P2 basis functions); see
        :meth:`fem3d.elements.space.Space.facet_load`."""
        return self.facet_nodes(facets, name), np.asarray(area)[:, None] * self.facet_shares

    def basis_values(self, bary) -> np.ndarray:
        return basis_values(bary, self.dim)

    def gradients_at(self, bary) -> np.ndarray:
        return basis_gradients(self.grads, bary, self.dim)

    def description(self) -> QuadraticMeshDescription:
        """The mesh as the results file sees it (:class:`QuadraticMeshDescription`)."""
        return QuadraticMeshDescription(self.mesh.points, self.mesh.cells, edges=self.edges)


SPACE = P2Space
