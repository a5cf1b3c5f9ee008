"""Linear solvers for the u-problem ``K(alpha) u = f``, created once per sparsity pattern.

Every alternate-minimization iteration solves the plate + Winkler system with a matrix whose
*pattern* never changes and whose *values* change a little (the damage field moves). The
solvers here are built around that: the expensive, value-independent work (ordering and
symbolic analysis; the near-nullspace and the AMG hierarchy) is done once and kept, and each
solve only redoes what the new values require.

Protocol (what the evolution engine relies on)::

    solver = make_solver(kind, pattern, near_nullspace=B, **options)   # once per pattern
    solver.update(K)                        # new values, same pattern (CSR)
    u, info = solver.solve(f, x0=u_prev, rtol=1e-8)
    u, info = solver(K, f, x0=u_prev)       # the same as update + solve: a plain function

Kinds
-----
``"direct"``
    Sparse Cholesky/LU. Backend ``"pardiso"`` (Intel MKL PARDISO through the ``pypardiso``
    wheel, which pulls the ``mkl`` wheel) when importable: METIS ordering and symbolic
    factorization once, numeric refactorization on each update. Otherwise ``"superlu"``
    (scipy's ``splu``, no extra dependency): the fill-reducing column order of the first
    factorization is kept and reused. A residual check follows every solve, with a few steps of
    factorization-preconditioned CG if round-off left it above ``rtol``.
``"amg"``
    Conjugate gradients preconditioned by one symmetric V-cycle of pyamg smoothed aggregation
    with the near-nullspace ``B`` the model gives (the free plate's ``[1, x, y]``). The hierarchy is kept across updates;
    only the finest level takes the new values (so smoothing and fine residuals are exact and
    the coarse levels are stale). The hierarchy is rebuilt when the convergence rate (CG
    iterations per decade of residual reduction) degrades past ``rebuild_factor`` times the
    rate measured right after the last rebuild, and at once if a stale hierarchy fails to
    converge.
``"auto"``
    ``"direct"`` unless the system is larger than the measured crossover
    (:data:`AUTO_AMG_MIN_UNKNOWNS`; docs/solvers.md#direct-solvers).

PARDISO on several threads does not sum in the same order twice (its parallel factorization
schedules work dynamically): two runs of one scene then differ by round-off. The direct
solver turns on MKL's conditional numerical reproducibility before PARDISO's first call
(:func:`pardiso_reproducible`), which makes them agree to the last bit
(docs/results.md#reproducibility).

Every solve returns an :class:`SolveInfo`; a solve that does not reach its tolerance, or that
produces a non-finite value, raises :class:`LinearSolverError`.

The solvers know nothing of the model: the matrix comes from its operator, and its
near-nullspace from the model (:func:`thinfilm.plate.operators.near_nullspace` for the film).
"""

from __future__ import annotations

import ctypes
import functools
import math
import os
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.solvers.errors import SolverError

__all__ = [
    "LinearSolverError",
    "SolveInfo",
    "DirectSolver",
    "AMGSolver",
    "make_solver",
    "auto_kind",
    "pardiso_available",
    "pardiso_reproducible",
    "AUTO_AMG_MIN_UNKNOWNS",
    "AUTO_SINGLE_MIN_UNKNOWNS",
    "KINDS",
    "PRECISIONS",
]

KINDS = ("auto", "direct", "amg")
#: Precisions of the direct solver's factorization (:class:`DirectSolver`).
PRECISIONS = ("auto", "double", "single")

#: ``kind="auto"`` picks ``"amg"`` from this many unknowns on: beyond the largest measured size
#: the O(N^1.5) factorization time and its memory favour AMG (docs/solvers.md#direct-solvers).
AUTO_AMG_MIN_UNKNOWNS = 1501 * 1501
#: The same crossover when only scipy's SuperLU is available (no ``pypardiso``), measured
#: (docs/solvers.md#direct-solvers).
AUTO_AMG_MIN_UNKNOWNS_SUPERLU = 400 * 400
#: ``precision="auto"`` factors in single precision (PARDISO only) from this many unknowns
#: on; below, the factorization is cheap and double keeps every solve exact to round-off (and
#: every result below that size unchanged). Measured: docs/solvers.md#reuse-across-iterations.
AUTO_SINGLE_MIN_UNKNOWNS = 1000 * 1000

DEFAULT_RTOL = 1e-8
#: CG steps allowed to refine a single-precision solve, a margin over the steps measured
#: (docs/solvers.md#reuse-across-iterations).
SINGLE_MAX_REFINE = 60
#: A single-precision solve starts its refinement from ``x0`` if x0's relative residual is
#: below this, well under what the float32 solve itself leaves
#: (docs/solvers.md#reuse-across-iterations).
SINGLE_START_RESIDUAL = 0.1


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


# --------------------------------------------------------------------------------------------
# shared pieces
# --------------------------------------------------------------------------------------------


def _as_csr(K, name="K"):
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


class _Pattern:
    """The fixed sparsity pattern (CSR, sorted indices) a solver was made for."""

    def __init__(self, A):
        A = _as_csr(A, "pattern")
        self.n = A.shape[0]
        self.indptr = A.indptr.copy()
        self.indices = A.indices.copy()

    def check(self, K):
        """Return K as CSR float64 if it has this pattern, else raise ValueError."""
        K = _as_csr(K)
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


def _relres(K, f, u, normf):
    return float(np.linalg.norm(f - K @ u) / normf)


#: Normwise backward error below which a solution is as exact as double precision allows.
#: A backward-stable solve reaches ~1e-16 whatever the conditioning; the relative residual
#: ``||f - K u|| / ||f||`` of that same solution grows like the condition number (like
#: ``n^4`` for the biharmonic: 1e-7 at 800 cells of a 1D film, 4e-4 at 6400), so an
#: ``rtol`` below it cannot be reached by any refinement.
ROUNDOFF_BACKWARD_ERROR = 1e-13


def _backward_error(K, f, u):
    """Normwise backward error ``||f - K u||_inf / (||K||_inf ||u||_inf + ||f||_inf)``.

    The smallest relative perturbation of ``K`` and ``f`` of which ``u`` is the exact
    solution (Rigal-Gaches); round-off makes it a few ``eps`` at best.
    """
    norm_K = float(abs(K).sum(axis=1).max())
    r = f - K @ u
    return float(np.abs(r).max() / (norm_K * np.abs(u).max() + np.abs(f).max()))


def _at_roundoff(K, f, u):
    return bool(np.all(np.isfinite(u))) and _backward_error(K, f, u) <= ROUNDOFF_BACKWARD_ERROR


def _check_rhs(f, n):
    f = np.asarray(f, dtype=np.float64)
    if f.shape != (n,):
        raise ValueError(f"f must have shape ({n},), got {f.shape}")
    if not np.all(np.isfinite(f)):
        raise ValueError("f has non-finite entries")
    return f


def _pcg(K, f, apply_M, x0, rtol, maxiter, kind):
    """Preconditioned CG on ``K u = f`` to ``||f - K u|| <= rtol ||f||``.

    Returns ``(u, iterations, relres, relres0)`` with ``relres0`` the relative residual of the
    start. Raises :class:`LinearSolverError` on a non-finite value or a CG breakdown (``p.Kp``
    or ``r.z`` not positive: K or the preconditioner is not SPD numerically). Hitting
    ``maxiter`` is *not* raised here (the caller may rebuild and retry); it is reported through
    ``relres > rtol``.
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


# --------------------------------------------------------------------------------------------
# direct
# --------------------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def pardiso_available() -> bool:
    """True if ``pypardiso`` (and its MKL runtime) can be imported and loaded (cached)."""
    try:
        import pypardiso  # noqa: F401

        solver = pypardiso.PyPardisoSolver(mtype=2)
    except Exception:  # ImportError, or the MKL runtime library not found
        return False
    _reproducible(solver.libmkl)
    return True


#: MKL's conditional numerical reproducibility branches (``mkl_service.h``): ``MKL_CBWR_Get``
#: of all branches gives 1 when it is off, 2 for AUTO (the code paths of this CPU, the same
#: from run to run), 3 for COMPATIBLE (the same on every x86 CPU, slower).
MKL_CBWR_ALL, MKL_CBWR_BRANCH_OFF, MKL_CBWR_AUTO = -1, 1, 2
_mkl_branch: list = []  # MKL's branch, once asked for (MKL fixes it once per process)


def _reproducible(libmkl) -> int:
    """Turn on CNR in the loaded MKL (``libmkl``, a ctypes library) unless ``MKL_CBWR`` is
    set, once per process; MKL's branch (:func:`pardiso_reproducible`)."""
    if not _mkl_branch:
        try:
            get, set_ = libmkl.MKL_CBWR_Get, libmkl.MKL_CBWR_Set
        except AttributeError:  # an MKL without CNR
            _mkl_branch.append(0)
            return 0
        for function in (get, set_):
            function.restype, function.argtypes = ctypes.c_int, [ctypes.c_int]
        if "MKL_CBWR" not in os.environ and get(MKL_CBWR_ALL) == MKL_CBWR_BRANCH_OFF:
            set_(MKL_CBWR_AUTO)
        _mkl_branch.append(int(get(MKL_CBWR_ALL)))
    return _mkl_branch[0]


def pardiso_reproducible() -> int:
    """MKL's conditional numerical reproducibility (CNR) branch for PARDISO.

    Threaded PARDISO without CNR sums in an order that changes from one factorization to the
    next, so two runs of a scene differ at round-off. With CNR (branch AUTO) it gives the
    same bits every time on one machine, also on 1 and 2 threads (docs/speed.md#threads),
    though MKL promises it only for a fixed number of threads. MKL fixes its branch at its first
    computation, so the solver turns CNR on (branch AUTO) when it loads MKL, before PARDISO's
    first call (:func:`pardiso_available`, the direct solver's backend); a branch the user
    chose with the environment variable ``MKL_CBWR`` is kept (``MKL_CBWR=``, empty, leaves CNR
    off: MKL's fastest).

    Returns
    -------
    int
        :data:`MKL_CBWR_AUTO` (2) as turned on here, 3 for COMPATIBLE, 1 if CNR is off, 0 if
        this MKL cannot say, -1 without PARDISO.
    """
    if not pardiso_available():
        return -1
    return _mkl_branch[0]


class _PardisoBackend:
    """MKL PARDISO for real SPD matrices (``mtype = 2``), upper triangle in CSR.

    pypardiso's public ``factorize`` redoes the ordering and symbolic analysis (phase 12) on
    every call, a large share of its time (docs/solvers.md#direct-solvers). Calling its
    ``_call_pardiso`` with phase 11 once and phase 22 per update keeps the analysis.

    The analysis holds for the number of MKL threads it was made with: a numeric
    factorization after ``mkl_set_num_threads`` changed it returned wrong solutions, and so
    did every later one (docs/speed.md#threads). The analysis is therefore redone, on the
    fresh handle, whenever the thread count differs from the analysis's
    (:mod:`thinfilm.threads` changes it between load steps).

    ``precision = "single"`` factors ``S K S`` in single precision (PARDISO's ``iparm(28)``),
    with ``S = diag(K)^(-1/2)`` so that the factored matrix has a unit diagonal whatever the
    damage; :meth:`solve` then returns ``S (S K S)^-1 S b`` in double, a solve accurate only
    to ``kappa(K) eps_single``, which :class:`DirectSolver` refines by CG. The factor is half
    the size and faster to compute (docs/solvers.md#reuse-across-iterations). Every PARDISO
    parameter is then set here (``iparm(1) = 1``; otherwise PARDISO overwrites all of them with its
    defaults, the single-precision flag included): the defaults of an SPD matrix, METIS
    ordering.
    """

    name = "pardiso"

    def __init__(self, pattern: _Pattern, precision="double"):  # "double" or "single", resolved by DirectSolver
        import pypardiso

        self._err = pypardiso.pardiso_wrapper.PyPardisoError
        self.ps = pypardiso.PyPardisoSolver(mtype=2)
        _reproducible(self.ps.libmkl)  # before PARDISO's first call: MKL fixes its branch then
        self.ps.set_iparm(12, 0)  # CSR input, no transposed solve
        self.single = precision == "single"
        self.dtype = np.float32 if self.single else np.float64
        if self.single:
            self.name = "pardiso-single"
            iparm = self.ps.iparm  # 0-based here: iparm[k] is PARDISO's iparm(k + 1)
            iparm[0] = 1   # use the values below, not PARDISO's defaults
            iparm[1] = 2   # METIS nested-dissection ordering (the default)
            iparm[9] = 8   # pivot perturbation 1e-8 (the symmetric default; unused for SPD)
            iparm[27] = 1  # single precision: matrix, right-hand side and solution in float32
        upper = sp.triu(pattern.index_matrix(), format="csr")
        upper.sort_indices()
        self.gather = upper.data.astype(np.int64) - 1
        if self.single:  # the row and column of each stored entry, to scale it
            self.rows = np.repeat(np.arange(upper.shape[0], dtype=np.int32), np.diff(upper.indptr))
            self.cols = upper.indices.astype(np.int32)
        self.U = sp.csr_matrix(
            (np.ones(self.gather.size, dtype=self.dtype), upper.indices.astype(np.int32),
             upper.indptr.astype(np.int32)), shape=upper.shape)
        self.scale = None
        self._max_threads = self.ps.libmkl.mkl_get_max_threads
        self._max_threads.restype, self._max_threads.argtypes = ctypes.c_int, []
        self._analyse()

    def _zeros(self):
        return np.zeros(self.U.shape[0], dtype=self.dtype)

    def _analyse(self):
        """Phase 11 on a fresh handle: ordering and symbolic analysis, which need only the
        structure (SPD: no value-based matching), for the present number of MKL threads."""
        self.ps.free_memory(everything=True)
        self._threads = int(self._max_threads())
        self._phase(11, self._zeros())

    def _phase(self, phase, b):
        self.ps.set_phase(phase)
        try:
            return self.ps._call_pardiso(self.U, b)
        except self._err as exc:
            raise LinearSolverError(f"PARDISO phase {phase} failed: {exc}",
                                    kind=f"direct:{self.name}") from exc

    def _threads_changed(self):
        """Whether MKL's thread count differs from the analysis's."""
        return int(self._max_threads()) != self._threads

    def factor(self, K):
        if self._threads_changed():
            self._analyse()
        values = K.data[self.gather]
        if self.single:
            diagonal = K.diagonal()
            if not np.all(diagonal > 0.0):  # also NaN; an SPD matrix has a positive diagonal
                raise LinearSolverError("the matrix is not positive definite (a diagonal entry <= 0)",
                                        kind=f"direct:{self.name}")
            self.scale = 1.0 / np.sqrt(diagonal)
            values = values * self.scale[self.rows] * self.scale[self.cols]
        self.U.data[:] = values
        self._phase(22, self._zeros())

    def solve(self, b):
        if self._threads_changed():  # since the factorization: redo both, U holds the last values
            self._analyse()
            self._phase(22, self._zeros())
        if not self.single:
            return self._phase(33, np.ascontiguousarray(b))
        x = self._phase(33, np.ascontiguousarray(self.scale * b, dtype=np.float32))
        return self.scale * x.astype(np.float64)

    def close(self):
        try:
            self.ps.free_memory(everything=True)
        except Exception:
            pass


class _SuperLUBackend:
    """scipy's SuperLU with a kept fill-reducing order (LU of an SPD matrix).

    The first factorization orders with ``MMD_AT_PLUS_A`` (minimum degree on the symmetric
    pattern, with half the fill of ``COLAMD`` on this operator); later ones reuse its column
    permutation on the pre-permuted matrix (``NATURAL``), so no ordering is recomputed.
    ``SymmetricMode`` with a zero pivot threshold keeps diagonal pivots (SPD: stable).
    """

    name = "superlu"

    def __init__(self, pattern: _Pattern):
        self.pattern = pattern
        self.perm = None
        self.gather = None
        self.lu = None
        self._permuted = False  # True once lu factors the pre-permuted matrix

    def factor(self, K):
        opts = dict(SymmetricMode=True)
        try:
            if self.perm is None:
                self.lu = spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A",
                                    diag_pivot_thresh=0.0, options=opts)
                # perm_c[i] is the position of unknown i in the factor's order; the matrix to
                # hand to NATURAL is K[q][:, q] with q its inverse.
                self.perm = np.argsort(self.lu.perm_c)
                Ip = self.pattern.index_matrix()[self.perm][:, self.perm].tocsc()
                Ip.sort_indices()
                self.Kp = Ip
                self.gather = Ip.data.astype(np.int64) - 1
                self._permuted = False
            else:
                self.Kp.data[:] = K.data[self.gather]
                self.lu = spla.splu(self.Kp, permc_spec="NATURAL", diag_pivot_thresh=0.0,
                                    options=opts)
                self._permuted = True
        except RuntimeError as exc:  # "Factor is exactly singular"
            raise LinearSolverError(f"SuperLU factorization failed: {exc}",
                                    kind="direct:superlu") from exc

    def solve(self, b):
        if not self._permuted:  # the first factorization: splu permuted by itself
            return self.lu.solve(b)
        x = np.empty_like(b)
        x[self.perm] = self.lu.solve(b[self.perm])
        return x

    def close(self):
        self.lu = None


class _LinearSolver:
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


class DirectSolver(_LinearSolver):
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
        self.pattern = _Pattern(pattern)
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
            self._backend = _PardisoBackend(self.pattern, precision)
            if precision == "single":
                # refinement from a solve accurate to ~1 digit takes more steps than round-off's
                max_refine = max(max_refine, SINGLE_MAX_REFINE)
        elif backend == "superlu":
            self._backend = _SuperLUBackend(self.pattern)
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
        f = _check_rhs(f, self.n)
        t0 = time.perf_counter()
        rebuilt = not self._factored
        if rebuilt:
            self._backend.factor(self.K)
            self._factored = True
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
            res = _relres(self.K, f, u, normf) if u.shape == f.shape and np.all(np.isfinite(u)) else float("nan")
            if not res <= SINGLE_START_RESIDUAL:
                u = None
        if u is None:
            u = self._backend.solve(f)
            res = _relres(self.K, f, u, normf) if np.all(np.isfinite(u)) else float("nan")
        its = 0
        # Above rtol but at the round-off floor (backward error of a few eps): no refinement
        # can lower the residual, which is then just the rounding of K @ u.
        if not res <= rtol and not _at_roundoff(self.K, f, u):  # also catches NaN
            # Round-off on an ill-conditioned K, or a single-precision factorization: CG
            # preconditioned by the factorization converges in a few steps (iterative
            # refinement that cannot diverge).
            start = u if np.all(np.isfinite(u)) else None
            u, its, res, _ = _pcg(self.K, f, self._backend.solve, start, rtol,
                                  self.max_refine, self.kind)
            if not res <= rtol and not _at_roundoff(self.K, f, u):
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


# --------------------------------------------------------------------------------------------
# AMG
# --------------------------------------------------------------------------------------------

#: Smoothed-aggregation settings, chosen by measurement at 500^2
#: (docs/solvers.md#amg-and-the-near-nullspace): symmetric strength, energy-minimizing
#: prolongation, forward Gauss-Seidel before and backward after (a symmetric V-cycle, so still
#: a valid CG preconditioner). The smoothers must not cache anything derived from the level matrix, since the finest
#: level's matrix is replaced on update: point Gauss-Seidel qualifies, ``block_gauss_seidel``
#: (caches inverted diagonal blocks) and ``jacobi`` (caches a spectral radius) do not.
AMG_DEFAULTS = dict(
    strength=("symmetric", {"theta": 0.08}),
    smooth=("energy", {"krylov": "cg", "maxiter": 3, "degree": 2, "weighting": "local"}),
    presmoother=("gauss_seidel", {"sweep": "forward", "iterations": 1}),
    postsmoother=("gauss_seidel", {"sweep": "backward", "iterations": 1}),
    max_coarse=500,
    max_levels=10,
)


class AMGSolver(_LinearSolver):
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

        self.pattern = _Pattern(pattern)
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
        f = _check_rhs(f, self.n)
        if x0 is not None:
            x0 = np.asarray(x0, dtype=np.float64)
            if x0.shape != (self.n,) or not np.all(np.isfinite(x0)):
                x0 = None  # a bad warm start is not worth failing a solve for
        if np.linalg.norm(f) == 0.0:
            return np.zeros(self.n), SolveInfo(self.kind, 0, 0.0, rtol, 0.0, 0.0, False)
        t_setup = 0.0
        rebuilt = False
        if self.ml is None or self._stale:
            self._build()
            t_setup += self.last_setup_time
            rebuilt = True
        t0 = time.perf_counter()
        u, its, res, res0 = _pcg(self.K, f, self._vcycle, x0, rtol, self.maxiter, self.kind)
        if not res <= rtol and not self._fresh:
            # A stale hierarchy gave up: rebuild now and try once more from where CG stopped.
            self._build()
            t_setup += self.last_setup_time
            rebuilt = True
            u, its2, res, res0 = _pcg(self.K, f, self._vcycle, u, rtol, self.maxiter, self.kind)
            its += its2
        t1 = time.perf_counter() - t0
        if not res <= rtol and not _at_roundoff(self.K, f, u):
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


# --------------------------------------------------------------------------------------------
# factory
# --------------------------------------------------------------------------------------------


def auto_kind(n, pardiso, near_nullspace=True):
    """The solver ``kind = "auto"`` gives a system of ``n`` unknowns: ``"amg"`` from
    :data:`AUTO_AMG_MIN_UNKNOWNS` unknowns (:data:`AUTO_AMG_MIN_UNKNOWNS_SUPERLU` without
    PARDISO) if the model gives a near-nullspace, else ``"direct"``.

    Parameters
    ----------
    n : int
    pardiso : bool
        Whether PARDISO is the direct backend (the memory estimate asks without loading MKL).
    near_nullspace : bool
    """
    limit = AUTO_AMG_MIN_UNKNOWNS if pardiso else AUTO_AMG_MIN_UNKNOWNS_SUPERLU
    return "amg" if (near_nullspace and n >= limit) else "direct"


def make_solver(kind, pattern, *, near_nullspace=None, **options):
    """Make a u-problem solver for one sparsity pattern.

    Parameters
    ----------
    kind : {"auto", "direct", "amg"}
        ``"auto"`` picks ``"amg"`` above :data:`AUTO_AMG_MIN_UNKNOWNS` unknowns (the lower
        SuperLU crossover if PARDISO is not installed) when a ``near_nullspace`` is given,
        else ``"direct"``.
    pattern : scipy.sparse matrix, shape (n, n)
        A matrix with the fixed sparsity pattern (its values are not used).
    near_nullspace : ndarray, shape (n, k), optional
        The model's near-nullspace; required for ``"amg"``.
    **options
        Passed to :class:`DirectSolver` (``backend``, ``rtol``, ``max_refine``, ``precision``) or
        :class:`AMGSolver` (``rtol``, ``maxiter``, ``rebuild_factor``,
        ``min_rebuild_iterations`` and pyamg settings). ``rtol`` is accepted by both.

    Returns
    -------
    DirectSolver or AMGSolver
    """
    if kind not in KINDS:
        raise ValueError(f"kind = {kind!r}; allowed: {KINDS}")
    if kind == "auto":
        kind = auto_kind(pattern.shape[0], pardiso_available(), near_nullspace is not None)
    common = {k: options.pop(k) for k in ("rtol",) if k in options}
    if kind == "direct":
        allowed = {"backend", "max_refine", "precision"}
        bad = set(options) - allowed
        if bad:
            raise ValueError(f"unknown options {sorted(bad)} for kind='direct'; "
                             f"allowed: {sorted(allowed | {'rtol'})}")
        return DirectSolver(pattern, **common, **options)
    options.pop("precision", None)  # AMG factors nothing
    return AMGSolver(pattern, near_nullspace=near_nullspace, **common, **options)
