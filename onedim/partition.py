"""Energy of a partition of the film into fragments (Proposition 1, eq. 2.32).

A film ``(a, b)`` cut at the points ``c_1 < ... < c_m`` into fragments of lengths
``l_0, ..., l_m`` has, at load ``t``, the minimal total energy

    E*_t = t^2/2 (b - a + sum_j F(l_j)) + m G/a,

since each fragment relaxes independently. For a fixed number of cracks the optimal cut
points minimize ``sum_j F(l_j)`` whatever the load, and the load at which that partition
beats the uncut film is ``t^2 = 2 m (G/a) / (F(b - a) - sum_j F(l_j))``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_banded

from onedim.fragment import (
    fragment_coefficient,
    fragment_energy_derivative_F,
    scaling_F,
    scaling_F_second_derivative,
)


def fragment_lengths(cracks, a, b):
    """Lengths of the fragments of ``(a, b)`` cut at ``cracks``.

    Parameters
    ----------
    cracks : array_like, shape (m,)
        Crack positions inside ``(a, b)``, any order.
    a, b : float
        Ends of the film.

    Returns
    -------
    ndarray, shape (m + 1,)
    """
    points = np.concatenate(([a], np.sort(np.asarray(cracks, dtype=float)), [b]))
    return np.diff(points)


def partition_elastic_coefficient(cracks, a, b, lam):
    """``sum_j (l_j + F(l_j))``: twice the elastic energy of the partition at ``t = 1``."""
    return float(np.sum(fragment_coefficient(fragment_lengths(cracks, a, b), lam)))


def partition_energy(cracks, a, b, lam, toughness, t):
    """Total energy (2.32) of the film ``(a, b)`` cut at ``cracks``, at load ``t``.

    Parameters
    ----------
    cracks : array_like, shape (m,)
        Crack positions in ``(a, b)``.
    a, b : float
        Ends of the film (units of L).
    lam : float
        Internal length scale.
    toughness : float
        ``G/a``, the cost of one crack.
    t : float or array_like
        Load(s).

    Returns
    -------
    elastic, surface, total : float or ndarray
        Energies per unit width; ``surface = m G/a``.
    """
    t = np.asarray(t, dtype=float)
    elastic = 0.5 * t**2 * partition_elastic_coefficient(cracks, a, b, lam)
    surface = len(np.atleast_1d(cracks)) * toughness
    return elastic, surface, elastic + surface


def nucleation_load(cracks, a, b, lam, toughness):
    """Load at which the partition of ``(a, b)`` by ``cracks`` ties with the uncut film.

    ``t^2 = 2 m (G/a) / (F(b - a) - sum_j F(l_j))``; ``inf`` if the cuts release no energy.
    """
    m = len(cracks)
    released = float(scaling_F(b - a, lam) - np.sum(scaling_F(fragment_lengths(cracks, a, b), lam)))
    if m == 0 or released <= 0.0:
        return math.inf
    return math.sqrt(2.0 * m * toughness / released)


def refine_cracks(cracks, a, b, lam, h, max_iter=50):
    """Move the cut points of ``(a, b)`` off the grid to a local minimum of ``sum_j F(l_j)``.

    The energy (2.32) of a fixed number of cracks depends on the load only through the
    factor ``t^2``, so the optimal positions are load-independent. Starting from the grid
    optimum, each cut may move by at most one cell ``h`` (a local refinement: the grid has
    already chosen the basin). Newton's method on the exact gradient
    ``d/dc_i = F'(l_{i-1}) - F'(l_i)`` and tridiagonal Hessian, with a backtracking line
    search that never increases the objective (F is not convex, so a gradient step replaces
    a Newton step that does not descend).

    Parameters
    ----------
    cracks : array_like, shape (m,)
        Sorted cut points found on the grid.
    a, b : float
        Ends of the fragment that is being cut.
    lam : float
        Internal length scale.
    h : float
        Grid cell size.
    max_iter : int, optional
        Newton iterations at most.

    Returns
    -------
    ndarray, shape (m,)
        Refined, sorted cut points.
    """
    c0 = np.sort(np.asarray(cracks, dtype=float))
    if c0.size == 0:
        return c0
    lower = np.maximum(c0 - h, a + 1e-3 * h)
    upper = np.minimum(c0 + h, b - 1e-3 * h)

    def objective(c):
        return float(np.sum(scaling_F(fragment_lengths(c, a, b), lam)))

    c, phi = c0.copy(), objective(c0)
    for _ in range(max_iter):
        lengths = fragment_lengths(c, a, b)
        d1 = fragment_energy_derivative_F(lengths, lam)
        d2 = scaling_F_second_derivative(lengths, lam)
        gradient = d1[:-1] - d1[1:]
        # Tridiagonal Hessian in banded storage: H_ii = F''(l_{i-1}) + F''(l_i),
        # H_i,i+1 = -F''(l_i).
        bands = np.zeros((3, c.size))
        bands[0, 1:] = -d2[1:-1]
        bands[1] = d2[:-1] + d2[1:]
        bands[2, :-1] = -d2[1:-1]
        try:
            step = -solve_banded((1, 1), bands, gradient)
        except np.linalg.LinAlgError:
            step = -gradient
        if not np.all(np.isfinite(step)) or step @ gradient >= 0.0:
            step = -gradient * h / max(np.max(np.abs(gradient)), 1e-300)  # not convex here: descend
        # Backtrack: stay in the box and never increase the objective.
        for _ in range(60):
            trial = np.clip(c + step, lower, upper)
            phi_trial = objective(trial)
            if phi_trial <= phi:
                break
            step *= 0.5
        else:
            break
        moved = np.max(np.abs(trial - c))
        c, phi = trial, phi_trial
        if moved <= 1e-15 * (b - a):
            break
    return np.sort(c)
