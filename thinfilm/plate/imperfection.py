"""Imperfect films: a random toughness field.

A real coating is not uniform: its toughness varies from place to place. A scene may give
the film a log-normal toughness field ::

    G(x) = G * exp(s xi(x))

with ``G`` the scene's ``toughness`` (the median), ``s`` its relative scatter
(``toughness_noise``) and ``xi`` a stationary Gaussian field of zero mean, unit variance and
covariance ``exp(-r^2 / (2 l^2))`` (``l`` = ``toughness_noise_length``). The log-normal form
keeps ``G > 0`` for any ``s``; for small ``s`` it is ``G (1 + s xi)``.

Besides modelling flaws, the field breaks the symmetries that a perfect scene and its
symmetric solution share: alternate minimization started from a symmetric state stays on
it (to round-off) even where a less symmetric state is lower.

The field is drawn on the nodes: white noise, smoothed by a Gaussian filter of standard
deviation ``l / sqrt(2)`` (the convolution of two such kernels gives the covariance above),
then scaled to zero mean and unit variance over the grid. ``l = 0`` gives independent
nodes. It is reproducible from its seed (numpy's PCG64 generator).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

from thinfilm.plate.grid import Grid

__all__ = ["gaussian_field", "toughness_factor"]


def gaussian_field(grid: Grid, length: float, seed: int, symmetry=None) -> np.ndarray:
    """A Gaussian random field on the nodes with zero mean and unit variance over the grid.

    Parameters
    ----------
    grid : Grid
    length : float
        Correlation length ``l`` (units of L), >= 0: the covariance of nodes a distance
        ``r`` apart is ``exp(-r^2 / (2 l^2))`` (away from the edges, for ``l`` well above
        the grid spacing and below the domain size). 0: independent nodes.
    seed : int
        Seed of the generator.
    symmetry : thinfilm.plate.symmetry.GridSymmetry, optional
        If given, the field is averaged over the group's images before it is scaled, so it
        is invariant (the symmetric fields of a restricted run must see a symmetric film).

    Returns
    -------
    ndarray, shape (n_nodes,)
        Flat nodal field (:mod:`thinfilm.plate.grid` order); empirical mean 0, variance 1.
    """
    if not (isinstance(length, (int, float)) and math.isfinite(length) and length >= 0):
        raise ValueError(f"length = {length!r} must be a finite number >= 0")
    rng = np.random.default_rng(seed)
    noise = rng.standard_normal(grid.shape)
    if length > 0:
        spacing = (grid.hx,) if grid.dim == 1 else (grid.hy, grid.hx)   # [j, i] order
        sigma = tuple(length / math.sqrt(2.0) / h for h in spacing)
        # Reflecting edges: no wrap-around correlation between opposite edges.
        noise = ndimage.gaussian_filter(noise, sigma=sigma, mode="reflect", truncate=4.0)
    xi = noise.ravel()
    if symmetry is not None:
        xi = symmetry.average(xi)
    std = float(np.std(xi))
    if std == 0.0:
        raise ValueError("the random field is constant on this grid (a correlation length far above the domain?)")
    return (xi - xi.mean()) / std


def toughness_factor(grid: Grid, noise: float, length: float, seed: int, symmetry=None) -> np.ndarray | None:
    """The factor ``exp(s xi)`` by which the toughness varies over the film.

    Parameters
    ----------
    grid : Grid
    noise : float
        Relative scatter ``s`` >= 0 (standard deviation of ``log G``). 0: a uniform film.
    length, seed, symmetry
        As in :func:`gaussian_field`.

    Returns
    -------
    ndarray, shape (n_nodes,), or None
        Positive factors, median about 1; None for ``noise = 0`` (uniform toughness).
    """
    if not (math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise = {noise!r} must be a finite number >= 0")
    if noise == 0:
        return None
    return np.exp(noise * gaussian_field(grid, length, seed, symmetry))
