"""Symmetric indefinite systems with their inertia: the coupled Newton system of the engine.

The Hessian of the energy in ``(u, alpha)`` restricted to the free damage nodes is symmetric
but not always positive definite (a crack that can grow at fixed load is a direction of
negative curvature). A Newton method must know when it is not, to correct it
(:mod:`thinfilm.engine.newton`): by Sylvester's law of inertia the signs of the pivots of an
``L D L^T`` factorization count the positive and negative eigenvalues. MKL PARDISO's symmetric
indefinite mode (``mtype = -2``: Bunch-Kaufman pivoting inside supernodes, tiny pivots
perturbed) reports them in ``iparm(22)`` and ``iparm(23)``; scipy has no sparse ``L D L^T``,
so without PARDISO only small systems are solved, densely (``scipy.linalg.ldl``).

The matrix is scaled symmetrically to a unit diagonal before it is factored, ``S H S`` with
``S = |diag H|^(-1/2)``: the displacement and damage blocks differ by orders of magnitude
(stiffness against toughness / eta), and a congruence keeps the inertia.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from thinfilm.solvers.linear.base import LinearSolverError
from thinfilm.solvers.linear.pardiso import max_threads, new_solver, pardiso_available, run_phase
from thinfilm.solvers.work import WORK

__all__ = ["Inertia", "IndefiniteSolver", "DENSE_MAX"]

#: Largest system solved densely when PARDISO is missing.
DENSE_MAX = 4000


@dataclass(frozen=True)
class Inertia:
    """Signs of the eigenvalues of a factored symmetric matrix.

    Attributes
    ----------
    positive, negative : int
        Numbers of positive and negative eigenvalues (the rest are zero or were perturbed).
    size : int
        Order of the matrix.
    """

    positive: int
    negative: int
    size: int

    @property
    def definite(self) -> bool:
        """True if the matrix is positive definite."""
        return self.positive == self.size and self.negative == 0


class IndefiniteSolver:
    """Factor symmetric matrices of changing pattern and report their inertia.

    ``factor(H)`` returns :class:`Inertia`; ``solve(b)`` then solves ``H x = b``. The symbolic
    analysis is kept while the pattern stays the same (a Newton step whose active set did not
    change) and redone when it changes or MKL's thread count does
    (:class:`thinfilm.solvers.linear.pardiso.PardisoBackend` says why).

    Attributes
    ----------
    factorizations : int
        Numeric factorizations done.
    """

    def __init__(self):
        self.pardiso = pardiso_available()
        self.factorizations = 0
        self._ps = None
        self._pattern = None
        self._threads = None
        self._scale = None
        self._U = None
        self._dense = None

    def factor(self, H, shift=None) -> Inertia:
        """Factor the symmetric ``H + diag(shift)``.

        Parameters
        ----------
        H : scipy.sparse matrix, shape (n, n)
            Both triangles stored, every diagonal entry in the pattern. Explicit zeros stay in
            the pattern (so that a matrix whose values vanish somewhere keeps its analysis).
        shift : ndarray, shape (n,), optional
            Added to the diagonal.

        Raises
        ------
        LinearSolverError
            If the factorization fails, or PARDISO is missing and ``n > DENSE_MAX``.
        """
        H = sp.csr_matrix(H, dtype=np.float64)
        if not H.has_sorted_indices:
            H = H.sorted_indices()
        n = H.shape[0]
        # Values are set entry by entry on the pattern: scipy's sparse sums and products drop
        # the entries that come out zero, and with them the pattern the analysis was made for.
        rows = np.repeat(np.arange(n, dtype=np.int32), np.diff(H.indptr))
        on_diagonal = np.flatnonzero(H.indices == rows)
        if on_diagonal.size != n:
            raise LinearSolverError("a diagonal entry is missing from the pattern", kind="indefinite")
        data = H.data.copy()
        if shift is not None:
            data[on_diagonal] += shift
        diagonal = np.abs(data[on_diagonal])
        scale = np.where(diagonal > 0.0, 1.0 / np.sqrt(np.where(diagonal > 0.0, diagonal, 1.0)), 1.0)
        self._scale = scale
        data *= scale[rows] * scale[H.indices]
        WORK.factorizations += 1
        self.factorizations += 1
        if not self.pardiso:
            if n > DENSE_MAX:
                raise LinearSolverError(f"a symmetric indefinite system of {n} unknowns needs PARDISO"
                                        " (pypardiso with MKL), which could not be loaded", kind="indefinite")
            return self._factor_dense(sp.csr_matrix((data, H.indices, H.indptr), shape=H.shape).toarray())
        upper = H.indices >= rows
        U = sp.csr_matrix((data[upper], H.indices[upper].astype(np.int32),
                           np.concatenate(([0], np.cumsum(np.bincount(rows[upper], minlength=n)))).astype(np.int32)),
                          shape=H.shape)
        return self._factor_pardiso(U)

    def _factor_dense(self, H):
        lu, d, perm = sla.ldl(H, lower=True, hermitian=True)
        eigenvalues = np.linalg.eigvalsh(d)  # d is block diagonal with 1x1 and 2x2 blocks
        self._dense = sla.lu_factor(H)
        return Inertia(int(np.sum(eigenvalues > 0.0)), int(np.sum(eigenvalues < 0.0)), H.shape[0])

    def _factor_pardiso(self, upper):
        if self._ps is None:
            self._ps = new_solver()
            self._ps.set_matrix_type(-2)
            self._ps.set_iparm(12, 0)  # CSR input, no transposed solve
            self._max_threads = max_threads(self._ps)
        pattern = (upper.shape[0], upper.indptr, upper.indices)
        threads = int(self._max_threads())
        same = (self._pattern is not None and self._threads == threads and self._pattern[0] == pattern[0]
                and np.array_equal(self._pattern[1], pattern[1]) and np.array_equal(self._pattern[2], pattern[2]))
        self._U = upper
        if not same:
            self._ps.free_memory(everything=True)
            self._phase(11, upper)
            self._pattern, self._threads = pattern, threads
        self._phase(22, upper)
        iparm = self._ps.iparm  # 0-based: iparm[k] is PARDISO's iparm(k + 1)
        return Inertia(int(iparm[21]), int(iparm[22]), upper.shape[0])

    def _phase(self, phase, U, b=None):
        return run_phase(self._ps, phase, U, np.zeros(U.shape[0]) if b is None else b, "indefinite")

    def solve(self, b: np.ndarray) -> np.ndarray:
        """``H^-1 b`` with the last factorization, shape ``(n,)``."""
        WORK.linear_solves += 1
        scaled = self._scale * np.asarray(b, dtype=np.float64)
        if not self.pardiso:
            x = sla.lu_solve(self._dense, scaled)
        else:
            x = self._phase(33, self._U, np.ascontiguousarray(scaled))
        x = self._scale * x
        if not np.all(np.isfinite(x)):
            raise LinearSolverError("the solution is not finite", kind="indefinite")
        return x

    def close(self):
        """Free PARDISO's memory."""
        if self._ps is not None:
            try:
                self._ps.free_memory(everything=True)
            except Exception:
                pass
            self._ps = None
            self._pattern = None

    def __del__(self):
        try:
            self.close()
        except Exception:
            pass
