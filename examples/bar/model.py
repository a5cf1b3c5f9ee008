"""A 1D AT1 bar in tension, P1 finite elements: a model of the evolution engine.

This module is the model half of the example (``examples/README.md`` walks through it): an
object with the attributes and methods of :class:`thinfilm.engine.protocol.FractureModel`,
and nothing else of the toolkit. The engine drives it; :mod:`examples.bar.kind` turns it into
a model kind that scenes can name.

The bar
-------
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

The weak band
-------------
The weak spot is a band ``|x - L/2| < band`` (element midpoints; default ``band = 3 ell``)
of toughness ``Gc_w = weakness Gc`` (default 0.9 Gc), in both surface terms. In the
homogeneous state every node has the continuum's damage threshold (see
:meth:`Bar.critical_load`), so damage first appears in the band, and the band is wide
enough for the AT1 softening to make that state unstable at once (modes wider than about
``2.6 ell`` are), so it snaps into one crack. The crack's profile ``(1 - |x - L/2| /
(2 ell))^2`` fits in the band, so it costs ``Gc_w`` in the continuum. A defect of one node
does not do this (examples/README.md#why-a-weak-band).

The damage problem
------------------
With ``A`` and ``b`` below, ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + E(u, 0)`` exactly:

    A = diag(2 c) + 3/4 ell sum_e Gc_e K_e,      b_i = 2 c_i - 3 W_i / (8 ell),

``K_e = (1/h) [[1, -1], [-1, 1]]`` the P1 stiffness of element ``e`` (free ends). ``A`` is
symmetric with positive diagonal, and positive definite as soon as some strain is non-zero
(the gradient term alone vanishes on constants; at ``t = 0``, ``b < 0`` and the box QP's
answer ``alpha = lower`` needs no solve). The engine minimizes this quadratic over the box
``lower <= alpha <= 1`` (``lower``: the damage of the previous step, irreversibility).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["Bar", "g"]


def g(alpha, k_res):
    """AT1 stiffness degradation ``(1 - alpha)^2 + k_res``.

    Parameters
    ----------
    alpha : ndarray
        Damage, any shape, in [0, 1].
    k_res : float
        Residual stiffness: a broken element keeps ``k_res`` of its stiffness, so that the
        u-problem stays non-singular.

    Returns
    -------
    ndarray
        The same shape as ``alpha``.
    """
    return (1.0 - alpha) ** 2 + k_res


class Bar:
    """The AT1 bar of the module docstring, in the engine's ``FractureModel`` protocol.

    Parameters
    ----------
    L, E, Gc, ell : float
        Length, Young's modulus, toughness outside the weak band, regularization length
        (any consistent units; the energies are per unit cross-section).
    n : int
        Number of elements (even: the middle ``L/2`` is the node ``m = n / 2``).
    k_res : float
        Residual stiffness. The default, 1e-8, keeps the floor it sets to the elastic
        energy of a crack, about ``E k_res t^2 / (4 h)`` (two elements of stiffness
        ``k_res``), well below the ``O(h)`` elastic energy the discrete crack keeps
        (examples/README.md#why-k_res-is-1e-8).
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
        Number of damage unknowns (``n + 1``, the ends included). Protocol attribute.
    proportional : bool
        True: the load is ``u(L) = t``, so at fixed damage ``u`` scales with ``t``.
        Protocol attribute (backtracking compares states moved along the load with it).
    toughness : float
        ``Gc`` (the engine scales its search threshold by it). Protocol attribute.
    b_surface : ndarray, shape (n + 1,)
        The linear part of the surface energy, ``3 W_i / (8 ell)``.
    A_surface : scipy.sparse.csr_matrix, shape (n + 1, n + 1)
        The quadratic part of the surface energy, ``3/4 ell sum_e Gc_e K_e``.

    Raises
    ------
    ValueError
        If ``n`` is odd or ``weakness`` is not in (0, 1].
    """

    #: Whether ``[solver] nonlinear = "auto"`` uses Newton on this model (docs/speed.md#newton).
    newton_pays = False

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
        # What the engine reads of every model (FractureModel's attributes).
        self.n_alpha = n + 1
        self.proportional = True
        self.toughness = self.Gc
        # The surface energy does not depend on u: its two parts are built once here, and
        # each damage problem only adds the elastic part.
        self.b_surface = 3.0 / (8.0 * self.ell) * self._to_nodes(0.5 * self.h * self.Gc_elements)
        self.A_surface = 0.75 * self.ell * self._assemble_stiffness(self.Gc_elements / self.h)

    def _to_nodes(self, per_element):
        """``sum_{e ni i} q_e`` at each node: an element quantity shared by its two nodes.

        Parameters
        ----------
        per_element : ndarray, shape (n,)

        Returns
        -------
        ndarray, shape (n + 1,)
        """
        nodal = np.zeros(self.n + 1)
        nodal[:-1] += per_element
        nodal[1:] += per_element
        return nodal

    def _assemble_stiffness(self, k):
        """``sum_e k_e [[1, -1], [-1, 1]]`` on all nodes.

        Parameters
        ----------
        k : ndarray, shape (n,)
            The stiffness of each element.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (n + 1, n + 1)
            Tridiagonal, free ends.
        """
        return sp.diags([-k, self._to_nodes(k), -k], [-1, 0, 1], format="csr")

    # -- closed forms -------------------------------------------------------------------
    def critical_load(self):
        """Load at which damage first appears, ``t_c = L sqrt(3 Gc_w / (8 E ell))``.

        In the homogeneous state (``alpha = 0``, ``u' = t / L``),
        ``c_i = sum_{e ni i} E h (t/L)^2 / 4`` and ``W_i = sum_{e ni i} Gc_e h / 2``, so
        ``b_i = h/2 sum_{e ni i} (E (t/L)^2 - 3 Gc_e / (8 ell))`` (``g'(0) = -2``; ``k_res``
        does not enter): element by element the continuum's threshold, first exceeded at
        the nodes whose elements are all in the weak band.

        Returns
        -------
        float
            ``t_c``, a displacement of the end (the unit of ``L``).
        """
        return self.L * np.sqrt(3.0 * self.Gc_weak / (8.0 * self.E * self.ell))

    # -- the FractureModel protocol -----------------------------------------------------
    def element_stiffness(self, alpha):
        """``g_e``: the mean of ``g`` at the two nodes of each element.

        Parameters
        ----------
        alpha : ndarray, shape (n + 1,)

        Returns
        -------
        ndarray, shape (n,)
        """
        g_nodes = g(alpha, self.k_res)
        return 0.5 * (g_nodes[:-1] + g_nodes[1:])

    def solve_u(self, alpha, t, u0=None, rtol=None):
        """Displacement at all nodes minimizing the energy at fixed ``alpha``.

        A sparse direct solve of the tridiagonal system of the inner nodes, with
        ``u_0 = 0`` and ``u_n = t``.

        Parameters
        ----------
        alpha : ndarray, shape (n + 1,)
            Damage.
        t : float
            Load: the displacement of the end ``x = L``.
        u0 : ndarray, optional
            The engine's warm start (the last ``u``): for iterative solvers, not needed here.
        rtol : float, optional
            The tolerance the engine asks of iterative solvers; a direct solve ignores it.

        Returns
        -------
        ndarray, shape (n + 1,)
        """
        K = self._assemble_stiffness(self.E * self.element_stiffness(alpha) / self.h)
        u = np.zeros(self.n + 1)
        u[-1] = t
        # The known end values moved to the right-hand side (u_0 = 0 contributes nothing).
        f = -(K[1:-1, -1].toarray().ravel()) * t
        u[1:-1] = spla.spsolve(K[1:-1, 1:-1].tocsc(), f)
        return u

    def strain_weights(self, u):
        """``c_i = sum_{e ni i} E h u'_e^2 / 4``: the elastic energy is ``sum_i c_i g(alpha_i)``.

        Parameters
        ----------
        u : ndarray, shape (n + 1,)

        Returns
        -------
        ndarray, shape (n + 1,)
        """
        strain = np.diff(u) / self.h
        return self._to_nodes(0.25 * self.E * self.h * strain**2)

    def damage_problem(self, u, t):
        """The energy at fixed ``u`` as a quadratic in ``alpha``.

        ``g(alpha_i) = 1 - 2 alpha_i + alpha_i^2 + k_res``, so ``sum_i c_i g(alpha_i)`` gives
        ``diag(2 c)`` to ``A`` and ``2 c`` to ``b``; the surface energy gives the rest.

        Parameters
        ----------
        u : ndarray, shape (n + 1,)
        t : float
            Load (the quadratic does not depend on it beyond ``u``).

        Returns
        -------
        A : scipy.sparse.csr_matrix, shape (n + 1, n + 1)
            Symmetric, an M-matrix, positive definite once some strain is non-zero.
        b : ndarray, shape (n + 1,)
            With ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + E(u, 0)``.
        """
        c = self.strain_weights(u)
        A = (sp.diags(2.0 * c) + self.A_surface).tocsr()
        b = 2.0 * c - self.b_surface
        return A, b

    def energies(self, u, alpha, t):
        """Elastic energy ``sum_e E h g_e u'_e^2 / 2`` and surface energy.

        Parameters
        ----------
        u, alpha : ndarray, shape (n + 1,)
        t : float
            Load (the energies depend on it only through ``u``).

        Returns
        -------
        elastic, surface : float
            Energies per unit cross-section (the unit of ``E L``).
        """
        strain = np.diff(u) / self.h
        elastic = 0.5 * self.E * self.h * float(np.sum(self.element_stiffness(alpha) * strain**2))
        surface = float(self.b_surface @ alpha) + 0.5 * float(alpha @ (self.A_surface @ alpha))
        return elastic, surface

    def trial_states(self, u, alpha, t):
        """No nucleation trials: the weak band starts the crack.

        The optional :class:`thinfilm.engine.protocol.TrialStates` hook; an empty list is a
        valid answer, so the nucleation search can be switched on for this model and finds
        nothing to try.

        Returns
        -------
        list
            Empty.
        """
        return []

    # -- the optional EnergyDerivatives hook ----------------------------------------------
    def free_u(self, u):
        """The free dofs of ``u``: the inner nodes ``1 .. n - 1``.

        The optional :class:`thinfilm.engine.protocol.EnergyDerivatives` hook (as the three
        methods below).

        Parameters
        ----------
        u : ndarray, shape (n + 1,)

        Returns
        -------
        ndarray, shape (n - 1,)
        """
        return np.asarray(u, dtype=np.float64)[1:-1].copy()

    def u_from_free(self, u_free, t):
        """The full displacement with ``u_0 = 0`` and ``u_n = t``.

        Parameters
        ----------
        u_free : ndarray, shape (n - 1,)
        t : float

        Returns
        -------
        ndarray, shape (n + 1,)
        """
        u = np.zeros(self.n + 1)
        u[1:-1] = u_free
        u[-1] = t
        return u

    def energy_gradient(self, u, alpha, t):
        """``(dE/du_free, dE/dalpha)`` at ``(u, alpha)``.

        ``dE/du = K(alpha) u`` on the inner nodes (``K`` the stiffness of :meth:`solve_u`);
        ``dE/dalpha = A alpha - b`` with ``(A, b)`` of :meth:`damage_problem` (the energy is
        quadratic in ``alpha``).

        Parameters
        ----------
        u, alpha : ndarray, shape (n + 1,)
        t : float

        Returns
        -------
        g_u : ndarray, shape (n - 1,)
        g_alpha : ndarray, shape (n + 1,)
        """
        K = self._assemble_stiffness(self.E * self.element_stiffness(alpha) / self.h)
        A, b = self.damage_problem(u, t)
        return (K @ u)[1:-1], A @ alpha - b

    def hessian_blocks(self, u, alpha, t):
        """``(K_uu, K_ua, K_aa)``: the second derivatives of the energy.

        ``K_uu`` is the inner block of :meth:`solve_u`'s stiffness, ``K_aa`` the ``A`` of
        :meth:`damage_problem`, and, with ``P = sum_i c_i(u) g(alpha_i)``,
        ``K_ua[m, i] = g'(alpha_i) dc_i/du_m``, ``dc_i/du = sum_{e ni i} E u'_e / 2
        (delta_{e+1} - delta_e)`` (element ``e = (e, e + 1)``): each element couples its two
        nodes' displacements with its two nodes' damage.

        Parameters
        ----------
        u, alpha : ndarray, shape (n + 1,)
        t : float

        Returns
        -------
        K_uu : scipy.sparse.csr_matrix, shape (n - 1, n - 1)
        K_ua : scipy.sparse.csr_matrix, shape (n - 1, n + 1)
        K_aa : scipy.sparse.csr_matrix, shape (n + 1, n + 1)
        """
        K = self._assemble_stiffness(self.E * self.element_stiffness(alpha) / self.h)
        e = np.arange(self.n)
        half = 0.5 * self.E * np.diff(u) / self.h               # E u'_e / 2: dc_i/du_{e+1} = -dc_i/du_e, i in e
        dg = -2.0 * (1.0 - np.asarray(alpha, dtype=np.float64))  # g'(alpha)
        rows = np.concatenate([e, e, e + 1, e + 1])
        cols = np.concatenate([e, e + 1, e, e + 1])
        vals = np.concatenate([-half * dg[e], -half * dg[e + 1], half * dg[e], half * dg[e + 1]])
        K_ua = sp.csr_matrix((vals, (rows, cols)), shape=(self.n + 1, self.n + 1))[1:-1]
        A, _ = self.damage_problem(u, t)
        return K[1:-1, 1:-1].tocsr(), K_ua, A.tocsr().copy()
