"""Plain NumPy versions of the kernels in :mod:`onedim.dynprog`.

They define what the kernels must compute (tests compare the two) and serve as the baseline
the benchmark measures the kernels against. Same signatures, same algorithm.
"""

import numpy as np


def best_partition_energies(coef, t, toughness):
    """NumPy reference of :func:`onedim.dynprog.best_partition_energies`."""
    m = coef.shape[0] - 1
    half_t2 = 0.5 * t * t
    piece = toughness + half_t2 * coef
    best = np.empty(m + 1)
    best[0] = 0.0
    for k in range(1, m + 1):
        b = half_t2 * coef[k]
        if k > 1:
            b = min(b, np.min(best[1:k] + piece[k - 1 : 0 : -1]))
        best[k] = b
    return best


def optimal_cuts(coef, t, toughness):
    """NumPy reference of :func:`onedim.dynprog.optimal_cuts`."""
    best = best_partition_energies(coef, t, toughness)
    half_t2 = 0.5 * t * t
    cuts = []
    k = coef.shape[0] - 1
    while best[k] < half_t2 * coef[k]:
        values = best[1:k] + (toughness + half_t2 * coef[k - 1 : 0 : -1])
        k = int(np.argmin(values)) + 1
        cuts.append(k)
    return np.array(cuts[::-1], dtype=np.int64)


def locate_nucleation(coef, t_lo, t_hi, toughness, rtol):
    """NumPy reference of :func:`onedim.dynprog.locate_nucleation`."""
    m = coef.shape[0] - 1

    def cracked(t):
        return best_partition_energies(coef, t, toughness)[m] < 0.5 * t * t * coef[m]

    if not cracked(t_hi):
        return np.inf, np.empty(0, dtype=np.int64)
    lo, hi = t_lo, t_hi
    if cracked(lo):
        hi = lo
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if cracked(mid):
            hi = mid
        else:
            lo = mid
    return hi, optimal_cuts(coef, hi, toughness)
