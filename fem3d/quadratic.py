r"""The P2 (quadratic) displacement space on a P1 mesh: edge midpoints, 6-node triangles and
10-node tetrahedra, quadrature rules, and the node set with the mesh's groups carried over.

Nodes and numbering
===================
The P2 nodes are the mesh's vertices, in the mesh's own numbering, then the midpoints of its
edges: node ``n_vertices + k`` is the midpoint of edge ``k``. Edges are numbered in the order
in which the cells first meet them (cell by cell, each cell's edges in the local order below),
so they follow the cells' order along the mesh, which keeps the assembly's memory access local.
A cell's P2 nodes are its ``d + 1`` vertices then its local edges' midpoints::

    triangle     (6 nodes):  0 1 2,  edges (0, 1) (1, 2) (0, 2)
    tetrahedron (10 nodes):  0 1 2 3, edges (0, 1) (1, 2) (0, 2) (0, 3) (1, 3) (2, 3)

(the vertex and edge order of VTK's quadratic triangle and tetrahedron). With the barycentric coordinates ``l_k`` of the cell,
the basis is ``l_k (2 l_k - 1)`` at vertex ``k`` and ``4 l_k l_m`` at the midpoint of edge
``(k, m)``; their gradients, ``(4 l_k - 1) grad l_k`` and ``4 (l_k grad l_m + l_m grad l_k)``,
come from the P1 gradients (:func:`fem3d.kernels.cell_geometry`): cells are straight-sided.

Groups (:class:`QuadraticSpace`)
================================
A region keeps its cells (its P2 nodes: all those of its cells); a boundary keeps its facets,
each with its edges' midpoints (a 3-node segment in 2D, a 6-node triangle in 3D), so its P2
nodes are its vertices and those midpoints; a group of named points keeps its vertices.

Quadrature
==========
Rules on the reference simplex are given in barycentric coordinates, shape (n_points, d + 1),
with weights summing to 1 (multiply by the cell's measure):

- :data:`STIFFNESS_RULES`: degree 2, the rule of the stiffness (the strain of a P2 field is
  linear in a cell, so ``e:C:e`` is quadratic and the rule is exact): 3 points on triangles
  (``(2/3, 1/6, 1/6)`` and permutations, weights 1/3), 4 on tetrahedra (``(a, b, b, b)`` and
  permutations, ``a = (5 + 3 sqrt 5)/20``, ``b = (5 - sqrt 5)/20``, weights 1/4);
- :func:`collapsed_gauss`: conical-product Gauss rules of any degree, for load vectors of
  smooth body forces and for errors against smooth fields.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.special import roots_jacobi

from fem3d.mesh import Mesh
from thinfilm.discretization import SimplexMesh

__all__ = ["LOCAL_EDGES", "STIFFNESS_RULES", "FACET_SHARES", "collapsed_gauss", "edge_numbering", "basis_values",
           "QuadraticSpace", "QuadraticMeshDescription"]

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


@lru_cache(maxsize=None)
def collapsed_gauss(dim: int, n: int):
    """A conical-product Gauss rule on the reference simplex, exact for polynomials of degree
    ``2 n - 1``: ``n^dim`` points with positive weights (Gauss-Jacobi in the collapsed
    directions, Stroud's construction).

    Returns
    -------
    bary : ndarray, shape (n^dim, dim + 1)
        Barycentric coordinates of the points.
    weights : ndarray, shape (n^dim,)
        Summing to 1 (fractions of the cell's measure).
    """
    if dim not in (2, 3) or n < 1:
        raise ValueError(f"dim = {dim!r} must be 2 or 3 and n = {n!r} >= 1")
    # Int_0^1 (1 - s)^k f(s) ds by Gauss-Jacobi on [-1, 1] with weight (1 - x)^k, s = (1 + x)/2
    rules = []
    for k in range(dim - 1, -1, -1):
        x, w = roots_jacobi(n, k, 0.0)
        rules.append(((1.0 + x) / 2.0, w / 2.0 ** (k + 1)))
    grids = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    weights = np.ones_like(grids[0])
    for axis, (_, w) in enumerate(rules):
        shape = [1] * dim
        shape[axis] = n
        weights = weights * w.reshape(shape)
    s = [g.ravel() for g in grids]
    # x_1 = s_1, x_2 = s_2 (1 - s_1), x_3 = s_3 (1 - s_1)(1 - s_2): Jacobian (1 - s_1)^(d-1) (1 - s_2)^(d-2)
    coords, rest = [], np.ones_like(s[0])
    for k in range(dim):
        coords.append(s[k] * rest)
        rest = rest * (1.0 - s[k])
    x = np.column_stack(coords)
    bary = np.column_stack([1.0 - x.sum(axis=1), x])
    weights = weights.ravel() * math.factorial(dim)
    bary.flags.writeable = weights.flags.writeable = False
    return bary, weights


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


class QuadraticSpace:
    """The P2 nodes of a P1 mesh, its 6- or 10-node cells and its groups.

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
    """

    def __init__(self, mesh: Mesh):
        if not isinstance(mesh, Mesh):
            raise TypeError(f"mesh = {mesh!r} must be a fem3d.mesh.Mesh")
        self.mesh = mesh
        self.dim = d = mesh.dim
        self.n_vertices = mesh.n_nodes
        self.edges, cell_edges = edge_numbering(mesh.cells)
        self.n_edges = int(self.edges.shape[0])
        self.n_nodes = self.n_vertices + self.n_edges
        self.cells = np.ascontiguousarray(np.concatenate([mesh.cells, self.n_vertices + cell_edges], axis=1))
        midpoints = 0.5 * (mesh.points[self.edges[:, 0]] + mesh.points[self.edges[:, 1]])
        self.points = np.concatenate([mesh.points, midpoints])
        self.cell_groups = mesh.cell_groups
        self.node_groups = mesh.node_groups
        self.facet_groups = {name: self.facet_nodes(facets, name) for name, facets in mesh.facet_groups.items()}
        self.facet_shares = FACET_SHARES[d]
        for a in (self.edges, self.cells, self.points):
            a.flags.writeable = False

    @property
    def n_cells(self) -> int:
        return self.mesh.n_cells

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

    def group_names(self):
        """Every group name, by kind (those of the mesh)."""
        return self.mesh.group_names()

    def nodes_of(self, name) -> np.ndarray:
        """The P2 nodes of group ``name``, sorted: a boundary's vertices and its facets' edge
        midpoints; a point group's vertices; all the nodes of a region's cells.

        Raises
        ------
        KeyError
            If no group has that name.
        """
        return Mesh.nodes_of(self, name)   # the same lookup, on this space's cells and groups

    def facet_load(self, facets, name="facets"):
        """``(nodes, shares)`` of the consistent load of a constant traction on ``facets``
        (vertices, shape (k, d)): each facet's P2 nodes (k, 3 or 6) and the fraction of the
        facet's measure each receives (:data:`FACET_SHARES`)."""
        return self.facet_nodes(facets, name), self.facet_shares

    # --- fields on the space -------------------------------------------------------------------
    def interpolate(self, function) -> np.ndarray:
        """The P2 interpolant of ``function`` (values at the nodes), flat ``node * d + component``.

        Parameters
        ----------
        function : callable
            ``function(x)`` with ``x`` of shape (n, d) returns an array of shape (n, d).
        """
        return np.asarray(function(self.points), dtype=np.float64).reshape(self.n_nodes * self.dim)

    def points_at(self, bary) -> np.ndarray:
        """The physical points of barycentric coordinates ``bary`` (n_p, d + 1) in every cell,
        shape (n_cells, n_p, d)."""
        return np.einsum("pk,ekc->epc", np.asarray(bary, dtype=np.float64), self.mesh.points[self.mesh.cells])

    def evaluate(self, u, bary) -> np.ndarray:
        """A P2 field ``u`` (flat, ``node * d + component``) at barycentric points of every cell,
        shape (n_cells, n_p, d)."""
        phi = basis_values(bary, self.dim)
        ue = np.asarray(u, dtype=np.float64).reshape(self.n_nodes, self.dim)[self.cells]  # (n_cells, nl, d)
        return np.einsum("pk,ekc->epc", phi, ue)

    def body_force(self, force, measure, thickness=1.0, n=4) -> np.ndarray:
        """The consistent load vector ``f_(i, a) = T Int force_a phi_i`` of a body force.

        Parameters
        ----------
        force : callable or array of shape (d,)
            ``force(x)``, x of shape (n, d), returns (n, d) (force per volume); or a constant.
        measure : ndarray, shape (n_cells,)
            The cells' areas or volumes (:func:`fem3d.kernels.cell_geometry`).
        thickness : float
            2D slab thickness (1 in 3D).
        n : int
            Points per direction of the :func:`collapsed_gauss` rule (exact to degree
            ``2 n - 1``: the product of a constant force and the basis needs ``n = 2``).

        Returns
        -------
        ndarray, shape (n_nodes * d,)
        """
        d = self.dim
        bary, weights = collapsed_gauss(d, n)
        if callable(force):
            x = self.points_at(bary)
            values = np.asarray(force(x.reshape(-1, d)), dtype=np.float64).reshape(x.shape)
        else:
            values = np.broadcast_to(np.asarray(force, dtype=np.float64), (self.n_cells, bary.shape[0], d))
        phi = basis_values(bary, d)
        local = np.einsum("e,p,pk,epc->ekc", thickness * np.asarray(measure), weights, phi, values)
        out = np.zeros(self.n_nodes * d)
        for c in range(d):
            out[c::d] = np.bincount(self.cells.ravel(), weights=local[:, :, c].ravel(), minlength=self.n_nodes)
        return out

    def description(self) -> QuadraticMeshDescription:
        """The mesh as the results file sees it (:class:`QuadraticMeshDescription`)."""
        return QuadraticMeshDescription(self.mesh.points, self.mesh.cells, self.edges)
