r"""The Ambrosio-Tortorelli surface energy and the damage problem on any discretization.

The definitions are those of ``docs/model.md#the-discrete-damage-problem``; the symbols here
are its symbols. A discretization supplies

- ``L``, its Laplacian-like stiffness: symmetric, zero row sums, ``alpha.L.alpha`` the
  discrete ``Int |grad alpha|^2`` (the plate's edge Laplacian, weighted by the toughness
  factor for an imperfect film; the P1 stiffness matrix of the finite elements);
- ``omega``, its lumped nodal measure: ``sum_n omega_n alpha_n^m`` the discrete
  ``Int alpha^m`` (the plate's node weights times the toughness factor; the finite elements'
  lumped area or volume);
- optionally fixed nodes, where the damage is held at 0;
- the constants: toughness ``Gc``, regularization length ``eta``, ``m = at`` (1: AT1, 2: AT2)
  and the thickness ``T`` of a 2D slab (1 otherwise).

With ``cs = Gc / (4 c_m)`` (:func:`c_m`) the surface energy is::

    S_h(alpha) = cs T [ sum_n omega_n alpha_n^m / eta + eta alpha.L.alpha ]

and, with ``e_n`` the model's nodal energy, such that the degraded elastic energy is
``1/2 sum_n g(alpha_n) e_n`` with ``g(a) = (1 - a)^2 + k_res``, the total energy at fixed
displacement is ``1/2 alpha.A.alpha - b.alpha + const`` with::

    A = diag(e) + 2 cs eta T L        (AT2: + diag(2 cs T omega / eta))
    b = e                             (AT1: - cs T omega / eta)

``k_res`` enters only ``const``. ``A`` is symmetric, positive definite for AT2, and for AT1
as soon as ``e > 0`` at one node of each connected part of the graph of ``L``.

A law that is not quadratic (the cohesive law of :mod:`thinfilm.laws`, with its own ``w``,
``g`` and ``c_w = 4 c_m``) has the damage energy at fixed displacement::

    F(alpha) = sum_n [ c_n g(alpha_n) + s_n w(alpha_n) ] + 1/2 alpha.K.alpha,
    c = e / 2,   s = cs T omega / eta,   K = 2 cs eta T L

(:class:`DamageEnergy`): separable nodal terms plus the same Laplacian, which
:func:`thinfilm.solvers.box_newton.solve_box_newton` minimizes over the box.

Fixed nodes (``docs/model.md#buffer-layers-and-fixed-regions``): their rows and columns are
decoupled, ``A_ii = 1``, ``b_i = -1``, the off-diagonal entries removed from the pattern. The
minimizer in that coordinate, ``-1``, lies below the lower bound (>= 0), so the bound holds
``alpha_i`` at 0 exactly whatever the solver's bounds there; and decoupling changes nothing
for admissible ``alpha``, since every removed term ``A_ij alpha_i alpha_j`` and
``b_i alpha_i`` has ``alpha_i = 0``. So ``1/2 alpha.A.alpha - b.alpha`` still equals
``E(u, alpha) - E(u, 0)`` whenever ``alpha = 0`` on the fixed nodes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from thinfilm.laws import AT1, AT2, DamageLaw
from thinfilm.options import index_array, real_in_range

__all__ = ["DamageOperator", "DamageEnergy", "c_m"]


def c_m(at: int) -> float:
    """The AT normalization ``c_m = Int_0^1 sqrt(s^m) ds``: 2/3 (AT1), 1/2 (AT2).

    With it a straight crack of optimal profile costs ``Gc`` per unit length
    (``docs/model.md#conventions``).

    Parameters
    ----------
    at : {1, 2}

    Raises
    ------
    ValueError
        If ``at`` is not 1 or 2 (``True`` included).
    """
    if isinstance(at, bool) or at not in (1, 2):
        raise ValueError(f"at = {at!r} must be 1 or 2")
    return 2.0 / 3.0 if at == 1 else 0.5


class DamageOperator:
    """The AT surface energy and the damage problem's ``(A, b)`` for a given ``L`` and ``omega``.

    Parameters
    ----------
    L : scipy.sparse.csr_matrix, shape (n, n)
        Symmetric, zero row sums, sorted indices, every diagonal entry stored; units
        length^(d-2) (``alpha.L.alpha`` approximates ``Int |grad alpha|^2``). Kept, not copied.
    omega : ndarray, shape (n,)
        Lumped nodal measure, > 0 (length^d). Copied.
    toughness : float
        ``Gc`` > 0: energy per unit crack length (2D, per unit thickness) or area (3D).
    eta : float
        Regularization length, > 0.
    at : {1, 2}
        AT1 (``alpha^m = alpha``) or AT2 (``alpha^2``); ignored with ``law``.
    thickness : float
        ``T`` > 0: the thickness of a 2D slab whose energies are the whole slab's; 1 otherwise.
    fixed_nodes : array of int, optional
        Nodes where the damage is held at 0, sorted without repeats.
    law : thinfilm.laws.DamageLaw, optional
        A law that is not quadratic (the cohesive law): its ``w`` and ``c_w`` make the surface
        energy, :meth:`energy` its damage energy (and :meth:`problem` is refused). An AT law
        here is the same as its ``at``.

    Attributes
    ----------
    toughness, eta, thickness, cs : float
        ``cs = toughness / (4 c_m)`` (``toughness / c_w``).
    at : int or None
        1 or 2 for an AT law, None otherwise.
    law : thinfilm.laws.DamageLaw
    L : scipy.sparse.csr_matrix
        The ``L`` given; do not modify.
    omega : ndarray, shape (n,)
        Read-only.
    fixed_nodes : ndarray of int64
        Empty if none; read-only.

    Notes
    -----
    The matrix ``A`` of :meth:`problem` is built once on the pattern of ``L`` (without the
    fixed nodes' couplings); each call rewrites only its diagonal, in place, and returns the
    same object.
    """

    def __init__(self, L, omega, toughness: float, eta: float, *, at: int = 1, thickness: float = 1.0,
                 fixed_nodes=None, law: DamageLaw | None = None):
        if not sp.issparse(L) or L.format != "csr" or L.ndim != 2 or L.shape[0] != L.shape[1]:
            raise ValueError(f"L must be a square scipy.sparse CSR matrix, got {type(L).__name__}"
                             f" of shape {getattr(L, 'shape', None)}")
        n = L.shape[0]
        if not L.has_sorted_indices:
            raise ValueError("L must have sorted indices")
        omega = np.array(omega, dtype=np.float64)
        if omega.shape != (n,) or not (np.all(np.isfinite(omega)) and np.all(omega > 0)):
            raise ValueError(f"omega must be finite and > 0 with shape ({n},), got shape {omega.shape}")
        omega.flags.writeable = False
        self.toughness = real_in_range("toughness", toughness, 0.0, math.inf, True, True)
        self.eta = real_in_range("eta", eta, 0.0, math.inf, True, True)
        self.thickness = real_in_range("thickness", thickness, 0.0, math.inf, True, True)
        if law is not None and law.quadratic:
            at, law = {"at1": 1, "at2": 2}[law.name], None
        if law is None:
            self.cs = self.toughness / (4.0 * c_m(at))
            self.at = int(at)
            self.law = AT1() if self.at == 1 else AT2()
        else:
            self.cs = self.toughness / law.c_w
            self.at = None
            self.law = law
        self.L, self.omega = L, omega
        self.fixed_nodes = _fixed_nodes(fixed_nodes, n)

        indptr, indices = L.indptr, L.indices
        rows = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr))
        if self.fixed_nodes.size:
            is_fixed = np.zeros(n, dtype=bool)
            is_fixed[self.fixed_nodes] = True
            keep = (rows == indices) | ~(is_fixed[rows] | is_fixed[indices])
            A_indptr = np.zeros(n + 1, dtype=np.int64)
            np.cumsum(np.bincount(rows[keep], minlength=n), out=A_indptr[1:])
            rows, A_indices, data = rows[keep], indices[keep], L.data[keep]
        else:
            A_indptr, A_indices, data = indptr, indices, L.data
        self._diag_pos = np.flatnonzero(rows == A_indices)  # one per row, in row order
        if self._diag_pos.size != n:
            raise ValueError("L must store every diagonal entry")
        # A = 2 cs eta T L (its pattern) + diag(...): only the diagonal depends on u; the
        # coefficients are formed as scalars first, so each array entry is rounded once.
        T, cs, eta = self.thickness, self.cs, self.eta
        self._A = sp.csr_matrix((2.0 * cs * eta * T * data, A_indices, A_indptr), shape=(n, n))
        self._A.has_sorted_indices = True
        self._diag_fixed = self._A.data[self._diag_pos].copy()
        self._diag_laplacian = self._diag_fixed.copy()    # K's (energy)
        if self.at == 2:
            self._diag_fixed += 2.0 * cs * T / eta * omega
            self._linear = np.zeros(n)
        else:
            self._linear = cs * T / eta * omega   # AT1's b; a nonlinear law's s

    @property
    def n_nodes(self) -> int:
        """The number of damage unknowns ``n``."""
        return self.L.shape[0]

    def _nodal(self, name, values) -> np.ndarray:
        a = np.ascontiguousarray(values, dtype=np.float64)
        if a.shape != (self.n_nodes,):
            raise ValueError(f"{name} has shape {a.shape}, expected ({self.n_nodes},) (flat nodal field)")
        return a

    def surface_energy(self, alpha) -> float:
        """``S_h(alpha) = cs T [sum_n omega_n alpha_n^m / eta + eta alpha.L.alpha]`` (energy).

        Parameters
        ----------
        alpha : ndarray, shape (n,)
        """
        alpha = self._nodal("alpha", alpha)
        local = float(np.dot(self.omega, self.law.w(alpha)))
        return self.cs * self.thickness * (local / self.eta + self.eta * float(alpha @ (self.L @ alpha)))

    def surface_density(self, alpha) -> np.ndarray:
        """The surface energy split over the nodes,
        ``cs T (omega_n alpha_n^m / eta + eta alpha_n (L alpha)_n)``, which sums to
        :meth:`surface_energy` up to round-off (the gradient sum ``alpha.L.alpha`` split as
        ``alpha_n (L alpha)_n``).

        Parameters
        ----------
        alpha : ndarray, shape (n,)

        Returns
        -------
        ndarray, shape (n,)
            Energy per node.
        """
        alpha = self._nodal("alpha", alpha)
        return self.cs * self.thickness * (self.omega * self.law.w(alpha) / self.eta
                                           + self.eta * alpha * (self.L @ alpha))

    def problem(self, e) -> tuple[sp.csr_matrix, np.ndarray]:
        """``(A, b)`` of the damage problem for the nodal energy ``e`` (module docstring), the
        fixed nodes decoupled.

        Parameters
        ----------
        e : ndarray, shape (n,)
            Nodal undamaged elastic energy, >= 0: the degraded elastic energy is
            ``1/2 sum_n g(alpha_n) e_n`` (energy units).

        Returns
        -------
        A : scipy.sparse.csr_matrix, shape (n, n)
            Symmetric, sorted indices; the same object every call, its diagonal rewritten in
            place (copy it to keep it).
        b : ndarray, shape (n,)
            A new array.
        """
        if self.at is None:
            raise ValueError(f"the {self.law.name} law's damage energy is not quadratic: use energy(e)")
        e = self._nodal("e", e)
        diag = self._diag_fixed + e
        b = e - self._linear
        if self.fixed_nodes.size:
            diag[self.fixed_nodes] = 1.0
            b[self.fixed_nodes] = -1.0
        self._A.data[self._diag_pos] = diag
        return self._A, b

    def energy(self, e) -> "DamageEnergy":
        """The damage energy at fixed displacement for the nodal energy ``e`` (module
        docstring), up to a constant, for any law.

        Parameters
        ----------
        e : ndarray, shape (n,)
            Nodal undamaged elastic energy, >= 0 (as for :meth:`problem`).
        """
        e = self._nodal("e", e)
        K = sp.csr_matrix((self._A.data.copy(), self._A.indices, self._A.indptr), shape=self._A.shape)
        K.has_sorted_indices = True
        K.data[self._diag_pos] = self._diag_laplacian
        return DamageEnergy(self.law, 0.5 * e, self.cs * self.thickness / self.eta * self.omega, K, self._diag_pos,
                            self.fixed_nodes)


class DamageEnergy:
    """The damage energy at fixed displacement of any law (module docstring)::

        F(alpha) = sum_n [ c_n g(alpha_n) + s_n w(alpha_n) ] + 1/2 alpha.K.alpha

    with the fixed nodes decoupled as in :meth:`DamageOperator.problem` (their rows of ``K``
    are the identity and their terms ``alpha_n``: a gradient of 1 holds them at the lower
    bound 0).

    Parameters
    ----------
    law : thinfilm.laws.DamageLaw
    c, s : ndarray, shape (n,)
        Nodal weights of ``g`` and ``w`` (energy units).
    K : scipy.sparse.csr_matrix, shape (n, n)
        ``2 cs eta T L`` with the fixed nodes decoupled; owned by the object.
    diag_pos : ndarray of int
        Positions of the diagonal entries in ``K.data``, in row order.
    fixed_nodes : ndarray of int
    """

    def __init__(self, law, c, s, K, diag_pos, fixed_nodes):
        self.law, self.K, self._diag_pos = law, K, diag_pos
        self.c, self.s = np.array(c, dtype=float), np.array(s, dtype=float)
        self.fixed_nodes = fixed_nodes
        self.c[fixed_nodes] = 0.0
        self.s[fixed_nodes] = 0.0
        self._K_diag = K.data[diag_pos].copy()
        self._K_diag[fixed_nodes] = 1.0
        K.data[diag_pos] = self._K_diag
        self._unit = np.zeros(K.shape[0])
        self._unit[fixed_nodes] = 1.0     # the fixed nodes' linear term

    @property
    def n(self) -> int:
        return self.K.shape[0]

    def value(self, alpha) -> float:
        """``F(alpha)`` (energy units, up to a constant)."""
        law = self.law
        return float(self.c @ law.g(alpha) + self.s @ law.w(alpha) + 0.5 * alpha @ (self.K @ alpha)
                     + self._unit @ alpha)

    def gradient(self, alpha) -> np.ndarray:
        """``dF/dalpha``, shape (n,)."""
        law = self.law
        return self.c * law.dg(alpha) + self.s * law.dw(alpha) + self.K @ alpha + self._unit

    def curvature(self, alpha) -> np.ndarray:
        """The nodal part of the Hessian, ``c g'' + s w''``, shape (n,) (0 at fixed nodes)."""
        law = self.law
        return self.c * law.d2g(alpha) + self.s * law.d2w(alpha)

    def _K_plus_diagonal(self, d):
        """``K + diag(d)``, a new matrix."""
        M = self.K.copy()
        M.data[self._diag_pos] += d
        return M

    def hessian(self, alpha) -> sp.csr_matrix:
        """``d2F/dalpha^2 = K + diag(curvature)``, a new matrix."""
        return self._K_plus_diagonal(self.curvature(alpha))

    def convex_model(self, alpha) -> tuple[sp.csr_matrix, np.ndarray]:
        """``(A, b)``: the convex quadratic model ``1/2 x.A.x - b.x`` of ``F`` about ``alpha``,
        with ``F``'s gradient there and the Hessian's nodal part replaced by its absolute
        value (a negative curvature, as ``w'' = -2`` of the cohesive law, would make the model
        unbounded; its size keeps the step's scale). ``A`` is a new matrix."""
        A = self._K_plus_diagonal(np.abs(self.curvature(alpha)))
        return A, A @ alpha - self.gradient(alpha)


def _fixed_nodes(value, n) -> np.ndarray:
    """``value`` as a read-only, strictly increasing int64 array of nodes in [0, n)."""
    a = np.zeros(0, dtype=np.int64) if value is None else index_array("fixed_nodes", value, n)
    a.flags.writeable = False
    return a
