"""Numba kernels of the dynamic-programming global minimizer (dissertation Algorithm 2.1).

A fragment of ``m`` grid cells of size ``h`` is cut at grid nodes. With
``coef[k] = k h + F(k h)`` (so that an uncut piece of ``k`` cells stores ``t^2/2 coef[k]``),
the minimal energy ``best[k]`` over all partitions of the first ``k`` cells obeys

    best[k] = min( t^2/2 coef[k],  min_{0<j<k} best[j] + G/a + t^2/2 coef[k - j] ),

because the energy (2.32) is additive over fragments and translation invariant: the last
fragment ``(j, k)`` costs its own energy plus one crack. One pass gives ``best[k]`` for every
``k <= m`` in O(m^2) operations.

Kernels take arrays and scalars only; :mod:`onedim.reference` holds the plain NumPy versions.
"""

import numpy as np
from numba import njit


@njit(cache=True)
def best_partition_energies(coef, t, toughness):
    """Minimal energies over partitions of the first k cells, for every k (Algorithm 2.1).

    Parameters
    ----------
    coef : ndarray of float64, shape (m + 1,)
        ``coef[k] = k h + F(k h)``; ``coef[0]`` is unused.
    t : float
        Load.
    toughness : float
        Cost ``G/a`` of one crack.

    Returns
    -------
    best : ndarray of float64, shape (m + 1,)
        ``best[k]`` = minimal energy of a film of ``k`` cells (``best[0] = 0``).
    """
    m = coef.shape[0] - 1
    half_t2 = 0.5 * t * t
    # piece_rev[m - i] = G + t^2/2 coef[i]: stored reversed so that the inner loop reads
    # both arrays forward and contiguously.
    piece_rev = np.empty(m + 1)
    for i in range(m + 1):
        piece_rev[m - i] = toughness + half_t2 * coef[i]
    best = np.empty(m + 1)
    best[0] = 0.0
    for k in range(1, m + 1):
        b = half_t2 * coef[k]
        offset = m - k
        for j in range(1, k):
            b = min(b, best[j] + piece_rev[offset + j])
        best[k] = b
    return best


@njit(cache=True)
def optimal_cuts(coef, t, toughness):
    """Cut indices of the optimal partition of the ``m`` cells at load ``t``.

    Parameters
    ----------
    coef : ndarray of float64, shape (m + 1,)
    t, toughness : float

    Returns
    -------
    ndarray of int64, shape (number of cracks,)
        Sorted node indices ``1..m-1`` where the optimal partition cuts (empty if uncut).
    """
    best = best_partition_energies(coef, t, toughness)
    half_t2 = 0.5 * t * t
    cuts = np.empty(coef.shape[0], dtype=np.int64)
    n = 0
    k = coef.shape[0] - 1
    # Walk back from the right end: the optimal partition of (0, k) ends with the fragment
    # (j, k) that attains best[k]; stop where the uncut piece is optimal.
    while best[k] < half_t2 * coef[k]:
        jbest = 0
        vbest = np.inf
        for j in range(1, k):
            v = best[j] + (toughness + half_t2 * coef[k - j])
            if v < vbest:
                vbest = v
                jbest = j
        cuts[n] = jbest
        n += 1
        k = jbest
    return cuts[:n][::-1].copy()


@njit(cache=True)
def locate_nucleation(coef, t_lo, t_hi, toughness, rtol):
    """Bracket the first load in ``[t_lo, t_hi]`` where the uncut fragment stops being optimal.

    The predicate "some partition beats the uncut fragment" is monotone in ``t`` (cracks
    only release elastic energy, whose weight ``t^2/2`` grows), so bisection applies.

    Parameters
    ----------
    coef : ndarray of float64, shape (m + 1,)
    t_lo, t_hi : float
        Search interval.
    toughness : float
    rtol : float
        Relative width of the final bracket.

    Returns
    -------
    t_cracked : float
        Upper end of the final bracket (``t_lo`` if already cracked there, ``inf`` if
        uncut up to ``t_hi``).
    cuts : ndarray of int64
        Optimal cut indices at ``t_cracked`` (empty if none).
    """
    m = coef.shape[0] - 1
    if best_partition_energies(coef, t_hi, toughness)[m] >= 0.5 * t_hi * t_hi * coef[m]:
        return np.inf, np.empty(0, dtype=np.int64)
    lo, hi = t_lo, t_hi
    if best_partition_energies(coef, lo, toughness)[m] < 0.5 * lo * lo * coef[m]:
        hi = lo
    while hi - lo > rtol * hi:
        mid = 0.5 * (lo + hi)
        if best_partition_energies(coef, mid, toughness)[m] < 0.5 * mid * mid * coef[m]:
            hi = mid
        else:
            lo = mid
    return hi, optimal_cuts(coef, hi, toughness)
