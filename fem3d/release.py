"""The energy release rate of a computed evolution, from its recorded steps.

Under a prescribed displacement ``t`` the bulk energy at a fixed crack is quadratic in t,
``B = c(A) t^2``, so ``dB/dt`` at fixed crack area ``A`` is ``2 B / t``, and along the
evolution ``dB = -G dA + (2 B / t) dt``. Hence (docs/model.md#energy-release-rate)

    G = (2 (B / t) dt - dB) / dA,

the dissertation's (4.17) with its sign corrected (the printed form is the negative). The
crack area is read from the surface energy, ``A = S / Gc``, and the crack length is
``a = A / T + a0`` (4.18), with ``T`` the thickness and ``a0`` the starter notch's length.

With this ``A``, an evolution that keeps the energy balance ``d(B + S) = (2 B / t) dt`` has
``G = dS / dA = Gc`` exactly: the computed G is a check of the energy balance of the
discrete evolution during crack growth. While the front does not move, dA is round-off and
G is meaningless: it is reported only over load intervals in which ``a`` grew by at least
``da_min`` (one mesh size in the crack's path), and NaN elsewhere.
"""

from __future__ import annotations

import numpy as np

__all__ = ["energy_release_rate"]


def energy_release_rate(t, elastic, surface, Gc, thickness, a0=0.0, da_min=0.0, jump=np.inf, carried=0.0,
                        meshes=None, previous=None):
    """G and the crack length at each recorded step.

    Parameters
    ----------
    t : array_like, shape (n,)
        The loads of the steps (a prescribed displacement), increasing, ``t[0] >= 0``.
    elastic, surface : array_like, shape (n,)
        Bulk (elastic) and surface energy of each step (energy units).
    Gc : float
        Toughness (energy per area).
    thickness : float
        ``T``: the crack area over T is a length.
    a0 : float
        Starter-notch length added to ``A / T``.
    da_min : float
        Least growth of ``a`` over which G is computed: step k's G is the finite difference
        between step k and the latest earlier step j with ``a_k - a_j >= da_min`` (and
        ``t_j > 0``); NaN if there is none, or if ``a`` did not grow at step k.
    jump : float
        A growth of ``a`` in one step larger than this is a jump (a brutal crack advance):
        its own step's G is that of the jump, but no later step is differenced back across
        it (after the jump, ``j`` is the jump's step or later).
    carried : float
        Fraction of the peak elastic energy so far below which the specimen no longer carries
        the load (cut through): G is NaN there, since ``a`` then grows only by the broken
        band widening.
    meshes : array_like of int, shape (n,), optional
        The version of each step's mesh (an adaptive run, docs/adaptivity.md#the-energy-release-rate):
        G is differenced only between steps on the same mesh, since a refinement changes the
        bulk energy at a fixed crack (NaN otherwise), or across a refinement with ``previous``.
    previous : tuple of array_like, shape (n,), optional
        ``(elastic, surface)``: at a step whose mesh differs from the step before, the
        energies of that earlier step's damage at its load solved on the step's own mesh
        (:attr:`thinfilm.engine.records.StepRecord.elastic_previous`; NaN where not
        computed). Such a step's G is then differenced from them, over that one step.

    Returns
    -------
    G : ndarray, shape (n,)
        Energy release rate (energy per area), NaN where the front did not move.
    a : ndarray, shape (n,)
        Crack length ``S / (Gc T) + a0``.
    """
    t = np.asarray(t, dtype=float)
    B = np.asarray(elastic, dtype=float)
    a = np.asarray(surface, dtype=float) / (Gc * thickness) + a0
    A = (a - a0) * thickness
    G = np.full(t.shape, np.nan)
    if meshes is not None:
        meshes = np.asarray(meshes)
    B_previous, S_previous = (np.full(t.shape, np.nan),) * 2 if previous is None else \
        (np.asarray(values, dtype=float) for values in previous)
    peak = np.maximum.accumulate(B) if len(B) else B
    jumps = np.flatnonzero(np.diff(a) > jump) + 1      # steps that end a jump
    for k in range(1, len(t)):
        if not a[k] > a[k - 1] or t[k] <= 0 or B[k] < carried * peak[k]:
            continue
        before = jumps[jumps < k]
        first = before[-1] if before.size else 0          # not across an earlier jump
        if meshes is not None and meshes[k] != meshes[k - 1]:
            # refined at step k: only step k - 1, as re-solved on step k's mesh
            if k - 1 < first or t[k - 1] <= 0:
                continue
            B_j = B_previous[k]
            A_j = S_previous[k] / Gc
            t_j = t[k - 1]
            if not (np.isfinite(B_j) and np.isfinite(A_j)) or not A[k] - A_j >= max(da_min, 0.0) * thickness:
                continue
        else:
            same = np.ones(k, dtype=bool) if meshes is None else meshes[:k] == meshes[k]
            grown = np.flatnonzero((a[k] - a[:k] >= max(da_min, 0.0)) & (t[:k] > 0) & (a[:k] < a[k])
                                   & (np.arange(k) >= first) & same)
            if len(grown) == 0:
                continue
            j = grown[-1]
            B_j, A_j, t_j = B[j], A[j], t[j]
        # B / t at the interval's middle (the mean of its ends): second order in the step
        b_over_t = 0.5 * (B_j / t_j + B[k] / t[k])
        G[k] = (2.0 * b_over_t * (t[k] - t_j) - (B[k] - B_j)) / (A[k] - A_j)
    return G, a
