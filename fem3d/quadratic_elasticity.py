r"""P2 linear elasticity with a degraded stiffness: the u-problem of the bulk solid with
quadratic displacements (6-node triangles, 10-node tetrahedra), the damage staying P1.

Discrete energy (``docs/model.md#p2-displacement``)
===================================================
Displacement ``u``: P2 on the P1 mesh (:mod:`fem3d.quadratic`), ``d`` components per P2 node,
dof ``node * d + component``, the vertices first (in the mesh's numbering), then the edges'
midpoints. Damage ``alpha``: P1 on the vertices, as with P1 displacements. The strain is
linear in each cell; the energy keeps the P1 element's degradation per cell,
``gbar_e = 1/(d + 1) sum_{i in e} g(alpha_i)`` with ``g(a) = (1 - a)^2 + k_res``, which
multiplies the whole cell::

    P(u, alpha) = T sum_e gbar_e Int_e psi(u) = T sum_e gbar_e |e| sum_q w_q psi(e(u)(x_q))

``psi = lam/2 tr(e)^2 + mu e:e`` (each cell's modulus included; :mod:`fem3d.elasticity` for
``lam``, plane stress and ``T``), integrated by the degree-2 rule of
:data:`fem3d.quadratic.STIFFNESS_RULES` (3 points on triangles, 4 on tetrahedra): ``psi`` is
quadratic in a cell, so the rule is exact and ``P`` is the exact energy of the P2 field at
the per-cell degradation. In the damage variables ``P = sum_i c_i g(alpha_i)`` with the nodal
energy on the vertices ``c_i = T sum_{e ni i} (Int_e psi) / (d + 1)``, shape (n_vertices,),
which is what :mod:`fem3d.damage` takes, unchanged.

With a contact split (:mod:`fem3d.split`) the switch ``H(tr e)`` is taken at each quadrature
point: ``gbar_e`` multiplies ``psi_plus`` and ``psi_minus`` is added intact, point by point, and
the stiffness at a frozen switch has effective Lame parameters per point, arrays
``(lam_q, mu_q)`` of shape (n_cells, n_q) (:meth:`QuadraticElasticity.lame`; without a split
``gbar_e modulus_e (lam, mu)``); :meth:`~QuadraticElasticity.matrix`,
:meth:`~QuadraticElasticity.rhs` and :meth:`~QuadraticElasticity.reactions` take them.

Assembly
========
As for P1 (:mod:`fem3d.elasticity`): the CSR pattern of ``K_ff`` is built once on the P2 node
graph, and :meth:`QuadraticElasticity.matrix` rewrites its values in place with a Numba
kernel (:mod:`fem3d.quadratic_kernels`) that forms the basis gradients at the quadrature
points on the fly and finds each entry's place through the int32 table of ``nl^2`` offsets
per cell (nl = 6 or 10 nodes: 144 or 400 bytes per cell). Measured (CPU time, one thread, a
busy 2-core machine) on jittered structured meshes, P2 against P1 on the same mesh and P1 on
a mesh twice as fine (as many dofs):

==========================  ======  ==========  ===========  ==========  ==============
mesh                        dofs    entries     assembly     matrix      offset table
==========================  ======  ==========  ===========  ==========  ==============
3D 20^3 Kuhn cubes, P2      206763  1.71e7      0.27-0.39 s  206 MB      19 MB
3D the same, P1             27783   1.16e6      0.02 s       14 MB       3 MB
3D 40^3 cubes, P1           206763  8.95e6      0.14 s       108 MB      25 MB
2D 200^2 squares, P2        321602  7.37e6      0.12 s       90 MB       12 MB
2D 400^2 squares, P1        321602  4.49e6      0.05 s       55 MB       12 MB
==========================  ======  ==========  ===========  ==========  ==============

In 3D a P2 entry costs about 1.5 times a P1 one (four points per cell; an element matrix of
30 x 30 formed from two symmetric products, :func:`fem3d.quadratic_kernels._element_parts`,
then scattered: about a third of the time each for the products, the scatter, and the rest).
A first version, which summed over the points for each entry inside the scatter loop, took
about 1.4 times as long.
"""

from __future__ import annotations

import numpy as np

from fem3d import quadratic_kernels as qk, split as splits
from fem3d.elasticity import Elasticity, mesh_geometry
from fem3d.mesh import Mesh
from fem3d.quadratic import LOCAL_EDGES, STIFFNESS_RULES, QuadraticSpace

__all__ = ["QuadraticElasticity"]


class QuadraticElasticity(Elasticity):
    """The elastic energy of the damaged solid with P2 displacements, and its u-problem.

    :class:`fem3d.elasticity.Elasticity` with the P2 element: the fields of the displacement
    (``u``, dofs, loads) live on the P2 nodes (:attr:`space`), the damage on the mesh's
    vertices, and per-cell quantities of P1 become per quadrature point (shape (n_cells, n_q)).
    What is written here is what the element changes: its nodes, its quadrature points, its
    two kernels and its strain; the material, the dofs, the split, the energies and the
    near-nullspace are P1's.

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh
        Triangles (2D) or tetrahedra (3D).
    E, nu, plane, thickness, k_res, modulus, split
        As for :class:`fem3d.elasticity.Elasticity`.
    constrained : array of int, optional
        The constrained dofs ``node * d + component`` over the P2 nodes, sorted without
        repeats.
    space : fem3d.quadratic.QuadraticSpace, optional
        The P2 nodes of ``mesh`` (built if not given).

    Attributes
    ----------
    mesh : Mesh
    space : QuadraticSpace
    dim : int
    E, nu, thickness, k_res : float
    plane : str or None
    lam, mu : float
    split : str
    grads : ndarray, shape (n_cells, d + 1, d)
        Gradients of the P1 basis functions (the P2 ones are formed from them).
    measure : ndarray, shape (n_cells,)
    modulus : ndarray, shape (n_cells,)
    bary, weights : ndarray, shapes (n_q, d + 1), (n_q,)
        The stiffness's quadrature rule (weights summing to 1).
    n_q : int
    nnz : int
        Stored entries of ``K_ff``.
    """

    def __init__(self, mesh: Mesh, E: float, nu: float, *, plane: str = "stress", thickness: float = 1.0,
                 k_res: float = 1e-6, constrained=None, modulus=None, split: str = "none", space=None):
        self.grads, self.measure = mesh_geometry(mesh)
        self.mesh = mesh
        self.space = QuadraticSpace(mesh) if space is None else space
        if self.space.mesh is not mesh:
            raise ValueError("space must be the QuadraticSpace of mesh")
        self._set_material(E, nu, plane, thickness, k_res, modulus, split)
        self.bary, self.weights = (np.ascontiguousarray(a) for a in STIFFNESS_RULES[self.dim])
        self.n_q = int(self.weights.size)
        self._local_edges = LOCAL_EDGES[self.dim]
        self._set_dofs(self.space.cells, self.space.points, constrained)

    # --- the quadrature points ------------------------------------------------------------------
    @property
    def _point_shape(self):
        return (self.mesh.n_cells, self.n_q)

    def _at_points(self, per_cell):
        return np.repeat(np.asarray(per_cell)[:, None], self.n_q, axis=1)

    def cell_mean(self, values) -> np.ndarray:
        """``sum_q w_q values[:, q]``: the mean over each cell of a quantity given at the
        quadrature points (exact for a quadratic one), shape (n_cells,)."""
        return self._pointwise("values", values) @ self.weights

    def _stiffness_values(self, lam, mu):
        qk.stiffness_values(self.grads, self.measure, self.space.cells, self._local_edges, self.bary, self.weights,
                            lam, mu, self.thickness, self._free_index, self._indptr, self._offsets,
                            self._matrix.data)

    def _boundary_product(self, lam, mu, row_index, col_index, x, sign, out):
        qk.boundary_product(self.grads, self.measure, self.space.cells, self._local_edges, self.bary, self.weights,
                            self._boundary_cells, lam, mu, self.thickness, row_index, col_index, x, sign, out)

    # --- fields -----------------------------------------------------------------------------------
    def strain(self, u) -> np.ndarray:
        """The strain at the quadrature points in Voigt order with tensor shear components
        (2D ``(e_xx, e_yy, e_xy)``, 3D ``(e_xx, e_yy, e_zz, e_yz, e_xz, e_xy)``), shape
        (n_cells, n_q, 3 or 6), dimensionless; the points are :attr:`bary`."""
        return qk.point_strain(self.grads, self.space.cells, self._local_edges, self.bary,
                               self._vector("u", u, self.n_dofs))

    def strain_energy_density(self, u) -> np.ndarray:
        """The mean over each cell of the undamaged density ``psi = 1/2 e:C_e:e``,
        ``Int_e psi / |e|``, shape (n_cells,) (energy per volume)."""
        psi, _ = splits.energy_parts(self.strain(u), self.lam, self.mu, self.dim, "none")
        return (psi @ self.weights) * self.modulus

    def body_force(self, force, n=4) -> np.ndarray:
        """The consistent load vector of a body force (force per volume), shape (n_dofs,)
        (:meth:`fem3d.quadratic.QuadraticSpace.body_force`)."""
        return self.space.body_force(force, self.measure, self.thickness, n)
