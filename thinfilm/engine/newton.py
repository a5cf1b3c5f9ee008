r"""A reduced-space active-set Newton method on both fields, ``(u, alpha)``, at one load.

Alternate minimization converges linearly, and slowly where a crack band settles; near a
solution a Newton method on the coupled energy converges quadratically. The engine
(:class:`thinfilm.engine.evolution.Engine`) runs alternate minimization while the damage still
changes a lot and hands its state to :func:`newton_minimize` below ``switch``
(:class:`thinfilm.engine.options.NewtonOptions`), the composition of Farrell and Maurini
(docs/solvers.md#newton-on-both-fields).

One Newton step at a feasible state ``x = (u, alpha)``, ``lower <= alpha <= 1``, with the
model's :class:`thinfilm.engine.protocol.EnergyDerivatives` (gradient ``g``, Hessian blocks):

1. *Active set.* A damage node is held where it is when it sits on a bound and the energy
   pushes it outward (``alpha = lower`` and ``g_alpha > 0``, or ``alpha = 1`` and
   ``g_alpha < 0``) or its bounds coincide; the others, ``F``, are free (the rule of PETSc's
   reduced-space ``vinewtonrsls``).
2. *Reduced system.* ``H d = -g`` on ``(u, alpha_F)``,
   ``H = [[K_uu, K_uF], [K_Fu, K_FF]]``, factored by a symmetric indefinite factorization
   that reports its inertia (:class:`thinfilm.solvers.linear.indefinite.IndefiniteSolver`).
3. *Negative curvature.* If ``H`` is not positive definite (a damage mode that lowers the
   energy: the state is past a stability threshold, a crack is on its way), the attempt
   gives the state back to alternate minimization (``indefinite = "altmin"``), or
   (``"shift"``, an inertia correction) ``K_FF`` becomes
   ``K_FF + delta diag(K_FF)``, ``delta`` from ``shift`` up by tens until it is: ``K_uu`` is
   positive definite, so the shifted ``H`` is once its damage Schur complement is. The
   corrected step is a descent direction that leans towards a scaled gradient step as
   ``delta`` grows.
4. *Line search.* Along the projected path ``x(s) = (u + s d_u, clip(alpha + s d_alpha,
   lower, 1))``, ``s = 1, 1/2, ...``, the first point that lowers the energy by at least
   ``c`` times the first-order prediction ``g . (x(s) - x)`` (Armijo, ``c = 1e-4``) is kept;
   the model's projection (:class:`thinfilm.engine.protocol.DamageProjection`) is applied to
   the damage.
5. *Stop.* When :func:`kkt_residual` is below ``tol`` and the energy has settled: the last
   step lowered it by less than ``energy_tol |E|``, or the next (uncorrected) step promises
   less, ``1/2 g.H^-1.g`` (the decrease of the quadratic model); *give up* (returning the
   last state, which is never above the first) when the line search fails, the correction
   exceeds ``max_shift``, a linear solve fails, or ``max_steps`` pass.

The energy decreases at every accepted step, so what alternate minimization receives back
after a failure is no worse than what it handed over.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from thinfilm.engine.protocol import NonlinearDamage
from thinfilm.solvers.errors import SolverError
from thinfilm.solvers.kernels import kkt_violation
from thinfilm.solvers.linear.indefinite import IndefiniteSolver

__all__ = ["NewtonResult", "newton_minimize", "kkt_residual", "load_norm", "state_kkt", "ARMIJO",
           "LINE_SEARCH_STEPS"]

#: Sufficient decrease of the line search, as a fraction of the first-order prediction.
ARMIJO = 1e-4
#: Halvings of the line search before it fails (the last step tried is 2^-(n-1)).
LINE_SEARCH_STEPS = 20


@dataclass
class NewtonResult:
    """What :func:`newton_minimize` returns.

    Attributes
    ----------
    u : ndarray, shape (n_u,)
        The full displacement of the last accepted state.
    alpha : ndarray, shape (n_alpha,)
    elastic, surface : float
        Its energies.
    converged : bool
    reason : str
        Why it stopped: ``"converged"``, ``"indefinite"``, ``"line search"``, ``"inertia"``,
        ``"linear solve"`` or ``"max steps"``.
    steps : int
        Newton steps accepted.
    rejections : int
        Trial points the line search rejected.
    corrections : int
        Steps whose Hessian needed an inertia correction.
    kkt : float
        :func:`kkt_residual` of the returned state (NaN if it was not evaluated there).
    residuals : list of float
        :func:`kkt_residual` at each state the attempt evaluated, the first one included.
    """

    u: np.ndarray
    alpha: np.ndarray
    elastic: float
    surface: float
    converged: bool = False
    reason: str = ""
    steps: int = 0
    rejections: int = 0
    corrections: int = 0
    kkt: float = math.nan
    residuals: list = field(default_factory=list)


def kkt_residual(g_u, g_alpha, load_norm, alpha, lower, damage_diagonal) -> float:
    """The scaled KKT residual of a state: ``max(r_alpha, r_u)``, dimensionless.

    ``r_alpha`` is the damage's, in units of damage (:func:`thinfilm.solvers.boxqp.kkt_residual`
    with the gradient ``g_alpha`` and the scale ``diag K_aa``): how far a node could move on
    its own, admissibly, to lower the energy. ``r_u = ||g_u|| / ||f||`` is the displacement's
    relative residual (the u-solves' own measure), ``f = -g_u(u_free = 0)`` the load the free
    dofs feel (:func:`load_norm`); 0 if ``g_u = 0``, infinite if only ``f`` is.

    Parameters
    ----------
    g_u : ndarray, shape (n_u_free,)
    g_alpha : ndarray, shape (n_alpha,)
    load_norm : float
        ``||f||``.
    alpha, lower : ndarray, shape (n_alpha,)
    damage_diagonal : ndarray, shape (n_alpha,)
        ``diag K_aa`` (positive).

    Returns
    -------
    float
    """
    r_alpha = float(np.max(kkt_violation(g_alpha, alpha, lower, 1.0) / damage_diagonal, initial=0.0))
    norm_g = float(np.linalg.norm(g_u))
    if norm_g == 0.0:
        r_u = 0.0
    else:
        r_u = norm_g / load_norm if load_norm > 0.0 else math.inf
    return max(r_alpha, r_u)


def load_norm(model, n_free, alpha, t) -> float:
    """``||f||``, ``f = -g_u`` at the ``n_free`` free dofs held at 0 (the constrained ones at
    their values at ``t``): the loads and prescribed motions as the free dofs feel them at
    ``alpha`` (exactly, for a split too: the internal force of a displacement is linear in it
    on each piece and vanishes with it)."""
    zero = model.u_from_free(np.zeros(n_free), t)
    return float(np.linalg.norm(model.energy_gradient(zero, alpha, t)[0]))


def state_kkt(model, u, alpha, lower, t) -> float:
    """:func:`kkt_residual` of the state ``(u, alpha)`` of a model with
    :class:`thinfilm.engine.protocol.EnergyDerivatives`: gradients only, no Hessian."""
    g_u, g_a = model.energy_gradient(u, alpha, t)
    # before load_norm: a model may rewrite the damage problem's arrays at its next call
    problem = model.damage_problem(u, t)
    A = problem.convex_model(alpha)[0] if isinstance(problem, NonlinearDamage) else problem[0]
    diagonal = A.diagonal()
    return kkt_residual(g_u, g_a, load_norm(model, g_u.size, alpha, t), alpha, lower, diagonal)


def _free_damage(alpha, lower, g_alpha):
    """The damage nodes a Newton step may move (step 1 of the module docstring)."""
    held = (lower >= 1.0) | ((alpha <= lower) & (g_alpha > 0.0)) | ((alpha >= 1.0) & (g_alpha < 0.0))
    return np.flatnonzero(~held)


def newton_minimize(model, u, alpha, lower, t, options, project=None, solver=None) -> NewtonResult:
    """Newton steps from the feasible state ``(u, alpha)`` at load ``t`` (module docstring).

    Parameters
    ----------
    model : FractureModel and EnergyDerivatives
    u : ndarray, shape (n_u,)
        Full displacement (its constrained dofs at their values at ``t``).
    alpha, lower : ndarray, shape (n_alpha,)
        Damage and its lower bound (``lower <= alpha <= 1``).
    t : float
    options : thinfilm.engine.options.NewtonOptions
    project : callable, optional
        The model's projection of a damage field (applied after each clip).
    solver : IndefiniteSolver, optional
        Reused across calls (its analysis is kept while the pattern holds).

    Returns
    -------
    NewtonResult
    """
    solver = IndefiniteSolver() if solver is None else solver
    project = project or (lambda a: a)
    lower = np.broadcast_to(np.asarray(lower, dtype=np.float64), alpha.shape)
    u = np.asarray(u, dtype=np.float64)
    alpha = np.asarray(alpha, dtype=np.float64)
    x = model.free_u(u)
    elastic, surface = model.energies(u, alpha, t)
    result = NewtonResult(u, alpha, elastic, surface)
    energy = elastic + surface
    decrease = math.inf
    delta = 0.0  # the last inertia correction (0: none was needed)
    for _ in range(options.max_steps + 1):
        g_u, g_a = model.energy_gradient(u, alpha, t)
        K_uu, K_ua, K_aa = model.hessian_blocks(u, alpha, t)
        result.kkt = kkt_residual(g_u, g_a, load_norm(model, x.size, alpha, t), alpha, lower,
                                  K_aa.diagonal())
        result.residuals.append(result.kkt)
        near = result.kkt <= options.tol
        if near and decrease <= options.energy_tol * abs(energy):
            result.converged, result.reason = True, "converged"
            return result
        if result.steps == options.max_steps:
            result.reason = "max steps"
            return result
        free = _free_damage(alpha, lower, g_a)
        # The held nodes are left out (not kept as identity rows): their couplings, stored as
        # zeros to keep one pattern, would cost the factorization their fill.
        K_uF = K_ua[:, free]
        K_FF = K_aa[free][:, free]
        H = sp.bmat([[K_uu, K_uF], [K_uF.T, K_FF]], format="csr")
        rhs = -np.concatenate([g_u, g_a[free]])
        n_u = x.size
        shift_scale = np.concatenate([np.zeros(n_u), K_FF.diagonal()])
        # IPOPT's rule: after a corrected step, start a third of the way below the last shift.
        delta = 0.0 if delta == 0.0 else max(options.shift, delta / 3.0)
        try:
            while True:
                inertia = solver.factor(H, None if delta == 0.0 else delta * shift_scale)
                if inertia.definite:
                    break
                if options.indefinite == "altmin":
                    result.reason = "indefinite"
                    return result
                delta = options.shift if delta == 0.0 else 10.0 * delta
                if delta > options.max_shift:
                    result.reason = "inertia"
                    return result
            if delta > 0.0:
                result.corrections += 1
            d = solver.solve(rhs)
        except SolverError:
            result.reason = "linear solve"
            return result
        d_u, d_a = d[:n_u], d[n_u:]
        if near and delta == 0.0 and -0.5 * float(rhs @ d) <= options.energy_tol * abs(energy):
            # A KKT point whose Newton step promises less than energy_tol of the energy (the
            # quadratic model's decrease, 1/2 g.H^-1.g): settled without taking the step.
            result.converged, result.reason = True, "converged"
            return result
        accepted = False
        s = 1.0
        for _ in range(LINE_SEARCH_STEPS):
            a_trial = alpha.copy()
            a_trial[free] = np.clip(alpha[free] + s * d_a, lower[free], 1.0)
            a_trial = project(a_trial)
            x_trial = x + s * d_u
            predicted = float(g_u @ (x_trial - x) + g_a @ (a_trial - alpha))
            if predicted < 0.0:
                u_trial = model.u_from_free(x_trial, t)
                e_trial, s_trial = model.energies(u_trial, a_trial, t)
                if e_trial + s_trial <= energy + ARMIJO * predicted:
                    accepted = True
                    break
            result.rejections += 1
            s *= 0.5
        if not accepted:
            result.reason = "line search"
            return result
        decrease = energy - (e_trial + s_trial)
        x, u, alpha, energy = x_trial, u_trial, a_trial, e_trial + s_trial
        result.u, result.alpha, result.elastic, result.surface = u, alpha, e_trial, s_trial
        result.kkt = math.nan
        result.steps += 1
    raise AssertionError("unreachable")  # the loop returns at max_steps
