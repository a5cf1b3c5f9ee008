r"""A displacement element on a simplicial mesh: what the elasticity operator needs of it.

A :class:`Space` is the displacement's finite-element space on a :class:`fem3d.mesh.Mesh`
(triangles in 2D, tetrahedra in 3D, straight-sided; the damage stays P1 on the vertices):

- its nodes: :attr:`~Space.points` (n_nodes, d), the mesh's vertices first in the mesh's
  numbering, then any others; each cell's ``nl`` nodes, :attr:`~Space.cells` (n_cells, nl);
  the displacement's dofs are ``node * d + component``;
- its quadrature rule of the stiffness and the energies, :attr:`~Space.bary` (n_q, d + 1)
  and :attr:`~Space.weights` (n_q,) summing to 1 (:mod:`fem3d.elements.quadrature`), and the
  basis gradients at those points, :attr:`~Space.basis_gradients` (n_cells, n_q, nl, d);
- its basis at any barycentric points (:meth:`~Space.basis_values`,
  :meth:`~Space.gradients_at`), hence interpolation, evaluation and body-force loads;
- how a boundary facet's traction is shared among its nodes (:meth:`~Space.facet_load`) and
  the nodes of the mesh's named groups (:meth:`~Space.nodes_of`);
- the description the results file stores (:meth:`~Space.description`).

A quantity "at the points" has shape (n_cells, n_q), or (n_cells,) for a one-point rule
(:attr:`~Space.point_shape`). The stiffness, right-hand side, strain and energy density are
the kernels of :mod:`fem3d.kernels` over the basis gradients; a subclass may replace them by
faster ones with the same results (the P1 element does: :mod:`fem3d.elements.p1`).

A subclass sets, in its ``__init__`` after ``super().__init__(mesh)``: :attr:`points`,
:attr:`cells`, :attr:`facet_groups`, :attr:`bary`, :attr:`weights`; and defines
:meth:`basis_values`, :meth:`gradients_at` and :meth:`facet_load`.
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from fem3d import kernels
from fem3d.elements.quadrature import collapsed_gauss
from fem3d.mesh import Mesh, mesh_geometry

__all__ = ["Space"]


class Space:
    """The displacement's element on a mesh (module docstring).

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh

    Attributes
    ----------
    name : str
        The element's name in :data:`fem3d.elements.ELEMENTS`.
    mesh : Mesh
        The P1 mesh (the vertices carry the damage).
    dim : int
    points : ndarray, shape (n_nodes, dim)
        The nodes' coordinates (length).
    cells : ndarray of int64, shape (n_cells, nl)
        Each cell's nodes.
    cell_groups, node_groups : dict
        The mesh's.
    facet_groups : dict of str -> ndarray of int64
        Each boundary facet's nodes.
    bary : ndarray, shape (n_q, dim + 1)
    weights : ndarray, shape (n_q,)
        The stiffness's quadrature rule, weights summing to 1.
    """

    name = ""

    def __init__(self, mesh: Mesh):
        if not isinstance(mesh, Mesh):
            raise TypeError(f"mesh = {mesh!r} must be a fem3d.mesh.Mesh")
        self.mesh = mesh
        self.dim = mesh.dim
        self.cell_groups = mesh.cell_groups
        self.node_groups = mesh.node_groups

    # --- sizes --------------------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        """Number of displacement nodes."""
        return int(self.points.shape[0])

    @property
    def n_vertices(self) -> int:
        """Number of the mesh's vertices (the first nodes)."""
        return self.mesh.n_nodes

    @property
    def n_cells(self) -> int:
        return self.mesh.n_cells

    @property
    def n_q(self) -> int:
        """Number of quadrature points per cell."""
        return int(self.weights.size)

    # --- geometry and basis -------------------------------------------------------------------
    @cached_property
    def _geometry(self):
        return mesh_geometry(self.mesh)

    @property
    def grads(self) -> np.ndarray:
        """The P1 basis gradients of the cells, shape (n_cells, d + 1, d) (1 / length)
        (:func:`fem3d.mesh.mesh_geometry`: raises ValueError on a degenerate cell or a node of
        no cell)."""
        return self._geometry[0]

    @property
    def measure(self) -> np.ndarray:
        """The cells' areas or volumes, shape (n_cells,)."""
        return self._geometry[1]

    @cached_property
    def basis_gradients(self) -> np.ndarray:
        """The basis gradients at the quadrature points, shape (n_cells, n_q, nl, d)
        (C-contiguous, read-only)."""
        out = np.ascontiguousarray(self.gradients_at(self.bary), dtype=np.float64)
        out.flags.writeable = False
        return out

    def basis_values(self, bary) -> np.ndarray:
        """The basis functions of a cell at barycentric points ``bary`` (n_p, d + 1), shape
        (n_p, nl), in the order of a cell's nodes."""
        raise NotImplementedError

    def gradients_at(self, bary) -> np.ndarray:
        """The basis gradients of every cell at barycentric points ``bary`` (n_p, d + 1), shape
        (n_cells, n_p, nl, d) (1 / length)."""
        raise NotImplementedError

    # --- groups and loads ---------------------------------------------------------------------
    def group_names(self):
        """Every group name, by kind (those of the mesh)."""
        return self.mesh.group_names()

    def nodes_of(self, name) -> np.ndarray:
        """The nodes of group ``name``, sorted: all those of a boundary's facets
        (:attr:`facet_groups`), of a point group, of a region's cells.

        Raises
        ------
        KeyError
            If no group has that name.
        """
        return Mesh.nodes_of(self, name)   # the mesh's lookup, on this space's cells and groups

    def facet_load(self, facets, area, name="facets"):
        """How a constant traction on boundary facets is shared among their nodes.

        Parameters
        ----------
        facets : ndarray of int, shape (k, d)
            The facets' vertices (segments in 2D, triangles in 3D).
        area : ndarray, shape (k,)
            Their lengths or areas (times the 2D thickness).
        name : str
            For messages.

        Returns
        -------
        nodes : ndarray of int64, shape (k, m)
            Each facet's nodes.
        shares : ndarray, shape (k, m)
            The part of ``area`` each receives (the integrals of the facet's basis
            functions): the load of a unit traction.
        """
        raise NotImplementedError

    # --- fields on the space ------------------------------------------------------------------
    def interpolate(self, function) -> np.ndarray:
        """The interpolant of ``function`` (values at the nodes), flat ``node * d + component``.

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
        """A field ``u`` (flat, ``node * d + component``) at barycentric points of every cell,
        shape (n_cells, n_p, d)."""
        phi = self.basis_values(bary)
        ue = np.asarray(u, dtype=np.float64).reshape(self.n_nodes, self.dim)[self.cells]  # (n_cells, nl, d)
        return np.einsum("pk,ekc->epc", phi, ue)

    def body_force(self, force, thickness=1.0, n=4) -> np.ndarray:
        """The consistent load vector ``f_(i, a) = T Int force_a phi_i`` of a body force.

        Parameters
        ----------
        force : callable or array of shape (d,)
            ``force(x)``, x of shape (n, d), returns (n, d) (force per volume); or a constant.
        thickness : float
            2D slab thickness (1 in 3D).
        n : int
            Points per direction of the :func:`~fem3d.elements.quadrature.collapsed_gauss`
            rule (exact to degree ``2 n - 1``).

        Returns
        -------
        ndarray, shape (n_nodes * d,)
            Force.
        """
        d = self.dim
        bary, weights = collapsed_gauss(d, n)
        if callable(force):
            x = self.points_at(bary)
            values = np.asarray(force(x.reshape(-1, d)), dtype=np.float64).reshape(x.shape)
        else:
            values = np.broadcast_to(np.asarray(force, dtype=np.float64), (self.n_cells, bary.shape[0], d))
        phi = self.basis_values(bary)
        local = np.einsum("e,p,pk,epc->ekc", thickness * np.asarray(self.measure), weights, phi, values)
        out = np.zeros(self.n_nodes * d)
        for c in range(d):
            out[c::d] = np.bincount(self.cells.ravel(), weights=local[:, :, c].ravel(), minlength=self.n_nodes)
        return out

    def description(self):
        """The mesh as the results file sees it (:class:`thinfilm.discretization.SimplexMesh`:
        the P1 mesh; an element with more nodes writes them too)."""
        return self.mesh.description()

    # --- quantities at the quadrature points --------------------------------------------------
    @property
    def point_shape(self) -> tuple:
        """Shape of a quantity given at every point: (n_cells, n_q), or (n_cells,) for one point."""
        return (self.n_cells,) if self.n_q == 1 else (self.n_cells, self.n_q)

    def at_points(self, per_cell) -> np.ndarray:
        """A per-cell quantity, shape (n_cells,), at every point (shape :attr:`point_shape`)."""
        per_cell = np.asarray(per_cell)
        return per_cell if self.n_q == 1 else np.repeat(per_cell[:, None], self.n_q, axis=1)

    def cell_mean(self, values) -> np.ndarray:
        """``sum_q w_q values[:, q]``: the mean over each cell of a quantity given at the points
        (exact to the rule's degree), shape (n_cells,)."""
        return values if self.n_q == 1 else values @ self.weights

    # --- the kernels --------------------------------------------------------------------------
    def _by_point(self, x):
        return np.reshape(x, (self.n_cells, self.n_q))

    def stiffness_values(self, lam, mu, thickness, free_index, indptr, offsets, data):
        """Write ``K_ff``'s values into ``data`` (:func:`fem3d.kernels.stiffness_values`),
        ``lam``, ``mu`` of shape :attr:`point_shape`."""
        kernels.stiffness_values(self.basis_gradients, self.measure, self.weights, self.cells, self._by_point(lam),
                                 self._by_point(mu), thickness, free_index, indptr, offsets, data)

    def boundary_product(self, cell_list, lam, mu, thickness, row_index, col_index, x, sign, out):
        """``out[row_index[i]] += sign (K_e x)_i`` over the cells of ``cell_list``
        (:func:`fem3d.kernels.boundary_product`)."""
        kernels.boundary_product(self.basis_gradients, self.measure, self.weights, self.cells, cell_list,
                                 self._by_point(lam), self._by_point(mu), thickness, row_index, col_index, x, sign,
                                 out)

    def strain(self, u) -> np.ndarray:
        """The strain of ``u`` (flat, float64) at the points, Voigt order with tensor shear
        components, shape :attr:`point_shape` + (3 or 6,) (:func:`fem3d.kernels.point_strain`)."""
        e = kernels.point_strain(self.basis_gradients, self.cells, u)
        return e.reshape(self.point_shape + e.shape[2:])

    def energy_density(self, u, lam, mu) -> np.ndarray:
        """``lam/2 tr(e)^2 + mu e:e`` of ``u`` at the points, shape :attr:`point_shape`
        (:func:`fem3d.kernels.energy_density`)."""
        return kernels.energy_density(self.basis_gradients, self.cells, u, lam, mu).reshape(self.point_shape)
