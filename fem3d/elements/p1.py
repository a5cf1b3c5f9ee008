"""The P1 element: linear displacements on the mesh's vertices (3-node triangles, 4-node
tetrahedra).

The nodes are the mesh's vertices and the cells its cells; the strain is constant in a cell,
so the rule of the stiffness is the centroid (one point: quantities at the points are per
cell) and the basis gradients are those of the barycentric coordinates
(:func:`fem3d.kernels.cell_geometry`). A traction on a boundary facet gives each of its ``d``
vertices ``1/d`` of the facet's load (exact for a constant traction). The stiffness and the
boundary product, the strain and the energy density use the P1 kernels of
:mod:`fem3d.kernels` (the fast path: the generic kernels' values, in fewer operations;
docs/speed.md#the-element-kernels).
"""

from __future__ import annotations

import numpy as np

from fem3d import kernels
from fem3d.elements.quadrature import centroid
from fem3d.elements.space import Space

__all__ = ["P1Space", "SPACE"]


class P1Space(Space):
    """The P1 displacement on a mesh (:class:`fem3d.elements.space.Space`): ``n_nodes`` the
    mesh's vertices, ``cells`` the mesh's (n_cells, d + 1), one quadrature point per cell."""

    name = "P1"

    def __init__(self, mesh):
        super().__init__(mesh)
        self.points = mesh.points
        self.cells = mesh.cells
        self.facet_groups = mesh.facet_groups
        self.bary, self.weights = centroid(self.dim)

    def basis_values(self, bary) -> np.ndarray:
        return np.asarray(bary, dtype=np.float64)

    def gradients_at(self, bary) -> np.ndarray:
        n_p = np.asarray(bary).shape[0]
        return np.broadcast_to(self.grads[:, None], (self.n_cells, n_p) + self.grads.shape[1:])

    @property
    def basis_gradients(self) -> np.ndarray:
        """:attr:`grads` as (n_cells, 1, d + 1, d) (a view)."""
        return self.grads[:, None]

    def facet_load(self, facets, area, name="facets"):
        d = self.dim
        return np.asarray(facets, dtype=np.int64), np.repeat(np.asarray(area)[:, None] / d, d, axis=1)

    def stiffness_values(self, lam, mu, thickness, free_index, indptr, offsets, data):
        kernels.p1_stiffness_values(self.grads, self.measure, self.cells, lam, mu, thickness, free_index, indptr,
                                    offsets, data)

    def boundary_product(self, cell_list, lam, mu, thickness, row_index, col_index, x, sign, out):
        kernels.p1_boundary_product(self.grads, self.measure, self.cells, cell_list, lam, mu, thickness, row_index,
                                    col_index, x, sign, out)

    def strain(self, u) -> np.ndarray:
        return kernels.p1_strain(self.grads, self.cells, u)

    def energy_density(self, u, lam, mu) -> np.ndarray:
        return kernels.p1_energy_density(self.grads, self.cells, u, lam, mu)


SPACE = P1Space
