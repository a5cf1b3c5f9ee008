"""Quadrature rules on the reference simplex, in barycentric coordinates.

A rule is ``(bary, weights)``: points of shape (n_points, d + 1) and weights summing to 1
(fractions of the cell's measure: multiply by it).
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from scipy.special import roots_jacobi

__all__ = ["centroid", "collapsed_gauss"]


@lru_cache(maxsize=None)
def centroid(dim: int):
    """The one-point rule at the centroid (exact for polynomials of degree 1).

    Returns
    -------
    bary : ndarray, shape (1, dim + 1)
    weights : ndarray, shape (1,)
    """
    bary, weights = np.full((1, dim + 1), 1.0 / (dim + 1)), np.ones(1)
    bary.flags.writeable = weights.flags.writeable = False
    return bary, weights


@lru_cache(maxsize=None)
def collapsed_gauss(dim: int, n: int):
    """A conical-product Gauss rule on the reference simplex, exact for polynomials of degree
    ``2 n - 1``: ``n^dim`` points with positive weights (Gauss-Jacobi in the collapsed
    directions, Stroud's construction).

    Returns
    -------
    bary : ndarray, shape (n^dim, dim + 1)
        Barycentric coordinates of the points.
    weights : ndarray, shape (n^dim,)
        Summing to 1 (fractions of the cell's measure).
    """
    if dim not in (2, 3) or n < 1:
        raise ValueError(f"dim = {dim!r} must be 2 or 3 and n = {n!r} >= 1")
    # Int_0^1 (1 - s)^k f(s) ds by Gauss-Jacobi on [-1, 1] with weight (1 - x)^k, s = (1 + x)/2
    rules = []
    for k in range(dim - 1, -1, -1):
        x, w = roots_jacobi(n, k, 0.0)
        rules.append(((1.0 + x) / 2.0, w / 2.0 ** (k + 1)))
    grids = np.meshgrid(*[r[0] for r in rules], indexing="ij")
    weights = np.ones_like(grids[0])
    for axis, (_, w) in enumerate(rules):
        shape = [1] * dim
        shape[axis] = n
        weights = weights * w.reshape(shape)
    s = [g.ravel() for g in grids]
    # x_1 = s_1, x_2 = s_2 (1 - s_1), x_3 = s_3 (1 - s_1)(1 - s_2): Jacobian (1 - s_1)^(d-1) (1 - s_2)^(d-2)
    coords, rest = [], np.ones_like(s[0])
    for k in range(dim):
        coords.append(s[k] * rest)
        rest = rest * (1.0 - s[k])
    x = np.column_stack(coords)
    bary = np.column_stack([1.0 - x.sum(axis=1), x])
    weights = weights.ravel() * math.factorial(dim)
    bary.flags.writeable = weights.flags.writeable = False
    return bary, weights
