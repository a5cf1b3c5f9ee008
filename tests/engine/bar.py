"""A 1D AT1 bar in tension, P1 finite elements: a model of the evolution engine that is not the plate.

The bar ``(0, L)`` (Young's modulus ``E``, unit cross-section) is pulled by its end,
``u(0) = 0`` and ``u(L) = t`` (displacement control, proportional to ``t``). Its energy is

    E(u, alpha) = 1/2 int g(alpha) E u'^2 dx + 3/8 int Gc(x) alpha/ell + Gc ell alpha'^2 dx,

with ``g(alpha) = (1 - alpha)^2 + k_res`` (AT1). Both ``u`` and ``alpha`` are P1 on the
uniform mesh ``x_i = i h``, ``h = L / n``, ``i = 0 .. n``; the integrals are evaluated as:

* elastic term: on element ``e = (i, i + 1)`` the strain ``u'_e = (u_{i+1} - u_i) / h``
  is constant, and ``g`` is taken as the mean of its values at the two nodes,
  ``g_e = (g(alpha_i) + g(alpha_{i+1})) / 2`` (trapezoidal rule). The elastic energy is then
  ``sum_i c_i ((1 - alpha_i)^2 + k_res)`` with ``c_i = sum_{e ni i} E h u'_e^2 / 4``: a
  diagonal ("mass-lumped") quadratic in alpha, so the damage problem keeps the sparsity of
  the gradient term and stays an M-matrix;
* local surface term ``3/8 int Gc alpha / ell``: lumped, ``3/8 sum_i Gc_i w_i alpha_i / ell``
  with the trapezoidal weights ``w_i = h`` inside and ``h / 2`` at the ends;
* gradient term: the exact P1 integral, ``3/8 Gc ell sum_e (alpha_{i+1} - alpha_i)^2 / h``.

The weak spot: the toughness of the *local* term at the middle node ``m = n / 2`` is
``Gc_m = weakness * Gc`` (default 0.9); everywhere else, and in the gradient term, it is
``Gc``. In the homogeneous state the damage threshold of every node is then that of the
continuum (see :meth:`Bar.critical_load`), the lowest at ``m``, so the crack has one place
to go, and the device costs only ``3/8 (1 - weakness) Gc h alpha_m / ell = O(h / ell)`` in a
crack centred there.

With ``A`` and ``b`` below, ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + E(u, 0)`` exactly:

    A = diag(2 c) + 3/4 Gc ell K,      b_i = 2 c_i - 3/8 Gc_i w_i / ell,

``K`` the P1 stiffness matrix (``(1/h) [[1, -1], [-1, 1]]`` per element, free ends). ``A``
is symmetric with positive diagonal, and positive definite as soon as some strain is
non-zero (``K`` alone vanishes on constants; at ``t = 0``, ``b < 0`` and the box QP's
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
        Length, Young's modulus, toughness, regularization length.
    n : int
        Number of elements (even, so that the weak node ``n / 2`` is the middle).
    k_res : float
        Residual stiffness.
    weakness : float
        Toughness factor of the local term at the middle node (``0 < weakness <= 1``).

    Attributes
    ----------
    x : ndarray, shape (n + 1,)
        Nodes.
    h : float
        Element length.
    w : ndarray, shape (n + 1,)
        Lumped (trapezoidal) nodal weights.
    Gc_nodes : ndarray, shape (n + 1,)
        Toughness of the local surface term at each node.
    m : int
        Index of the weak node.
    n_alpha : int
        Number of damage unknowns (``n + 1``, the ends included).
    proportional : bool
        True: the load is ``u(L) = t``.
    toughness : float
        ``Gc`` (the engine scales its search threshold by it).
    """

    def __init__(self, L=1.0, E=1.0, Gc=1.0, ell=0.05, n=200, k_res=1e-6, weakness=0.9):
        if n % 2:
            raise ValueError(f"n = {n}: must be even (the weak node is the middle one)")
        if not 0.0 < weakness <= 1.0:
            raise ValueError(f"weakness = {weakness}: must be in (0, 1]")
        self.L, self.E, self.Gc, self.ell, self.n, self.k_res = float(L), float(E), float(Gc), float(ell), n, k_res
        self.h = self.L / n
        self.x = np.linspace(0.0, self.L, n + 1)
        self.w = np.full(n + 1, self.h)
        self.w[[0, -1]] = self.h / 2
        self.m = n // 2
        self.Gc_nodes = np.full(n + 1, self.Gc)
        self.Gc_nodes[self.m] *= weakness
        self.n_alpha = n + 1
        self.proportional = True
        self.toughness = self.Gc
        ones = np.ones(n + 1)
        inner = ones.copy()
        inner[1:-1] = 2.0
        K = sp.diags([-ones[:-1], inner, -ones[:-1]], [-1, 0, 1]) / self.h
        #: The quadratic part of the surface energy, ``3/4 Gc ell K`` (independent of u).
        self.A_surface = (0.75 * self.Gc * self.ell * K).tocsr()
        #: The linear part of the surface energy, ``3/8 Gc_i w_i / ell``.
        self.b_surface = 0.375 * self.Gc_nodes * self.w / self.ell

    # -- closed forms -------------------------------------------------------------------
    def critical_load(self):
        """Load at which damage first appears, ``t_c = L sqrt(3 Gc_m / (8 E ell))``.

        In the homogeneous state (``alpha = 0``, ``u' = t / L``), ``c_i = E (t/L)^2 w_i / 2``
        (a node inside has two elements of length ``h``, an end one: ``sum h / 4 = w_i / 2``),
        so ``b_i = w_i (E (t/L)^2 - 3 Gc_i / (8 ell))``: the same threshold as the
        continuum's, node by node, lowest at the weak node. Damage appears when ``b_m > 0``.
        """
        return self.L * np.sqrt(3.0 * self.Gc_nodes.min() / (8.0 * self.E * self.ell))

    # -- the FractureModel protocol -----------------------------------------------------
    def element_stiffness(self, alpha):
        """``g_e``: the mean of ``g`` at the two nodes of each element, shape (n,)."""
        g_nodes = g(alpha, self.k_res)
        return 0.5 * (g_nodes[:-1] + g_nodes[1:])

    def solve_u(self, alpha, t, u0=None, rtol=None):
        """Displacement at all nodes minimizing the energy at fixed ``alpha``.

        A sparse direct solve of the tridiagonal system of the inner nodes, with
        ``u_0 = 0`` and ``u_n = t``; ``u0`` and ``rtol`` (for iterative solvers) are
        not needed.
        """
        k = self.E * self.element_stiffness(alpha) / self.h  # spring constant of each element
        diagonal = k[:-1] + k[1:]
        off = -k[1:-1]
        K = sp.diags([off, diagonal, off], [-1, 0, 1], format="csc")
        f = np.zeros(self.n - 1)
        f[-1] = k[-1] * t  # the known end value u_n = t moved to the right-hand side
        u = np.empty(self.n + 1)
        u[0], u[-1] = 0.0, t
        u[1:-1] = spla.spsolve(K, f)
        return u

    def strain_weights(self, u):
        """``c_i = sum_{e ni i} E h u'_e^2 / 4``: elastic energy = ``sum_i c_i g(alpha_i)``."""
        strain = np.diff(u) / self.h
        half = 0.25 * self.E * self.h * strain**2
        c = np.zeros(self.n + 1)
        c[:-1] += half
        c[1:] += half
        return c

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
        """No nucleation trials: the weak node starts the crack."""
        return []
