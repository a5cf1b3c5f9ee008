"""The AMG solver of the u-problem: CG preconditioned by a kept smoothed-aggregation V-cycle.

pyamg's smoothed aggregation with the near-nullspace the model gives, its hierarchy kept
across value updates (only the finest level takes the new values) and rebuilt when the
convergence rate degrades: :class:`AMGSolver`.
"""

from __future__ import annotations

import math
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
)
from thinfilm.solvers.work import WORK

__all__ = ["AMGSolver", "AMG_DEFAULTS"]

#: Smoothed-aggregation settings, chosen by measurement at 500^2
#: (docs/solvers.md#amg-and-the-near-nullspace): symmetric strength, energy-minimizing
#: prolongation, forward Gauss-Seidel before and backward after (a symmetric V-cycle, so still
#: a valid CG preconditioner). The smoothers must not cache anything derived from the level
#: matrix, since the finest level's matrix is replaced on update: point Gauss-Seidel
#: qualifies, ``block_gauss_seidel`` (caches inverted diagonal blocks) and ``jacobi`` (caches a
#: spectral radius) do not.
AMG_DEFAULTS = dict(
    strength=("symmetric", {"theta": 0.08}),
    smooth=("energy", {"krylov": "cg", "maxiter": 3, "degree": 2, "weighting": "local"}),
    presmoother=("gauss_seidel", {"sweep": "forward", "iterations": 1}),
    postsmoother=("gauss_seidel", {"sweep": "backward", "iterations": 1}),
    max_coarse=500,
    max_levels=10,
)


class AMGSolver(LinearSolver):
    """CG preconditioned by a kept smoothed-aggregation V-cycle.

    Parameters
    ----------
    pattern : scipy.sparse matrix, shape (n, n)
        Any matrix with the fixed sparsity pattern.
    near_nullspace : ndarray, shape (n, k)
        The operator's near-nullspace, from the model (the free plate's ``[1, x, y]``, the
        three or six rigid-body modes of elasticity): required, since with the constant
        alone smoothed aggregation fails on these operators.
    rtol : float
        Default relative residual tolerance ``||f - K u|| <= rtol ||f||``.
    maxiter : int
        CG iterations before giving up (after one rebuild-and-retry if the hierarchy was stale).
    rebuild_factor : float
        Rebuild the hierarchy (before the next solve) when the iterations per decade of
        residual reduction exceed ``rebuild_factor`` times the value measured in the first
        solve after the last rebuild. Per decade rather than raw counts, so warm starts and
        per-call tolerances do not trigger or mask a rebuild.
    min_rebuild_iterations : int
        Never rebuild because of a solve that took fewer CG iterations than this (cheap solves
        are not worth a setup, whatever their rate).
    **amg_options
        Override entries of :data:`AMG_DEFAULTS` (passed to
        ``pyamg.smoothed_aggregation_solver``).
    """

    kind = "amg"

    def __init__(self, pattern, *, near_nullspace=None, rtol=DEFAULT_RTOL, maxiter=500,
                 rebuild_factor=2.0, min_rebuild_iterations=10, **amg_options):
        import pyamg  # noqa: F401  (fail early if missing)

        self.pattern = Pattern(pattern)
        self.n = self.pattern.n
        if near_nullspace is None:
            raise ValueError("near_nullspace (shape (n, k)) is required by kind='amg': the model's"
                             " near-nullspace, e.g. the free plate's [1, x, y]")
        self.B = np.ascontiguousarray(np.asarray(near_nullspace, dtype=np.float64).reshape(self.n, -1))

        unknown = set(amg_options) - set(AMG_DEFAULTS) - {"aggregate", "improve_candidates"}
        if unknown:
            raise ValueError(f"unknown AMG options {sorted(unknown)}; allowed: "
                             f"{sorted(AMG_DEFAULTS) + ['aggregate', 'improve_candidates']}")
        self.amg_options = {**AMG_DEFAULTS, **amg_options}
        self.rtol = float(rtol)
        self.maxiter = int(maxiter)
        self.rebuild_factor = float(rebuild_factor)
        self.min_rebuild_iterations = int(min_rebuild_iterations)
        self.K = None
        self.ml = None
        self._baseline = None  # iterations per decade right after the last rebuild
        self._stale = True     # True: rebuild before the next solve
        self._fresh = False    # True: no solve since the last rebuild
        self.n_builds = 0
        self.last_setup_time = 0.0

    # -- hierarchy -----------------------------------------------------------------------
    def _build(self):
        import pyamg

        t0 = time.perf_counter()
        self.ml = pyamg.smoothed_aggregation_solver(self.K, B=self.B, **self.amg_options)
        self._levels = self.ml.levels
        self._coarse = self._coarse_inverse(self._levels[-1].A)
        self._stale = False
        self._fresh = True
        self._baseline = None
        self.n_builds += 1
        self.last_setup_time = time.perf_counter() - t0

    @staticmethod
    def _coarse_inverse(A):
        """Return a function applying the coarsest-level inverse.

        The coarsest matrix (a few hundred to a thousand unknowns) can be singular: an
        aggregate whose nodes are collinear gives P a zero column and A_c a zero row. Those
        rows are dropped and the rest factored by Cholesky, with a relative diagonal shift of
        1e-12 if round-off (tiny k_res) makes it fail; a matrix that is still not positive
        definite gets an LU (CG will then report the breakdown). No eigendecomposition: it is
        far slower (docs/solvers.md#amg-and-the-near-nullspace).
        """
        import scipy.linalg as sla

        Ad = A.toarray()
        d = np.diag(Ad)
        keep = np.flatnonzero(d > 1e-14 * max(float(d.max()), 1e-300))
        Ak = Ad[np.ix_(keep, keep)]
        factor, apply = None, None
        for shift in (0.0, 1e-12):
            try:
                factor = sla.cho_factor(Ak + shift * float(d.max()) * np.eye(len(keep)),
                                        check_finite=False)
                apply = sla.cho_solve
                break
            except np.linalg.LinAlgError:
                continue
        if factor is None:
            factor, apply = sla.lu_factor(Ak, check_finite=False), sla.lu_solve
        WORK.factorizations += 1  # the coarsest level's, once per hierarchy

        def solve(b):
            x = np.zeros_like(b)
            x[keep] = apply(factor, b[keep], check_finite=False)
            return x

        return solve

    def operator_complexity(self):
        """Sum of nnz over levels divided by the fine nnz (None before the first build)."""
        return None if self.ml is None else self.ml.operator_complexity()

    def _vcycle(self, b, lvl=0):
        """One symmetric V-cycle from a zero guess (an SPD preconditioner for CG).

        Written out instead of ``ml.aspreconditioner`` because pyamg's ``solve`` wrapper
        computes residual norms on every call (extra fine-level matvecs per CG step).
        """
        levels = self._levels
        if lvl == len(levels) - 1:
            return self._coarse(b)
        L = levels[lvl]
        x = np.zeros_like(b)
        L.presmoother(L.A, x, b)
        r = b - L.A @ x
        x += L.P @ self._vcycle(L.R @ r, lvl + 1)
        L.postsmoother(L.A, x, b)
        return x

    # -- protocol --------------------------------------------------------------------------
    def update(self, K):
        """Take new values ``K`` (same pattern).

        The hierarchy is kept: only its finest matrix is replaced, so the smoother and the
        fine-level residual use the new values while the coarse operators stay as built.
        """
        self.K = self.pattern.check(K)
        if self.ml is not None:
            self._levels[0].A = self.K

    def solve(self, f, x0=None, rtol=None):
        """Solve ``K u = f`` by AMG-preconditioned CG.

        Parameters
        ----------
        f : ndarray, shape (n,)
        x0 : ndarray, shape (n,), optional
            Warm start (e.g. the previous u).
        rtol : float, optional
            Relative residual tolerance for this call (loosen it in early alternate-
            minimization iterations); default the solver's ``rtol``. A solution at the
            round-off floor of ``K`` is accepted as for :class:`DirectSolver`.

        Returns
        -------
        u : ndarray, shape (n,)
        info : SolveInfo

        Raises
        ------
        LinearSolverError
            If CG does not reach ``rtol`` in ``maxiter`` iterations with a freshly built
            hierarchy, breaks down, or meets a non-finite value.
        """
        if self.K is None:
            raise RuntimeError("call update(K) before solve")
        rtol = self.rtol if rtol is None else float(rtol)
        f = check_rhs(f, self.n)
        if x0 is not None:
            x0 = np.asarray(x0, dtype=np.float64)
            if x0.shape != (self.n,) or not np.all(np.isfinite(x0)):
                x0 = None  # a bad warm start is not worth failing a solve for
        WORK.linear_solves += 1
        if np.linalg.norm(f) == 0.0:
            return np.zeros(self.n), SolveInfo(self.kind, 0, 0.0, rtol, 0.0, 0.0, False)
        t_setup = 0.0
        rebuilt = False
        if self.ml is None or self._stale:
            self._build()
            t_setup += self.last_setup_time
            rebuilt = True
        t0 = time.perf_counter()
        u, its, res, res0 = pcg(self.K, f, self._vcycle, x0, rtol, self.maxiter, self.kind)
        if not res <= rtol and not self._fresh:
            # A stale hierarchy gave up: rebuild now and try once more from where CG stopped.
            self._build()
            t_setup += self.last_setup_time
            rebuilt = True
            u, its2, res, res0 = pcg(self.K, f, self._vcycle, u, rtol, self.maxiter, self.kind)
            its += its2
        t1 = time.perf_counter() - t0
        if not res <= rtol and not at_roundoff(self.K, f, u):
            self._stale = True
            raise LinearSolverError(f"CG did not reach rtol = {rtol:.1e}", residual=res,
                                    iterations=its, kind=self.kind)
        self._track_rate(its, res0, res)
        return u, SolveInfo(self.kind, its, res, rtol, t_setup, t1, rebuilt)

    def _track_rate(self, its, res0, res):
        if its == 0 or res0 <= 0.0:
            return
        decades = max(math.log10(res0 / max(res, 1e-300)), 1e-3)
        rate = its / decades
        if self._fresh:
            self._baseline = rate
            self._fresh = False
        elif (self._baseline is not None and its >= self.min_rebuild_iterations
              and rate > self.rebuild_factor * self._baseline):
            self._stale = True

    def close(self):
        """Drop the hierarchy."""
        self.ml = None
        self._levels = None
        self._stale = True
