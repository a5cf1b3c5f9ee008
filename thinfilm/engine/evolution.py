"""The quasi-static evolution engine: alternate minimization, backtracking, nucleation search.

The engine knows nothing of grids or meshes. It drives any model that offers the small
interface :class:`thinfilm.engine.protocol.FractureModel` (the finite-difference film of
:mod:`thinfilm.plate.model`, a finite-element solid, a test suite's 1D bar):

* at each load step ``t_i``, alternate minimization: ``u = argmin E(., alpha)`` (a linear
  solve), then ``alpha = argmin E(u, .)`` under ``alpha_{i-1} <= alpha <= 1`` (a
  bound-constrained QP, :func:`thinfilm.solvers.boxqp.solve_box_qp`), until the largest change of
  alpha is below ``tol`` (or, with ``stop = "energy"``, the energy has settled at a
  near-stationary state: :meth:`Engine._energy_settled`). Each half-step minimizes the energy exactly, so the energy never
  increases. An over-relaxed damage update (:class:`thinfilm.engine.options.AltMinOptions`) replaces the plain one
  only if, after the next u-solve, the energy is below that of the plain update; otherwise
  the plain update is restored, so the energy of the accepted states still decreases
  monotonically;
* with ``[solver] nonlinear = "newton"`` (:class:`thinfilm.engine.options.NewtonOptions`),
  alternate minimization hands its settling tail over to a Newton method on both fields
  (:mod:`thinfilm.engine.newton`), which ends the step at a KKT point or gives the state back
  (never at a higher energy); a step that alternate minimization finishes first is polished
  by Newton to the same tolerance;
* backtracking (dissertation Alg. 3.1): once step ``n`` has converged, a state
  ``(u_n, alpha_n)`` scaled to ``(t_k/t_n) u_n`` is admissible at every earlier step ``k``
  (alpha only grows), so if ``P_k + S_k - ((t_k/t_n)^2 P_n + S_n) >= delta`` the evolution
  goes back to step ``k``, starts it from ``alpha_n`` and marches forward again. Deep
  backtracking (Alg. 3.2) runs the same test every ``interval`` alternate-minimization
  iterations, over earlier steps scanned in ``direction`` within ``scope`` steps. Only for
  loads proportional to ``t``;
* a nucleation search: alternate minimization only finds stationary points and cannot
  start a crack where the elastic state is below the damage threshold. After it converges,
  the model proposes trial states (a crack profile inserted at candidate points of the
  sound regions); alternate minimization restarts from each, with irreversibility against
  the previous step only (a trial crack may heal), and the lowest energy is kept;
* a model that refines its discretization (:class:`thinfilm.engine.protocol.AdaptiveMesh`)
  is asked to refine around each converged state; while it does, every field the engine
  holds is carried to the finer discretization and the step is solved again from the
  transferred state (:meth:`Engine._refine_and_solve`).

The options of each part are declared in :mod:`thinfilm.engine.options`. Every step is
recorded (:class:`thinfilm.engine.records.StepRecord`); a solver that fails raises
:class:`EvolutionError` naming the step, the iteration and the residual, and the steps
already done stay with the caller (the ``on_step`` callback has seen each of them).
"""

from __future__ import annotations

import time
from typing import Callable, Sequence

import numpy as np

from thinfilm.engine.newton import newton_minimize, state_kkt
from thinfilm.engine.options import (AltMinOptions, BacktrackOptions, EngineOptions, NewtonOptions, SearchOptions,
                                     StabilityOptions)
from thinfilm.engine.protocol import (AdaptiveMesh, AffineLoad, DamageProjection, EnergyDerivatives, FractureModel,
                                      NonlinearDamage, StabilityModes, TrialStates)
from thinfilm.engine.records import State, StepRecord
from thinfilm.solvers.box_newton import solve_box_newton
from thinfilm.solvers.boxqp import solve_box_qp
from thinfilm.solvers.errors import SolverError
from thinfilm.solvers.linear.indefinite import IndefiniteSolver
from thinfilm.solvers.work import WORK

__all__ = ["Engine", "EvolutionError"]


class EvolutionError(RuntimeError):
    """A load step could not be computed; the message names step, iteration and residual."""


#: Iterations over which the energy stop (``Engine._energy_settled``) requires the energy's
#: decrease and the change of alpha to fall.
SETTLED_WINDOW = 3

#: Least cosine between consecutive updates of alpha for a phase of over-relaxation to count
#: as an unstable damage mode (see ``Engine._extrapolate``).
MODE_COSINE = 0.9


def _cosine(a, b):
    """Cosine of the angle between two updates of alpha (0 if either is missing or zero)."""
    if b is None:
        return 0.0
    norm = float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(a @ b) / norm if norm > 0.0 else 0.0


class _Backtrack(Exception):
    """Raised inside alternate minimization when an earlier step is beaten."""

    def __init__(self, k, alpha, u, t_from):
        self.k, self.alpha, self.u, self.t_from = k, alpha, u, t_from


class Engine:
    """Quasi-static evolution of a :class:`thinfilm.engine.protocol.FractureModel` over given loads.

    Parameters
    ----------
    model : FractureModel
    altmin, backtrack, search, stability, newton : option objects of
        :mod:`thinfilm.engine.options`, optional (their values are checked when they are made)

    Raises
    ------
    ValueError
        If the options ask for what the model cannot do: backtracking with a load that is not
        proportional to ``t``, the search without :class:`TrialStates`, the stability check
        without :class:`StabilityModes`, Newton (``newton.method = "newton"``) without
        :class:`EnergyDerivatives`.

    Attributes
    ----------
    uses_newton : bool
        Whether load steps hand over to Newton (``newton.method`` resolved for this model).
    newton_solver : thinfilm.solvers.linear.indefinite.IndefiniteSolver or None
        The factorization of the coupled Newton system, kept across steps.
    """

    def __init__(self, model: FractureModel, altmin=AltMinOptions(), backtrack=BacktrackOptions(),
                 search=SearchOptions(), stability=StabilityOptions(), newton=NewtonOptions()):
        if backtrack.kind != "none" and not (model.proportional or isinstance(model, AffineLoad)):
            raise ValueError(f"backtrack.kind = {backtrack.kind!r}: backtracking needs a load proportional to t"
                             " or with a constant part (this load is neither); use kind = \"none\"")
        if search.enabled and not isinstance(model, TrialStates):
            raise ValueError("nucleation search asked for a model without trial_states")
        if stability.enabled and not isinstance(model, StabilityModes):
            raise ValueError("stability check asked for a model without stability_modes")
        derivatives = isinstance(model, EnergyDerivatives)
        if newton.method == "newton" and not derivatives:
            raise ValueError("nonlinear = \"newton\" asked for a model without the derivatives of its energy"
                             " (EnergyDerivatives); use \"altmin\" or \"auto\"")
        self.newton = newton
        self.uses_newton = newton.method == "newton" or (newton.method == "auto" and derivatives
                                                          and model.newton_pays)
        self._derivatives = derivatives
        #: The factorization of the coupled Newton system (None without Newton).
        self.newton_solver = IndefiniteSolver() if self.uses_newton else None
        self.model, self.altmin, self.backtrack, self.search = model, altmin, backtrack, search
        self.stability = stability
        self._projection = model if isinstance(model, DamageProjection) else None
        self._adaptive = model if isinstance(model, AdaptiveMesh) else None
        # u of the last solve and the alpha/t it was computed for: with a proportional load
        # and unchanged alpha the next u is a multiple of it, no solve needed.
        self._u_cache = None
        #: Work done by the whole evolution, including steps later undone by backtracking and
        #: rejected trials: alternate-minimization iterations, linear solves, backtracks,
        #: nucleation trials tried and accepted.
        self.work = {"iterations": 0, "u_solves": 0, "backtracks": 0, "trials": 0, "trials_accepted": 0,
                     "saddles_left": 0, "newton_steps": 0}

    @classmethod
    def from_options(cls, model: FractureModel, options: EngineOptions) -> "Engine":
        """The engine with one :class:`thinfilm.engine.options.EngineOptions` (a scene's)."""
        return cls(model, options.altmin, options.backtrack, options.search, options.stability, options.newton)

    # -- the two half-steps ---------------------------------------------------------------
    def _solve_u(self, alpha, t, u0, rtol, record):
        cache = self._u_cache
        if (self.model.proportional and cache is not None and cache[2] != 0.0
                and np.array_equal(cache[1], alpha)):
            record.u_solves_skipped += 1
            return cache[0] * (t / cache[2])
        start = time.perf_counter()
        u = self.model.solve_u(alpha, t, u0, rtol)
        record.time_u += time.perf_counter() - start
        record.u_solves += 1
        self.work["u_solves"] += 1
        self._u_cache = (u, alpha.copy(), t)
        return u

    def _keep_u(self, state):
        """After a step: keep its ``u`` as the one the next step may rescale, if it is the last
        u-solve's at the step's damage (bit for bit); returns whether it is.

        The kept triple is the step's stored state, so a run resumed from the file (which
        restores it when the step's record says so) rescales exactly the same numbers.
        """
        cache = self._u_cache
        if self.model.proportional and cache is not None and np.array_equal(cache[1], state.alpha):
            if cache[2] == state.t:
                solved = cache[0]
            else:  # the rescaled u, computed as _solve_u computes it
                solved = cache[0] * (state.t / cache[2]) if cache[2] != 0.0 else None
            if solved is not None and np.array_equal(solved, state.u):
                self._u_cache = (state.u, cache[1], state.t)
                return True
        self._u_cache = None
        return False

    def _solve_alpha(self, u, t, alpha, lower, record, step, iteration):
        start = time.perf_counter()
        problem = self.model.damage_problem(u, t)
        try:
            if isinstance(problem, NonlinearDamage):   # a law that is not quadratic: Newton on the box
                result = solve_box_newton(problem, lower, 1.0, a0=alpha, rtol=self.altmin.damage_rtol)
                record.damage_newton_iterations += result.iterations
            else:
                A, b = problem
                result = solve_box_qp(A, b, lower, 1.0, a0=alpha, rtol=self.altmin.damage_rtol)
        except SolverError as err:
            raise EvolutionError(f"step {step} (t = {t:g}), alternate-minimization iteration {iteration}:"
                                 f" damage solver failed: {err}") from err
        # How far the pair (u, alpha) is from stationary: u minimizes E(., alpha) (up to the
        # solver's tolerance), so only the damage's KKT conditions can fail. The damage
        # solver has measured it at its start point a0 = alpha (units of damage).
        record.kkt = float(result.kkt_residuals[0])
        alpha = self._project(result.a)
        record.time_alpha += time.perf_counter() - start
        return alpha

    def _project(self, alpha):
        """The model's projection of a damage field onto its admissible set beyond the
        bounds (the orbit average of a symmetric plate model), if it has one. It must keep
        a field that is above an admissible bound (:meth:`_admissible_lower`) above it; the
        orbit average, clipped to each orbit's least value, does."""
        return alpha if self._projection is None else self._projection.project_alpha(alpha)

    def _admissible_lower(self, lower):
        """The least admissible damage above ``lower`` (for a symmetric plate model, its
        orbit maximum: a bound that is not symmetric, e.g. an asymmetric initial damage,
        would otherwise let an asymmetric alpha reach the restricted u-solve)."""
        return lower if self._projection is None else self._projection.project_lower(lower)

    # -- one load step --------------------------------------------------------------------
    def alternate_minimization(self, t, alpha0, lower, u0, record, step, history=None):
        """Alternate minimization at load ``t`` from ``alpha0`` (bounds ``lower <= alpha <= 1``).

        Parameters
        ----------
        t : float
        alpha0, lower : ndarray, shape (n_alpha,)
        u0 : ndarray or None
            Warm start of the first u-solve.
        record : StepRecord
            Updated with iteration counts, timings and the energy history.
        step : int
            Step index (for messages and deep backtracking).
        history : list of State, optional
            Converged earlier steps, for deep backtracking.

        Returns
        -------
        State
        """
        opts = self.altmin
        lower = self._admissible_lower(lower)
        alpha = self._project(np.maximum(alpha0, lower))
        u = u0
        change = opts.tol
        changes = []
        settled = []  # the energy after each alpha-solve (the states alternate minimization keeps)
        omega, omega_cap = 1.0, opts.omega
        direction = None  # the last plain update of alpha
        # An extrapolated alpha waiting for its u-solve: the plain update it replaced, with
        # that update's u and energy, to return to if the extrapolation does not pay.
        pending = None
        deep = self.backtrack.kind == "deep" and history
        # Newton takes over below this change of alpha (see _hand_over); after a failed
        # attempt, below half the change it failed at, or again below switch once the
        # change has risen above it (a new phase of the step).
        switch, attempts = self.newton.switch, 0
        for iteration in range(1, opts.max_iter + 1):
            rtol = float(np.clip(1e-2 * change, opts.u_rtol_min, opts.u_rtol_max))
            try:
                u_new = self._solve_u(alpha, t, u, rtol, record)
            except SolverError as err:
                raise EvolutionError(f"step {step} (t = {t:g}), alternate-minimization iteration {iteration}:"
                                     f" u-solve failed: {err}") from err
            if not np.all(np.isfinite(u_new)):
                raise EvolutionError(f"step {step} (t = {t:g}), alternate-minimization iteration {iteration}:"
                                     " the displacement is not finite")
            energy_u = sum(self.model.energies(u_new, alpha, t))
            record.iterations += 1
            self.work["iterations"] += 1
            if pending is not None:
                u_plain, alpha_plain, energy_plain = pending
                pending = None
                if energy_u > energy_plain:
                    # The extrapolation raised the energy against the plain update it replaced:
                    # go back to that update (its u is known) and stop extrapolating for now.
                    record.extrapolations_rejected += 1
                    omega_cap = max(1.0, omega / opts.omega_growth)
                    omega = 1.0
                    alpha, u = alpha_plain, u_plain
                    continue
            u = u_new
            record.energy_history.append(energy_u)
            alpha_star = self._solve_alpha(u, t, alpha, lower, record, step, iteration)
            update = alpha_star - alpha
            change = float(np.max(np.abs(update))) if alpha.size else 0.0
            changes.append(change)
            elastic, surface = self.model.energies(u, alpha_star, t)
            record.energy_history.append(elastic + surface)
            if deep and iteration % self.backtrack.interval == 0:
                self._deep_check(step, t, u, alpha_star, elastic, surface, history, record)
            settled.append(elastic + surface)
            if change > self.newton.switch:
                switch = self.newton.switch
            converged = change < opts.tol
            if self.uses_newton and attempts < self.newton.attempts and (
                    converged or self._hand_over(changes, settled, switch)):
                # (converged: alternate minimization's answer, polished to Newton's tolerance)
                attempts += 1
                result = self._newton(u, alpha_star, lower, t, record)
                if result.converged:
                    return State(t, result.u, result.alpha, result.elastic, result.surface)
                if converged and result.steps == 0:
                    return State(t, u, alpha_star, elastic, surface)
                # Back to alternate minimization from Newton's last state (never above the
                # one handed over).
                switch = 0.5 * min(switch, change)
                alpha, u = result.alpha, result.u
                omega, omega_cap, direction = 1.0, opts.omega, None
                continue
            if converged:
                return State(t, u, alpha_star, elastic, surface)
            if opts.stop == "energy" and self._energy_settled(settled, record.kkt, changes):
                record.stopped_by_energy = 1
                return State(t, u, alpha_star, elastic, surface)
            candidate = self._extrapolate(alpha_star, update, direction, changes, omega, omega_cap)
            direction = update
            if candidate is not None:
                candidate, omega = candidate
                candidate = np.clip(candidate, lower, 1.0)
                if not np.array_equal(candidate, alpha_star):
                    pending = (u, alpha_star, elastic + surface)
                    alpha = candidate
                    continue
            else:
                omega, omega_cap = 1.0, opts.omega
            alpha = alpha_star
        raise EvolutionError(f"step {step} (t = {t:g}): alternate minimization did not converge in"
                             f" {opts.max_iter} iterations (last change of alpha {change:.3g}, tol {opts.tol:g})")

    @staticmethod
    def _hand_over(changes, energies, switch):
        """Whether alternate minimization hands over to Newton: its change of alpha is below
        ``switch``, and over the last :data:`SETTLED_WINDOW` iterations both the change and
        the energy's decrease have fallen at each iteration: a settling tail (where Newton
        converges in a few steps), not the slow start of a damage mode growing through its
        instability, where the change also starts small but the decrease grows (Newton there
        moves a crack front about as far per step as alternate minimization per iteration,
        at a higher cost: docs/solvers.md#newton-on-both-fields)."""
        n = SETTLED_WINDOW
        if len(changes) < n + 1 or len(energies) < n + 2 or not changes[-1] < switch:
            return False
        recent = changes[-(n + 1):]
        decrease = -np.diff(energies[-(n + 2):])
        return (all(a > b for a, b in zip(recent[:-1], recent[1:]))
                and all(a > b for a, b in zip(decrease[:-1], decrease[1:])))

    def _newton(self, u, alpha, lower, t, record):
        """A Newton attempt (:func:`thinfilm.engine.newton.newton_minimize`) from ``(u, alpha)``,
        counted in ``record``."""
        start = time.perf_counter()
        result = newton_minimize(self.model, u, alpha, lower, t, self.newton, project=self._project,
                                 solver=self.newton_solver)
        record.newton_attempts += 1
        record.newton_steps += result.steps
        record.newton_rejections += result.rejections
        record.inertia_corrections += result.corrections
        record.newton_failures += int(not result.converged)
        record.time_newton += time.perf_counter() - start
        self.work["newton_steps"] += result.steps
        return result

    def final_kkt(self, state, lower):
        """The scaled KKT residual of a converged state (:func:`thinfilm.engine.newton.state_kkt`),
        NaN for a model without :class:`EnergyDerivatives`."""
        if not self._derivatives:
            return float("nan")
        lower = self._admissible_lower(np.broadcast_to(lower, state.alpha.shape))
        return state_kkt(self.model, state.u, state.alpha, lower, state.t)

    def _energy_settled(self, energies, kkt, changes):
        """Whether a step may stop before the change of alpha is below ``tol`` (``stop =
        "energy"``): its energy has settled and its state is near stationary.

        Over the last :data:`SETTLED_WINDOW` iterations the energy decreased by less at
        each one than at the one before (``d_k < d_{k-1}``, with ``d_k = E_{k-1} - E_k`` the
        decrease of the k-th iteration), and the last decrease, with what a geometric tail
        at the slowest recent ratio ``q = max d_k / d_{k-1}`` would still bring, ``d_k / (1 -
        q)``, is below ``energy_tol |E_k|``; the scaled KKT residual of the damage problem at
        the last u-solve (how far a node of alpha is from its optimum for the present u,
        units of damage) is below ``kkt_factor tol``; and the change of alpha is falling.

        Why all three: a slow, steady settling tail passes them, but so would, for a few
        iterations, a state creeping past a saddle, where the energy barely moves before a
        crack grows. There the decreases grow again (``q >= 1``) and the change of alpha
        rises, but only after more iterations near the saddle than any window covers, so the
        stop is not the default (measured: docs/speed.md#full-resolution-levers).
        """
        opts = self.altmin
        n = SETTLED_WINDOW
        if len(energies) < n + 2 or len(changes) < n + 1:
            return False
        recent = np.asarray(energies[-(n + 2):])
        decrease = recent[:-1] - recent[1:]
        if not np.all(decrease > 0.0):
            return False
        ratios = decrease[1:] / decrease[:-1]
        q = float(np.max(ratios))
        if not q < 1.0:
            return False
        remaining = decrease[-1] / (1.0 - q)
        falling = all(a > b for a, b in zip(changes[-(n + 1):-1], changes[-n:]))
        return (remaining <= opts.energy_tol * abs(energies[-1]) and kkt <= opts.kkt_factor * opts.tol
                and falling)

    def _extrapolate(self, alpha_star, update, previous, changes, omega, omega_cap):
        """The over-relaxed next alpha (before projection) and its factor, or None.

        ``update = alpha* - alpha`` is this iteration's plain update, ``previous`` the last
        one (None at the first iteration).

        Above ``10 tol``, the growth of damage is over-relaxed only while alternate
        minimization is in a slow, steady phase (the change of alpha shrinks by less than
        half per iteration). Plain alternate minimization forms a crack in two such phases,
        and the factor doubles (``omega_growth``) at each extrapolation up to a cap that
        depends on the phase:

        - a damage mode growing through its instability: the change grows and the update
          keeps its shape (cosine with the last one above ``MODE_COSINE``); cap ``omega``;
        - a crack front crossing the film (anything else): cap ``omega_front`` (2). A larger
          factor there can land one node off the crack's place, which plain alternate
          minimization takes hundreds of iterations to undo.

        Only the growth of damage is extrapolated, ``alpha* + (omega - 1) max(alpha* - alpha,
        0)``, and no node is moved more than half-way from ``alpha*`` to 1: extrapolating
        where damage recedes leaves half-healed bands, and reaching 1 locks in fully broken
        bands of too high an energy. The caps and both limits were chosen by measurement
        (docs/speed.md#acceleration).

        Below ``10 tol`` (the tail of a step, where a settling crack band drifts by a node or
        two), alternate minimization converges linearly, the updates all of one shape. When
        the last three changes decrease, by a ratio ``rho > 1/2``, and the last two updates
        have a cosine above ``MODE_COSINE``, the remaining path is summed as a geometric
        series (Aitken): ``alpha* + (omega - 1) (alpha* - alpha)`` with ``omega = 1 / (1 -
        rho)`` capped at ``omega_tail``, both signs (the band moves); measured:
        docs/speed.md#tail-extrapolation.
        """
        opts = self.altmin
        if opts.acceleration != "overrelax" or len(changes) < 2:
            return None
        if changes[-1] <= 10 * opts.tol:
            return self._extrapolate_tail(alpha_star, update, previous, changes)
        steady = changes[-1] > 0.5 * changes[-2]
        if not steady:
            return None
        unstable_mode = changes[-1] > changes[-2] and _cosine(update, previous) > MODE_COSINE
        cap = omega_cap if unstable_mode else min(omega_cap, opts.omega_front)
        omega = min(opts.omega_growth * omega, cap)
        candidate = alpha_star + (omega - 1.0) * np.maximum(update, 0.0)
        return np.minimum(candidate, 0.5 * (1.0 + alpha_star)), omega

    def _extrapolate_tail(self, alpha_star, update, previous, changes):
        """The tail extrapolation of :meth:`_extrapolate` (``(candidate, omega)``), or None."""
        opts = self.altmin
        if opts.omega_tail <= 1.0 or len(changes) < 3 or not changes[-1] < changes[-2] < changes[-3]:
            return None
        rho = changes[-1] / changes[-2]
        if rho <= 0.5 or _cosine(update, previous) <= MODE_COSINE:
            return None
        omega = min(1.0 / (1.0 - rho), opts.omega_tail)
        candidate = alpha_star + (omega - 1.0) * update
        return np.minimum(candidate, 0.5 * (1.0 + alpha_star)), omega

    def _moved(self, u, alpha, t, elastic):
        """``(B, X, P)``: the current state moved to the load ``s t`` has the elastic energy
        ``B + s X + s^2 P`` ((3.17): ``(0, 0, elastic)`` for a proportional load; with a
        constant part, :class:`AffineLoad`, and the dissertation's (3.18) dropping ``X``)."""
        if self.model.proportional:
            return 0.0, 0.0, elastic
        B, X, P = self.model.elastic_along_load(u, alpha, t)
        return B, (0.0 if self.backtrack.test == "dissertation" else X), P

    def _beats(self, k_state, t, moved, surface):
        """Whether the current state, moved to step ``k``'s load, beats step ``k``'s energy."""
        B, X, P = moved
        s = k_state.t / t
        # with B = X = 0 (a proportional load) this is (3.17)'s (t_k/t)^2 P + S, to the bit
        return k_state.total - (B + s * X + s ** 2 * P + surface) >= self.backtrack.delta

    def _beats_fresh(self, k_state, t, moved, surface, record):
        """:meth:`_beats`, with a stale state's energies (:attr:`State.stale`) made current
        first, in place, if the stale ones say it is beaten: its ``u`` solved again on the
        current discretization (one u-solve; the u-solve cache is left as it was)."""
        if not self._beats(k_state, t, moved, surface):
            return False
        if not k_state.stale:
            return True
        k_state.u, k_state.elastic, k_state.surface = self._on_this_mesh(k_state, record)
        k_state.stale = False
        return self._beats(k_state, t, moved, surface)

    def _deep_check(self, step, t, u, alpha, elastic, surface, history, record):
        n_prev = len(history)
        scope = self.backtrack.scope or n_prev
        ks = range(max(n_prev - scope, 0), n_prev)
        if self.backtrack.direction < 0:
            ks = reversed(ks)
        moved = None
        for k in ks:
            if history[k].t > 0:
                moved = moved or self._moved(u, alpha, t, elastic)
                if self._beats_fresh(history[k], t, moved, surface, record):
                    raise _Backtrack(k, alpha.copy(), u.copy(), t)

    def _search(self, state, lower, record, step):
        """Nucleation search from a converged state; returns the best state found."""
        best = state
        threshold = self.search.delta * self.model.toughness
        # The u-solve cache must describe the kept state's u (solved at the damage before its
        # last alpha-solve), not the last trial's: remember it with the state it belongs to.
        best_cache = self._u_cache
        for _ in range(self.search.rounds):
            improved = False
            for trial_alpha in self.model.trial_states(best.u, best.alpha, best.t):
                trial, trial_record = self._trial(best, trial_alpha, lower, record, step)
                if trial.total < best.total - threshold:
                    best, improved, best_cache = trial, True, self._u_cache
                    record.trials_accepted += 1
                    self.work["trials_accepted"] += 1
                    record.iterations += trial_record.iterations
                    record.newton_steps += trial_record.newton_steps
            if not improved:
                break
        self._u_cache = best_cache
        return best

    def _trial(self, best, trial_alpha, lower, record, step):
        """Alternate minimization at ``best.t`` from ``trial_alpha`` (raised to ``lower``);
        its work is added to ``record``'s (its iterations only if the caller keeps it)."""
        record.trials += 1
        self.work["trials"] += 1
        trial_record = StepRecord(step, best.t)
        trial = self.alternate_minimization(best.t, np.maximum(trial_alpha, lower), lower, best.u,
                                            trial_record, step)
        record.u_solves += trial_record.u_solves
        record.u_solves_skipped += trial_record.u_solves_skipped
        record.time_u += trial_record.time_u
        record.time_alpha += trial_record.time_alpha
        record.time_newton += trial_record.time_newton
        for name in ("newton_attempts", "newton_failures", "newton_rejections", "inertia_corrections"):
            setattr(record, name, getattr(record, name) + getattr(trial_record, name))
        return trial, trial_record

    def _leave_saddles(self, state, lower, record, step):
        """The stability check (:class:`StabilityOptions`) from a converged state; returns
        the state kept and records its lowest curvature."""
        opts = self.stability
        best, best_cache = state, self._u_cache
        for round_ in range(opts.rounds + 1):
            lowest, modes = self.model.stability_modes(best.alpha, best.t, lower, opts.modes)
            record.lowest_curvature = lowest
            if lowest >= -opts.tol or round_ == opts.rounds:
                break
            start = self._descent_along(best, modes[0], lower, record)
            if start is None:
                break
            trial, trial_record = self._trial(best, start, lower, record, step)
            if not trial.total < best.total - opts.delta:
                break
            best, best_cache = trial, self._u_cache
            record.iterations += trial_record.iterations
            record.newton_steps += trial_record.newton_steps
            record.trials_accepted += 1
            record.saddles_left += 1
            self.work["trials_accepted"] += 1
            self.work["saddles_left"] += 1
        self._u_cache = best_cache
        return best

    def _descent_along(self, state, mode, lower, record):
        """The damage ``clip(alpha + s mode, lower, 1)`` of least reduced energy over the steps
        ``s = +-amplitude 2^-j``, ``j = 0..6``, if it is below the state's; else None.

        Irreversibility cuts the mode where it would lower alpha by more than this step has
        raised it, so the best step is searched for rather than fixed: a step too long
        leaves the unstable direction, one too short gains too little for alternate
        minimization to move on from (one u-solve per step tried; they leave the u-solve
        cache describing the last one, which the caller restores).
        """
        best_alpha, best_total = None, state.total - self.stability.delta
        for sign in (1.0, -1.0):
            for j in range(7):
                alpha = np.clip(state.alpha + sign * self.stability.amplitude * 0.5**j * mode, lower, 1.0)
                u = self._solve_u(alpha, state.t, state.u, self.altmin.u_rtol_min, record)
                total = sum(self.model.energies(u, alpha, state.t))
                if total < best_total:
                    best_alpha, best_total = alpha, total
        return best_alpha

    def _search_and_check(self, state, t, lower, record, step):
        """A converged state after the nucleation search and the stability check, where
        enabled (not at t = 0)."""
        if self.search.enabled and t > 0:
            state = self._search(state, lower, record, step)
        if self.stability.enabled and t > 0:
            state = self._leave_saddles(state, lower, record, step)
        return state

    # -- a discretization that refines itself ----------------------------------------------
    def _refine_and_solve(self, state, t, step, record, states):
        """The corrector passes of step ``step`` (:class:`AdaptiveMesh`): while the model
        refines around the converged ``state``, carry the earlier steps' states (in place in
        ``states``), the damage before the first step (``self._alpha_prev``, in place: a deep
        backtrack raised by a pass leaves this call) and the state to the new
        discretization, and solve the step again from the transferred state, with its
        search and stability check. The transfer is exact for nested P1 fields, so the
        transferred state starts where the coarse one ended: the front that crossed coarse
        elements is not sent back to the step's start.

        When the step refined, the previous step's damage is also solved for ``u`` at its own
        load on the final discretization, and its energies recorded
        (:attr:`StepRecord.elastic_previous`): a refinement lowers the bulk energy at a fixed
        crack, so an energy difference between two steps means something only on one mesh
        (the energy release rate, :func:`fem3d.release.energy_release_rate`). One u-solve per
        refined step; the evolution does not see it.

        Returns
        -------
        State
            The step's state on the final discretization.
        """
        while True:
            transfer = self._adaptive.refine(state.u, state.alpha, t)
            if transfer is None:
                if record.refinements and step > 0:
                    self._previous_on_this_mesh(states[step - 1], record)
                return state
            record.refinements += 1
            for k, s in enumerate(states):
                states[k] = State(s.t, None if s.u is None else transfer.u(s.u),
                                  None if s.alpha is None else transfer.alpha(s.alpha), s.elastic, s.surface,
                                  s.u_rescalable, stale=True)
            self._alpha_prev = transfer.alpha(self._alpha_prev)
            lower = self._alpha_prev if step == 0 else states[step - 1].alpha
            self._u_cache = None   # a solve on the old discretization
            if self.newton_solver is not None:
                self.newton_solver = IndefiniteSolver()
            state = self.alternate_minimization(t, transfer.alpha(state.alpha), lower, transfer.u(state.u), record,
                                                step, history=states[:step])
            state = self._search_and_check(state, t, lower, record, step)

    def _on_this_mesh(self, state, record):
        """``(u, elastic, surface)`` of ``state``'s damage at its load, ``u`` solved on the
        current discretization (one u-solve); the u-solve cache (what the next step may
        rescale) is left as it was."""
        cache = self._u_cache
        u = self._solve_u(state.alpha, state.t, state.u, self.altmin.u_rtol_min, record)
        self._u_cache = cache
        return (u, *self.model.energies(u, state.alpha, state.t))

    def _previous_on_this_mesh(self, previous, record):
        """Record the energies of the ``previous`` step's damage at its load, ``u`` solved on
        the current discretization."""
        _, record.elastic_previous, record.surface_previous = self._on_this_mesh(previous, record)

    # -- the evolution --------------------------------------------------------------------
    @staticmethod
    def _warm_start(state, t_values, i):
        """First guess of u at step ``i`` from a converged state: its u scaled to the new load."""
        if i < len(t_values) and state.t != 0:
            return state.u * (t_values[i] / state.t)
        return state.u

    def run(self, t_values, alpha_initial=None, on_step: Callable[[StepRecord, State], None] | None = None,
            progress: Callable[[int], None] = lambda n: None, history: Sequence[State] = (),
            guess: Callable[[float], np.ndarray | None] | None = None):
        """March over the loads ``t_values`` (increasing, ``t_values[0]`` usually 0).

        Parameters
        ----------
        t_values : array_like, shape (N + 1,)
            Loads; step 0 at ``t_values[0]`` is computed like the others.
        alpha_initial : ndarray, optional
            Damage before the first step (default 0).
        on_step : callable, optional
            ``on_step(record, state)`` after each step is (re)computed: steps redone after a
            backtrack are reported again with the same index.
        progress : callable, optional
            Called with the number of newly finished steps (for a progress bar; negative
            after a backtrack).
        history : sequence of State, optional
            Steps ``0 .. k`` already finished (a resumed run): the evolution continues at
            step ``k + 1`` from them as it would have without the stop, bit for bit: the last
            state's ``u_rescalable`` (its step's record) restores the u the next step may
            rescale. Each state needs ``t``, ``alpha`` and the energies, and the last one also
            ``u``.
        guess : callable, optional
            ``guess(t)``: a damage field (shape ``(n_alpha,)``) to start step ``t`` from, or
            None (grid sequencing, :mod:`thinfilm.plate.sequencing`). Alternate minimization then
            starts from ``max(alpha_{i-1}, guess(t))``; irreversibility stays against
            ``alpha_{i-1}``. Not used for a step restarted by a backtrack, which starts from
            the state that triggered it.

        Returns
        -------
        records : list of StepRecord
        states : list of State
        """
        t_values = np.asarray(t_values, dtype=float)
        n_alpha = self.model.n_alpha
        # the damage before the first step, on the current discretization
        self._alpha_prev = np.zeros(n_alpha) if alpha_initial is None else np.asarray(alpha_initial, float).copy()
        states: list[State] = list(history)
        records: list[StepRecord] = [StepRecord(k, s.t, s.elastic, s.surface, s.total) for k, s in enumerate(states)]
        backtracks_into: dict[int, int] = {}  # step -> backtracks that restarted it
        total_backtracks = 0
        i = len(states)
        restarted = False  # True while step i restarts from a backtrack
        alpha_start, u_start = self._alpha_prev, None
        if states:
            alpha_start, u_start = states[-1].alpha, self._warm_start(states[-1], t_values, i)
            last = states[-1]
            if last.u_rescalable and self.model.proportional:
                self._u_cache = (last.u, np.array(last.alpha, dtype=float), last.t)
        while i < len(t_values):
            t = float(t_values[i])
            lower = self._alpha_prev if i == 0 else states[i - 1].alpha
            record = StepRecord(i, t, backtracks=backtracks_into.get(i, 0))
            started = time.perf_counter()
            work_before = WORK.snapshot()
            if guess is not None and not restarted:
                start = guess(t)
                if start is not None:
                    alpha_start = np.maximum(alpha_start, start)
            try:
                state = self.alternate_minimization(t, alpha_start, lower, u_start, record, i,
                                                    history=states[:i])
                state = self._search_and_check(state, t, lower, record, i)
                if self._adaptive is not None:
                    state = self._refine_and_solve(state, t, i, record, states)
                    lower = self._alpha_prev if i == 0 else states[i - 1].alpha
                if self.backtrack.kind != "none":
                    moved = None
                    for k in range(i):
                        if states[k].t > 0:
                            moved = moved or self._moved(state.u, state.alpha, t, state.elastic)
                            if self._beats_fresh(states[k], t, moved, state.surface, record):
                                raise _Backtrack(k, state.alpha.copy(), state.u.copy(), t)
            except _Backtrack as back:
                total_backtracks += 1
                self.work["backtracks"] += 1
                if total_backtracks > self.backtrack.limit:
                    raise EvolutionError(f"step {i} (t = {t:g}): more than {self.backtrack.limit}"
                                         " backtracks; raise solver.backtrack_limit or backtrack_delta") from None
                k = back.k
                backtracks_into[k] = backtracks_into.get(k, 0) + 1
                progress(k - i)
                del states[k:], records[k:]
                alpha_start = back.alpha
                u_start = back.u * (t_values[k] / back.t_from)
                i, restarted = k, True
                continue
            record.kkt_final = self.final_kkt(state, lower)
            record.time_total = time.perf_counter() - started
            factorizations, linear_solves = WORK.snapshot()
            record.factorizations = factorizations - work_before[0]
            record.linear_solves = linear_solves - work_before[1]
            record.elastic, record.surface, record.total = state.elastic, state.surface, state.total
            record.u_rescalable = int(self._keep_u(state))
            states.append(state)
            records.append(record)
            if on_step is not None:
                on_step(record, state)
            progress(1)
            alpha_start, u_start = state.alpha, self._warm_start(state, t_values, i + 1)
            i, restarted = i + 1, False
        return records, states
