r"""Linear elasticity with a degraded stiffness: the u-problem of the bulk solid, over any
displacement element (:mod:`fem3d.elements`).

Discrete energy (``docs/model.md#bulk-solids-finite-elements``)
===============================================================
Displacement ``u``: ``d`` components per node of the element's space (``d`` = 2 triangles,
3 tetrahedra), dof ``node * d + component`` (P1: the mesh's vertices; P2: the vertices, then
the edges' midpoints). Damage ``alpha``: P1 scalar per vertex, 0 sound, 1 broken. The
undamaged strain-energy density is ``psi = 1/2 e:C:e = lam/2 tr(e)^2 + mu e:e``, with
``mu = E / (2 (1 + nu))`` and

- 3D and 2D plane strain: ``lam = E nu / ((1 + nu)(1 - 2 nu))`` (plane strain: ``e_zz = 0``);
- 2D plane stress: ``lam* = 2 lam mu / (lam + 2 mu)`` (``sigma_zz = 0``, ``e_zz`` eliminated),

and ``tr``, ``e:e`` taken over the in-plane components in 2D. With ``g(a) = (1 - a)^2 + k_res``,
the cell's degradation is the mean of ``g`` at its vertices (the vertex quadrature of
``Int_e g(alpha_h) psi``, exact for the part of ``g`` linear in ``alpha``; it keeps the
damage problem's bulk part diagonal, as for the thin film), and ``psi`` is integrated by the
element's rule (points ``x_q``, weights ``w_q`` summing to 1; exact: P1 one point, the strain
being constant; P2 the degree-2 rule)::

    P(u, alpha) = T sum_e gbar_e |e| sum_q w_q psi(e(u)(x_q)),      gbar_e = 1/(d + 1) sum_{i in e} g(alpha_i)

With a contact split (:mod:`fem3d.split`) ``gbar_e`` multiplies the degraded part ``psi_plus``
only and ``psi_minus`` is added intact, point by point (the switch ``H(tr e)`` at each
quadrature point); at a frozen switch the stiffness has effective Lame parameters per point
(:meth:`Elasticity.lame`). ``T`` the thickness in 2D (1 in 3D; energies and forces are those
of the whole slab), ``|e|`` the cell's area or volume. The u-problem at fixed ``alpha``
minimizes ``P(u, alpha) - f.u`` (``f`` consistent nodal forces) over ``u`` with the
constrained (Dirichlet) dofs prescribed: ``K(alpha)`` (the Hessian of ``P``), split into free
(``f``) and constrained (``d``) dofs::

    K_ff u_f = f_f - K_fd u_d,          reactions  r_d = (K u)_d - f_d

``r_d`` is the force the support exerts on the body at each constrained dof. In the damage
variables, ``P = sum_i c_i g(alpha_i) + T sum_e |e| sum_q w_q psi_minus`` with the nodal
energy on the vertices ``c_i = T sum_{e ni i} |e| (sum_q w_q psi_plus) / (d + 1)``
(:meth:`Elasticity.nodal_energy`), which is what the damage problem of :mod:`fem3d.damage`
takes.

Units: lengths in the mesh's unit, ``E`` a stress; forces in the unit of ``E`` times length^2,
energies in force times length (for a 2D slab: of the whole thickness ``T``).

Assembly
========
The CSR pattern of ``K_ff`` (the free dofs only: constrained rows and columns are not stored)
is built once per space and set of constrained dofs, on the node graph of the element's
cells; :meth:`Elasticity.matrix` rewrites its values in place with the space's kernel
(:mod:`fem3d.kernels`), which forms each element block from the basis gradients at the
quadrature points and finds its place through an int32 table of ``nl^2`` offsets per cell
(nl nodes per cell). Measurements: docs/speed.md#the-element-kernels.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from fem3d import kernels, split as splits
from fem3d.elements.p1 import P1Space
from fem3d.elements.space import Space
from fem3d.mesh import Mesh
from thinfilm.laws import AT1
from thinfilm.options import index_array, real_in_range

__all__ = ["Elasticity", "lame_parameters"]


def lame_parameters(E: float, nu: float, plane: str | None = None) -> tuple[float, float]:
    """``(lam, mu)`` of the energy density ``lam/2 tr(e)^2 + mu e:e``.

    Parameters
    ----------
    E : float
        Young's modulus (> 0).
    nu : float
        Poisson's ratio, in (-1, 0.5).
    plane : {"stress", "strain", None}
        2D model; None in 3D (same as ``"strain"``). Plane stress returns
        ``lam* = 2 lam mu / (lam + 2 mu)``.
    """
    lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu))
    mu = E / (2.0 * (1.0 + nu))
    if plane == "stress":
        lam = 2.0 * lam * mu / (lam + 2.0 * mu)
    return lam, mu


class Elasticity:
    """The elastic energy of the damaged solid and its u-problem, over a displacement element.

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh
        Triangles (2D) or tetrahedra (3D).
    E : float
        Young's modulus, > 0 (a stress).
    nu : float
        Poisson's ratio, in (-1, 0.5).
    plane : {"stress", "strain"}
        2D model (ignored in 3D).
    thickness : float
        ``T`` > 0: 2D slab thickness (length unit); must be 1 in 3D.
    k_res : float
        Residual stiffness in ``g(a) = (1 - a)^2 + k_res``, >= 0.
    constrained : array of int, optional
        The constrained (Dirichlet) dofs ``node * d + component`` over the space's nodes,
        sorted without repeats. Default: none (``K`` is then singular: the rigid-body modes).
    modulus : ndarray, shape (n_cells,), optional
        Each cell's Young's modulus over ``E`` (a buffer layer's ``E_b / E``), > 0, the same
        ``nu``; default 1 everywhere. It multiplies the cell's stiffness, stress and energy.
    split : {"none", "amor", "positive"}
        The part of the energy the damage degrades (:mod:`fem3d.split`, (4.10)-(4.12)).
        With a split the u-problem depends on each point's switch ``H(tr e)``: the
        stiffness, the right-hand side and the reactions take it frozen (``tension``).
    space : fem3d.elements.space.Space, optional
        The displacement's element on ``mesh`` (:func:`fem3d.elements.make_space`); default
        P1 (:class:`fem3d.elements.p1.P1Space`).
    law : thinfilm.laws.DamageLaw, optional
        The damage law whose ``g`` replaces ``(1 - a)^2`` (the cohesive law's rational
        degradation); default AT's.

    Attributes
    ----------
    mesh : Mesh
    space : Space
    dim : int
    E, nu, thickness, k_res : float
    plane : str or None
        ``"stress"`` or ``"strain"`` in 2D, None in 3D.
    lam, mu : float
        The Lame parameters of the energy density (plane stress: ``lam*``).
    split : str
    grads : ndarray, shape (n_cells, d + 1, d)
        Gradients of the P1 basis functions (1 / length).
    measure : ndarray, shape (n_cells,)
        Cell areas or volumes.
    modulus : ndarray, shape (n_cells,)
        The cells' moduli over ``E``.
    nnz : int
        Stored entries of ``K_ff``.

    Notes
    -----
    A quantity "at the points" (Lame parameters, switch, strain, densities) has the space's
    :attr:`~fem3d.elements.space.Space.point_shape`: (n_cells,) for P1, (n_cells, n_q) for an
    element of ``n_q`` quadrature points.
    """

    def __init__(self, mesh: Mesh, E: float, nu: float, *, plane: str = "stress", thickness: float = 1.0,
                 k_res: float = 1e-6, constrained=None, modulus=None, split: str = "none", space=None, law=None):
        if not isinstance(mesh, Mesh):
            raise TypeError(f"mesh = {mesh!r} must be a fem3d.mesh.Mesh")
        space = P1Space(mesh) if space is None else space
        if not isinstance(space, Space) or space.mesh is not mesh:
            raise ValueError("space must be an element space (fem3d.elements) of mesh")
        self.space = space
        self.grads, self.measure = space.grads, space.measure
        self.mesh = mesh
        self.law = AT1() if law is None else law     # only g matters here: AT1's is AT2's
        self._set_material(E, nu, plane, thickness, k_res, modulus, split)
        self._set_dofs(space.cells, space.points, constrained)

    def _set_material(self, E, nu, plane, thickness, k_res, modulus, split):
        """Check and store the material, the model and each cell's modulus (on :attr:`mesh`)."""
        mesh = self.mesh
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
        self.modulus = np.ones(mesh.n_cells) if modulus is None else np.array(self._vector("modulus", modulus, mesh.n_cells))
        if not (np.all(np.isfinite(self.modulus)) and np.all(self.modulus > 0)):
            raise ValueError("modulus must be positive and finite in every cell")
        self.modulus.flags.writeable = False

    def _set_dofs(self, cells, points, constrained):
        """The displacement's dofs on the nodes ``points`` of ``cells`` (the space's): free and
        constrained dofs, the CSR pattern of ``K_ff`` with each cell's offsets, and the cells
        with a constrained dof."""
        d = self.dim
        self._node_points = points
        n_nodes = points.shape[0]
        n_dofs = d * n_nodes
        con = np.zeros(0, dtype=np.int64) if constrained is None else index_array("constrained", constrained, n_dofs)
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
        self._indptr = indptr  # int64, for the kernel; the matrix may hold int32 copies
        n = self._free.size
        self._matrix = sp.csr_matrix((np.zeros(indices.size), indices, indptr), shape=(n, n))
        self._matrix.has_sorted_indices = True
        self.nnz = int(indices.size)
        # cells with a constrained dof: the only ones in K_fd and in the constrained rows
        node_con = np.zeros(n_nodes, dtype=bool)
        node_con[con // d] = True
        self._boundary_cells = np.flatnonzero(node_con[cells].any(axis=1)).astype(np.int64)

    # --- sizes and dofs -----------------------------------------------------------------------
    @property
    def n_dofs(self) -> int:
        """Number of displacement dofs, ``d`` per node of the displacement."""
        return self.dim * self._node_points.shape[0]

    @property
    def free(self) -> np.ndarray:
        """The free dofs, increasing, int64 (read-only), shape (n_free,)."""
        return self._free

    @property
    def constrained(self) -> np.ndarray:
        """The constrained dofs, increasing, int64 (read-only), shape (n_constrained,)."""
        return self._constrained

    def expand(self, u_free, u_constrained) -> np.ndarray:
        """The full displacement from its free and constrained parts.

        Parameters
        ----------
        u_free : ndarray, shape (n_free,)
        u_constrained : ndarray, shape (n_constrained,) or float
            In the order of :attr:`constrained`.

        Returns
        -------
        u : ndarray, shape (n_dofs,)
        """
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

    def _pointwise(self, name, x):
        x = np.ascontiguousarray(x, dtype=np.float64)
        if x.shape != self.space.point_shape:
            raise ValueError(f"{name} must have shape {self.space.point_shape}, got {x.shape}")
        return x

    def degradation(self, alpha) -> np.ndarray:
        """Cell degradation ``gbar_e``, the mean of ``g(alpha) + k_res`` at the cell's
        vertices, shape (n_cells,) (``g = (1 - a)^2`` unless the law has its own).

        Parameters
        ----------
        alpha : ndarray, shape (n_nodes,)
            Damage at the mesh's vertices.
        """
        alpha = self._vector("alpha", alpha, self.mesh.n_nodes)
        if self.law.quadratic:
            return kernels.cell_degradation(alpha, self.mesh.cells, self.k_res)
        return self.law.g(alpha)[self.mesh.cells].mean(axis=1) + self.k_res

    def degradation_slope(self, alpha) -> np.ndarray:
        """``g'(alpha)`` at the vertices, shape (n_nodes,) (the cross block's factor,
        :func:`fem3d.derivatives.cross_block`)."""
        return self.law.dg(self._vector("alpha", alpha, self.mesh.n_nodes))

    def tension(self, u) -> np.ndarray:
        """The switch ``H(tr e)`` at every point of the displacement ``u``: True where it is in
        tension, shape (n_cells,) for P1 (each cell), (n_cells, n_q) for an element of ``n_q``
        points."""
        return splits.tension(self.strain(u), self.dim)

    def cell_mean(self, values) -> np.ndarray:
        """The mean over each cell of a quantity given at every point, ``sum_q w_q values[:, q]``
        (P1: the cell's own value), shape (n_cells,)."""
        return self.space.cell_mean(self._pointwise("values", values))

    def lame(self, alpha, tension=None) -> tuple[np.ndarray, np.ndarray]:
        """The effective Lame parameters ``(lam, mu)`` at every point (shape
        (n_cells,) each for P1, (n_cells, n_q) otherwise): the cell's degradation and the split
        with the switch frozen at ``tension`` (None: every point in tension, the whole density
        degraded), times the cell's modulus (:func:`fem3d.split.effective_lame`)."""
        lam, mu = splits.effective_lame(self.space.at_points(self.degradation(alpha)), tension, self.lam, self.mu,
                                        self.dim, self.split)
        modulus = self.space.at_points(self.modulus)
        return lam * modulus, mu * modulus

    def _point_lame(self, alpha, tension, lame):
        if lame is None:
            return self.lame(alpha, tension)
        if alpha is not None or tension is not None:
            raise ValueError("give alpha (and tension) or lame, not both")
        lam, mu = lame
        return self._pointwise("lame[0]", lam), self._pointwise("lame[1]", mu)

    # --- the linear system --------------------------------------------------------------------
    def matrix(self, alpha, *, tension=None, lame=None) -> sp.csr_matrix:
        """The free block ``K_ff(alpha)`` of the stiffness matrix.

        The same ``csr_matrix`` is returned by every call, its ``data`` rewritten in place
        (copy it to keep an earlier one; do not change its pattern). Sorted indices;
        symmetric; positive definite when the constrained dofs fix the rigid-body modes.

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
            Damage at the mesh's vertices.
        tension : ndarray of bool, optional
            The split's switch at every point, frozen (:meth:`tension` of an earlier
            displacement); None: every point in tension. Irrelevant without a split.
        lame : (ndarray, ndarray), optional
            The effective Lame parameters at every point, in place of :meth:`lame`'s (then
            ``alpha`` must be None).

        Returns
        -------
        K_ff : scipy.sparse.csr_matrix, shape (n_free, n_free)
            Units of ``E`` times length (force per displacement).
        """
        lam, mu = self._point_lame(alpha, tension, lame)
        self.space.stiffness_values(lam, mu, self.thickness, self._free_index, self._indptr, self._offsets,
                                    self._matrix.data)
        return self._matrix

    def rhs(self, alpha, u_constrained, f=None, *, tension=None, lame=None) -> np.ndarray:
        """Right-hand side ``f_f - K_fd(alpha) u_d`` of the u-problem.

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
        u_constrained : ndarray, shape (n_constrained,), or float
            Prescribed displacements (length), in the order of :attr:`constrained`.
        f : ndarray, shape (n_dofs,), optional
            Consistent nodal forces (force); only the free entries enter.
        tension, lame : optional
            See :meth:`matrix`.

        Returns
        -------
        ndarray, shape (n_free,)
            Force.
        """
        lam, mu = self._point_lame(alpha, tension, lame)
        u_d = np.ascontiguousarray(np.broadcast_to(np.asarray(u_constrained, dtype=np.float64),
                                                   self._constrained.shape))
        out = np.zeros(self._free.size) if f is None else self._vector("f", f, self.n_dofs)[self._free].copy()
        self.space.boundary_product(self._boundary_cells, lam, mu, self.thickness, self._free_index, self._con_index,
                                    u_d, -1.0, out)
        return out

    def reactions(self, alpha, u, f=None, *, lame=None) -> np.ndarray:
        """The residual ``K(alpha) u - f`` on the constrained dofs: the forces the supports
        exert on the body, per dof.

        At a solution of the u-problem they balance the applied forces: their sum and
        moment equal minus those of ``f``. Along a prescribed displacement ``t v`` (``v`` on
        the constrained dofs), ``v . reactions`` is ``dP/dt`` (``P`` the elastic energy at
        the solution, ``f = 0``). With a split, ``K`` is that of ``u``'s own switch, whose
        ``K u`` is the true internal force (module :mod:`fem3d.split`).

        Parameters
        ----------
        alpha : ndarray, shape (n_vertices,)
        u : ndarray, shape (n_dofs,)
            The full displacement.
        f : ndarray, shape (n_dofs,), optional
            Consistent nodal forces; default 0.
        lame : optional
            See :meth:`matrix`.

        Returns
        -------
        ndarray, shape (n_constrained,)
            Force, in the order of :attr:`constrained`.
        """
        u = self._vector("u", u, self.n_dofs)
        tension = None if (lame is not None or self.split == "none") else self.tension(u)
        lam, mu = self._point_lame(alpha, tension, lame)
        out = np.zeros(self._constrained.size)
        self.space.boundary_product(self._boundary_cells, lam, mu, self.thickness, self._con_index, self._dof_index,
                                    u, 1.0, out)
        if f is not None:
            out -= self._vector("f", f, self.n_dofs)[self._constrained]
        return out

    # --- energies and fields ------------------------------------------------------------------
    def strain(self, u) -> np.ndarray:
        """The strain at every point in Voigt order with tensor shear components, 2D
        ``(e_xx, e_yy, e_xy)``, 3D ``(e_xx, e_yy, e_zz, e_yz, e_xz, e_xy)``; shape
        (n_cells, 3 or 6) for P1, (n_cells, n_q, 3 or 6) otherwise (the points
        ``space.bary``), dimensionless."""
        return self.space.strain(self._vector("u", u, self.n_dofs))

    def stress(self, u) -> np.ndarray:
        """Undamaged stresses ``C_e e(u)`` at every point in Voigt order, 2D ``(s_xx, s_yy, s_xy)``
        (in plane; plane strain's ``s_zz = lam (e_xx + e_yy)`` is not returned), 3D
        ``(s_xx, s_yy, s_zz, s_yz, s_xz, s_xy)``; the shape of :meth:`strain`, units of ``E``
        (each cell's own modulus). The damaged stress is ``gbar_e`` times this."""
        e = self.strain(u)
        d = self.dim
        s = 2.0 * self.mu * e
        s[..., :d] += self.lam * e[..., :d].sum(axis=-1, keepdims=True)
        return s * self.space.at_points(self.modulus)[..., None]

    def strain_energy_density(self, u) -> np.ndarray:
        """The mean over each cell of the undamaged density ``psi = 1/2 e:C_e:e`` (its own
        modulus), ``Int_e psi / |e|``, shape (n_cells,) (energy per volume, units of ``E``)."""
        psi = self.space.energy_density(self._vector("u", u, self.n_dofs), self.lam, self.mu)
        return self.space.cell_mean(psi) * self.modulus

    def energy_parts(self, u) -> tuple[np.ndarray, np.ndarray]:
        """``(psi_plus, psi_minus)`` at every point (shape of :meth:`tension`): the part of the
        density the damage degrades and the part it leaves intact
        (:func:`fem3d.split.energy_parts`), each cell's modulus included (energy per volume)."""
        plus, minus = splits.energy_parts(self.strain(u), self.lam, self.mu, self.dim, self.split)
        modulus = self.space.at_points(self.modulus)
        return plus * modulus, minus * modulus

    def nodal_energy(self, u) -> np.ndarray:
        """The nodal energy on the vertices ``c_i = T sum_{e ni i} |e| psi_plus_e / (d + 1)``
        (``psi_plus_e`` the cell's mean), shape (n_vertices,) (energy):
        ``P(u, alpha) = sum_i c_i g(alpha_i) + T sum_e |e| psi_minus_e``, whose first part
        alone depends on the damage."""
        out = np.empty(self.mesh.n_nodes)
        kernels.nodal_energy(self.cell_mean(self.energy_parts(u)[0]), self.measure, self.mesh.cells, self.thickness,
                             out)
        return out

    def elastic_energy(self, u, alpha) -> float:
        """``P(u, alpha) = T sum_e |e| (gbar_e psi_plus_e(u) + psi_minus_e(u))`` (cell means;
        energy)."""
        plus, minus = (self.cell_mean(part) for part in self.energy_parts(u))
        return float(self.thickness * (np.dot(self.measure * plus, self.degradation(alpha))
                                       + np.dot(self.measure, minus)))

    def body_force(self, force, n=4) -> np.ndarray:
        """The consistent load vector of a body force (force per volume), shape (n_dofs,)
        (:meth:`fem3d.elements.space.Space.body_force`)."""
        return self.space.body_force(force, self.thickness, n)

    # --- near-nullspace -----------------------------------------------------------------------
    def rigid_modes(self) -> np.ndarray:
        """The rigid-body modes restricted to the free dofs, for AMG's near-nullspace.

        Columns: the ``d`` unit translations, then the rotations about the centroid of the
        nodes (2D: about z; 3D: about x, y, z), divided by the mesh's largest extent so that
        every column is of order 1.

        Returns
        -------
        ndarray, shape (n_free, 3) in 2D, (n_free, 6) in 3D
        """
        points = self._node_points
        d, n = self.dim, points.shape[0]
        x = points - points.mean(axis=0)
        x = x / (float(np.ptp(points, axis=0).max()) or 1.0)
        B = np.zeros((n, d, 3 if d == 2 else 6))
        for a in range(d):
            B[:, a, a] = 1.0
        if d == 2:
            B[:, 0, 2], B[:, 1, 2] = -x[:, 1], x[:, 0]
        else:
            # rotation about axis k: omega_k e_k x (x, y, z)
            B[:, 1, 3], B[:, 2, 3] = -x[:, 2], x[:, 1]  # about x: (0, -z, y)
            B[:, 0, 4], B[:, 2, 4] = x[:, 2], -x[:, 0]  # about y: (z, 0, -x)
            B[:, 0, 5], B[:, 1, 5] = -x[:, 1], x[:, 0]  # about z: (-y, x, 0)
        return np.ascontiguousarray(B.reshape(n * d, -1)[self._free])
