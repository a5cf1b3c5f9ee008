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

Modules, one per solver family and backend; this package holds the choice of kind
(:func:`auto_kind`, :func:`make_solver`) and re-exports what callers use:

* :mod:`~thinfilm.solvers.linear.base`: what every solver shares (the pattern, :class:`SolveInfo`,
  :class:`LinearSolverError`, the round-off test, preconditioned CG);
* :mod:`~thinfilm.solvers.linear.direct`: :class:`DirectSolver` and its precision rule, on
  :mod:`~thinfilm.solvers.linear.pardiso` (MKL PARDISO, conditional numerical
  reproducibility) or :mod:`~thinfilm.solvers.linear.superlu` (scipy's SuperLU);
* :mod:`~thinfilm.solvers.linear.amg`: :class:`AMGSolver` and its pyamg settings.
"""

from __future__ import annotations

from thinfilm.solvers.linear.amg import AMG_DEFAULTS, AMGSolver
from thinfilm.solvers.linear.base import (
    DEFAULT_RTOL,
    ROUNDOFF_BACKWARD_ERROR,
    LinearSolverError,
    SolveInfo,
    backward_error,
)
from thinfilm.solvers.linear.direct import AUTO_SINGLE_MIN_UNKNOWNS, PRECISIONS, DirectSolver
from thinfilm.solvers.linear.pardiso import pardiso_available, pardiso_reproducible

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
    "AUTO_AMG_MIN_UNKNOWNS_SUPERLU",
    "AUTO_SINGLE_MIN_UNKNOWNS",
    "AMG_DEFAULTS",
    "DEFAULT_RTOL",
    "ROUNDOFF_BACKWARD_ERROR",
    "backward_error",
    "KINDS",
    "PRECISIONS",
]

KINDS = ("auto", "direct", "amg")

#: ``kind="auto"`` picks ``"amg"`` from this many unknowns on: beyond the largest measured size
#: the O(N^1.5) factorization time and its memory favour AMG (docs/solvers.md#direct-solvers).
AUTO_AMG_MIN_UNKNOWNS = 1501 * 1501
#: The same crossover when only scipy's SuperLU is available (no ``pypardiso``), measured
#: (docs/solvers.md#direct-solvers).
AUTO_AMG_MIN_UNKNOWNS_SUPERLU = 400 * 400


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
