r"""The damage operator on P1: the Laplacian and the lumped measure of a mesh.

The surface energy and the damage problem are :class:`thinfilm.damage.DamageOperator`'s
(``docs/model.md#the-discrete-damage-problem``); on a mesh of simplices (``d`` = 2 or 3) they
take

- ``L`` the P1 stiffness (Laplacian) matrix, ``L_ij = sum_e |e| grad psi_i . grad psi_j``, so
  that ``alpha.L.alpha = Int |grad alpha_h|^2`` exactly;
- ``omega_i = sum_{e ni i} |e| / (d + 1)``, the lumped nodal measure (exact for
  ``Int alpha_h``);
- the fixed nodes of the gray regions (``docs/model.md#buffer-layers-and-fixed-regions``) and
  the thickness ``T`` of a 2D slab (1 in 3D).

The nodal energy the damage problem takes is twice :meth:`fem3d.elasticity.Elasticity.nodal_energy`
(``e = 2 c``: that method's ``c`` has ``P = sum_i c_i g(alpha_i)``); :meth:`fem3d.model.FemModel.damage_problem`
doubles it. On a mesh without obtuse angles (non-positive off-diagonal ``L``) ``A`` is an
M-matrix.

Units: ``Gc`` energy per area (2D: per length and thickness), ``eps`` a length; the surface
energy, ``A`` and ``b`` in energy units (2D: of the whole thickness ``T``).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from fem3d import kernels
from fem3d.mesh import Mesh, mesh_geometry
from thinfilm.damage import DamageOperator
from thinfilm.options import index_array, real_in_range

__all__ = ["P1Damage"]


class P1Damage(DamageOperator):
    """The AT damage operator on a P1 mesh (:class:`thinfilm.damage.DamageOperator` on the P1
    Laplacian and lumped measure).

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh
    Gc : float
        Toughness, > 0 (energy per crack area; in 2D per crack length and thickness).
    eps : float
        Regularization length ``eta``, > 0 (mesh length unit).
    at : {1, 2}
        AT1 (``alpha^m = alpha``) or AT2 (``alpha^2``).
    thickness : float
        ``T`` > 0 in 2D; must be 1 in 3D.
    fixed_nodes : array of int, optional
        Nodes where the damage is held at 0, sorted without repeats.
    law : thinfilm.laws.DamageLaw, optional
        A law other than AT1/AT2 (the cohesive law): :class:`thinfilm.damage.DamageOperator`.

    Attributes
    ----------
    mesh : Mesh
    L : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
        P1 Laplacian (length^(d-2)), sorted indices; do not modify.
    omega : ndarray, shape (n_nodes,)
        Lumped nodal measure (area or volume; read-only).

    Notes
    -----
    The other attributes (``toughness`` = ``Gc``, ``eta`` = ``eps``, ``at``, ``thickness``,
    ``fixed_nodes``, ``cs``) and the methods are :class:`thinfilm.damage.DamageOperator`'s.
    """

    def __init__(self, mesh: Mesh, Gc: float, eps: float, *, at: int = 1, thickness: float = 1.0,
                 fixed_nodes=None, law=None):
        grads, measure = mesh_geometry(mesh)
        self.mesh = mesh
        # checked here too so that an error names the scene's keys (Gc, eps), not the shared ones
        real_in_range("Gc", Gc, 0.0, math.inf, low_open=True)
        real_in_range("eps", eps, 0.0, math.inf, low_open=True)
        thickness = real_in_range("thickness", thickness, 0.0, math.inf, low_open=True)
        if mesh.dim == 3 and thickness != 1.0:
            raise ValueError(f"thickness = {thickness!r} must be 1 for a 3D mesh")
        n = mesh.n_nodes
        if fixed_nodes is not None:
            fixed_nodes = index_array("fixed_nodes", fixed_nodes, n)
        omega = kernels.lumped_measure(measure, mesh.cells, n)
        indptr, indices = kernels.node_graph(mesh.cells, n)
        data = np.empty(indices.size)
        kernels.laplacian_values(grads, measure, mesh.cells, indptr, indices, data)
        L = sp.csr_matrix((data, indices, indptr), shape=(n, n))
        L.has_sorted_indices = True
        super().__init__(L, omega, Gc, eps, at=at, thickness=thickness, fixed_nodes=fixed_nodes, law=law)
