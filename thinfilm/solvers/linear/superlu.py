"""The SuperLU backend of the direct solver: scipy's ``splu`` with a kept fill-reducing order.

No dependency beyond scipy; :class:`thinfilm.solvers.linear.DirectSolver` falls back to it
when PARDISO cannot be loaded.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse.linalg as spla

from thinfilm.solvers.linear.base import LinearSolverError, Pattern

__all__ = ["SuperLUBackend"]


class SuperLUBackend:
    """scipy's SuperLU with a kept fill-reducing order (LU of an SPD matrix).

    The first factorization orders with ``MMD_AT_PLUS_A`` (minimum degree on the symmetric
    pattern, with half the fill of ``COLAMD`` on this operator); later ones reuse its column
    permutation on the pre-permuted matrix (``NATURAL``), so no ordering is recomputed.
    ``SymmetricMode`` with a zero pivot threshold keeps diagonal pivots (SPD: stable).
    """

    name = "superlu"

    def __init__(self, pattern: Pattern):
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
