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

import math

import numpy as np
import scipy.sparse as sp

from fem3d import kernels, quadratic_kernels as qk, split as splits
from fem3d.elasticity import _index_array, lame_parameters, mesh_geometry
from fem3d.mesh import Mesh
from fem3d.quadratic import LOCAL_EDGES, STIFFNESS_RULES, QuadraticSpace
from thinfilm.options import real_in_range

__all__ = ["QuadraticElasticity"]


class QuadraticElasticity:
    """The elastic energy of the damaged solid with P2 displacements, and its u-problem.

    The same interface as :class:`fem3d.elasticity.Elasticity`; the fields of the
    displacement (``u``, dofs, loads) live on the P2 nodes (:attr:`space`), the damage on the
    mesh's vertices, and per-cell quantities of P1 become per quadrature point
    (shape (n_cells, n_q)).

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
        self.dim = d = mesh.dim
        self.E = real_in_range("E", E, 0.0, math.inf, low_open=True)
        self.nu = real_in_range("nu", nu, -1.0, 0.5, low_open=True)
        self.k_res = real_in_range("k_res", k_res, 0.0, math.inf)
        self.thickness = real_in_range("thickness", thickness, 0.0, math.inf, low_open=True)
        if d == 2:
            if plane not in ("stress", "strain"):
                raise ValueError(f'plane = {plane!r} must be "stress" or "strain"')
            self.plane = plane
        else:
            if self.thickness != 1.0:
                raise ValueError(f"thickness = {thickness!r} must be 1 for a 3D mesh (energies and forces are"
                                 " those of the solid itself)")
            self.plane = None
        self.lam, self.mu = lame_parameters(self.E, self.nu, self.plane)
        if split not in splits.SPLITS:
            raise ValueError(f"split = {split!r} must be one of {', '.join(splits.SPLITS)}")
        self.split = split
        self.modulus = (np.ones(mesh.n_cells) if modulus is None
                        else np.array(self._vector("modulus", modulus, mesh.n_cells)))
        if not (np.all(np.isfinite(self.modulus)) and np.all(self.modulus > 0)):
            raise ValueError("modulus must be positive and finite in every cell")
        self.modulus.flags.writeable = False
        self.bary, self.weights = (np.ascontiguousarray(a) for a in STIFFNESS_RULES[d])
        self.n_q = int(self.weights.size)
        self._local_edges = LOCAL_EDGES[d]
        cells = self.space.cells

        n_nodes = self.space.n_nodes
        n_dofs = d * n_nodes
        con = np.zeros(0, dtype=np.int64) if constrained is None else _index_array("constrained", constrained, n_dofs)
        mask = np.ones(n_dofs, dtype=bool)
        mask[con] = False
        self._constrained = con
        self._free = np.flatnonzero(mask).astype(np.int64)
        self._free_index = np.full(n_dofs, -1, dtype=np.int64)
        self._free_index[self._free] = np.arange(self._free.size)
        self._con_index = np.full(n_dofs, -1, dtype=np.int64)
        self._con_index[con] = np.arange(con.size)
        self._dof_index = np.arange(n_dofs, dtype=np.int64)   # every dof its own column (reactions)
        for a in (self._constrained, self._free):
            a.flags.writeable = False

        if self._free.size >= 2**31:
            raise ValueError(f"{self._free.size} free dofs: more than the int32 column indices hold")
        node_indptr, node_indices = kernels.node_graph(cells, n_nodes)
        indptr, indices, entry_offset = kernels.free_pattern(node_indptr, node_indices, self._free_index, d,
                                                             self._free.size)
        self._offsets = kernels.cell_offsets(cells, node_indptr, node_indices, entry_offset)
        self._indptr = indptr
        n = self._free.size
        self._matrix = sp.csr_matrix((np.zeros(indices.size), indices, indptr), shape=(n, n))
        self._matrix.has_sorted_indices = True
        self.nnz = int(indices.size)
        node_con = np.zeros(n_nodes, dtype=bool)
        node_con[con // d] = True
        self._boundary_cells = np.flatnonzero(node_con[cells].any(axis=1)).astype(np.int64)

    # --- sizes and dofs -----------------------------------------------------------------------
    @property
    def n_dofs(self) -> int:
        """Number of displacement dofs, ``d * n_nodes`` over the P2 nodes."""
        return self.dim * self.space.n_nodes

    @property
    def free(self) -> np.ndarray:
        """The free dofs, increasing, int64 (read-only), shape (n_free,)."""
        return self._free

    @property
    def constrained(self) -> np.ndarray:
        """The constrained dofs, increasing, int64 (read-only), shape (n_constrained,)."""
        return self._constrained

    def expand(self, u_free, u_constrained) -> np.ndarray:
        """The full displacement (shape (n_dofs,)) from its free part (n_free,) and its
        constrained part (n_constrained,) or a float, in the order of :attr:`constrained`."""
        u = np.empty(self.n_dofs)
        u[self._free] = self._vector("u_free", u_free, self._free.size)
        u[self._constrained] = u_constrained
        return u

    # --- helpers ------------------------------------------------------------------------------
    def _vector(self, name, x, size):
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.shape != (size,):
            raise ValueError(f"{name} must have shape ({size},), got {x.shape}")
        return x

    def _points(self, name, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.shape != (self.mesh.n_cells, self.n_q):
            raise ValueError(f"{name} must have shape ({self.mesh.n_cells}, {self.n_q}), got {x.shape}")
        return x

    def degradation(self, alpha) -> np.ndarray:
        """Cell degradation ``gbar_e``, the mean of ``(1 - alpha)^2 + k_res`` at the cell's
        vertices, shape (n_cells,).

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
        """
        alpha = self._vector("alpha", alpha, self.mesh.n_nodes)
        return kernels.cell_degradation(alpha, self.mesh.cells, self.k_res)

    def tension(self, u) -> np.ndarray:
        """The split's switch ``H(tr e)`` at every quadrature point of ``u``, bool, shape
        (n_cells, n_q)."""
        return splits.tension(self.strain(u), self.dim)

    def lame(self, alpha, tension=None) -> tuple[np.ndarray, np.ndarray]:
        """The effective Lame parameters ``(lam_q, mu_q)`` at every quadrature point, shape
        (n_cells, n_q) each: the cell's degradation ``gbar_e`` and the split with the switch
        frozen at ``tension`` (None: every point in tension), times the cell's modulus
        (:func:`fem3d.split.effective_lame`). Without a split ``gbar_e modulus_e (lam, mu)``."""
        g = np.repeat(self.degradation(alpha)[:, None], self.n_q, axis=1)
        if tension is not None:
            tension = np.asarray(tension, dtype=bool)
            if tension.shape != g.shape:
                raise ValueError(f"tension must have shape {g.shape}, got {tension.shape}")
        lam, mu = splits.effective_lame(g, tension, self.lam, self.mu, self.dim, self.split)
        return lam * self.modulus[:, None], mu * self.modulus[:, None]

    def _point_lame(self, alpha, tension, lame):
        if lame is None:
            return self.lame(alpha, tension)
        if alpha is not None or tension is not None:
            raise ValueError("give alpha (and tension) or lame, not both")
        lam, mu = lame
        return self._points("lame[0]", lam), self._points("lame[1]", mu)

    # --- the linear system --------------------------------------------------------------------
    def matrix(self, alpha, *, tension=None, lame=None) -> sp.csr_matrix:
        """The free block ``K_ff(alpha)`` of the stiffness matrix.

        The same ``csr_matrix`` is returned by every call, its ``data`` rewritten in place.
        Sorted indices; symmetric bit for bit; positive definite when the constrained dofs
        fix the rigid-body modes.

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
        tension : ndarray of bool, shape (n_cells, n_q), optional
            The split's switch, frozen; None: every point in tension.
        lame : (ndarray, ndarray), shape (n_cells, n_q) each, optional
            Effective Lame parameters at the quadrature points (stress; degradation, split
            and modulus included), in place of :meth:`lame`'s (then ``alpha`` must be None).

        Returns
        -------
        K_ff : scipy.sparse.csr_matrix, shape (n_free, n_free)
        """
        lam, mu = self._point_lame(alpha, tension, lame)
        qk.stiffness_values(self.grads, self.measure, self.space.cells, self._local_edges, self.bary, self.weights,
                            lam, mu, self.thickness, self._free_index, self._indptr, self._offsets,
                            self._matrix.data)
        return self._matrix

    def rhs(self, alpha, u_constrained, f=None, *, tension=None, lame=None) -> np.ndarray:
        """Right-hand side ``f_f - K_fd(alpha) u_d`` of the u-problem, shape (n_free,).

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
        u_constrained : ndarray, shape (n_constrained,), or float
        f : ndarray, shape (n_dofs,), optional
            Consistent nodal forces on the P2 nodes.
        tension, lame : optional
            See :meth:`matrix`.
        """
        lam, mu = self._point_lame(alpha, tension, lame)
        u_d = np.ascontiguousarray(np.broadcast_to(np.asarray(u_constrained, dtype=np.float64),
                                                   self._constrained.shape))
        out = np.zeros(self._free.size) if f is None else self._vector("f", f, self.n_dofs)[self._free].copy()
        qk.boundary_product(self.grads, self.measure, self.space.cells, self._local_edges, self.bary, self.weights,
                            self._boundary_cells, lam, mu, self.thickness, self._free_index, self._con_index, u_d,
                            -1.0, out)
        return out

    def reactions(self, alpha, u, f=None, *, lame=None) -> np.ndarray:
        """The residual ``K(alpha) u - f`` on the constrained dofs (force, shape
        (n_constrained,)): the forces the supports exert on the body. With a split, ``K`` is
        that of ``u``'s own switch. See :meth:`fem3d.elasticity.Elasticity.reactions`."""
        u = self._vector("u", u, self.n_dofs)
        tension = None if (lame is not None or self.split == "none") else self.tension(u)
        lam, mu = self._point_lame(alpha, tension, lame)
        out = np.zeros(self._constrained.size)
        qk.boundary_product(self.grads, self.measure, self.space.cells, self._local_edges, self.bary, self.weights,
                            self._boundary_cells, lam, mu, self.thickness, self._con_index, self._dof_index, u, 1.0,
                            out)
        if f is not None:
            out -= self._vector("f", f, self.n_dofs)[self._constrained]
        return out

    # --- energies and fields ------------------------------------------------------------------
    def strain(self, u) -> np.ndarray:
        """The strain at the quadrature points in Voigt order with tensor shear components
        (2D ``(e_xx, e_yy, e_xy)``, 3D ``(e_xx, e_yy, e_zz, e_yz, e_xz, e_xy)``), shape
        (n_cells, n_q, 3 or 6), dimensionless; the points are :attr:`bary`."""
        return qk.point_strain(self.grads, self.space.cells, self._local_edges, self.bary,
                               self._vector("u", u, self.n_dofs))

    def stress(self, u) -> np.ndarray:
        """Undamaged stresses ``C_e e(u)`` at the quadrature points in Voigt order (as
        :meth:`fem3d.elasticity.Elasticity.stress`), shape (n_cells, n_q, 3 or 6)."""
        e = self.strain(u)
        d = self.dim
        s = 2.0 * self.mu * e
        s[..., :d] += self.lam * e[..., :d].sum(axis=-1, keepdims=True)
        return s * self.modulus[:, None, None]

    def cell_mean(self, values) -> np.ndarray:
        """``sum_q w_q values[:, q]``: the mean over each cell of a quantity given at the
        quadrature points (exact for a quadratic one), shape (n_cells,)."""
        return self._points("values", values) @ self.weights

    def energy_parts(self, u) -> tuple[np.ndarray, np.ndarray]:
        """``(psi_plus, psi_minus)`` at the quadrature points (:func:`fem3d.split.energy_parts`),
        each cell's modulus included, shape (n_cells, n_q) each (energy per volume)."""
        plus, minus = splits.energy_parts(self.strain(u), self.lam, self.mu, self.dim, self.split)
        return plus * self.modulus[:, None], minus * self.modulus[:, None]

    def strain_energy_density(self, u) -> np.ndarray:
        """The mean over each cell of the undamaged density ``psi = 1/2 e:C_e:e``,
        ``Int_e psi / |e|``, shape (n_cells,) (energy per volume)."""
        e = self.strain(u)
        psi, _ = splits.energy_parts(e, self.lam, self.mu, self.dim, "none")
        return (psi @ self.weights) * self.modulus

    def nodal_energy(self, u) -> np.ndarray:
        """The nodal energy on the vertices ``c_i = T sum_{e ni i} Int_e psi_plus / (d + 1)``,
        shape (n_vertices,): ``P(u, alpha) = sum_i c_i g(alpha_i) + T sum_e Int_e psi_minus``."""
        out = np.empty(self.mesh.n_nodes)
        kernels.nodal_energy(self.energy_parts(u)[0] @ self.weights, self.measure, self.mesh.cells, self.thickness,
                             out)
        return out

    def elastic_energy(self, u, alpha) -> float:
        """``P(u, alpha) = T sum_e |e| sum_q w_q (gbar_e psi_plus + psi_minus)`` (energy)."""
        plus, minus = self.energy_parts(u)
        return float(self.thickness * (np.dot(self.measure * (plus @ self.weights), self.degradation(alpha))
                                       + np.dot(self.measure, minus @ self.weights)))

    def body_force(self, force, n=4) -> np.ndarray:
        """The consistent load vector of a body force (force per volume), shape (n_dofs,)
        (:meth:`fem3d.quadratic.QuadraticSpace.body_force`)."""
        return self.space.body_force(force, self.measure, self.thickness, n)

    # --- near-nullspace -----------------------------------------------------------------------
    def rigid_modes(self) -> np.ndarray:
        """The rigid-body modes on the free dofs, for AMG's near-nullspace: the ``d``
        translations, then the rotations about the nodes' centroid (2D: z; 3D: x, y, z)
        divided by the mesh's largest extent; shape (n_free, 3) in 2D, (n_free, 6) in 3D."""
        d, n = self.dim, self.space.n_nodes
        points = self.space.points
        x = points - points.mean(axis=0)
        x = x / (float(np.ptp(points, axis=0).max()) or 1.0)
        B = np.zeros((n, d, 3 if d == 2 else 6))
        for a in range(d):
            B[:, a, a] = 1.0
        if d == 2:
            B[:, 0, 2], B[:, 1, 2] = -x[:, 1], x[:, 0]
        else:
            B[:, 1, 3], B[:, 2, 3] = -x[:, 2], x[:, 1]
            B[:, 0, 4], B[:, 2, 4] = x[:, 2], -x[:, 0]
            B[:, 0, 5], B[:, 1, 5] = -x[:, 1], x[:, 0]
        return np.ascontiguousarray(B.reshape(n * d, -1)[self._free])
