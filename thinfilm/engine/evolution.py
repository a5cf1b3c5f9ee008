"""The quasi-static evolution engine: alternate minimization, backtracking, nucleation search.

The engine knows nothing of grids or meshes. It drives any model that offers the small
interface :class:`FractureModel` (the finite-difference plate of :mod:`thinfilm.plate.model` now,
the finite-element module later):

* at each load step ``t_i``, alternate minimization: ``u = argmin E(., alpha)`` (a linear
  solve), then ``alpha = argmin E(u, .)`` under ``alpha_{i-1} <= alpha <= 1`` (a
  bound-constrained QP, :func:`thinfilm.solvers.boxqp.solve_box_qp`), until the largest change of
  alpha is below ``tol``. Each half-step minimizes the energy exactly, so the energy never
  increases. An over-relaxed damage update (:class:`AltMinOptions`) replaces the plain one
  only if, after the next u-solve, the energy is below that of the plain update; otherwise
  the plain update is restored, so the energy of the accepted states still decreases
  monotonically;
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
  the previous step only (a trial crack may heal), and the lowest energy is kept.

Every step is recorded (:class:`StepRecord`); a solver that fails raises
:class:`EvolutionError` naming the step, the iteration and the residual, and the steps
already done stay with the caller (the ``on_step`` callback has seen each of them).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Protocol, Sequence

import numpy as np

from thinfilm.solvers.boxqp import DamageSolverError, solve_box_qp
from thinfilm.solvers.linear import LinearSolverError


class EvolutionError(RuntimeError):
    """A load step could not be computed; the message names step, iteration and residual."""


class FractureModel(Protocol):
    """What the engine needs from a discretized model.

    Attributes
    ----------
    n_alpha : int
        Number of damage unknowns.
    proportional : bool
        True if the load is ``w_t = t w_1``, so that at fixed alpha the minimizer ``u``
        scales with ``t`` and the elastic energy with ``t^2`` (backtracking needs it).
    """

    n_alpha: int
    proportional: bool

    def solve_u(self, alpha: np.ndarray, t: float, u0: np.ndarray | None, rtol: float) -> np.ndarray:
        """Minimize the energy over u at fixed alpha (warm start ``u0``, relative tolerance)."""

    def damage_problem(self, u: np.ndarray, t: float):
        """``(A, b)`` with ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + const(u, t)``."""

    def energies(self, u: np.ndarray, alpha: np.ndarray, t: float) -> tuple[float, float]:
        """Elastic energy ``P`` and surface energy ``S``."""

    def trial_states(self, u: np.ndarray, alpha: np.ndarray, t: float) -> Sequence[np.ndarray]:
        """Damage fields with one trial crack each, for the nucleation search."""

    # Optional, for the stability check (StabilityOptions):
    # ``stability_modes(alpha, t, lower, k) -> (lowest, modes)``, the lowest curvature of
    # the reduced energy on the free damage nodes (units of toughness / eta) and the ``k``
    # lowest modes, shape (k, n_alpha), the first the most unstable.
    #
    # Optional, for a model whose damage is restricted to a subset (symmetric fields):
    # ``project_lower(lower) -> lower``, the least admissible bound above ``lower``, applied
    # once per load step; ``project_alpha(alpha) -> alpha``, applied after every alpha-solve
    # and to the start of every load step.


#: Least cosine between consecutive updates of alpha for a phase of over-relaxation to count
#: as an unstable damage mode (see ``Engine._extrapolate``).
MODE_COSINE = 0.9


def _cosine(a, b):
    """Cosine of the angle between two updates of alpha (0 if either is missing or zero)."""
    if b is None:
        return 0.0
    norm = float(np.linalg.norm(a) * np.linalg.norm(b))
    return float(a @ b) / norm if norm > 0.0 else 0.0


@dataclass(frozen=True)
class AltMinOptions:
    """Alternate minimization.

    Attributes
    ----------
    tol : float
        Convergence when ``max |alpha_new - alpha| < tol``.
    max_iter : int
        Iterations per load step before :class:`EvolutionError`.
    acceleration : {"none", "overrelax"}
        ``"overrelax"``: the growth of damage is extrapolated (see ``omega``), and so is the
        linear settling tail of a step (see ``omega_tail``); each extrapolation is projected on
        the bounds and kept only if the energy after the next u-solve is below that of the
        plain update it replaces. Anderson acceleration of the same fixed-point map was
        measured and dropped: on the Fig. 2.7 strip it took more iterations than plain
        alternate minimization (173 against 124 in the nucleation step).
    omega : float
        With ``acceleration = "overrelax"``: the largest over-relaxation factor (>= 1) of the
        damage growth, ``alpha <- alpha* + (omega_k - 1) max(alpha* - alpha, 0)`` with
        ``alpha*`` the plain update. ``omega_k`` starts at 1 and doubles at each
        extrapolation in a slow, steady phase, up to ``omega`` while a damage mode grows
        through its instability and up to ``omega_front`` while a crack front crosses the
        film (see :meth:`Engine._extrapolate`); it falls back to 1 when the phase ends, and
        after a rejected extrapolation its cap is lowered to the last accepted factor until
        the phase ends (1 = plain alternate minimization). The scenes' default, 4, halves
        the iterations of the Fig. 2.7 strip's nucleation step on 300 x 60 to 600 x 120
        grids (README); 8 saves a few more there but splits the first crack of the 1D
        Fig. 2.5 film (800 cells, no search) in two.
    omega_front : float
        The cap of ``omega_k`` in a front-crossing phase (>= 1).
    omega_tail : float
        With ``acceleration = "overrelax"``: the cap of the factor of the tail extrapolation
        (``Engine._extrapolate``), by which the last plain update is extended once the change
        of alpha is below ``10 tol`` and decays geometrically (1 turns it off).
    omega_growth : float
        Growth factor of ``omega_k`` (> 1).
    u_rtol_min, u_rtol_max : float
        Linear-solver tolerance range. The u-solve of iteration k asks for a relative
        residual ``1e-2 * change_{k-1}`` (the last change of alpha; ``tol`` before the
        first), clipped to ``[u_rtol_min, u_rtol_max]``: loose while alpha still moves a
        lot, tighter than ``1e-2 tol`` when it has settled, so a step that converges at its
        first iteration has an accurate u. Direct solvers reach round-off whatever they are
        asked; this saves CG iterations with ``linear = "amg"``.
    damage_rtol : float
        KKT tolerance of the damage QP.
    """

    tol: float = 1e-4
    max_iter: int = 2000
    acceleration: str = "none"
    omega: float = 1.0
    omega_front: float = 2.0
    omega_tail: float = 8.0
    omega_growth: float = 2.0
    u_rtol_min: float = 1e-8
    u_rtol_max: float = 1e-5
    damage_rtol: float = 1e-9


@dataclass(frozen=True)
class BacktrackOptions:
    """Backtracking (Alg. 3.1, ``kind = "standard"``) or deep backtracking (Alg. 3.2).

    Attributes
    ----------
    kind : {"none", "standard", "deep"}
    delta : float
        Energy gain that triggers a backtrack (``delta_BT`` > 0).
    interval : int
        Deep: test every ``interval`` alternate-minimization iterations (``bi``).
    direction : {1, -1}
        Deep: scan earlier steps oldest first (+1) or newest first (-1) (``bd``).
    scope : int
        Deep: how many earlier steps are scanned (``bs``; 0 = all).
    max_backtracks : int
        Total backtracks allowed in one evolution (a guard against cycling).
    """

    kind: str = "none"
    delta: float = 1e-6
    interval: int = 10
    direction: int = 1
    scope: int = 0
    max_backtracks: int = 200


@dataclass(frozen=True)
class SearchOptions:
    """Nucleation search.

    Attributes
    ----------
    enabled : bool
    delta : float
        A trial state is kept only if it lowers the total energy by more than ``delta``.
    rounds : int
        After a trial is accepted the search is repeated (another crack may follow), at
        most ``rounds`` times per load step.
    """

    enabled: bool = False
    delta: float = 1e-9
    rounds: int = 3


@dataclass
class StabilityOptions:
    """Leaving saddles: a second-order check of every converged state (:mod:`thinfilm.plate.stability`).

    After a load step converges, the lowest curvatures of the reduced energy on the free
    damage nodes are computed. If the lowest is below ``-tol`` (units of the model's
    ``toughness / eta``), the state is a saddle: the damage is moved along the most unstable
    mode, both ways, by the step of at most ``amplitude`` that lowers the energy most
    (``Engine._descent_along``), alternate minimization is restarted from there, and its
    result is kept if it lowers the energy by more than ``delta``; then the new state is
    checked, at most ``rounds`` times per load step. The check's time counts in the step's
    ``time_total``.

    Attributes
    ----------
    enabled : bool
    tol : float
    amplitude : float
        Largest change of alpha of the perturbation.
    delta : float
    rounds : int
    modes : int
        Eigenpairs computed (the lowest is followed; a block of a few helps LOBPCG with the
        pairs of equal eigenvalues that symmetric states have).
    """

    enabled: bool = False
    tol: float = 1e-3
    amplitude: float = 0.1
    delta: float = 1e-9
    rounds: int = 3
    modes: int = 4


@dataclass
class StepRecord:
    """What happened at one load step (the last time it was computed).

    Attributes
    ----------
    index : int
        Step number (1-based; step 0 is the unloaded state).
    t : float
        Load.
    elastic, surface, total : float
        Energies of the converged state.
    iterations : int
        Alternate-minimization iterations (one u-solve each, skipped or not) of the accepted
        state, including its accepted trials and rejected extrapolations.
    u_solves, u_solves_skipped : int
        Linear solves done, and skipped because alpha had not changed (proportional load).
    backtracks : int
        Backtracks that went back to this step and restarted it.
    trials, trials_accepted : int
        Trials tried and kept: those of the nucleation search and the restarts of the
        stability check.
    extrapolations_rejected : int
        Accelerated damage updates that raised the energy and were undone (each cost one
        u-solve).
    lowest_curvature : float
        With the stability check: the lowest curvature of the reduced energy at the kept
        state, in units of ``toughness / eta`` (negative: a saddle that could not be left
        in the rounds allowed); NaN without it.
    saddles_left : int
        Saddles the stability check left at this step.
    time_u, time_alpha, time_total : float
        Wall-clock seconds in u-solves, alpha-solves and in the whole step.
    energy_history : list of float
        Total energy after every half-step of alternate minimization (non-increasing).
    """

    index: int
    t: float
    elastic: float = math.nan
    surface: float = math.nan
    total: float = math.nan
    iterations: int = 0
    u_solves: int = 0
    u_solves_skipped: int = 0
    backtracks: int = 0
    trials: int = 0
    trials_accepted: int = 0
    time_u: float = 0.0
    time_alpha: float = 0.0
    time_total: float = 0.0
    extrapolations_rejected: int = 0
    lowest_curvature: float = math.nan
    saddles_left: int = 0
    energy_history: list = field(default_factory=list)


@dataclass
class State:
    """A converged state ``(u, alpha)`` at load ``t`` with its energies."""

    t: float
    u: np.ndarray
    alpha: np.ndarray
    elastic: float
    surface: float

    @property
    def total(self):
        return self.elastic + self.surface


class _Backtrack(Exception):
    """Raised inside alternate minimization when an earlier step is beaten."""

    def __init__(self, k, alpha, u, t_from):
        self.k, self.alpha, self.u, self.t_from = k, alpha, u, t_from


class Engine:
    """Quasi-static evolution of a :class:`FractureModel` over given loads.

    Parameters
    ----------
    model : FractureModel
    altmin : AltMinOptions, optional
    backtrack : BacktrackOptions, optional
    search : SearchOptions, optional

    Raises
    ------
    ValueError
        If backtracking is asked for a load that is not proportional to ``t``.
    """

    def __init__(self, model, altmin=AltMinOptions(), backtrack=BacktrackOptions(), search=SearchOptions(),
                 stability=StabilityOptions()):
        if backtrack.kind not in ("none", "standard", "deep"):
            raise ValueError(f"backtrack.kind = {backtrack.kind!r}: must be one of none, standard, deep")
        if backtrack.kind != "none" and not model.proportional:
            raise ValueError(f"backtrack.kind = {backtrack.kind!r}: backtracking needs a load proportional to t"
                             " (this load is not); use kind = \"none\"")
        if altmin.acceleration not in ("none", "overrelax"):
            raise ValueError(f"acceleration = {altmin.acceleration!r}: must be one of none, overrelax")
        if not 1.0 <= altmin.omega <= 64.0:
            raise ValueError(f"omega = {altmin.omega}: must be in [1, 64]")
        if not altmin.omega_front >= 1.0:
            raise ValueError(f"omega_front = {altmin.omega_front}: must be >= 1")
        if not altmin.omega_tail >= 1.0:
            raise ValueError(f"omega_tail = {altmin.omega_tail}: must be >= 1")
        if not altmin.omega_growth > 1.0:
            raise ValueError(f"omega_growth = {altmin.omega_growth}: must be > 1")
        if stability.enabled and not callable(getattr(model, "stability_modes", None)):
            raise ValueError("stability check asked for a model without stability_modes")
        self.model, self.altmin, self.backtrack, self.search = model, altmin, backtrack, search
        self.stability = stability
        # u of the last solve and the alpha/t it was computed for: with a proportional load
        # and unchanged alpha the next u is a multiple of it, no solve needed.
        self._u_cache = None
        #: Work done by the whole evolution, including steps later undone by backtracking and
        #: rejected trials: alternate-minimization iterations, linear solves, backtracks,
        #: nucleation trials tried and accepted.
        self.work = {"iterations": 0, "u_solves": 0, "backtracks": 0, "trials": 0, "trials_accepted": 0,
                     "saddles_left": 0}

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

    def _solve_alpha(self, u, t, alpha, lower, record, step, iteration):
        start = time.perf_counter()
        A, b = self.model.damage_problem(u, t)
        try:
            result = solve_box_qp(A, b, lower, 1.0, a0=alpha, rtol=self.altmin.damage_rtol)
        except DamageSolverError as err:
            raise EvolutionError(f"step {step} (t = {t:g}), alternate-minimization iteration {iteration}:"
                                 f" damage solver failed: {err}") from err
        alpha = self._project(result.a)
        record.time_alpha += time.perf_counter() - start
        return alpha

    def _project(self, alpha):
        """The model's projection of a damage field onto its admissible set beyond the
        bounds (the orbit average of a symmetric plate model), if it has one. It must keep
        a field that is above an admissible bound (:meth:`_admissible_lower`) above it; the
        orbit average, clipped to each orbit's least value, does."""
        project = getattr(self.model, "project_alpha", None)
        return alpha if project is None else project(alpha)

    def _admissible_lower(self, lower):
        """The least admissible damage above ``lower`` (for a symmetric plate model, its
        orbit maximum: a bound that is not symmetric, e.g. an asymmetric initial damage,
        would otherwise let an asymmetric alpha reach the restricted u-solve)."""
        project = getattr(self.model, "project_lower", None)
        return lower if project is None else project(lower)

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
        omega, omega_cap = 1.0, opts.omega
        direction = None  # the last plain update of alpha
        # An extrapolated alpha waiting for its u-solve: the plain update it replaced, with
        # that update's u and energy, to return to if the extrapolation does not pay.
        pending = None
        deep = self.backtrack.kind == "deep" and history
        for iteration in range(1, opts.max_iter + 1):
            rtol = float(np.clip(1e-2 * change, opts.u_rtol_min, opts.u_rtol_max))
            try:
                u_new = self._solve_u(alpha, t, u, rtol, record)
            except LinearSolverError as err:
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
                self._deep_check(step, t, u, alpha_star, elastic, surface, history)
            if change < opts.tol:
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
          factor there can land one node off the crack's place (on the Fig. 2.7 strip with
          600 x 120 cells, cap 4 left a segment one node off that took 700 iterations to
          creep back; cap 2 does not).

        Only the growth of damage is extrapolated, ``alpha* + (omega - 1) max(alpha* - alpha,
        0)``, and no node is moved more than half-way from ``alpha*`` to 1. Both limits were
        measured necessary: extrapolating where damage recedes left half-healed bands that
        took hundreds of iterations to settle (Fig. 2.7 strip), and letting the
        extrapolation reach 1 locked in wide fully broken bands whose energy is 4% too high
        (1D film).

        Below ``10 tol`` (the tail of a step, where a settling crack band drifts by a node or
        two), alternate minimization converges linearly: on the indentation scene at 640^2
        the change of alpha shrank by 4-5% per iteration over 30 iterations, the updates all
        of one shape. When the last three changes decrease, by a ratio ``rho > 1/2``, and the
        last two updates have a cosine above ``MODE_COSINE``, the remaining path is summed
        as a geometric series (Aitken): ``alpha* + (omega - 1) (alpha* - alpha)`` with
        ``omega = 1 / (1 - rho)`` capped at ``omega_tail``, both signs (the band moves). It
        halved that step (42 -> 21 iterations) and ended at a lower energy.
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

    def _beats(self, k_state, t, elastic, surface):
        scale = (k_state.t / t) ** 2
        return k_state.total - (scale * elastic + surface) >= self.backtrack.delta

    def _deep_check(self, step, t, u, alpha, elastic, surface, history):
        n_prev = len(history)
        scope = self.backtrack.scope or n_prev
        ks = range(max(n_prev - scope, 0), n_prev)
        if self.backtrack.direction < 0:
            ks = reversed(ks)
        for k in ks:
            if history[k].t > 0 and self._beats(history[k], t, elastic, surface):
                raise _Backtrack(k, alpha.copy(), u.copy(), t)

    def _search(self, state, lower, record, step):
        """Nucleation search from a converged state; returns the best state found."""
        best = state
        # The u-solve cache must describe the kept state's u (solved at the damage before its
        # last alpha-solve), not the last trial's: remember it with the state it belongs to.
        best_cache = self._u_cache
        for _ in range(self.search.rounds):
            improved = False
            for trial_alpha in self.model.trial_states(best.u, best.alpha, best.t):
                trial, trial_record = self._trial(best, trial_alpha, lower, record, step)
                if trial.total < best.total - self.search.delta:
                    best, improved, best_cache = trial, True, self._u_cache
                    record.trials_accepted += 1
                    self.work["trials_accepted"] += 1
                    record.iterations += trial_record.iterations
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
            step ``k + 1`` from them as it would have without the stop, except that its
            first u-solve is never skipped (the damage the last ``u`` was solved at is not
            kept). Each state needs ``t``, ``alpha`` and the energies, and the last one also
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
        alpha_prev = np.zeros(n_alpha) if alpha_initial is None else np.asarray(alpha_initial, float).copy()
        states: list[State] = list(history)
        records: list[StepRecord] = [StepRecord(k, s.t, s.elastic, s.surface, s.total) for k, s in enumerate(states)]
        backtracks_into: dict[int, int] = {}  # step -> backtracks that restarted it
        total_backtracks = 0
        i = len(states)
        restarted = False  # True while step i restarts from a backtrack
        alpha_start, u_start = alpha_prev, None
        if states:
            alpha_start, u_start = states[-1].alpha, self._warm_start(states[-1], t_values, i)
        while i < len(t_values):
            t = float(t_values[i])
            lower = alpha_prev if i == 0 else states[i - 1].alpha
            record = StepRecord(i, t, backtracks=backtracks_into.get(i, 0))
            started = time.perf_counter()
            if guess is not None and not restarted:
                start = guess(t)
                if start is not None:
                    alpha_start = np.maximum(alpha_start, start)
            try:
                state = self.alternate_minimization(t, alpha_start, lower, u_start, record, i,
                                                    history=states[:i])
                if self.search.enabled and t > 0:
                    state = self._search(state, lower, record, i)
                if self.stability.enabled and t > 0:
                    state = self._leave_saddles(state, lower, record, i)
                if self.backtrack.kind != "none":
                    for k in range(i):
                        if states[k].t > 0 and self._beats(states[k], t, state.elastic, state.surface):
                            raise _Backtrack(k, state.alpha.copy(), state.u.copy(), t)
            except _Backtrack as back:
                total_backtracks += 1
                self.work["backtracks"] += 1
                if total_backtracks > self.backtrack.max_backtracks:
                    raise EvolutionError(f"step {i} (t = {t:g}): more than {self.backtrack.max_backtracks}"
                                         " backtracks; raise backtrack.max_backtracks or delta") from None
                k = back.k
                backtracks_into[k] = backtracks_into.get(k, 0) + 1
                progress(k - i)
                del states[k:], records[k:]
                alpha_start = back.alpha
                u_start = back.u * (t_values[k] / back.t_from)
                i, restarted = k, True
                continue
            record.time_total = time.perf_counter() - started
            record.elastic, record.surface, record.total = state.elastic, state.surface, state.total
            states.append(state)
            records.append(record)
            if on_step is not None:
                on_step(record, state)
            progress(1)
            alpha_start, u_start = state.alpha, self._warm_start(state, t_values, i + 1)
            i, restarted = i + 1, False
        return records, states
