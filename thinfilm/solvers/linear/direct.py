"""The sparse direct solver of the u-problem: :class:`DirectSolver`.

A factorization by PARDISO (:mod:`thinfilm.solvers.linear.pardiso`) or, without it, SuperLU
(:mod:`thinfilm.solvers.linear.superlu`), its analysis kept across value updates; a residual
check after every solve, with CG preconditioned by the factorization where round-off (or a
single-precision factorization) leaves the residual above ``rtol``.
"""

from __future__ import annotations

import time

import numpy as np

from thinfilm.solvers.linear.base import (
    DEFAULT_RTOL,
    LinearSolver,
    LinearSolverError,
    Pattern,
    SolveInfo,
    at_roundoff,
    check_rhs,
    pcg,
    relative_residual,
)
from thinfilm.solvers.linear.pardiso import PardisoBackend, pardiso_available
from thinfilm.solvers.linear.superlu import SuperLUBackend
from thinfilm.solvers.work import WORK

__all__ = ["DirectSolver", "PRECISIONS", "AUTO_SINGLE_MIN_UNKNOWNS", "SINGLE_MAX_REFINE",
           "SINGLE_START_RESIDUAL"]

#: Precisions of the direct solver's factorization (:class:`DirectSolver`).
PRECISIONS = ("auto", "double", "single")

#: ``precision="auto"`` factors in single precision (PARDISO only) from this many unknowns
#: on; below, the factorization is cheap and double keeps every solve exact to round-off (and
#: every result below that size unchanged). Measured: docs/solvers.md#reuse-across-iterations.
AUTO_SINGLE_MIN_UNKNOWNS = 1000 * 1000

#: CG steps allowed to refine a single-precision solve, a margin over the steps measured
#: (docs/solvers.md#reuse-across-iterations).
SINGLE_MAX_REFINE = 60
#: A single-precision solve starts its refinement from ``x0`` if x0's relative residual is
#: below this, well under what the float32 solve itself leaves
#: (docs/solvers.md#reuse-across-iterations).
SINGLE_START_RESIDUAL = 0.1


class DirectSolver(LinearSolver):
    """Sparse direct solver with the analysis kept across value updates.

    Parameters
    ----------
    pattern : scipy.sparse matrix, shape (n, n)
        Any matrix with the fixed sparsity pattern (values ignored). Symmetric positive
        definite matrices with this pattern are passed to :meth:`update`.
    backend : {"auto", "pardiso", "superlu"}
        ``"auto"``: PARDISO if ``pypardiso`` imports, else SuperLU.
    rtol : float
        Default relative residual tolerance checked after each solve.
    max_refine : int
        Factorization-preconditioned CG steps allowed when round-off leaves the residual above
        ``rtol`` (ill-conditioned K, e.g. ``k_res = 1e-10`` on a crack that cuts the plate),
        or, in single precision, to refine the solve to ``rtol``.
    precision : {"auto", "double", "single"}
        Precision of the factorization. ``"single"`` (PARDISO only): half the factor's
        memory and less time per factorization; its solve is accurate to about one digit and
        is refined to ``rtol`` by CG preconditioned by it, so a solve returns ``rtol``, not
        round-off (measured: docs/solvers.md#reuse-across-iterations). ``"auto"``: single
        from :data:`AUTO_SINGLE_MIN_UNKNOWNS` unknowns with PARDISO, else double.
    """

    def __init__(self, pattern, *, backend="auto", rtol=DEFAULT_RTOL, max_refine=20, precision="auto"):
        self.pattern = Pattern(pattern)
        self.n = self.pattern.n
        if backend == "auto":
            backend = "pardiso" if pardiso_available() else "superlu"
        if precision not in PRECISIONS:
            raise ValueError(f"precision = {precision!r}; allowed: {PRECISIONS}")
        if precision == "auto":
            precision = "single" if backend == "pardiso" and self.n >= AUTO_SINGLE_MIN_UNKNOWNS else "double"
        if precision == "single" and backend != "pardiso":
            raise ValueError(f"precision = 'single' needs the PARDISO backend (backend = {backend!r})")
        self.precision = precision
        if backend == "pardiso":
            self._backend = PardisoBackend(self.pattern, precision)
            if precision == "single":
                # refinement from a solve accurate to ~1 digit takes more steps than round-off's
                max_refine = max(max_refine, SINGLE_MAX_REFINE)
        elif backend == "superlu":
            self._backend = SuperLUBackend(self.pattern)
        else:
            raise ValueError(f"backend = {backend!r}; allowed: 'auto', 'pardiso', 'superlu'")
        self.kind = f"direct:{self._backend.name}"
        self.rtol = float(rtol)
        self.max_refine = int(max_refine)
        self.K = None
        self._factored = False

    def update(self, K):
        """Take new values ``K`` (same pattern); the refactorization happens at the next solve."""
        self.K = self.pattern.check(K)
        self._factored = False

    def solve(self, f, x0=None, rtol=None):
        """Solve ``K u = f``.

        Parameters
        ----------
        f : ndarray, shape (n,)
        x0 : ndarray, shape (n,), optional
            In single precision, the start of the refinement if it is closer than the
            single-precision solve (relative residual below ``SINGLE_START_RESIDUAL``);
            ignored in double precision (accepted so the kinds are interchangeable).
        rtol : float, optional
            Relative residual to guarantee; default the solver's ``rtol``. Where it lies
            below the round-off floor of ``K`` (the refined solution's normwise backward
            error is under ``ROUNDOFF_BACKWARD_ERROR``) the round-off-limited solution is
            returned, its residual in ``info``.

        Returns
        -------
        u : ndarray, shape (n,)
        info : SolveInfo
        """
        if self.K is None:
            raise RuntimeError("call update(K) before solve")
        rtol = self.rtol if rtol is None else float(rtol)
        f = check_rhs(f, self.n)
        t0 = time.perf_counter()
        rebuilt = not self._factored
        if rebuilt:
            self._backend.factor(self.K)
            self._factored = True
            WORK.factorizations += 1
        WORK.linear_solves += 1
        t1 = time.perf_counter()
        normf = np.linalg.norm(f)
        if normf == 0.0:
            return np.zeros(self.n), SolveInfo(self.kind, 0, 0.0, rtol, t1 - t0, 0.0, rebuilt)
        u, res = None, float("nan")
        if self.precision == "single" and x0 is not None:
            # The refinement starts from the better of x0 and the single-precision solve: in
            # alternate minimization x0 (the last iteration's u) is often within 1e-3 of
            # the solution, and each CG step costs a solve with the factor.
            u = np.array(x0, dtype=np.float64)
            res = relative_residual(self.K, f, u, normf) if u.shape == f.shape and np.all(np.isfinite(u)) else float("nan")
            if not res <= SINGLE_START_RESIDUAL:
                u = None
        if u is None:
            u = self._backend.solve(f)
            res = relative_residual(self.K, f, u, normf) if np.all(np.isfinite(u)) else float("nan")
        its = 0
        # Above rtol but at the round-off floor (backward error of a few eps): no refinement
        # can lower the residual, which is then just the rounding of K @ u.
        if not res <= rtol and not at_roundoff(self.K, f, u):  # also catches NaN
            # Round-off on an ill-conditioned K, or a single-precision factorization: CG
            # preconditioned by the factorization converges in a few steps (iterative
            # refinement that cannot diverge).
            start = u if np.all(np.isfinite(u)) else None
            u, its, res, _ = pcg(self.K, f, self._backend.solve, start, rtol,
                                  self.max_refine, self.kind)
            if not res <= rtol and not at_roundoff(self.K, f, u):
                raise LinearSolverError(f"did not reach rtol = {rtol:.1e}", residual=res,
                                        iterations=its, kind=self.kind)
        t2 = time.perf_counter()
        return u, SolveInfo(self.kind, its, res, rtol, t1 - t0, t2 - t1, rebuilt)

    def close(self):
        """Free the factorization (PARDISO keeps it in MKL-owned memory)."""
        self._backend.close()
        self._factored = False

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
