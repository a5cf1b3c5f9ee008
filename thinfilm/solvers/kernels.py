"""Numba kernels of the bound-constrained damage solver (:mod:`thinfilm.solvers.boxqp`).

Arrays and scalars in; no allocation in the per-node loops. Each kernel that replaces a
NumPy expression has its NumPy reference here too (``*_reference``); the tests compare them.
"""

import numba
import numpy as np

# Node status codes, shared with thinfilm.solvers.boxqp: free, on the lower bound, on the upper
# bound, predicted to go to the lower bound, predicted to go to the upper bound.
FREE, AT_LOWER, AT_UPPER, TO_LOWER, TO_UPPER = 0, 1, 2, 3, 4


def kkt_violation(r: np.ndarray, a: np.ndarray, lower, upper) -> np.ndarray:
    """Per-node violation ``v`` of the KKT conditions, unscaled (see :mod:`thinfilm.solvers.boxqp`).

    Parameters
    ----------
    r : ndarray, shape (n,)
        Residual ``A a - b`` (the gradient of the energy).
    a : ndarray, shape (n,)
        A feasible point.
    lower, upper : float or ndarray, shape (n,)
        Bounds.

    Returns
    -------
    ndarray, shape (n,)
        ``v_i >= 0``; zero where node ``i`` satisfies its KKT condition exactly.
    """
    r, a = np.asarray(r, dtype=np.float64), np.asarray(a, dtype=np.float64)
    lower = np.broadcast_to(np.asarray(lower, dtype=np.float64), a.shape)
    upper = np.broadcast_to(np.asarray(upper, dtype=np.float64), a.shape)
    v = np.abs(r)
    v = np.where(a == lower, np.maximum(-r, 0.0), v)
    v = np.where(a == upper, np.maximum(r, 0.0), v)
    return np.where(lower == upper, 0.0, v)


@numba.njit(cache=True, inline="always")
def _predict_node(i, a, r, lower, upper, dinv, status, z, dz, violation):
    """KKT violation and active-set prediction of node ``i`` (see :func:`predict_all`)."""
    ai, lo, hi = a[i], lower[i], upper[i]
    step = r[i] * dinv[i]  # Jacobi update of node i, in units of damage
    if lo == hi:
        v = 0.0
    elif ai == lo:
        v = max(-step, 0.0)
    elif ai == hi:
        v = max(step, 0.0)
    else:
        v = abs(step)
    # A non-finite residual must never pass the KKT test.
    violation[i] = v if v == v else np.inf
    target = ai - step
    if target <= lo:
        status[i] = AT_LOWER if ai == lo else TO_LOWER
        z[i] = lo
    elif target >= hi:
        status[i] = AT_UPPER if ai == hi else TO_UPPER
        z[i] = hi
    else:
        status[i] = FREE
        z[i] = ai
    dz[i] = z[i] - ai


@numba.njit(cache=True)
def predict_all(a, r, lower, upper, dinv, status, z, dz, violation):
    """At every node: scaled KKT violation and prediction from the Jacobi point.

    Writes ``violation[i]`` (the module docstring's ``v_i / d_i``), and the prediction
    from ``a_i - r_i / d_i``: on or below ``lower_i`` -> ``z_i = lower_i`` and
    ``status`` 1 (``a_i`` is there already) or 3 (it is not); on or above ``upper_i``
    -> ``z_i = upper_i``, status 2 or 4 (a fixed node, ``lower == upper``, always
    lands in one of these); else status 0 (free), ``z_i = a_i``. And ``dz = z - a``.
    """
    for i in range(a.size):
        _predict_node(i, a, r, lower, upper, dinv, status, z, dz, violation)


@numba.njit(cache=True)
def predict_nodes(nodes, a, r, lower, upper, dinv, status, z, dz, violation):
    """:func:`predict_all` restricted to the nodes listed in ``nodes`` (int64)."""
    for i in nodes:
        _predict_node(i, a, r, lower, upper, dinv, status, z, dz, violation)


def predict_reference(a, r, lower, upper, dinv):
    """NumPy reference of :func:`predict_all`: ``(status, z, dz, violation)``."""
    violation = kkt_violation(r, a, lower, upper) * dinv
    target = a - r * dinv
    to_lower, to_upper = target <= lower, (target >= upper) & ~(target <= lower)
    z = np.where(to_lower, lower, np.where(to_upper, upper, a))
    status = np.select([to_lower & (a == lower), to_lower, to_upper & (a == upper), to_upper],
                       [AT_LOWER, TO_LOWER, AT_UPPER, TO_UPPER], FREE).astype(np.int8)
    return status, z, z - a, violation


@numba.njit(cache=True)
def extract_free_system(indptr, indices, data, free, local_index, r, dz):
    """Reduced matrix ``A_FF`` (CSR) and right-hand side of the Newton step.

    Parameters
    ----------
    indptr, indices, data : CSR arrays of A, shape (n + 1,), (nnz,), (nnz,)
    free : int64 array, shape (m,)
        The free nodes, increasing.
    local_index : int64 array, shape (n,)
        Position of each node in ``free``, -1 for the others.
    r, dz : float64 arrays, shape (n,)
        Residual ``A a - b`` and the move ``z - a`` of the predicted active nodes
        (zero on the free set).

    Returns
    -------
    sub_indptr, sub_indices, sub_data : CSR arrays of ``A_FF``
    rhs : float64 array, shape (m,)
        ``-(r + A dz)`` on the free rows, i.e. minus the residual at ``z``.
    """
    m = free.size
    capacity = 0
    for k in range(m):
        capacity += indptr[free[k] + 1] - indptr[free[k]]
    # int32 indices: less memory traffic in CG (a free set of 2^31 nodes would need
    # far more memory than any machine this runs on).
    sub_indptr = np.empty(m + 1, dtype=np.int32)
    sub_indices = np.empty(capacity, dtype=np.int32)
    sub_data = np.empty(capacity)
    rhs = np.empty(m)
    nnz = 0
    sub_indptr[0] = 0
    for k in range(m):
        i = free[k]
        acc = r[i]
        for p in range(indptr[i], indptr[i + 1]):
            j = indices[p]
            acc += data[p] * dz[j]
            if local_index[j] >= 0:
                sub_indices[nnz] = local_index[j]
                sub_data[nnz] = data[p]
                nnz += 1
        rhs[k] = -acc
        sub_indptr[k + 1] = nnz
    return sub_indptr, sub_indices[:nnz], sub_data[:nnz], rhs


def extract_free_system_reference(A, free, r, dz):
    """NumPy/SciPy reference of :func:`extract_free_system`: ``(A_FF, rhs)``."""
    rows = A[free]
    return rows[:, free], -(r[free] + rows @ dz)


@numba.njit(cache=True)
def scatter_product(indptr, indices, data, nodes, s, r, As, marked, touched):
    """Accumulate ``As += A s`` for a step ``s`` on ``nodes``, list the nodes reached, and
    return the slope ``r.s`` and curvature ``s.A.s`` of the step.

    Uses the symmetry of A (column ``j`` is row ``j``), so only the rows of the step's
    support are read. (The reductions are done here rather than with ``numpy.dot``:
    BLAS would wake its worker threads for vectors of this size, which costs
    milliseconds on a busy machine, and would make the sums thread-count dependent.)

    Parameters
    ----------
    indptr, indices, data : CSR arrays of A
    nodes : int64 array, shape (m,)
        Distinct nodes carrying the step.
    s : float64 array, shape (m,)
        The step on those nodes (zeros are skipped).
    r : float64 array, shape (n,)
        Residual ``A a - b`` at the current iterate.
    As : float64 array, shape (n,)
        Accumulator, zero on the nodes not yet reached.
    marked : bool array, shape (n,)
        All False on entry and on exit.
    touched : int64 array, shape (n,)
        Receives, in its first entries, the nodes where ``A s`` is structurally nonzero.

    Returns
    -------
    count : int
        Number of entries written to ``touched``.
    slope, curvature : float
        ``r.s`` and ``s.A.s``.
    """
    count = 0
    for k in range(nodes.size):
        if s[k] == 0.0:
            continue
        j = nodes[k]
        for p in range(indptr[j], indptr[j + 1]):
            i = indices[p]
            As[i] += data[p] * s[k]
            if not marked[i]:
                marked[i] = True
                touched[count] = i
                count += 1
    for k in range(count):
        marked[touched[k]] = False
    slope = 0.0
    curvature = 0.0
    for k in range(nodes.size):
        slope += s[k] * r[nodes[k]]
        curvature += s[k] * As[nodes[k]]
    return count, slope, curvature


@numba.njit(cache=True)
def energy_from_residual(a, r, b):
    """``1/2 a.A.a - b.a = 1/2 (a.r - a.b)`` with ``r = A a - b`` (serial sums, see
    :func:`scatter_product`)."""
    ar = 0.0
    ab = 0.0
    for i in range(a.size):
        ar += a[i] * r[i]
        ab += a[i] * b[i]
    return 0.5 * (ar - ab)


@numba.njit(cache=True)
def any_on_bound(nodes, a, lower, upper):
    """Whether some listed node sits on one of its bounds."""
    for i in nodes:
        if a[i] == lower[i] or a[i] == upper[i]:
            return True
    return False


@numba.njit(cache=True)
def residual_rows(indptr, indices, data, a, b, rows, r):
    """``r[i] = (A a - b)[i]`` from scratch for the nodes ``i`` listed in ``rows``."""
    for i in rows:
        acc = 0.0
        for p in range(indptr[i], indptr[i + 1]):
            acc += data[p] * a[indices[p]]
        r[i] = acc - b[i]


@numba.njit(cache=True)
def split_step_nodes(status):
    """Free nodes and moving nodes (predicted on a bound, not there yet), both
    increasing int64 arrays. Reads only the int8 status: the cheapest O(n) scan."""
    n_free = 0
    n_moving = 0
    for i in range(status.size):
        if status[i] == FREE:
            n_free += 1
        elif status[i] >= TO_LOWER:
            n_moving += 1
    free = np.empty(n_free, dtype=np.int64)
    moving = np.empty(n_moving, dtype=np.int64)
    n_free = 0
    n_moving = 0
    for i in range(status.size):
        if status[i] == FREE:
            free[n_free] = i
            n_free += 1
        elif status[i] >= TO_LOWER:
            moving[n_moving] = i
            n_moving += 1
    return free, moving


@numba.njit(cache=True)
def prepare(b, lower, upper, a0, diag, a, dinv):
    """Check the inputs and project the initial guess, in one pass over the nodes.

    Writes ``a = min(max(a0, lower), upper)`` and ``dinv = 1 / diag``.

    Returns
    -------
    problem : int
        0 if all is well; else the first failed check: 1-4 a non-finite entry of
        ``b``, ``lower``, ``upper``, ``a0``; 5 ``lower > upper``; 6 ``diag <= 0``.
    index : int
        The node where it failed.
    n_projected : int
        Entries of ``a0`` moved onto a bound.
    """
    n_projected = 0
    for i in range(b.size):
        if not np.isfinite(b[i]):
            return 1, i, 0
        lo, hi, guess = lower[i], upper[i], a0[i]
        if not np.isfinite(lo):
            return 2, i, 0
        if not np.isfinite(hi):
            return 3, i, 0
        if not np.isfinite(guess):
            return 4, i, 0
        if lo > hi:
            return 5, i, 0
        if not diag[i] > 0.0:
            return 6, i, 0
        dinv[i] = 1.0 / diag[i]
        if guess < lo:
            a[i] = lo
            n_projected += 1
        elif guess > hi:
            a[i] = hi
            n_projected += 1
        else:
            a[i] = guess
    return 0, 0, n_projected


@numba.njit(cache=True)
def count_classes(a, lower, upper):
    """``(n_free, n_lower, n_upper, n_fixed)`` of a feasible point (see BoxQPResult)."""
    n_free = n_lower = n_upper = n_fixed = 0
    for i in range(a.size):
        if lower[i] == upper[i]:
            n_fixed += 1
        elif a[i] == lower[i]:
            n_lower += 1
        elif a[i] == upper[i]:
            n_upper += 1
        else:
            n_free += 1
    return n_free, n_lower, n_upper, n_fixed


@numba.njit(cache=True)
def pcg_jacobi(indptr, indices, data, rhs, dinv, tol, max_iter, x):
    """Jacobi-preconditioned CG for the SPD CSR system ``M x = rhs``, from ``x = 0``.

    Stops when ``max_i |rhs - M x|_i / M_ii <= tol``: the measure of the outer KKT test
    (and the infinity norm of the preconditioned residual, available for free).

    Returns
    -------
    iterations : int
        >= 0 on convergence; ``-k`` if not converged after ``k`` iterations.
    residual : float
        Final scaled residual; -1.0 on a breakdown (``p.Mp <= 0``: M is not SPD).
    """
    n = rhs.size
    res = rhs.copy()
    zr = res * dinv
    p = zr.copy()
    q = np.empty(n)
    rz = 0.0
    err = 0.0
    for i in range(n):
        rz += res[i] * zr[i]
        err = max(err, abs(zr[i]))
    if err <= tol:
        return 0, err
    for k in range(1, max_iter + 1):
        pq = 0.0
        for i in range(n):
            acc = 0.0
            for j in range(indptr[i], indptr[i + 1]):
                acc += data[j] * p[indices[j]]
            q[i] = acc
            pq += p[i] * acc
        if not pq > 0.0:
            return -k, -1.0
        step = rz / pq
        rz_new = 0.0
        err = 0.0
        for i in range(n):
            x[i] += step * p[i]
            res[i] -= step * q[i]
            zr[i] = res[i] * dinv[i]
            rz_new += res[i] * zr[i]
            err = max(err, abs(zr[i]))
        if err <= tol:
            return k, err
        beta = rz_new / rz
        rz = rz_new
        for i in range(n):
            p[i] = zr[i] + beta * p[i]
    return -max_iter, err
