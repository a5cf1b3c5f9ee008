"""A 1D AT1 bar in tension, P1 finite elements: a model of the evolution engine that is not the plate.

The bar ``(0, L)`` (Young's modulus ``E``, unit cross-section) is pulled by its end,
``u(0) = 0`` and ``u(L) = t`` (displacement control, proportional to ``t``). Its energy is

    E(u, alpha) = 1/2 int g(alpha) E u'^2 dx + 3/8 int Gc(x) (alpha/ell + ell alpha'^2) dx,

with ``g(alpha) = (1 - alpha)^2 + k_res`` (AT1). Both ``u`` and ``alpha`` are P1 on the
uniform mesh ``x_i = i h``, ``h = L / n``, ``i = 0 .. n``, and the toughness is constant on
each element, ``Gc_e``. The integrals are evaluated element by element:

* elastic term: on element ``e = (i, i + 1)`` the strain ``u'_e = (u_{i+1} - u_i) / h`` is
  constant, and ``g`` is the mean of its values at the two nodes,
  ``g_e = (g(alpha_i) + g(alpha_{i+1})) / 2`` (trapezoidal rule). The elastic energy is then
  ``sum_i c_i g(alpha_i)`` with ``c_i = sum_{e ni i} E h u'_e^2 / 4``: a diagonal
  ("mass-lumped") quadratic in alpha, so the damage problem keeps the sparsity of the
  gradient term and stays an M-matrix;
* local surface term: lumped (trapezoidal), ``3/(8 ell) sum_e Gc_e h (alpha_i + alpha_{i+1})/2
  = 3/(8 ell) sum_i W_i alpha_i`` with ``W_i = sum_{e ni i} Gc_e h / 2``;
* gradient term: the exact P1 integral, ``3/8 ell sum_e Gc_e (alpha_{i+1} - alpha_i)^2 / h``.

The weak spot is a band ``|x - L/2| < band`` (element midpoints; default ``band = 3 ell``)
of toughness ``Gc_w = weakness Gc`` (default 0.9 Gc), in both surface terms. In the
homogeneous state every node has the continuum's damage threshold (see
:meth:`Bar.critical_load`), so damage first appears in the band, and the band is wide
enough for the AT1 softening to make that state unstable at once (modes wider than about
``2.6 ell`` are), so it snaps into one crack. The crack's profile ``(1 - |x - L/2| /
(2 ell))^2`` fits in the band, so it costs ``Gc_w`` in the continuum. (A single weak node,
``Gc_m = 0.9 Gc`` in the local term only, was tried first: it is a defect of size ``O(h)``,
the damage it starts at ``L sqrt(3 Gc_m / (8 E ell))`` stays ``O(h)`` and stable, and the bar
only snapped at the bulk threshold ``L sqrt(3 Gc / (8 E ell))``: within 0.4% of it with
n = 200 and 400, ell = 0.05, on a load grid of step 0.26%.)

With ``A`` and ``b`` below, ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + E(u, 0)`` exactly:

    A = diag(2 c) + 3/4 ell sum_e Gc_e K_e,      b_i = 2 c_i - 3 W_i / (8 ell),

``K_e = (1/h) [[1, -1], [-1, 1]]`` the P1 stiffness of element ``e`` (free ends). ``A`` is
symmetric with positive diagonal, and positive definite as soon as some strain is non-zero
(the gradient term alone vanishes on constants; at ``t = 0``, ``b < 0`` and the box QP's
answer ``alpha = lower`` needs no solve).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla


def g(alpha, k_res):
    """AT1 stiffness degradation ``(1 - alpha)^2 + k_res``."""
    return (1.0 - alpha) ** 2 + k_res


class Bar:
    """The AT1 bar of the module docstring, in the engine's ``FractureModel`` protocol.

    Parameters
    ----------
    L, E, Gc, ell : float
        Length, Young's modulus, toughness outside the weak band, regularization length.
    n : int
        Number of elements (even: the middle ``L/2`` is the node ``m = n / 2``).
    k_res : float
        Residual stiffness. The default, 1e-8, keeps the floor it sets to the elastic
        energy of a crack, about ``E k_res t^2 / (4 h)`` (two elements of stiffness
        ``k_res``), well below the ``O(h)`` elastic energy the discrete crack keeps for
        ``h >= L / 800``; with 1e-6 that floor was already most of it at ``n = 800``.
    weakness : float
        Toughness of the weak band relative to ``Gc`` (``0 < weakness <= 1``).
    band : float, optional
        Half-width of the weak band (default ``3 ell``).

    Attributes
    ----------
    x : ndarray, shape (n + 1,)
        Nodes.
    h : float
        Element length.
    w : ndarray, shape (n + 1,)
        Lumped (trapezoidal) nodal weights, ``h`` inside and ``h / 2`` at the ends.
    Gc_elements : ndarray, shape (n,)
        Toughness ``Gc_e`` of each element.
    Gc_weak : float
        ``weakness * Gc``, the least toughness.
    m : int
        Index of the middle node.
    n_alpha : int
        Number of damage unknowns (``n + 1``, the ends included).
    proportional : bool
        True: the load is ``u(L) = t``.
    toughness : float
        ``Gc`` (the engine scales its search threshold by it).
    """

    def __init__(self, L=1.0, E=1.0, Gc=1.0, ell=0.05, n=200, k_res=1e-8, weakness=0.9, band=None):
        if n % 2:
            raise ValueError(f"n = {n}: must be even (the middle of the bar is a node)")
        if not 0.0 < weakness <= 1.0:
            raise ValueError(f"weakness = {weakness}: must be in (0, 1]")
        self.L, self.E, self.Gc, self.ell, self.n, self.k_res = float(L), float(E), float(Gc), float(ell), n, k_res
        self.band = 3.0 * self.ell if band is None else float(band)
        self.h = self.L / n
        self.x = np.linspace(0.0, self.L, n + 1)
        self.w = np.full(n + 1, self.h)
        self.w[[0, -1]] = self.h / 2
        self.m = n // 2
        self.Gc_weak = weakness * self.Gc
        midpoints = 0.5 * (self.x[:-1] + self.x[1:])
        self.Gc_elements = np.where(np.abs(midpoints - 0.5 * self.L) < self.band, self.Gc_weak, self.Gc)
        self.n_alpha = n + 1
        self.proportional = True
        self.toughness = self.Gc
        #: The linear part of the surface energy, ``3 W_i / (8 ell)``.
        self.b_surface = 3.0 / (8.0 * self.ell) * self._to_nodes(0.5 * self.h * self.Gc_elements)
        #: The quadratic part of the surface energy, ``3/4 ell sum_e Gc_e K_e`` (independent of u).
        self.A_surface = 0.75 * self.ell * self._assemble_stiffness(self.Gc_elements / self.h)

    def _to_nodes(self, per_element):
        """``sum_{e ni i} q_e`` at each node: an element quantity shared by its two nodes."""
        nodal = np.zeros(self.n + 1)
        nodal[:-1] += per_element
        nodal[1:] += per_element
        return nodal

    def _assemble_stiffness(self, k):
        """``sum_e k_e [[1, -1], [-1, 1]]`` on all nodes (tridiagonal, CSR)."""
        return sp.diags([-k, self._to_nodes(k), -k], [-1, 0, 1], format="csr")

    # -- closed forms -------------------------------------------------------------------
    def critical_load(self):
        """Load at which damage first appears, ``t_c = L sqrt(3 Gc_w / (8 E ell))``.

        In the homogeneous state (``alpha = 0``, ``u' = t / L``),
        ``c_i = sum_{e ni i} E h (t/L)^2 / 4`` and ``W_i = sum_{e ni i} Gc_e h / 2``, so
        ``b_i = h/2 sum_{e ni i} (E (t/L)^2 - 3 Gc_e / (8 ell))`` (``g'(0) = -2``; ``k_res``
        does not enter): element by element the continuum's threshold, first exceeded at
        the nodes whose elements are all in the weak band.
        """
        return self.L * np.sqrt(3.0 * self.Gc_weak / (8.0 * self.E * self.ell))

    # -- the FractureModel protocol -----------------------------------------------------
    def element_stiffness(self, alpha):
        """``g_e``: the mean of ``g`` at the two nodes of each element, shape (n,)."""
        g_nodes = g(alpha, self.k_res)
        return 0.5 * (g_nodes[:-1] + g_nodes[1:])

    def solve_u(self, alpha, t, u0=None, rtol=None):
        """Displacement at all nodes minimizing the energy at fixed ``alpha``.

        A sparse direct solve of the tridiagonal system of the inner nodes, with
        ``u_0 = 0`` and ``u_n = t``; ``u0`` and ``rtol`` (for iterative solvers) are not
        needed.
        """
        K = self._assemble_stiffness(self.E * self.element_stiffness(alpha) / self.h)
        u = np.zeros(self.n + 1)
        u[-1] = t
        # The known end values moved to the right-hand side (u_0 = 0 contributes nothing).
        f = -(K[1:-1, -1].toarray().ravel()) * t
        u[1:-1] = spla.spsolve(K[1:-1, 1:-1].tocsc(), f)
        return u

    def strain_weights(self, u):
        """``c_i = sum_{e ni i} E h u'_e^2 / 4``: the elastic energy is ``sum_i c_i g(alpha_i)``."""
        strain = np.diff(u) / self.h
        return self._to_nodes(0.25 * self.E * self.h * strain**2)

    def damage_problem(self, u, t):
        """``(A, b)`` with ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + E(u, 0)``."""
        c = self.strain_weights(u)
        A = (sp.diags(2.0 * c) + self.A_surface).tocsr()
        b = 2.0 * c - self.b_surface
        return A, b

    def energies(self, u, alpha, t):
        """Elastic energy ``sum_e E h g_e u'_e^2 / 2`` and surface energy."""
        strain = np.diff(u) / self.h
        elastic = 0.5 * self.E * self.h * float(np.sum(self.element_stiffness(alpha) * strain**2))
        surface = float(self.b_surface @ alpha) + 0.5 * float(alpha @ (self.A_surface @ alpha))
        return elastic, surface

    def trial_states(self, u, alpha, t):
        """No nucleation trials: the weak band starts the crack."""
        return []
