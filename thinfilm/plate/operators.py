r"""Set-up of the discrete plate + Winkler operator and of the damage (alpha) operator.

The discrete energy comes first; the matrices are its exact Hessians, so the u-matrix is
symmetric, positive definite whenever ``winkler > 0`` (for every ``alpha`` and ``k_res >= 0``),
and the boundary conditions of free edges are natural.

Discrete energy (non-dimensional, docs/model.md)
================================================
On a :class:`~thinfilm.plate.grid.Grid` with spacings ``hx``, ``hy``, trapezoidal node weights
``omega_n = omega_x_i omega_y_j`` (``h`` inside, ``h/2`` on the boundary) and nodal degradation
``g_n = (1 - alpha_n)^2 + k_res``::

    E_h(u, alpha) = P_h(u, alpha, w) + S_h(alpha)
    P_h = 1/2 sum_n omega_n g_n Q_n(a_n, b_n)                 (bending at nodes)
        + 1/2 sum_c hx hy gbar_c 2 (1 - nu) d_c^2               (twist at cell centres)
        + winkler/2 sum_n omega_n (u_n - w_n)^2                 (foundation, w = w_t)

with, at node ``n = (i, j)``,

- ``a_n = (u_{i-1,j} - 2 u_{i,j} + u_{i+1,j}) / hx^2`` (``D_xx u``), ``b_n`` likewise in y;
- on cell ``c`` with lower-left node ``(i, j)``:
  ``d_c = (u_{i,j} - u_{i+1,j} - u_{i,j+1} + u_{i+1,j+1}) / (hx hy)`` (``D_xy u`` at the
  centre) and ``gbar_c`` the mean of ``g`` at the four corners (so the energy is linear in
  the nodal ``g`` and the alpha-problem stays diagonal + Laplacian);
- the nodal density ``Q_n``:

  ==========================================  ===========================================
  node                                        ``Q_n``
  ==========================================  ===========================================
  interior (both differences exist)           ``a^2 + b^2 + 2 nu a b``
  free edge normal to y (``y = y0, y1``)       ``(1 - nu^2) a^2``
  free edge normal to x (``x = x0, x1``)       ``(1 - nu^2) b^2``
  corner of two free edges                    ``0``
  1D grid, interior                           ``a^2`` (1D free end: ``0``)
  ==========================================  ===========================================

  i.e. ``W = u_xx^2 + u_yy^2 + 2 nu u_xx u_yy + 2 (1 - nu) u_xy^2`` split as
  ``(u_nn + nu u_tt)^2 + (1 - nu^2) u_tt^2 + twist``; where the normal second difference does
  not exist (free edge) the first square is the free-edge moment ``M_nn``, which vanishes
  for the exact solution, and is dropped. At a free-free corner both moments vanish, so
  ``u_xx = u_yy = 0`` there. This closure is second-order accurate; simply dropping the
  missing differences (density ``a^2`` on a y-edge) is first order for ``nu > 0``
  (``docs/solvers.md#free-edges-of-the-plate``; measured again in ``tests/plate/test_convergence.py``).

Clamped edges (``u = 0``, ``du/dn = 0``) use a mirrored ghost node: on a clamped edge
``x = x0`` the missing ``u_{-1,j}`` equals ``u_{1,j}``, so ``a_{0,j} = 2 (u_{1,j} - u_{0,j}) / hx^2``
and the edge node keeps both second differences (``Q = a^2 + b^2 + 2 nu a b`` with
``b = 0``). The discrete energy is then exactly half that of the even extension across the
edge. Nodes on clamped edges are fixed at ``u = 0``: the energy ignores the values stored
there, and the u-matrix keeps only their diagonal (the Hessian's), decoupled from the rest,
with a zero right-hand side. A node where a clamped edge meets a free edge takes the
free-edge closure in the free direction (``(1 - nu^2) a^2`` with the ghost ``a``).

Surface energy and the alpha-problem (``docs/model.md#the-discrete-damage-problem``, held by
:class:`thinfilm.damage.DamageOperator`): gradients by forward differences on grid edges, so
``L`` is the edge Laplacian, ``alpha.L.alpha = sum_{x-edges} omega_y_j / hx
(alpha_{i+1,j} - alpha_{i,j})^2 + sum_{y-edges} omega_x_i / hy (alpha_{i,j+1} - alpha_{i,j})^2``,
and the lumped measure is the node weights ``omega``; no fixed nodes, thickness 1. An imperfect
film, of toughness ``toughness * f_n`` at node ``n`` (:mod:`thinfilm.plate.imperfection`),
weights node ``n``'s local term by ``f_n`` and an edge's gradient term by the mean of its two
nodes' factors (``omega -> omega f``, ``L -> L_f``): a second-order quadrature of
``Int G(x) (...)`` for a smooth ``G``. The nodal energy is ``e`` of
:func:`thinfilm.plate.energy.bending_density` (``P_bending = 1/2 sum_n g_n e_n``), and
``const = 1/2 (1 + k_res) sum_n e_n + foundation energy``.

All fields follow the flattening convention of :mod:`thinfilm.plate.grid`. Lengths are in units
of the domain size L, energies in the non-dimensional units of ``docs/model.md``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.damage import DamageOperator
from thinfilm.options import real_in_range
from thinfilm.plate.grid import Grid
from thinfilm.plate import energy
from thinfilm.plate.kernels import stencil as kernels

__all__ = ["PlateOperator", "GridDamage", "degradation", "near_nullspace"]


def degradation(alpha: np.ndarray, k_res: float) -> np.ndarray:
    """``g(alpha) = (1 - alpha)^2 + k_res``, elementwise, float64."""
    one_minus = 1.0 - np.asarray(alpha, dtype=np.float64)
    return one_minus * one_minus + k_res


def near_nullspace(coords):
    """Rigid modes of the free plate, ``B = [1, x, y]`` (a beam in 1D: ``[1, x]``): the null
    space of the bending energy without foundation, which the AMG solver needs to be told
    (:class:`thinfilm.solvers.linear.AMGSolver`; ``docs/solvers.md``).

    Parameters
    ----------
    coords : ndarray, shape (n, d) or (n,), d = 1 or 2
        Node coordinates (any length unit).

    Returns
    -------
    B : ndarray, shape (n, 1 + d)
        Columns 1, (x - mean x)/L, ... with L the largest extent (the scaling keeps the
        columns of comparable size for the aggregation's local QR).
    """
    coords = np.asarray(coords, dtype=np.float64)
    if coords.ndim == 1:
        coords = coords[:, None]
    if coords.ndim != 2 or coords.shape[1] not in (1, 2):
        raise ValueError(f"coords must have shape (n, 2) or (n, 1), got {coords.shape}")
    c = coords - coords.mean(axis=0)
    L = float(np.ptp(coords, axis=0).max()) or 1.0
    return np.column_stack([np.ones(len(c)), c / L])



class PlateOperator:
    """The u-problem of the discrete plate + Winkler energy on a structured grid.

    Minimizing ``P_h(u, alpha, w)`` over ``u`` (``alpha`` fixed) means solving
    ``K(alpha) u = rhs(w)``. The CSR pattern of ``K`` is built once here; :meth:`matrix`
    rewrites only its values.

    Parameters
    ----------
    grid : Grid
        1D or 2D structured grid.
    nu : float
        Poisson ratio, in (-1, 1) (ignored in 1D, where the density is ``u_xx^2``).
    winkler : float
        Foundation stiffness ``K/a^4 = 4 lam^4`` >= 0. ``K`` is positive definite for every
        ``alpha`` if ``winkler > 0``; with ``winkler = 0`` the free plate has the zero modes
        ``1, x, y``.
    k_res : float
        Residual stiffness in ``g(alpha) = (1 - alpha)^2 + k_res``, >= 0.
    clamped : iterable of str, optional
        Clamped edges among ``"x0", "x1", "y0", "y1"`` (``"x0", "x1"`` in 1D); the others
        are free. Default: all free.

    Attributes
    ----------
    clamped : tuple of str
        The clamped edges, in the order of ``grid.edges``.
    clamped_flags : ndarray of int64, shape (4,)
        1 for each clamped edge among ``x0, x1, y0, y1``: the form the kernels take.
    clamped_nodes, free_nodes : ndarray of int64
        Flat indices of the nodes fixed at ``u = 0`` and of the unknowns.
    nnz : int
        Number of stored entries of ``K`` (13 per interior row in 2D, 5 in 1D).
    """

    def __init__(self, grid: Grid, nu: float, winkler: float, k_res: float, clamped: Iterable[str] = ()):
        if not isinstance(grid, Grid):
            raise TypeError(f"grid = {grid!r} must be a thinfilm.plate.grid.Grid")
        self.grid = grid
        self.nu = real_in_range("nu", nu, -1.0, 1.0, True, True)
        self.winkler = real_in_range("winkler", winkler, 0.0, math.inf, False, True)
        self.k_res = real_in_range("k_res", k_res, 0.0, math.inf, False, True)
        if isinstance(clamped, str):
            clamped = (clamped,)
        clamped = tuple(clamped)
        for edge in clamped:
            if edge not in grid.edges:
                raise ValueError(f"clamped edge {edge!r} not in {grid.edges}")
        if len(set(clamped)) != len(clamped):
            raise ValueError(f"clamped = {clamped!r} lists an edge twice")
        self.clamped = tuple(e for e in grid.edges if e in clamped)
        self.clamped_flags = np.array([int(e in clamped) for e in ("x0", "x1", "y0", "y1")], dtype=np.int64)

        nodes = [grid.edge_nodes(e) for e in self.clamped]
        self.clamped_nodes = np.unique(np.concatenate(nodes)) if nodes else np.zeros(0, dtype=np.int64)
        mask = np.ones(grid.n_nodes, dtype=bool)
        mask[self.clamped_nodes] = False
        self.free_nodes = np.flatnonzero(mask).astype(np.int64)
        self._free_mask = mask

        # Pattern once; the csr_matrix owns (int32 or int64) copies of the indices, the
        # kernel only needs our int64 indptr to know where each row starts.
        indptr, indices = kernels.plate_pattern(grid.nx, grid.ny, self.clamped_flags)
        self._indptr = indptr
        self._matrix = sp.csr_matrix(
            (np.zeros(indices.size, dtype=np.float64), indices, indptr), shape=(grid.n_nodes, grid.n_nodes)
        )
        self._matrix.has_sorted_indices = True
        self.nnz = int(indices.size)
        self._weights_free = np.where(mask, grid.weights, 0.0)
        self._work = None  # work arrays of apply(), allocated on first use

    # --- helpers --------------------------------------------------------------------------
    def _args(self):
        g = self.grid
        return g.nx, g.ny, g.hx, g.hy, self.nu, self.winkler, self.clamped_flags

    def degradation(self, alpha) -> np.ndarray:
        """Nodal ``g(alpha) = (1 - alpha)^2 + k_res``, shape ``(n_nodes,)``."""
        return degradation(self.grid.nodal("alpha", alpha), self.k_res)

    # --- the linear system ------------------------------------------------------------
    def matrix(self, alpha) -> sp.csr_matrix:
        """The u-matrix ``K(alpha)`` (SPD, shape ``(n_nodes, n_nodes)``).

        The same ``csr_matrix`` object is returned by every call, its ``data`` rewritten in
        place: copy it (``K.copy()``) to keep the values of an earlier ``alpha``. Do not
        change its pattern (``eliminate_zeros``, ``sum_duplicates`` on a modified matrix...).

        Parameters
        ----------
        alpha : ndarray, shape (n_nodes,)
            Damage in [0, 1] at the nodes.
        """
        g = self.degradation(alpha)
        nx, ny, hx, hy, nu, winkler, flags = self._args()
        kernels.plate_values(g, nx, ny, hx, hy, nu, winkler, flags, self._indptr, self._matrix.data)
        return self._matrix

    def apply(self, alpha, u, out: np.ndarray | None = None) -> np.ndarray:
        """Matrix-free ``K(alpha) @ u``, equal to ``self.matrix(alpha) @ u`` to round-off.

        Parameters
        ----------
        alpha, u : ndarray, shape (n_nodes,)
        out : ndarray, shape (n_nodes,), optional
            C-contiguous float64 output array.

        Returns
        -------
        ndarray, shape (n_nodes,)
        """
        if out is not None and (out.dtype != np.float64 or out.shape != (self.grid.n_nodes,)
                                or not out.flags.c_contiguous):
            raise ValueError("out must be a C-contiguous float64 array of shape (n_nodes,)")
        return self._apply_g(self.degradation(alpha), u, self.winkler, out)

    def apply_bending(self, g, u) -> np.ndarray:
        """``sum_n g_n M_n u``: the bending part of ``K`` for an arbitrary nodal field ``g``
        (any sign, no foundation) times ``u``, shape ``(n_nodes,)``.

        ``K(alpha) = sum_n g(alpha_n) M_n + winkler diag(omega)`` is linear in the nodal
        degradation, so with ``g = g'(alpha) * dalpha`` this is the derivative of ``K(alpha) u``
        along ``dalpha`` (:mod:`thinfilm.plate.stability`).
        """
        return self._apply_g(self.grid.nodal("g", g), u, 0.0, None)

    def _apply_g(self, g, u, winkler, out):
        """``(sum_n g_n M_n + winkler diag(omega)) u`` for a nodal ``g``, into ``out`` (or a new array)."""
        u = self.grid.nodal("u", u)
        if out is None:
            out = np.empty(self.grid.n_nodes, dtype=np.float64)
        if self._work is None:
            # moments at nodes (2) and on cells: kept between calls, since allocating and
            # first-touching ~3 N doubles costs as much as the apply itself at 1500^2
            n_cells = max(self.grid.nx * self.grid.ny, 1)
            self._work = (np.empty(self.grid.n_nodes), np.empty(self.grid.n_nodes), np.empty(n_cells))
        mx, my, tw = self._work
        nx, ny, hx, hy, nu, _, flags = self._args()
        kernels.plate_apply(u, g, nx, ny, hx, hy, nu, winkler, flags, mx, my, tw, out)
        return out

    def linear_operator(self, alpha) -> spla.LinearOperator:
        """``K(alpha)`` as a matrix-free ``scipy.sparse.linalg.LinearOperator`` (for Krylov
        solvers); ``g(alpha)`` is computed once here, not at every product.

        The operator keeps its own work arrays, so it stays valid after later calls of
        :meth:`apply` or :meth:`matrix`.
        """
        g = self.degradation(alpha)
        n = self.grid.n_nodes
        nx, ny, hx, hy, nu, winkler, flags = self._args()
        work = (np.empty(n), np.empty(n), np.empty(max(nx * ny, 1)))

        def matvec(u):
            u = np.ascontiguousarray(np.ravel(u), dtype=np.float64)
            y = np.empty(n)
            kernels.plate_apply(u, g, nx, ny, hx, hy, nu, winkler, flags, *work, y)
            return y

        return spla.LinearOperator((n, n), matvec=matvec, rmatvec=matvec, dtype=np.float64)

    def rhs(self, w) -> np.ndarray:
        """Right-hand side ``winkler * omega * w`` of the u-problem (``omega`` the node weights), 0 on
        clamped nodes.

        Parameters
        ----------
        w : ndarray, shape (n_nodes,)
            Substrate displacement ``w_t`` at the nodes.
        """
        return self.winkler * self._weights_free * self.grid.nodal("w", w)

    def constrain(self, u) -> np.ndarray:
        """A copy of ``u`` with the clamped nodes set to 0 (the admissible field it stands for)."""
        u = np.array(self.grid.nodal("u", u))
        u[self.clamped_nodes] = 0.0
        return u

    # --- energies (see thinfilm.plate.energy) ---------------------------------------------------
    def elastic_energy(self, u, alpha, w) -> float:
        """Elastic energy ``P_h(u, alpha, w)`` = bending + foundation; see
        :func:`thinfilm.plate.energy.elastic_energy`."""
        return energy.elastic_energy(self, u, alpha, w)

    def bending_density(self, u) -> np.ndarray:
        """Lumped undamaged bending energy ``e``; see :func:`thinfilm.plate.energy.bending_density`."""
        return energy.bending_density(self, u)


class GridDamage(DamageOperator):
    """The damage operator of the plate: :class:`thinfilm.damage.DamageOperator` on the grid's
    edge Laplacian and node weights (module docstring).

    Parameters
    ----------
    grid : Grid
    eta : float
        Regularization length (units of L), > 0.
    toughness : float
        ``G/a``, > 0 (energy per unit crack length, non-dimensional).
    at : int
        1 (AT1, linear ``alpha/eta``) or 2 (AT2, ``alpha^2/eta``).
    toughness_factor : ndarray, shape (n_nodes,), optional
        A film of varying toughness ``G_n = toughness * factor_n`` (factors > 0, see
        :mod:`thinfilm.plate.imperfection`). The local term of node ``n`` takes ``factor_n``, the
        gradient term of an edge the mean of its two nodes' factors. None: uniform.

    Attributes
    ----------
    grid : Grid
    toughness_factor : ndarray or None
    L : scipy.sparse.csr_matrix
        ``L_f``: the edge Laplacian with each edge weighted by its toughness factor,
        ``alpha.L_f.alpha = sum_e f_e omega_e (D alpha)_e^2`` (:attr:`laplacian` for a uniform
        film).
    omega : ndarray
        ``omega_n f_n``: the node weights of the local term ``alpha^m / eta``.
    """

    def __init__(self, grid: Grid, eta: float, toughness: float, at: int = 1, toughness_factor=None):
        if not isinstance(grid, Grid):
            raise TypeError(f"grid = {grid!r} must be a thinfilm.plate.grid.Grid")
        self.grid = grid
        if toughness_factor is not None:
            toughness_factor = grid.nodal("toughness_factor", toughness_factor)
            if not (np.all(np.isfinite(toughness_factor)) and np.all(toughness_factor > 0)):
                raise ValueError("toughness_factor must be finite and > 0 at every node")
        self.toughness_factor = toughness_factor

        indptr, indices, data, diag_pos = kernels.laplacian_pattern(grid.nx, grid.ny, grid.hx, grid.hy)
        n = grid.n_nodes
        self._laplacian = sp.csr_matrix((data, indices, indptr), shape=(n, n))
        self._laplacian.has_sorted_indices = True
        if toughness_factor is None:
            L, omega = self._laplacian, grid.weights
        else:
            L, omega = _edge_weighted(self._laplacian, diag_pos, toughness_factor), grid.weights * toughness_factor
        super().__init__(L, omega, toughness, eta, at=at)

    @property
    def laplacian(self) -> sp.csr_matrix:
        """Edge Laplacian ``L`` of a uniform film, ``alpha.L.alpha = sum_e omega_e (D alpha)_e^2``
        (a copy)."""
        return self._laplacian.copy()

    def surface_energy(self, alpha) -> float:
        """Surface energy ``S_h(alpha)``; see :func:`thinfilm.plate.energy.surface_energy` (the
        grid's stencil kernel for a uniform film, the sum of :meth:`surface_density` for an
        imperfect one)."""
        return energy.surface_energy(self, alpha)

def _edge_weighted(L: sp.csr_matrix, diag_pos: np.ndarray, factor: np.ndarray) -> sp.csr_matrix:
    """The Laplacian ``L`` (zero row sums) with the edge ``(p, q)`` scaled by
    ``(factor_p + factor_q) / 2``: the off-diagonal entries are scaled, the diagonal is the
    negated sum of its row's off-diagonal entries again. Same pattern as ``L``."""
    n = L.shape[0]
    rows = np.repeat(np.arange(n), np.diff(L.indptr))
    off = L.indices != rows
    data = L.data.copy()
    data[off] *= 0.5 * (factor[rows[off]] + factor[L.indices[off]])
    data[diag_pos] = -np.bincount(rows[off], weights=data[off], minlength=n)
    out = sp.csr_matrix((data, L.indices.copy(), L.indptr.copy()), shape=L.shape)
    out.has_sorted_indices = True
    return out
