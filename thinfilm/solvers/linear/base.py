"""What the u-problem's linear solvers share: the pattern a solver is made for, what a solve
reports, the error it raises, the round-off test and preconditioned CG.

:class:`LinearSolver` is the protocol of every solver (:mod:`thinfilm.solvers.linear`):
``update(K)`` (new values, same pattern), ``solve(f, x0, rtol) -> (u, SolveInfo)`` and the two
in one call. :func:`pcg` is the CG of both families: the AMG solver's iteration and the direct
solver's refinement.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from thinfilm.solvers.errors import SolverError

__all__ = ["LinearSolverError", "SolveInfo", "LinearSolver", "Pattern", "DEFAULT_RTOL",
           "ROUNDOFF_BACKWARD_ERROR", "as_csr", "relative_residual", "backward_error", "at_roundoff",
           "check_rhs", "pcg"]

#: Relative residual ``||f - K u|| / ||f||`` a solve guarantees unless told otherwise.
DEFAULT_RTOL = 1e-8


class LinearSolverError(SolverError):
    """A linear solve failed: no convergence, a breakdown, or a non-finite value.

    Attributes
    ----------
    residual : float
        Final relative residual ``||f - K u|| / ||f||`` (NaN if it could not be computed).
    iterations : int
        Iterations (CG steps or refinement steps) done before giving up.
    kind : str
        The solver kind that failed.
    """

    def __init__(self, message, *, residual=float("nan"), iterations=0, kind=""):
        super().__init__(
            f"{kind} linear solve failed: {message} "
            f"(relative residual {residual:.3e} after {iterations} iterations)"
        )
        self.residual = float(residual)
        self.iterations = int(iterations)
        self.kind = kind


@dataclass
class SolveInfo:
    """What one ``solve`` did.

    Attributes
    ----------
    kind : str
        ``"direct:pardiso"``, ``"direct:superlu"`` or ``"amg"``.
    iterations : int
        CG iterations (for ``direct``: refinement steps after the triangular solves, usually 0).
    residual : float
        Final true relative residual ``||f - K u||_2 / ||f||_2``; above ``rtol`` only when
        the solution is at the round-off floor of ``K`` (see ``ROUNDOFF_BACKWARD_ERROR``).
    rtol : float
        The tolerance that was asked for.
    time_setup : float
        Seconds spent in this call on (re)factorization or hierarchy (re)building.
    time_solve : float
        Seconds spent in the triangular solves or the CG iterations.
    rebuilt : bool
        True when this call refactorized (direct) or rebuilt the hierarchy (amg).
    """

    kind: str
    iterations: int
    residual: float
    rtol: float
    time_setup: float
    time_solve: float
    rebuilt: bool

    @property
    def time(self) -> float:
        """Total seconds of the call."""
        return self.time_setup + self.time_solve

def as_csr(K, name="K"):
    """``K`` as CSR float64 with sorted indices; TypeError or ValueError if it is not a square
    scipy sparse matrix (``name`` names it in the message)."""
    if not sp.issparse(K):
        raise TypeError(f"{name} must be a scipy sparse matrix, got {type(K).__name__}")
    K = K.tocsr()
    if K.shape[0] != K.shape[1]:
        raise ValueError(f"{name} must be square, got shape {K.shape}")
    if not K.has_sorted_indices:
        K = K.sorted_indices()
    if K.dtype != np.float64:
        K = K.astype(np.float64)
    return K


class Pattern:
    """The fixed sparsity pattern (CSR, sorted indices) a solver was made for."""

    def __init__(self, A):
        A = as_csr(A, "pattern")
        self.n = A.shape[0]
        self.indptr = A.indptr.copy()
        self.indices = A.indices.copy()

    def check(self, K):
        """Return K as CSR float64 if it has this pattern, else raise ValueError."""
        K = as_csr(K)
        if K.shape[0] != self.n:
            raise ValueError(f"K has shape {K.shape}, the solver was made for n = {self.n}")
        same = (K.indices is self.indices) or (
            K.nnz == self.indices.size
            and np.array_equal(K.indptr, self.indptr)
            and np.array_equal(K.indices, self.indices)
        )
        if not same:
            raise ValueError(
                f"K has a different sparsity pattern (nnz {K.nnz}, expected "
                f"{self.indices.size}); make a new solver for a new pattern"
            )
        if not np.all(np.isfinite(K.data)):
            bad = int(np.count_nonzero(~np.isfinite(K.data)))
            raise ValueError(f"K has {bad} non-finite values")
        return K

    def index_matrix(self):
        """CSR matrix with this pattern whose values are 1 + the position in ``data``.

        Used to turn a permutation or triangle extraction of the pattern into a gather index
        into ``K.data`` (computed once; values start at 1 so no entry is an explicit zero).
        """
        data = np.arange(1, self.indices.size + 1, dtype=np.float64)
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def relative_residual(K, f, u, normf):
    """``||f - K u||_2 / normf``, with ``normf = ||f||_2`` computed by the caller."""
    return float(np.linalg.norm(f - K @ u) / normf)


#: Normwise backward error below which a solution is as exact as double precision allows.
#: A backward-stable solve reaches ~1e-16 whatever the conditioning; the relative residual
#: ``||f - K u|| / ||f||`` of that same solution grows like the condition number (like
#: ``n^4`` for the biharmonic: 1e-7 at 800 cells of a 1D film, 4e-4 at 6400), so an
#: ``rtol`` below it cannot be reached by any refinement.
ROUNDOFF_BACKWARD_ERROR = 1e-13


def backward_error(K, f, u):
    """Normwise backward error ``||f - K u||_inf / (||K||_inf ||u||_inf + ||f||_inf)``.

    The smallest relative perturbation of ``K`` and ``f`` of which ``u`` is the exact
    solution (Rigal-Gaches); round-off makes it a few ``eps`` at best.

    Parameters
    ----------
    K : scipy.sparse matrix, shape (n, n)
    f : ndarray, shape (n,)
    u : ndarray, shape (n,)

    Returns
    -------
    float
        Dimensionless.
    """
    norm_K = float(abs(K).sum(axis=1).max())
    r = f - K @ u
    return float(np.abs(r).max() / (norm_K * np.abs(u).max() + np.abs(f).max()))


def at_roundoff(K, f, u):
    """Whether ``u`` is finite and at the round-off floor of ``K``: its normwise backward error
    (:func:`backward_error`) is at most :data:`ROUNDOFF_BACKWARD_ERROR`."""
    return bool(np.all(np.isfinite(u))) and backward_error(K, f, u) <= ROUNDOFF_BACKWARD_ERROR


def check_rhs(f, n):
    """``f`` as a float64 array of shape ``(n,)``; ValueError if its shape differs or an entry
    is not finite."""
    f = np.asarray(f, dtype=np.float64)
    if f.shape != (n,):
        raise ValueError(f"f must have shape ({n},), got {f.shape}")
    if not np.all(np.isfinite(f)):
        raise ValueError("f has non-finite entries")
    return f


def pcg(K, f, apply_M, x0, rtol, maxiter, kind):
    """Preconditioned CG on ``K u = f`` to ``||f - K u|| <= rtol ||f||``.

    Parameters
    ----------
    K : scipy.sparse matrix, shape (n, n)
        Symmetric positive definite.
    f : ndarray, shape (n,)
        Not zero.
    apply_M : callable
        ``apply_M(r) -> z``, shape (n,) to (n,): the SPD preconditioner.
    x0 : ndarray, shape (n,), or None
        Start (None: zero).
    rtol : float
        Relative residual to reach.
    maxiter : int
        CG iterations at most.
    kind : str
        The solver kind named in an error.

    Returns
    -------
    u : ndarray, shape (n,)
    iterations : int
    relres : float
        True relative residual of ``u``; above ``rtol`` when ``maxiter`` was hit, which is
        *not* raised here (the caller may rebuild and retry).
    relres0 : float
        Relative residual of the start.

    Raises
    ------
    LinearSolverError
        On a non-finite value or a CG breakdown (``p.Kp`` or ``r.z`` not positive: K or the
        preconditioner is not SPD numerically).
    """
    normf = np.linalg.norm(f)
    x = np.zeros_like(f) if x0 is None else np.array(x0, dtype=np.float64, copy=True)
    r = f - K @ x if x0 is not None else f.copy()
    rnorm = np.linalg.norm(r)
    relres0 = rnorm / normf
    target = rtol * normf
    it = 0
    # The recursively updated residual drifts from the true one; when it says "converged" we
    # check the true residual and restart from there (at most a few times) if it disagrees.
    for _restart in range(3):
        if rnorm <= target:
            break
        z = apply_M(r)
        p = z.copy()
        rz = float(r @ z)
        while it < maxiter:
            if not (rz > 0.0 and math.isfinite(rz)):
                raise LinearSolverError(
                    f"CG breakdown (r.z = {rz:.3e}: preconditioner not SPD or non-finite)",
                    residual=rnorm / normf, iterations=it, kind=kind)
            q = K @ p
            pq = float(p @ q)
            if not (pq > 0.0 and math.isfinite(pq)):
                raise LinearSolverError(
                    f"CG breakdown (p.Kp = {pq:.3e}: K not SPD or non-finite)",
                    residual=rnorm / normf, iterations=it, kind=kind)
            a = rz / pq
            x += a * p
            r -= a * q
            it += 1
            rnorm = np.linalg.norm(r)
            if not math.isfinite(rnorm):
                raise LinearSolverError("non-finite residual in CG", residual=rnorm / normf,
                                        iterations=it, kind=kind)
            if rnorm <= target:
                break
            z = apply_M(r)
            rz_new = float(r @ z)
            p *= rz_new / rz
            p += z
            rz = rz_new
        r = f - K @ x
        rnorm = np.linalg.norm(r)
        if it >= maxiter:
            break
    if not np.all(np.isfinite(x)):
        raise LinearSolverError("non-finite solution", residual=float("nan"), iterations=it,
                                kind=kind)
    return x, it, float(rnorm / normf), float(relres0)


class LinearSolver:
    """What both solvers share: ``update(K)`` (new values, same pattern), ``solve(f, x0,
    rtol) -> (u, SolveInfo)`` and the two in one call."""

    def __call__(self, K, f, x0=None, rtol=None):
        """``update(K)`` then ``solve``.

        Always takes K's current values, also when K is the object passed before:
        :meth:`thinfilm.plate.operators.PlateOperator.matrix` rewrites one matrix in place, so
        identity says nothing about the values. Call :meth:`solve` alone to reuse the last
        update.
        """
        self.update(K)
        return self.solve(f, x0=x0, rtol=rtol)
