"""The MKL PARDISO backend of the direct solver, and MKL's conditional numerical reproducibility.

:class:`PardisoBackend` factors an SPD matrix through ``pypardiso`` (which pulls the ``mkl``
wheel) with the ordering and symbolic analysis kept across value updates, in double or single
precision. :func:`pardiso_available` says whether it can be loaded; :func:`pardiso_reproducible`
which reproducibility branch MKL runs (:class:`thinfilm.solvers.linear.DirectSolver` uses both).
"""

from __future__ import annotations

import ctypes
import functools
import os

import numpy as np
import scipy.sparse as sp

from thinfilm.solvers.linear.base import LinearSolverError, Pattern

__all__ = ["PardisoBackend", "pardiso_available", "pardiso_reproducible", "new_solver", "max_threads", "run_phase",
           "MKL_CBWR_ALL",
           "MKL_CBWR_BRANCH_OFF", "MKL_CBWR_AUTO"]


@functools.lru_cache(maxsize=1)
def pardiso_available() -> bool:
    """True if ``pypardiso`` (and its MKL runtime) can be imported and loaded (cached)."""
    try:
        import pypardiso  # noqa: F401

        solver = new_solver()
    except Exception:  # ImportError, or the MKL runtime library not found
        return False
    _reproducible(solver.libmkl)
    return True


def new_solver():
    """A ``pypardiso.PyPardisoSolver`` for SPD matrices.

    pypardiso looks for MKL's runtime library each time it makes a solver, searching the whole
    Python installation when the system's loader does not know it (0.3-0.6 s each, several
    times per run); its variable ``PYPARDISO_MKL_RT`` skips the search. The first solver's
    library is therefore named there (unless the user already set it), for the rest of the
    process and the processes it starts (a scan's workers).
    """
    import pypardiso

    solver = pypardiso.PyPardisoSolver(mtype=2)
    name = getattr(solver.libmkl, "_name", None)
    if name and "PYPARDISO_MKL_RT" not in os.environ:
        os.environ["PYPARDISO_MKL_RT"] = name
    return solver


def max_threads(solver):
    """MKL's ``mkl_get_max_threads`` of ``solver``'s library, as a function of no argument.

    PARDISO's symbolic analysis holds only for the thread count it was made with
    (:class:`PardisoBackend`), so its users compare this count before each factorization.
    """
    function = solver.libmkl.mkl_get_max_threads
    function.restype, function.argtypes = ctypes.c_int, []
    return function


def run_phase(solver, phase, matrix, b, kind):
    """PARDISO's ``phase`` on ``matrix`` (CSR, upper triangle) and right-hand side ``b``; its
    failure as a :class:`LinearSolverError` of ``kind``."""
    import pypardiso

    solver.set_phase(phase)
    try:
        return solver._call_pardiso(matrix, b)
    except pypardiso.pardiso_wrapper.PyPardisoError as exc:
        raise LinearSolverError(f"PARDISO phase {phase} failed: {exc}", kind=kind) from exc


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


class PardisoBackend:
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

    def __init__(self, pattern: Pattern, precision="double"):  # "double" or "single", resolved by DirectSolver
        self.ps = new_solver()
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
        self._max_threads = max_threads(self.ps)
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
        return run_phase(self.ps, phase, self.U, b, f"direct:{self.name}")

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
