r"""The Ambrosio-Tortorelli surface energy on P1 and the damage problem at fixed displacement.

Discrete energy (``docs/model.md#bulk-solids-finite-elements``)
===============================================================
Damage ``alpha``: P1 scalar per node (0 sound, 1 broken); ``d`` = 2 or 3; ``T`` the thickness
in 2D (1 in 3D)::

    S(alpha) = T Gc / (4 c_V) [ sum_i m_i V(alpha_i) / eps + eps alpha.L.alpha ]

- ``m_i = sum_{e ni i} |e| / (d + 1)``: the lumped nodal measure (exact for ``Int alpha_h``);
- ``L`` the P1 stiffness (Laplacian) matrix, ``L_ij = sum_e |e| grad psi_i . grad psi_j``, so
  ``alpha.L.alpha = Int |grad alpha_h|^2`` exactly;
- AT1: ``V(a) = a``, ``c_V = 2/3`` (prefactor ``3 Gc / 8``); AT2: ``V(a) = a^2``,
  ``c_V = 1/2`` (prefactor ``Gc / 2``).

The elastic energy of :mod:`fem3d.elasticity` is, in the damage variables,
``P = sum_i c_i g(alpha_i)``, ``g(a) = (1 - a)^2 + k_res``, with the nodal energy
``c_i = T sum_{e ni i} |e| psi_e / (d + 1)``. Since ``g(a) = 1 + k_res - 2 a + a^2``, at fixed
``u`` the total energy is ``E = 1/2 a.A.a - b.a + const`` with::

    AT1:  A = diag(2 c) + (3 Gc eps T / 4) L,              b = 2 c - (3 Gc T / (8 eps)) m
    AT2:  A = diag(2 c + Gc T m / eps) + Gc eps T L,       b = 2 c

``const = (1 + k_res) sum_i c_i``; ``k_res`` enters neither ``A`` nor ``b``. ``A`` is
symmetric, positive definite for AT2 and for AT1 as soon as ``c > 0`` at one node of each
connected part; on a mesh without obtuse angles (non-positive off-diagonal ``L``) it is an
M-matrix. The damage step minimizes this under ``lower <= a <= upper``
(:func:`thinfilm.solvers.boxqp.solve_box_qp`).

Fixed nodes (the gray regions, where damage is held at 0): their rows and columns are
decoupled, ``A_ii = 1``, ``b_i = -1``, off-diagonal entries removed from the pattern. The
minimizer in that coordinate, ``-1``, lies below the lower bound (>= 0), so the bound holds
``a_i`` at 0 exactly whatever the solver's bounds there; and decoupling changes nothing for
admissible ``a``, since every removed term ``A_ij a_i a_j`` and ``b_i a_i`` has ``a_i = 0``.
So ``1/2 a.A.a - b.a`` still equals ``E(u, a) - E(u, 0)`` whenever ``a = 0`` on the fixed nodes.

Units: ``Gc`` energy per area (2D: per length and thickness), ``eps`` a length; ``S``, ``A``,
``b`` in energy units (2D: of the whole thickness ``T``).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from fem3d import kernels
from fem3d.elasticity import _index_array, mesh_geometry
from fem3d.mesh import Mesh
from thinfilm.options import real_in_range

__all__ = ["DamageOperator", "c_V"]


def c_V(at: int) -> float:
    """AT normalization ``c_V = Int_0^1 sqrt(V(s)) ds``: 2/3 (AT1), 1/2 (AT2)."""
    if isinstance(at, bool) or at not in (1, 2):
        raise ValueError(f"at = {at!r} must be 1 or 2")
    return 2.0 / 3.0 if at == 1 else 0.5


class DamageOperator:
    """The AT surface energy on a P1 mesh and the damage problem's ``(A, b)``.

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh
    Gc : float
        Toughness, > 0 (energy per crack area; in 2D per crack length and thickness).
    eps : float
        Regularization length, > 0 (mesh length unit).
    at : {1, 2}
        AT1 (``V = a``) or AT2 (``V = a^2``).
    thickness : float
        ``T`` > 0 in 2D; must be 1 in 3D.
    fixed_nodes : array of int, optional
        Nodes where the damage is held at 0, sorted without repeats.

    Attributes
    ----------
    mesh : Mesh
    Gc, eps, thickness : float
    at : int
    m : ndarray, shape (n_nodes,)
        Lumped nodal measure (area or volume; read-only).
    L : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
        P1 Laplacian (length^(d-2)), sorted indices; do not modify.
    fixed_nodes : ndarray of int64
        The fixed nodes (empty if none; read-only).
    """

    def __init__(self, mesh: Mesh, Gc: float, eps: float, *, at: int = 1, thickness: float = 1.0,
                 fixed_nodes=None):
        grads, measure = mesh_geometry(mesh)
        self.mesh = mesh
        self.Gc = real_in_range("Gc", Gc, 0.0, math.inf, low_open=True)
        self.eps = real_in_range("eps", eps, 0.0, math.inf, low_open=True)
        self.thickness = real_in_range("thickness", thickness, 0.0, math.inf, low_open=True)
        if mesh.dim == 3 and self.thickness != 1.0:
            raise ValueError(f"thickness = {thickness!r} must be 1 for a 3D mesh")
        c_V(at)  # validates
        self.at = int(at)
        n = mesh.n_nodes
        fixed = np.zeros(0, dtype=np.int64) if fixed_nodes is None else _index_array("fixed_nodes", fixed_nodes, n)
        fixed.flags.writeable = False
        self.fixed_nodes = fixed

        self.m = kernels.lumped_measure(measure, mesh.cells, n)
        self.m.flags.writeable = False
        indptr, indices = kernels.node_graph(mesh.cells, n)
        data = np.empty(indices.size)
        kernels.laplacian_values(grads, measure, mesh.cells, indptr, indices, data)
        self.L = sp.csr_matrix((data, indices, indptr), shape=(n, n))
        self.L.has_sorted_indices = True

        T, cs = self.thickness, self.Gc / (4.0 * c_V(self.at))
        self._cs = cs
        # A: 2 cs eps T L without the fixed nodes' off-diagonal entries; the diagonal is set
        # by problem(). diag_fixed: the part of the diagonal that does not depend on u.
        is_fixed = np.zeros(n, dtype=bool)
        is_fixed[fixed] = True
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
        keep = (rows == indices) | ~(is_fixed[rows] | is_fixed[indices])
        A_indptr = np.zeros(n + 1, dtype=np.int64)
        np.cumsum(np.bincount(rows[keep], minlength=n), out=A_indptr[1:])
        A_indices = indices[keep]
        self._A = sp.csr_matrix((2.0 * cs * self.eps * T * data[keep], A_indices, A_indptr), shape=(n, n))
        self._A.has_sorted_indices = True
        self._diag_pos = np.flatnonzero(rows[keep] == A_indices)  # one per row, in row order
        self._diag_fixed = self._A.data[self._diag_pos].copy()
        if self.at == 2:
            self._diag_fixed += 2.0 * cs * T * self.m / self.eps
            self._linear = np.zeros(n)
        else:
            self._linear = cs * T * self.m / self.eps

    @property
    def n_nodes(self) -> int:
        return self.mesh.n_nodes

    def _alpha(self, alpha):
        alpha = np.ascontiguousarray(alpha, dtype=np.float64)
        if alpha.shape != (self.n_nodes,):
            raise ValueError(f"alpha must have shape ({self.n_nodes},), got {alpha.shape}")
        return alpha

    def surface_energy(self, alpha) -> float:
        """``S(alpha) = T Gc/(4 c_V) [sum_i m_i V(alpha_i)/eps + eps alpha.L.alpha]`` (energy).

        Parameters
        ----------
        alpha : ndarray, shape (n_nodes,)
        """
        alpha = self._alpha(alpha)
        local = float(np.dot(self.m, alpha if self.at == 1 else alpha * alpha))
        return self._cs * self.thickness * (local / self.eps + self.eps * float(alpha @ (self.L @ alpha)))

    def problem(self, c) -> tuple[sp.csr_matrix, np.ndarray]:
        """``(A, b)`` of the damage problem for the nodal energy ``c``: the total energy at
        fixed ``u`` is ``1/2 a.A.a - b.a + const`` (module docstring), fixed nodes decoupled.

        Parameters
        ----------
        c : ndarray, shape (n_nodes,)
            Nodal energy, >= 0 (:meth:`fem3d.elasticity.Elasticity.nodal_energy`).

        Returns
        -------
        A : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
            Symmetric, sorted indices; the same object every call, its diagonal rewritten in
            place (copy it to keep it).
        b : ndarray, shape (n_nodes,)
            A new array.
        """
        c = np.ascontiguousarray(c, dtype=np.float64)
        if c.shape != (self.n_nodes,):
            raise ValueError(f"c must have shape ({self.n_nodes},), got {c.shape}")
        two_c = 2.0 * c
        diag = self._diag_fixed + two_c
        b = two_c - self._linear
        diag[self.fixed_nodes] = 1.0
        b[self.fixed_nodes] = -1.0
        self._A.data[self._diag_pos] = diag
        return self._A, b
