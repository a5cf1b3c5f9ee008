"""Bound-constrained Newton for a damage energy that is not quadratic.

Minimize ``F(a)`` subject to ``lower <= a <= upper`` for an ``F`` that gives its value, its
gradient and a convex quadratic model about any point (:class:`thinfilm.damage.DamageEnergy`:
the cohesive law, whose degradation is rational and whose geometric function is concave).

Each iteration solves the box QP of the convex model about the current point with
:func:`thinfilm.solvers.boxqp.solve_box_qp` (the solver of the AT laws' one-QP damage step),
then searches along the segment from the current point to the QP's minimizer: both are in the
box, so every point of the segment is, and the step ``s`` in 1, 1/2, 1/4, ... is the first that
lowers ``F`` by Armijo's fraction of the model's slope (up to the rounding of ``F``, which
near the minimizer is larger than the decrease). The model has ``F``'s gradient, so the
QP's minimizer ``x`` gives a descent direction (``grad F . (x - a) <= -(x - a).A.(x - a)``)
and the energy decreases at every iteration. Where ``F``'s curvature is positive the model is
``F``'s second-order expansion (Newton's method, quadratic convergence near a minimizer that
is not degenerate); where it is negative its absolute value is used, which keeps the model's
step at the scale of the curvature rather than unbounded.

That absolute value costs Newton's speed, for two reasons the cohesive law shows. Where
the damage is small its nodal curvature ``c g'' + s w''`` is negative (``w'' = -2``) while the
full Hessian, with the gradient term's stiffness, is positive definite on the free nodes:
the model's steps then shrink by a constant factor per iteration (linear convergence;
``docs/solvers.md#the-cohesive-damage-step``). And where a damage zone softens into
a crack within one damage step, the energy's curvature is negative along the way and the
model creeps towards it by a few percent per iteration. So each iteration first tries the
Newton step of the true problem for the active set the model's QP predicts (the nodes it
puts on a bound go there, the others solve the true Hessian's system), and takes it when it
descends with positive curvature and passes the line search: quadratic convergence once the
active set is identified. Where the Hessian's curvature along that step is negative (a
saddle the damage leaves) its descending sign is taken. Otherwise it takes the model's
step. A full step that passes the line search is tried twice, four times, ... as long
while the energy keeps falling. The energy falls at every iteration either way.

Convergence is measured as for the QP: the scaled KKT residual (:func:`thinfilm.solvers.boxqp.kkt_residual`)
of the model at the current point, whose residual ``A a - b`` is ``grad F(a)`` and whose
diagonal scales it to units of damage.

Why not a library: scipy's bound-constrained minimizers (L-BFGS-B, trust-constr) use no
sparse Hessian and take hundreds of iterations on a field of 10^5 nodes; the box QP solver
is the toolkit's own, warm-started, and its active-set steps are what the damage fronts need.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from thinfilm.solvers.boxqp import kkt_residual, solve_box_qp
from thinfilm.solvers.errors import SolverError

__all__ = ["BoxNewtonResult", "solve_box_newton"]


@dataclass
class BoxNewtonResult:
    """The minimizer found by :func:`solve_box_newton`.

    Attributes
    ----------
    a : ndarray, shape (n,)
        ``lower <= a <= upper`` exactly.
    iterations : int
        Newton iterations (box QPs solved).
    kkt_residuals : ndarray, shape (iterations + 1,)
        The scaled KKT residual at every iterate, the start included (units of damage).
    energies : ndarray, shape (iterations + 1,)
        ``F`` at every iterate; non-increasing.
    qp_iterations : int
        Active-set steps of the box QPs, summed.
    converged : bool
    """

    a: np.ndarray
    iterations: int
    kkt_residuals: np.ndarray
    energies: np.ndarray
    qp_iterations: int
    converged: bool

    @property
    def kkt_residual(self) -> float:
        return float(self.kkt_residuals[-1])


def solve_box_newton(energy, lower, upper=1.0, a0=None, *, rtol=1e-8, max_iter=100, armijo=1e-4,
                     max_halvings=30) -> BoxNewtonResult:
    """Minimize ``energy`` over ``lower <= a <= upper`` (module docstring).

    Parameters
    ----------
    energy : object
        With ``n``, ``value(a)``, ``gradient(a)``, ``hessian(a)`` (sparse, symmetric) and
        ``convex_model(a) -> (A, b)`` (sparse symmetric positive definite ``A``,
        ``A a - b = gradient(a)``).
    lower, upper : float or ndarray, shape (n,)
    a0 : ndarray, shape (n,), optional
        Start (projected on the box); default ``lower``.
    rtol : float
        Tolerance on the scaled KKT residual (units of damage).
    max_iter : int
        Newton iterations allowed.
    armijo : float
        Fraction of the model's decrease a step must achieve.
    max_halvings : int
        Step halvings before the iteration is declared stalled.

    Returns
    -------
    BoxNewtonResult

    Raises
    ------
    thinfilm.solvers.errors.SolverError
        If the tolerance is not met in ``max_iter`` iterations, or no step lowers ``F``.
    """
    n = energy.n
    lower = np.broadcast_to(np.asarray(lower, dtype=float), (n,))
    upper = np.broadcast_to(np.asarray(upper, dtype=float), (n,))
    a = np.clip(lower if a0 is None else np.asarray(a0, dtype=float), lower, upper)
    F = energy.value(a)
    A, b = energy.convex_model(a)
    kkts, energies = [kkt_residual(A, b, a, lower, upper)], [F]
    qp_iterations = 0
    for iteration in range(1, max_iter + 1):
        if kkts[-1] <= rtol:
            return BoxNewtonResult(a, iteration - 1, np.array(kkts), np.array(energies), qp_iterations, True)
        qp = solve_box_qp(A, b, lower, upper, a0=a, rtol=min(1e-2 * kkts[-1], 1e-2), max_iter=200)
        qp_iterations += qp.iterations
        gradient = A @ a - b                      # the energy's, by the model's construction
        rounding = _rounding(F, gradient, a)
        trial = None
        d = _newton_step(energy, a, gradient, qp.a, lower, upper)
        if d is not None:
            trial, F_trial = _line_search(energy, a, F, d, float(gradient @ d), rounding, lower, upper, armijo,
                                          max_halvings)
            if trial is not None:
                trial, F_trial = _expand(energy, a, d, trial, F_trial, rounding, lower, upper, max_halvings)
        if trial is None:
            d = qp.a - a
            slope = float(gradient @ d)               # <= -d.A.d < 0
            if not slope < 0.0:
                break
            trial, F_trial = _line_search(energy, a, F, d, slope, rounding, lower, upper, armijo, max_halvings)
            if trial is None:
                break
            trial, F_trial = _expand(energy, a, d, trial, F_trial, rounding, lower, upper, max_halvings)
        a, F = trial, F_trial
        A, b = energy.convex_model(a)
        kkts.append(kkt_residual(A, b, a, lower, upper))
        energies.append(F)
    if kkts[-1] <= rtol:
        return BoxNewtonResult(a, len(kkts) - 1, np.array(kkts), np.array(energies), qp_iterations, True)
    raise SolverError(f"bound-constrained Newton: scaled KKT residual {kkts[-1]:.3g} > rtol = {rtol:g} after"
                      f" {len(kkts) - 1} iterations")


def _rounding(F, gradient, a):
    """How much ``F`` may rise by rounding alone near its minimizer: the Armijo test's slack
    (near the minimizer ``F``'s decrease falls below its rounding)."""
    return 16.0 * np.finfo(float).eps * (abs(F) + float(np.abs(gradient * a).sum()))


def _line_search(energy, a, F, d, slope, rounding, lower, upper, armijo, max_halvings):
    """``(a + s d, F there)`` clipped to the box, for the first ``s`` in 1, 1/2, ... that
    lowers ``F`` by Armijo's fraction of ``s slope`` (up to ``rounding``); ``(None, None)``
    if none of ``max_halvings`` does."""
    step = 1.0
    for _ in range(max_halvings):
        trial = np.clip(a + step * d, lower, upper)
        F_trial = energy.value(trial)
        if F_trial <= F + armijo * step * slope + rounding:
            return trial, F_trial
        step *= 0.5
    return None, None


def _expand(energy, a, d, trial, F_trial, rounding, lower, upper, max_doublings):
    """From a full step ``trial = a + d`` (clipped), the steps ``a + s d`` (clipped) for
    ``s`` = 2, 4, ... while each lowers ``F`` below the one before by more than ``rounding``:
    where the energy's curvature along ``d`` is negative the convex model's step is too short
    by a growing factor (a damage zone softening into a crack), and doubling reaches the bound
    or the minimizer along ``d`` in a few energy evaluations."""
    if not np.array_equal(trial, np.clip(a + d, lower, upper)):
        return trial, F_trial          # the line search halved: the model's step was too long already
    step = 1.0
    for _ in range(max_doublings):
        step *= 2.0
        longer = np.clip(a + step * d, lower, upper)
        if np.array_equal(longer, trial):
            break                      # every node has reached its bound
        F_longer = energy.value(longer)
        if not F_longer < F_trial - rounding:
            break                      # (a fall within F's rounding would let it cycle near a minimizer)
        trial, F_trial = longer, F_longer
    return trial, F_trial


def _newton_step(energy, a, gradient, x, lower, upper):
    """The Newton step for the active set of the model's minimizer ``x``: the nodes ``x``
    puts on a bound go there (``d_A = x_A - a_A``) unless the gradient moves them off it, the
    others solve ``H_FF d_F = -gradient_F - H_FA d_A`` with ``H`` the energy's Hessian (a
    semismooth Newton step of the true problem, the active set predicted by the convex
    model); where ``H``'s curvature along ``d`` is negative, ``d`` or ``-d``, whichever
    descends. None when no node is free, when ``d`` with positive curvature does not descend,
    or when ``H_FF`` cannot be factorized. Sparse LU (SuperLU) with partial pivoting: ``H_FF``
    need not be definite."""
    # Free: the nodes inside the box at x, and the nodes on a bound that the energy's gradient
    # at a pushes into the box (the convex model may hold them there while the true problem
    # would move them, and the iteration would then stall at their KKT residual).
    pushed_off = (lower < upper) & ((a <= lower) & (gradient < 0.0) | (a >= upper) & (gradient > 0.0))
    free = (x > lower) & (x < upper) | pushed_off
    if not free.any():
        return None
    index = np.flatnonzero(free)
    d = np.where(free, 0.0, x - a)
    H = energy.hessian(a).tocsr()
    try:
        d[index] = spla.splu(H[index][:, index].tocsc()).solve(-gradient[index] - (H @ d)[index])
    except RuntimeError:       # singular
        return None
    if not np.all(np.isfinite(d)):
        return None
    slope, curvature = float(gradient @ d), float(d @ (H @ d))
    if curvature < 0.0:
        # H is indefinite along d: the energy falls along -sign(slope) d at least as a
        # concave parabola does (a saddle the damage leaves; the convex model's steps would
        # creep away from it)
        return -d if slope > 0.0 else d
    if not slope < 0.0:
        return None
    return d
