"""The finite-difference thin-film model as seen by the evolution engine.

:class:`PlateModel` binds a grid, the plate + Winkler operator, the damage operator, a load
``t -> w_t`` and a linear solver into the :class:`thinfilm.engine.protocol.FractureModel`
interface: ``solve_u``, ``damage_problem``, ``energies``, ``trial_states`` (the trial
cracks of the nucleation search) and ``stability_modes`` (the stability check); ``force``
gives the force conjugate to the load parameter, which the runs record at every step.
"""

from __future__ import annotations

from typing import Callable

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from thinfilm.plate.derivatives import cross_block
from thinfilm.plate.energy import load_force
from thinfilm.plate.grid import Grid
from thinfilm.solvers.linear import DirectSolver, make_solver
from thinfilm.plate.operators import GridDamage, PlateOperator
from thinfilm.plate.stability import lowest_modes


def crack_profile(distance, eta, at):
    """Optimal 1D damage profile across a crack, as a function of the distance to it.

    AT1: ``(1 - d / (2 eta))^2`` for ``d < 2 eta``, 0 beyond; AT2: ``exp(-d / eta)``.

    Parameters
    ----------
    distance : ndarray
        Distance to the crack (units of L), >= 0.
    eta : float
    at : {1, 2}

    Returns
    -------
    ndarray
        Damage in [0, 1], same shape as ``distance``.
    """
    d = np.asarray(distance, dtype=float)
    if at == 1:
        return np.clip(1.0 - d / (2.0 * eta), 0.0, 1.0) ** 2
    return np.exp(-d / eta)


class PlateModel:
    """A thin film (plate on a Winkler foundation) with AT damage on a structured grid.

    Parameters
    ----------
    grid : Grid
    nu, winkler, k_res : float
        Poisson ratio, foundation stiffness ``K/a^4``, residual stiffness.
    eta, toughness : float
        Regularization length and ``G/a``.
    at : {1, 2}
    load : callable
        ``load(t) -> w_t``, the substrate displacement at the nodes, shape ``(n_nodes,)``.
    proportional : bool
        True if ``load(t) = t load(1)``.
    linear_solver : object
        With ``update(K)`` and ``solve(f, x0=None, rtol=None) -> (u, info)``
        (:mod:`thinfilm.solvers.linear`).
    clamped : tuple of str, optional
        Clamped edges.
    trial_radius : float, optional
        Radius (units of L) of the fully damaged core of a 2D trial crack (a disk); 0 in 1D.
    sound_threshold : float, optional
        Nodes with ``alpha`` below this are "sound" for the nucleation search.
    symmetry : GridSymmetry, optional
        Look for u and alpha among fields invariant under this mirror group
        (:mod:`thinfilm.plate.symmetry`): the u-problem is solved for one unknown per orbit of
        nodes (``linear_solver`` is then made for the reduced matrix,
        :meth:`reduced_matrix`), the damage is averaged over each orbit after every
        alpha-solve (:meth:`project_alpha`) and every trial crack is inserted with all its
        mirror images. Fields stay full-size everywhere else, but for the displacement
        unknowns of the derivatives (:meth:`free_u`): one per orbit of free nodes.
    toughness_factor : ndarray, shape (n_nodes,), optional
        A film of varying toughness ``toughness * factor`` (:mod:`thinfilm.plate.imperfection`);
        with a symmetry it must be invariant under it.
    load_rate : callable, optional
        ``load_rate(t) -> dw_t/dt`` at the nodes (:meth:`thinfilm.plate.loads.Load.dw`), for
        :meth:`force`; by default ``load(1)`` for a proportional load.
    """

    #: Whether ``[solver] nonlinear = "auto"`` uses Newton on this model (docs/speed.md#newton).
    newton_pays = False

    def __init__(self, grid: Grid, nu, winkler, k_res, eta, toughness, at, load: Callable, proportional,
                 linear_solver, clamped=(), trial_radius=0.0, sound_threshold=0.5, symmetry=None,
                 toughness_factor=None, load_rate=None):
        self.grid = grid
        self.plate = PlateOperator(grid, nu, winkler, k_res, clamped=clamped)
        self.damage = GridDamage(grid, eta, toughness, at, toughness_factor=toughness_factor)
        self.eta, self.at = float(eta), int(at)
        self.load = load
        self.proportional = bool(proportional)
        self.load_rate = load_rate
        self.linear_solver = linear_solver
        self.n_alpha = grid.n_nodes
        self.toughness = float(toughness)  # G/a: the search's threshold is relative to it
        self.trial_radius = float(trial_radius)
        self.sound_threshold = float(sound_threshold)
        self.symmetry = symmetry
        self.last_solve_info = None
        self._stability_solver = None
        self._derivative_orbits = None   # (free orbits, P_f^T) of the EnergyDerivatives hook

    def reduced_matrix(self, alpha):
        """The matrix the linear solver sees: the plate operator at ``alpha``, restricted to
        symmetric fields (``P^T K P``) if the model has a symmetry."""
        K = self.plate.matrix(alpha)
        return K if self.symmetry is None else self.symmetry.reduce_matrix(K)

    def solve_u(self, alpha, t, u0, rtol):
        """Minimize the energy over u at fixed ``alpha`` (shape ``(n_nodes,)``).

        With a symmetry ``alpha`` must be symmetric (the engine sees to it) and the solver
        works on ``P^T K P v = P^T f``; an iterative solver's ``rtol`` then measures the
        residual ``P^T r``, whose entries are orbit sums (a norm weighted by orbit size, within
        a factor sqrt(8) of the full residual's for a symmetric residual).
        """
        sym = self.symmetry
        self.linear_solver.update(self.reduced_matrix(alpha))
        f = self.plate.rhs(self.load(t))
        if sym is None:
            u, info = self.linear_solver.solve(f, x0=u0, rtol=rtol)
        else:
            v, info = self.linear_solver.solve(sym.reduce_vector(f), x0=None if u0 is None else sym.restrict(u0),
                                               rtol=rtol)
            u = sym.expand(v)
        self.last_solve_info = info
        return u

    def project_alpha(self, alpha):
        """The damage the engine keeps after an alpha-solve: ``alpha`` itself, or its orbit
        average if the model has a symmetry (the exact minimizer, unique since the damage
        problem is positive definite, is symmetric; the average removes the damage solver's
        asymmetric rounding, and is feasible and no worse)."""
        return alpha if self.symmetry is None else self.symmetry.average(alpha)

    def project_lower(self, lower):
        """The irreversibility bound of a load step: ``lower`` itself, or with a symmetry its
        orbit maximum (the least symmetric field above it), shape ``(n_nodes,)``."""
        return lower if self.symmetry is None else self.symmetry.maximum(np.broadcast_to(lower, (self.n_alpha,)))

    def damage_problem(self, u, t):
        return self.damage.problem(self.plate.bending_density(u))

    def energies(self, u, alpha, t):
        return self.plate.elastic_energy(u, alpha, self.load(t)), self.damage.surface_energy(alpha)

    def force(self, u, t):
        """The force conjugate to the load parameter, ``dE/dt`` at fixed ``u`` and ``alpha``
        (:func:`thinfilm.plate.energy.load_force`; the damage does not enter: only the
        foundation depends on ``t``).

        Parameters
        ----------
        u : ndarray, shape (n_nodes,)
        t : float

        Returns
        -------
        float
            Non-dimensional energy per unit of ``t``.

        Raises
        ------
        ValueError
            For a load that is not proportional and was given without its rate.
        """
        if self.load_rate is not None:
            rate = self.load_rate(t)
        elif self.proportional:
            rate = self.load(1.0)
        else:
            raise ValueError("the force of a load that is not proportional to t needs its rate (load_rate)")
        return load_force(self.plate, u, self.load(t), rate)

    def elastic_density(self, u, alpha, t):
        """Undamaged bending energy per unit area at the nodes (lumped), shape ``(n_nodes,)``."""
        return self.plate.bending_density(u) / self.grid.weights

    def candidates(self, u, alpha, t):
        """Candidate nucleation points: in each sound region, its point of largest elastic
        energy density (relative to the local toughness in an imperfect film: where AT
        damage would start first) and its point farthest from damage and edges (its "middle").

        Returns
        -------
        list of int
            Flat node indices, without repeats.
        """
        shape = self.grid.shape
        sound = (alpha < self.sound_threshold).reshape(shape)
        density = self.elastic_density(u, alpha, t)
        if self.damage.toughness_factor is not None:
            density = density / self.damage.toughness_factor
        density = density.reshape(shape)
        labels, n = ndimage.label(sound)
        # Distance to damage and to the domain boundary: pad with non-sound nodes.
        padded = np.pad(sound, 1, constant_values=False)
        spacing = (self.grid.hx,) if self.grid.dim == 1 else (self.grid.hy, self.grid.hx)  # [j, i] order
        distance = ndimage.distance_transform_edt(padded, sampling=spacing)[(slice(1, -1),) * sound.ndim]
        out = []
        orbits = set()   # with a symmetry, one candidate per orbit (its images are added anyway)
        for region in range(1, n + 1):
            mask = labels == region
            if mask.sum() < 3:
                continue
            for field in (np.where(mask, density, -np.inf), np.where(mask, distance, -np.inf)):
                node = int(np.ravel_multi_index(np.unravel_index(np.argmax(field), shape), shape))
                orbit = node if self.symmetry is None else int(self.symmetry.orbit[node])
                if orbit not in orbits:
                    orbits.add(orbit)
                    out.append(node)
        return out

    def stability_modes(self, alpha, t, lower, k=4):
        """The lowest curvatures of the reduced energy at ``alpha`` on its free nodes
        (:func:`thinfilm.plate.stability.lowest_modes`, which solves for the minimizing u at
        ``alpha`` itself: a converged state's u belongs to the damage before its last
        alpha-solve).

        Parameters
        ----------
        alpha, lower : ndarray, shape (n_nodes,)
            Damage and its lower bound at this load step.
        t : float
        k : int

        Returns
        -------
        lowest : float
            The lowest curvature in units of ``toughness / eta`` (``+inf`` without free nodes).
        modes : ndarray, shape (k', n_nodes)
            The modes, most unstable first, ``max |mode| = 1``.

        Raises
        ------
        ValueError
            For a model restricted to symmetric fields: its damage cannot follow a mode
            that breaks the symmetry.
        """
        if self.symmetry is not None:
            raise ValueError("the stability check needs fields free of symmetry restrictions")
        if self._stability_solver is None:
            # The u-solver is reused when it is a direct one (the next u-solve refactors it
            # anyway); an iterative one is no use for the many solves of the eigensolver.
            self._stability_solver = (self.linear_solver if isinstance(self.linear_solver, DirectSolver)
                                      else make_solver("direct", self.plate.matrix(np.zeros(self.n_alpha))))
        modes = lowest_modes(self.plate, self.damage, alpha, self.load(t), lower, k=k,
                             solver=self._stability_solver)
        scale = self.damage.toughness / self.eta
        return modes.lowest / scale, modes.modes

    def trial_states(self, u, alpha, t):
        """One damage field per candidate point, with a crack profile inserted there.

        In 1D the trial crack is the optimal profile centred at the node; in 2D a disk of
        radius ``trial_radius`` fully damaged, with the profile around it, which alternate
        minimization then grows into a crack or heals. With a symmetry the crack is inserted
        at the candidate and at all its mirror images.
        """
        coords = self.grid.coordinates
        trials = []
        for node in self.candidates(u, alpha, t):
            if self.grid.dim == 1:
                distance = np.abs(coords[0] - coords[0][node])
            else:
                distance = np.hypot(coords[0] - coords[0][node], coords[1] - coords[1][node])
                distance = np.maximum(distance - self.trial_radius, 0.0)
            trial = np.maximum(alpha, crack_profile(distance, self.eta, self.at))
            trials.append(trial if self.symmetry is None else self.symmetry.maximum(trial))
        return trials

    # --- the optional EnergyDerivatives hook (docs/model.md#second-order-information) --------
    def _free_orbits(self):
        """``(free, R)`` of a model with a symmetry: the orbits of free nodes, shape
        ``(n_free_orbits,)``, and the 0/1 matrix ``R = P_f^T``, shape ``(n_free_orbits,
        n_free)``, that sums the free nodes' entries over each orbit. Computed once."""
        if self._derivative_orbits is None:
            sym = self.symmetry
            clamped = np.zeros(self.grid.n_nodes)
            clamped[self.plate.clamped_nodes] = 1.0
            count = np.bincount(sym.orbit, weights=clamped, minlength=sym.n_orbits)
            if np.any((count != 0) & (count != sym.orbit_size)):
                # solve_u would then solve another problem: an orbit mixing clamped and free nodes
                raise ValueError(f"the clamped edges {self.plate.clamped} are not mapped onto themselves by the"
                                 f" symmetry {sym.group!r}")
            free = np.flatnonzero(count == 0)
            position = np.full(sym.n_orbits, -1, dtype=np.int64)
            position[free] = np.arange(free.size)
            nodes = self.plate.free_nodes
            R = sp.csr_matrix((np.ones(nodes.size), (position[sym.orbit[nodes]], np.arange(nodes.size))),
                              shape=(free.size, nodes.size))
            self._derivative_orbits = free, R
        return self._derivative_orbits

    def free_u(self, u):
        """The free displacement unknowns of the displacement ``u`` (shape ``(n_nodes,)``).

        Without a symmetry: the free (not clamped) nodes' values, shape ``(n_free,)``. With a
        symmetry: the orbit values ``v`` of the symmetric field ``u = P v`` (each orbit's value
        at its representative) on the orbits of free nodes, shape ``(n_free_orbits,)``: the
        unknowns of :meth:`solve_u`, whose clamped orbits are decoupled and held at 0 (the
        clamped edges are mapped onto themselves, so an orbit is all clamped or all free).
        ``u`` must then be symmetric (as :meth:`solve_u` returns it).

        :class:`thinfilm.engine.protocol.EnergyDerivatives`, as the three methods below; with
        a symmetry they are the derivatives of the restricted energy ``e(v, alpha) = E(P v, alpha)``.
        """
        if self.symmetry is None:
            return np.array(self.grid.nodal("u", u)[self.plate.free_nodes])
        free, _ = self._free_orbits()
        return np.array(self.symmetry.restrict(self.grid.nodal("u", u))[free])

    def u_from_free(self, u_free, t):
        """The full displacement, shape ``(n_nodes,)``, 0 on the clamped nodes (whatever
        ``t``): ``u_free`` (shape ``(n_free,)``) on the free nodes, or with a symmetry the
        symmetric field ``P v`` of the free orbits' values ``v = u_free``, shape
        ``(n_free_orbits,)``."""
        if self.symmetry is None:
            u = np.zeros(self.grid.n_nodes)
            u[self.plate.free_nodes] = u_free
            return u
        free, _ = self._free_orbits()
        v = np.zeros(self.symmetry.n_orbits)
        v[free] = u_free
        return self.symmetry.expand(v)

    def energy_gradient(self, u, alpha, t):
        """The gradient of the energy in the displacement unknowns and in the damage.

        Parameters
        ----------
        u, alpha : ndarray, shape (n_nodes,)
            Displacement (its clamped nodes count as 0, as in the energy; symmetric if the
            model has a symmetry) and damage.
        t : float
            Load.

        Returns
        -------
        g_u : ndarray, shape (n_free,) or (n_free_orbits,)
            ``K(alpha) u - winkler omega w_t`` on the free nodes, or with a symmetry its orbit
            sums ``P^T (K(alpha) u - winkler omega w_t)`` on the free orbits.
        g_alpha : ndarray, shape (n_nodes,)
            ``A alpha - b`` of :meth:`damage_problem`.
        """
        u = self.plate.constrain(u)
        g_u = self.plate.apply(alpha, u) - self.plate.rhs(self.load(t))
        A, b = self.damage_problem(u, t)
        g_alpha = A @ self.grid.nodal("alpha", alpha) - b
        if self.symmetry is None:
            return g_u[self.plate.free_nodes], g_alpha
        free, _ = self._free_orbits()
        return self.symmetry.reduce_vector(g_u)[free], g_alpha

    def hessian_blocks(self, u, alpha, t):
        """The Hessian blocks of the energy, fresh sparse matrices.

        Parameters
        ----------
        u, alpha : ndarray, shape (n_nodes,)
            As for :meth:`energy_gradient`.
        t : float

        Returns
        -------
        K_uu : scipy.sparse.csr_matrix, shape (n_free, n_free) or (n_free_orbits, n_free_orbits)
            The u-matrix at ``alpha`` on the free nodes; with a symmetry :meth:`reduced_matrix`
            (``P^T K P``, what :meth:`solve_u` factorizes) on the free orbits.
        K_ua : scipy.sparse.csr_matrix, shape (n_free, n_nodes) or (n_free_orbits, n_nodes)
            :func:`thinfilm.plate.derivatives.cross_block`; with a symmetry its rows summed
            over each orbit (``P^T K_ua``). Columns: every node.
        K_aa : scipy.sparse.csr_matrix, shape (n_nodes, n_nodes)
            The ``A`` of :meth:`damage_problem` (the damage stays a nodal field).
        """
        A, _ = self.damage_problem(self.plate.constrain(u), t)
        K_ua = cross_block(self.plate, u, alpha)
        if self.symmetry is None:
            free = self.plate.free_nodes
            K = self.plate.matrix(alpha)
            K_uu = K[free][:, free] if free.size < self.grid.n_nodes else K.copy()
            return K_uu.tocsr(), K_ua, A.copy()
        free, R = self._free_orbits()
        K = self.reduced_matrix(alpha)
        K_uu = K[free][:, free] if free.size < self.symmetry.n_orbits else K
        return K_uu.tocsr(), (R @ K_ua).tocsr(), A.copy()
