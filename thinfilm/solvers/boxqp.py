"""Bound-constrained damage solver: ``min 1/2 a.A.a - b.a`` subject to ``lower <= a <= upper``.

Every Ambrosio-Tortorelli model of the toolkit (1D and 2D finite differences, P1 finite
elements; AT1 and AT2) reduces the damage step of alternate minimization to this convex
quadratic program with box constraints: ``A`` is sparse symmetric positive definite,
``upper`` is 1 and ``lower`` is the damage of the previous load step (irreversibility).
This module solves it once for all of them; it assumes nothing about ``A`` beyond
"sparse, symmetric, positive definite".

Algorithm (details in :func:`solve_box_qp`)
--------------------------------------------
A feasible, monotone variant of the primal-dual active-set method of Hintermueller, Ito
and Kunisch (equivalently, a semismooth Newton method for ``a = P(a - D^-1 (A a - b))``,
``P`` the projection on the box and ``D = diag(A)``):

1. from the current feasible iterate ``a`` with residual ``r = A a - b``, predict the
   active sets from the *Jacobi point* ``a - r / D``: a node whose own coordinate
   minimizer lies on or beyond a bound goes on that bound, the others are free;
2. Newton step: active nodes are set to their bound, the free nodes solve the reduced
   system ``A_FF x_F = b_F - A_FA a_A`` (sparse direct solve for small free sets,
   Jacobi-preconditioned conjugate gradients in a Numba kernel for large ones);
3. safeguard: the Newton point is projected on the box and accepted only if it lowers
   the energy enough (Armijo test); otherwise the projected Newton path is backtracked,
   and as a last resort a projected-gradient step with an Armijo search is taken,
   which always lowers the energy.

Every iterate is produced by assigning bound values or by :func:`numpy.clip` against
the bounds, so the bounds hold exactly (bit for bit) at every iteration, and the energy
never increases. When the Newton points are feasible (as for the M-matrices of finite
differences and of P1 elements on non-obtuse meshes with the lower bound active, the
case of Hintermueller, Ito and Kunisch's convergence theory) the method is the plain
primal-dual active-set method; the safeguard is there for the other matrices (a
consistent mass term, obtuse meshes) and for inexact reduced solves.

Each step moves the boundary of the free set by about one grid layer, so the step count
grows with the distance (in nodes) the damage front travels: about 15 from a cold start
with eta = 4 dx, 1-4 when warm-started from the previous solution after a small change.

Cost: after a first full pass, a step touches only the free set, the nodes that move to
a bound and their neighbours (the residual is updated by ``A s`` on the support of the
step ``s``), plus a few O(n) array scans; before returning, the residual is recomputed
from scratch wherever it was updated and the KKT conditions are checked on it.

Tolerance
---------
Convergence is measured by the *scaled KKT residual* (:func:`kkt_residual`), with
``r = A a - b`` and ``d = diag(A)``::

    v_i = |r_i|            if lower_i < a_i < upper_i      (free node)
    v_i = max(-r_i, 0)     if a_i == lower_i < upper_i     (may only move up)
    v_i = max(r_i, 0)      if a_i == upper_i > lower_i     (may only move down)
    v_i = 0                if lower_i == upper_i           (fixed node)
    kkt_residual = max_i v_i / d_i

``r_i / d_i`` is how far node ``i`` would move if the energy were minimized in that
coordinate alone (a Jacobi update), so the residual is in units of damage
(dimensionless; alpha is in [0, 1]) and does not change when the energy is scaled
(``A, b -> c A, c b``) or the grid is refined (both sides scale with the node area).
So ``rtol = 1e-8`` means: no node could lower the energy by moving more than 1e-8 in an
admissible direction on its own. A tolerance relative to ``||b||`` was rejected: for
AT1, ``b`` = elastic density minus the damage threshold, which can be near zero
everywhere.

Kernels
-------
The Numba kernels are in :mod:`thinfilm.solvers.kernels`, with NumPy references
(``*_reference``) that the tests compare them with, and with :func:`kkt_violation`, the
NumPy definition of the KKT measure that they implement node by node.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Optional, Union

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.solvers import kernels
from thinfilm.solvers.kernels import kkt_violation
from thinfilm.solvers.errors import SolverError
from thinfilm.solvers.work import WORK

__all__ = [
    "BoxQPResult",
    "DamageSolverError",
    "ReducedSolver",
    "box_qp_energy",
    "kkt_residual",
    "kkt_violation",
    "solve_box_qp",
]

#: A user-supplied solver of the reduced (free-set) system, called as
#: ``solver(A_ff, rhs, tol)`` with ``A_ff`` a (n_free, n_free) CSR SPD matrix and ``rhs``
#: of shape (n_free,). It returns ``x``, shape (n_free,), with
#: ``max_i |(A_ff x - rhs)_i| / A_ff[i, i] <= tol`` (an inexact solve is allowed: the
#: outer iteration corrects it, at the price of more iterations).
ReducedSolver = Callable[[sp.csr_array, np.ndarray, float], np.ndarray]

_LINEAR_SOLVERS = ("auto", "direct", "cg")

# Status codes of the active-set prediction: free; predicted on a bound and already
# there; predicted on a bound and not there yet (the "moving" nodes of a step).
FREE, AT_LOWER, AT_UPPER, TO_LOWER, TO_UPPER = (
    kernels.FREE, kernels.AT_LOWER, kernels.AT_UPPER, kernels.TO_LOWER, kernels.TO_UPPER)

# Armijo constant: a step must achieve this fraction of the decrease predicted by the
# linear model. Small, as usual: it only rules out steps that barely decrease.
_ARMIJO = 1e-4
# Backtracking on the projected Newton path: theta = 1/2, 1/4, ... this many times.
_NEWTON_BACKTRACKS = 3
# Halvings allowed in the projected-gradient search before its guaranteed step.
_GRADIENT_BACKTRACKS = 30
# The reduced systems are solved to this fraction of rtol, so that the free nodes pass
# the KKT test after the step that finds the right active set.
_LINEAR_TOL_FRACTION = 0.25
# Inexact Newton: in a step that changes the active set (some node leaves or reaches a
# bound), the set is likely to change again and an exact reduced solve is wasted, so
# CG stops at max(0.25 rtol, _FORCING * current KKT residual). The value was chosen by
# measurement (docs/solvers.md#damage-problem).
_FORCING = 0.01


class DamageSolverError(SolverError):
    """The damage solver did not reach the requested KKT tolerance.

    Attributes
    ----------
    kkt_residual : float
        Scaled KKT residual of the last iterate (see :func:`kkt_residual`).
    iterations : int
        Iterations performed.
    result : BoxQPResult or None
        The last iterate (feasible, lowest energy so far), for inspection.
    """

    def __init__(self, message: str, *, kkt_residual: float, iterations: int,
                 result: Optional["BoxQPResult"] = None):
        super().__init__(message)
        self.kkt_residual = kkt_residual
        self.iterations = iterations
        self.result = result


@dataclass(frozen=True)
class BoxQPResult:
    """Solution of the box-constrained QP returned by :func:`solve_box_qp`.

    Attributes
    ----------
    a : ndarray, shape (n,)
        The minimizer; ``lower <= a <= upper`` holds exactly.
    iterations : int
        Steps taken; 0 if the initial guess was already optimal.
    kkt_residual : float
        Scaled KKT residual of ``a`` (units of damage, see :func:`kkt_residual`),
        computed from a freshly evaluated ``A a - b``.
    energy : float
        ``1/2 a.A.a - b.a`` at ``a`` (in the units that assembled ``A`` and ``b``).
    n_free, n_lower, n_upper, n_fixed : int
        Nodes strictly inside the bounds, on the lower bound, on the upper bound, and
        with ``lower == upper`` (the fixed nodes are counted in no other class).
    converged : bool
        ``kkt_residual <= rtol``; always True unless ``raise_on_failure=False``.
    energies : ndarray, shape (iterations + 1,)
        Energy of every iterate, from the (projected) initial guess on; non-increasing.
    kkt_residuals : ndarray, shape (iterations + 1,)
        Scaled KKT residual of every iterate (the intermediate ones from the
        incrementally updated residual).
    steps : tuple of str, length iterations
        Kind of each step: ``"newton"`` (full projected Newton step),
        ``"newton-backtracked"`` (shortened along the projected Newton path) or
        ``"projected-gradient"`` (the fallback).
    n_free_history : tuple of int, length iterations
        Size of the reduced system solved at each step.
    linear_iterations : int
        CG iterations summed over all reduced solves (0 for direct solves).
    a0_projected : int
        Entries of the initial guess that violated the bounds and were projected.
    timings : dict of str to float
        Wall-clock seconds: ``setup`` (checks, diagonal), ``residual`` (full products
        with A), ``active_set`` (KKT test and prediction), ``reduced_system``
        (extracting the free-set system), ``linear_solve``, ``step`` (energy test and
        update of the iterate and residual), ``safeguard`` (backtracking and fallback),
        ``total``.
    """

    a: np.ndarray
    iterations: int
    kkt_residual: float
    energy: float
    n_free: int
    n_lower: int
    n_upper: int
    n_fixed: int
    converged: bool
    energies: np.ndarray
    kkt_residuals: np.ndarray
    steps: tuple
    n_free_history: tuple
    linear_iterations: int
    a0_projected: int
    timings: dict = field(default_factory=dict)


# --------------------------------------------------------------------------------------
# Public helpers
# --------------------------------------------------------------------------------------


def box_qp_energy(A, b: np.ndarray, a: np.ndarray) -> float:
    """Energy ``1/2 a.A.a - b.a``.

    Parameters
    ----------
    A : sparse matrix, shape (n, n)
    b, a : ndarray, shape (n,)

    Returns
    -------
    float
    """
    a = np.asarray(a, dtype=np.float64)
    return float(0.5 * (a @ (A @ a)) - np.asarray(b, dtype=np.float64) @ a)


def kkt_residual(A, b: np.ndarray, a: np.ndarray, lower, upper) -> float:
    """Scaled KKT residual ``max_i v_i / A_ii`` of a point, in units of damage.

    Parameters
    ----------
    A : sparse matrix, shape (n, n)
        Matrix of the QP (positive diagonal).
    b, a : ndarray, shape (n,)
        Linear term and the (feasible) point to assess.
    lower, upper : float or ndarray, shape (n,)
        Bounds.

    Returns
    -------
    float
        0 at an exact KKT point; :func:`solve_box_qp` stops when it is ``<= rtol``.
    """
    a = np.asarray(a, dtype=np.float64)
    if a.size == 0:
        return 0.0
    r = A @ a - np.asarray(b, dtype=np.float64)
    return float(np.max(kkt_violation(r, a, lower, upper) / A.diagonal()))


# --------------------------------------------------------------------------------------
# The solver
# --------------------------------------------------------------------------------------


def solve_box_qp(
    A,
    b: np.ndarray,
    lower: Union[float, np.ndarray],
    upper: Union[float, np.ndarray] = 1.0,
    a0: Optional[np.ndarray] = None,
    *,
    rtol: float = 1e-8,
    max_iter: int = 100,
    linear_solver: Union[str, ReducedSolver] = "auto",
    direct_max_free: int = 2_000,
    cg_max_iter: int = 1_000,
    raise_on_failure: bool = True,
    callback: Optional[Callable[[int, np.ndarray], None]] = None,
) -> BoxQPResult:
    """Minimize ``1/2 a.A.a - b.a`` subject to ``lower <= a <= upper``.

    A warm-started, safeguarded primal-dual active-set (semismooth Newton) method; the
    module docstring describes the algorithm and the tolerance.

    Parameters
    ----------
    A : scipy.sparse matrix or array, shape (n, n)
        Symmetric positive definite. A non-positive diagonal entry is reported;
        symmetry and definiteness are assumed (checking them would cost more than a
        solve). CSR float64 is used as is; anything else is converted.
    b : ndarray, shape (n,)
        Linear term (units of energy per unit damage, like ``A``).
    lower : float or ndarray, shape (n,)
        Lower bound, e.g. the damage of the previous load step (irreversibility).
    upper : float or ndarray, shape (n,), default 1.0
        Upper bound. Entries with ``lower == upper`` are fixed nodes.
    a0 : ndarray, shape (n,), optional
        Initial guess (warm start), typically the previous solution. Entries outside
        the bounds are projected on them (counted in ``a0_projected``). Default:
        ``lower``.
    rtol : float, default 1e-8
        Tolerance on the scaled KKT residual, in units of damage; > 0.
    max_iter : int, default 100
        Maximum number of steps; >= 0. Active-set methods need about one step per
        grid layer by which the boundary of the free set moves, so a cold start on a
        fine grid needs more than a warm start.
    linear_solver : {"auto", "direct", "cg"} or callable, default "auto"
        Solver of the reduced system on the free set: ``"direct"`` (SuperLU with a
        symmetric ordering), ``"cg"`` (Jacobi-preconditioned CG, Numba), ``"auto"``
        (direct up to ``direct_max_free`` free nodes, CG above, falling back to direct
        if CG has not converged after ``cg_max_iter`` iterations), or a
        :data:`ReducedSolver`.
    direct_max_free : int, default 2000
        Free-set size up to which ``"auto"`` solves directly; >= 0. (Chosen by
        measurement: docs/solvers.md#damage-problem.)
    cg_max_iter : int, default 1000
        CG iteration limit per reduced solve; >= 1. (A wide margin over the iterations
        measured: docs/solvers.md#damage-problem.)
    raise_on_failure : bool, default True
        Raise :class:`DamageSolverError` if not converged; otherwise return the last
        iterate with ``converged=False``.
    callback : callable, optional
        ``callback(iteration, a)`` after every step (do not modify ``a``).

    Returns
    -------
    BoxQPResult

    Raises
    ------
    ValueError
        Inconsistent shapes, non-finite entries, ``lower > upper`` somewhere, a
        non-positive diagonal entry of ``A``, or an invalid option (the message names
        the offending key, value and allowed range).
    DamageSolverError
        Not converged within ``max_iter`` steps (the message names the KKT residual and
        the iteration count), or a reduced system that is not positive definite.

    Notes
    -----
    One step, from a feasible ``a`` with residual ``r = A a - b`` and ``d = diag(A)``:

    - prediction: ``L = {i: a_i - r_i/d_i <= lower_i}``, ``U = {... >= upper_i}``,
      ``F`` = the rest (a fixed node always lands in ``L`` or ``U``);
    - Newton point ``y``: ``y_L = lower_L``, ``y_U = upper_U``, and on ``F`` the
      reduced system ``A_FF (y_F - a_F) = -(A (z - a) + r)_F`` with ``z`` = ``a`` moved
      onto the predicted bounds;
    - trial ``P(y)`` (projection on the box), accepted if
      ``E(P(y)) - E(a) <= 1e-4 r.(P(y) - a)`` (Armijo on the projected path, so a
      step that raises the energy is never accepted); otherwise ``P(a + theta (y - a))``
      for ``theta = 1/2, 1/4, 1/8``; otherwise a projected-gradient step.

    Energy differences are evaluated as ``r.s + 1/2 s.A.s`` on the support of the step
    ``s``, without cancellation, so the monotonicity test is meaningful even for tiny
    steps.
    """
    t_start = time.perf_counter()
    timings = dict.fromkeys(("setup", "residual", "active_set", "reduced_system",
                             "linear_solve", "step", "safeguard"), 0.0)

    # ---- checks and set-up ---------------------------------------------------------
    _check_options(rtol, max_iter, linear_solver, direct_max_free, cg_max_iter)
    A = _as_csr(A)
    n = A.shape[0]
    b = _as_vector("b", b, n)
    lower = _as_vector("lower", lower, n)
    upper = _as_vector("upper", upper, n)
    a0 = lower if a0 is None else _as_vector("a0", a0, n)
    diag = A.diagonal()
    a = np.empty(n)
    dinv = np.empty(n)
    # One pass: finiteness, lower <= upper, diag > 0, and the projection of a0 (its
    # entries outside the bounds become the bound values themselves, so the bounds
    # hold exactly from the start).
    problem, where, a0_projected = kernels.prepare(b, lower, upper, a0, diag, a, dinv)
    if problem:
        _raise_input_error(problem, where, b, lower, upper, a0, diag)

    # Work arrays, allocated once: the prediction (status; z = a moved onto the
    # predicted bounds; dz = z - a), the scaled KKT violation of every node, and the
    # scratch space of the free-set extraction and of the local steps.
    status = np.empty(n, dtype=np.int8)
    z = np.empty(n)
    dz = np.empty(n)
    violation = np.empty(n)
    local_index = np.full(n, -1, dtype=np.int64)
    step = LocalStep(A)
    # Nodes whose residual has been updated incrementally since it was last computed
    # from scratch: the final KKT test recomputes them (the updates assume A
    # symmetric and accumulate round-off).
    stale = np.zeros(n, dtype=np.bool_)
    timings["setup"] += time.perf_counter() - t_start

    def refresh():
        """Residual from scratch and the prediction at every node."""
        tic = time.perf_counter()
        r_new = A @ a - b
        timings["residual"] += time.perf_counter() - tic
        tic = time.perf_counter()
        kernels.predict_all(a, r_new, lower, upper, dinv, status, z, dz, violation)
        timings["active_set"] += time.perf_counter() - tic
        stale[:] = False
        return r_new

    def recompute_stale(r):
        """The residual ``r`` from scratch on the stale nodes (in place), and their
        prediction."""
        tic = time.perf_counter()
        rows = np.flatnonzero(stale)
        kernels.residual_rows(A.indptr, A.indices, A.data, a, b, rows, r)
        stale[rows] = False
        timings["residual"] += time.perf_counter() - tic
        tic = time.perf_counter()
        kernels.predict_nodes(rows, a, r, lower, upper, dinv, status, z, dz, violation)
        timings["active_set"] += time.perf_counter() - tic

    r = refresh()
    any_stale = False
    kkt = float(violation.max()) if n else 0.0
    if not np.isfinite(kkt):
        # a0, b are finite, so a non-finite residual means a non-finite entry of A in
        # that row (checked on n values rather than on every nonzero of A).
        i = int(np.flatnonzero(~np.isfinite(violation))[0])
        raise ValueError(f"A has a non-finite entry in row {i} ((A a - b)[{i}] = "
                         f"{float(r[i])!r}): all entries must be finite")
    energy = kernels.energy_from_residual(a, r, b)
    energies = [energy]
    kkts = [kkt]
    steps, free_sizes = [], []
    linear_iterations = 0
    iteration = 0

    while True:
        if kkt <= rtol and any_stale:
            # Certify convergence on a residual computed from scratch.
            recompute_stale(r)
            any_stale = False
            kkt = kkts[-1] = float(violation.max())
        if kkt <= rtol or iteration >= max_iter:
            break
        iteration += 1

        # ---- Newton step on the predicted active set -------------------------------
        tic = time.perf_counter()
        free, moving = kernels.split_step_nodes(status)
        timings["active_set"] += time.perf_counter() - tic

        tic = time.perf_counter()
        local_index[free] = np.arange(free.size)
        sub_indptr, sub_indices, sub_data, rhs = kernels.extract_free_system(
            A.indptr, A.indices, A.data, free, local_index, r, dz)
        local_index[free] = -1
        A_ff = sp.csr_array((sub_data, sub_indices, sub_indptr), shape=(free.size,) * 2)
        timings["reduced_system"] += time.perf_counter() - tic

        tic = time.perf_counter()
        linear_tol = _LINEAR_TOL_FRACTION * rtol
        if moving.size or kernels.any_on_bound(free, a, lower, upper):
            # The active set changes in this step, so it is likely to change again:
            # an exact solve would be wasted (inexact Newton).
            linear_tol = max(linear_tol, _FORCING * kkt)
        delta, n_lin = _solve_reduced(A_ff, rhs, dinv[free], linear_tol,
                                      linear_solver, direct_max_free, cg_max_iter)
        linear_iterations += n_lin
        free_sizes.append(int(free.size))
        timings["linear_solve"] += time.perf_counter() - tic

        # The step lives on `nodes` = free + moving; y is the Newton point there.
        tic = time.perf_counter()
        nodes = np.concatenate((free, moving))
        start = a[nodes]
        lo, hi = lower[nodes], upper[nodes]
        newton_point = np.concatenate((start[:free.size] + delta, z[moving]))
        values = np.clip(newton_point, lo, hi)
        d_energy, slope = step.evaluate(nodes, values - start, r)
        kind = "newton"
        timings["step"] += time.perf_counter() - tic

        if not _armijo_ok(d_energy, slope):
            # Safeguard 1: backtrack along the projected path P(a + theta (y - a)).
            tic = time.perf_counter()
            kind = None
            theta = 1.0
            for _ in range(_NEWTON_BACKTRACKS):
                theta *= 0.5
                values = np.clip(start + theta * (newton_point - start), lo, hi)
                d_energy, slope = step.evaluate(nodes, values - start, r)
                if _armijo_ok(d_energy, slope):
                    kind = "newton-backtracked"
                    break
            timings["safeguard"] += time.perf_counter() - tic

        if kind is not None:
            tic = time.perf_counter()
            changed = step.apply(nodes, values, a, r)
            stale[changed] = True
            any_stale = True
            timings["step"] += time.perf_counter() - tic
            tic = time.perf_counter()
            kernels.predict_nodes(changed, a, r, lower, upper, dinv, status, z, dz, violation)
            timings["active_set"] += time.perf_counter() - tic
        else:
            # Safeguard 2: projected gradient, which always lowers the energy.
            tic = time.perf_counter()
            kind = "projected-gradient"
            a[:], d_energy = _projected_gradient_step(A, b, a, r, lower, upper, dinv)
            timings["safeguard"] += time.perf_counter() - tic
            r, any_stale = refresh(), False

        # Energy from the accurately computed decrement: the recorded history is
        # exactly what the safeguard enforced.
        energy += d_energy
        energies.append(energy)
        kkt = float(violation.max())
        kkts.append(kkt)
        steps.append(kind)
        if callback is not None:
            callback(iteration, a)

    if any_stale:  # only when max_iter stopped the iteration
        recompute_stale(r)
        kkt = kkts[-1] = float(violation.max())
    converged = kkt <= rtol
    n_free, n_lower, n_upper, n_fixed = kernels.count_classes(a, lower, upper)
    result = BoxQPResult(
        a=a,
        iterations=iteration,
        kkt_residual=kkt,
        energy=kernels.energy_from_residual(a, r, b),
        n_free=n_free,
        n_lower=n_lower,
        n_upper=n_upper,
        n_fixed=n_fixed,
        converged=bool(converged),
        energies=np.asarray(energies),
        kkt_residuals=np.asarray(kkts),
        steps=tuple(steps),
        n_free_history=tuple(free_sizes),
        linear_iterations=linear_iterations,
        a0_projected=a0_projected,
        timings={**timings, "total": time.perf_counter() - t_start},
    )
    if not converged and raise_on_failure:
        raise DamageSolverError(
            f"damage solver did not converge: KKT residual {kkt:.3e} > rtol {rtol:.3e} "
            f"after {iteration} iterations (max_iter = {max_iter}; steps: "
            f"{_summarize_steps(steps)})",
            kkt_residual=kkt, iterations=iteration, result=result)
    return result


# --------------------------------------------------------------------------------------
# Pieces of the iteration
# --------------------------------------------------------------------------------------


class LocalStep:
    """A step ``s`` supported on a few nodes, with ``A s`` formed on their neighbours only.

    ``evaluate`` gives the energy change of a trial step, ``apply`` makes it the new
    iterate and updates the residual ``r += A s`` in place; the cost of both is
    proportional to the number of nonzeros in the rows of the step's support, not to
    the size of the problem.
    """

    def __init__(self, A):
        n = A.shape[0]
        self._A = A
        self._As = np.zeros(n)  # A s on the touched nodes, zero elsewhere
        self._marked = np.zeros(n, dtype=np.bool_)
        self._touched = np.empty(n, dtype=np.int64)
        self._count = 0

    def evaluate(self, nodes, s, r):
        """Energy change ``r.s + 1/2 s.A.s`` and slope ``r.s`` of the step ``s`` on ``nodes``.

        Evaluated from the residual, never as a difference of two energies, so there is
        no cancellation even when the step is tiny.
        """
        self._As[self._touched[:self._count]] = 0.0
        A = self._A
        self._count, slope, curvature = kernels.scatter_product(
            A.indptr, A.indices, A.data, nodes, s, r, self._As, self._marked, self._touched)
        return slope + 0.5 * curvature, slope

    def apply(self, nodes, values, a, r):
        """Accept the last evaluated step: ``a[nodes] = values``, ``r += A s``.

        ``values`` are assigned (not added), so bound values stay bit exact. Returns
        the nodes whose value or residual changed.
        """
        a[nodes] = values
        changed = self._touched[:self._count].copy()
        r[changed] += self._As[changed]
        self._As[changed] = 0.0
        self._count = 0
        return changed


def _raise_input_error(problem, i, b, lower, upper, a0, diag):
    """Turn the code returned by :func:`kernels.prepare` into a ValueError naming the entry."""
    if problem <= 4:  # a non-finite entry
        key, values = (("b", b), ("lower", lower), ("upper", upper), ("a0", a0))[problem - 1]
        raise ValueError(f"{key}[{i}] = {float(values[i])!r}: must be finite")
    if problem == 5:
        raise ValueError(f"lower[{i}] = {float(lower[i])!r} > upper[{i}] = "
                         f"{float(upper[i])!r}: the bounds must satisfy lower <= upper")
    raise ValueError(f"A[{i}, {i}] = {float(diag[i])!r}: the diagonal of A must be > 0 "
                     f"(A must be symmetric positive definite)")


def _armijo_ok(d_energy: float, slope: float) -> bool:
    """Sufficient decrease ``dE <= c r.s`` for a step ``s`` with ``r.s < 0``.

    A step along which the energy does not decrease to first order (``r.s >= 0``) is
    rejected, and with it any step that would raise the energy (``dE <= c r.s < 0``).
    """
    return slope < 0.0 and d_energy <= _ARMIJO * slope


def _projected_gradient_step(A, b, a, r, lower, upper, dinv):
    """One Jacobi-scaled projected-gradient step with an Armijo search on the path.

    The direction is ``p = -r / diag(A)`` with the components that leave the box at
    nodes on a bound set to zero. The search starts at the exact minimizer ``theta*``
    of the energy along the straight line and halves it; if that fails (only when a
    node sits extremely close to a bound), it takes the longest step that keeps every
    node inside the box, on which the energy is an exact quadratic that decreases.

    Returns
    -------
    a_new : ndarray, shape (n,)
    d_energy : float
        Energy change, <= 0 (0 if ``a`` is already stationary).
    """
    p = -r * dinv
    p[((a == lower) & (p < 0.0)) | ((a == upper) & (p > 0.0))] = 0.0
    Ap = A @ p
    curvature = float(p @ Ap)
    descent = float(r @ p)  # < 0 unless a is a KKT point
    if not (descent < 0.0 and curvature > 0.0):
        return a.copy(), 0.0

    def energy_change(trial):
        s = trial - a
        return float(s @ r) + 0.5 * float(s @ (A @ s)), float(s @ r)

    theta = -descent / curvature
    for _ in range(_GRADIENT_BACKTRACKS):
        trial = np.clip(a + theta * p, lower, upper)
        d_energy, slope = energy_change(trial)
        if _armijo_ok(d_energy, slope):
            return trial, d_energy
        theta *= 0.5
    with np.errstate(divide="ignore", invalid="ignore"):
        room = np.where(p > 0, (upper - a) / p, np.where(p < 0, (lower - a) / p, np.inf))
    theta = min(-descent / curvature, float(np.min(room)))
    trial = np.clip(a + theta * p, lower, upper)
    d_energy, _ = energy_change(trial)
    if not d_energy <= 0.0:  # round-off only: stay
        return a.copy(), 0.0
    return trial, d_energy


def _solve_reduced(A_ff, rhs, dinv_ff, tol, linear_solver, direct_max_free, cg_max_iter):
    """Solve the free-set system ``A_ff x = rhs`` to scaled residual ``tol``.

    Returns
    -------
    x : ndarray, shape (n_free,)
    cg_iterations : int
    """
    n_free = rhs.size
    if n_free == 0:
        return np.zeros(0), 0
    if callable(linear_solver):
        x = np.asarray(linear_solver(A_ff, rhs, tol), dtype=np.float64)
        if x.shape != rhs.shape:
            raise ValueError(f"linear_solver returned an array of shape {x.shape}; "
                             f"expected {rhs.shape}")
        return x, 0
    if linear_solver == "direct" or (linear_solver == "auto" and n_free <= direct_max_free):
        return _direct_solve(A_ff, rhs), 0
    x = np.zeros(n_free)
    iterations, residual = kernels.pcg_jacobi(A_ff.indptr, A_ff.indices, A_ff.data, rhs,
                                       dinv_ff, tol, cg_max_iter, x)
    if residual < 0.0:
        raise DamageSolverError(
            f"reduced damage matrix on {n_free} free nodes is not positive definite "
            f"(CG breakdown at iteration {-iterations}); A must be SPD",
            kkt_residual=float("nan"), iterations=0)
    if iterations < 0:  # CG reached cg_max_iter
        if linear_solver == "auto":
            return _direct_solve(A_ff, rhs), cg_max_iter
        # With "cg" forced, the inexact Newton point is still a trial point: the
        # safeguard and the outer KKT test take care of it.
        return x, cg_max_iter
    return x, iterations


def _direct_solve(A_ff, rhs):
    """Sparse LU (SuperLU) with a symmetric fill-reducing ordering and no pivoting.

    No pivoting is needed for an SPD matrix, and an ordering of ``A + A^T`` keeps the
    fill small. Since ``A_ff`` is symmetric, its CSR arrays are also its CSC arrays.
    """
    A_csc = sp.csc_matrix((A_ff.data, A_ff.indices, A_ff.indptr), shape=A_ff.shape)
    try:
        lu = spla.splu(A_csc, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                       options={"SymmetricMode": True})
    except RuntimeError as exc:  # e.g. "Factor is exactly singular"
        raise DamageSolverError(
            f"reduced damage matrix on {rhs.size} free nodes could not be factorized "
            f"({exc}); A must be SPD", kkt_residual=float("nan"), iterations=0) from exc
    WORK.factorizations += 1
    return lu.solve(rhs)


def _summarize_steps(steps):
    counts = {}
    for kind in steps:
        counts[kind] = counts.get(kind, 0) + 1
    return ", ".join(f"{kind} x{count}" for kind, count in counts.items()) or "none"


def _check_options(rtol, max_iter, linear_solver, direct_max_free, cg_max_iter):
    if not (isinstance(rtol, (int, float, np.floating)) and np.isfinite(rtol) and rtol > 0):
        raise ValueError(f"rtol = {rtol!r}: must be a finite number > 0")
    for key, value, low in (("max_iter", max_iter, 0),
                            ("direct_max_free", direct_max_free, 0),
                            ("cg_max_iter", cg_max_iter, 1)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
            raise ValueError(f"{key} = {value!r}: must be an integer >= {low}")
    if not callable(linear_solver) and linear_solver not in _LINEAR_SOLVERS:
        raise ValueError(f"linear_solver = {linear_solver!r}: must be one of "
                         f"{', '.join(_LINEAR_SOLVERS)} or a callable (A_ff, rhs, tol) -> x")


def _as_csr(A):
    """CSR float64 view of A (no copy when it already is one)."""
    if not sp.issparse(A):
        raise ValueError(f"A is a {type(A).__name__}: must be a scipy.sparse matrix "
                         f"or array")
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A.shape = {A.shape}: must be square (n, n)")
    if A.format != "csr" or A.dtype != np.float64:
        A = sp.csr_array(A, dtype=np.float64)
    return A


def _as_vector(key, value, n):
    """C-contiguous float64 vector of length n (a scalar is broadcast)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        if not np.isfinite(arr):
            raise ValueError(f"{key} = {float(arr)!r}: must be finite")
        return np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{key}.shape = {arr.shape}: must be ({n},) or a scalar")
    return np.ascontiguousarray(arr)  # finiteness: checked by kernels.prepare
