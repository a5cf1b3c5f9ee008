"""Reading cracks off a damage field.

A crack of the regularized model is a band where ``alpha`` rises to 1; its position along a
line is the local maximum of ``alpha`` (the middle of a plateau of equal values), and the
cracks that leave a point cross a circle about it as arcs of high damage.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

#: Damage above which a local maximum counts as a crack.
CRACK_THRESHOLD = 0.9


def crack_positions(x, alpha, threshold=CRACK_THRESHOLD):
    """Positions of the cracks along a line: local maxima of ``alpha`` above ``threshold``.

    Parameters
    ----------
    x : ndarray, shape (n,)
        Increasing node coordinates along the line.
    alpha : ndarray, shape (n,)
        Damage at those nodes.
    threshold : float, optional

    Returns
    -------
    ndarray
        Sorted crack positions; a plateau of equal maximal values gives its middle, and a
        maximum at an end of the line counts (padding makes the ends interior).
    """
    x = np.asarray(x, dtype=float)
    padded = np.concatenate(([-np.inf], np.asarray(alpha, dtype=float), [-np.inf]))
    peaks, props = find_peaks(padded, height=threshold, plateau_size=1)
    left = props["left_edges"] - 1
    right = props["right_edges"] - 1
    return 0.5 * (x[left] + x[right])


def centre_line(grid, field):
    """The values of a nodal field along ``y = 0`` (the row nearest to it in 2D).

    Parameters
    ----------
    grid : thinfilm.grid.Grid
    field : ndarray, shape (n_nodes,)

    Returns
    -------
    x, values : ndarray, shape (nx + 1,)
    """
    if grid.dim == 1:
        return np.asarray(grid.x), np.asarray(field)
    j = int(np.argmin(np.abs(np.asarray(grid.y))))
    return np.asarray(grid.x), np.asarray(field).reshape(grid.shape)[j]


def arms(alpha, x, y, radius, centre=(0.0, 0.0), threshold=CRACK_THRESHOLD, samples=720):
    """Directions of the cracks that cut a circle: the centres of its arcs where
    ``alpha >= threshold``.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
        Node coordinates.
    radius : float
        Radius of the circle (units of L); it must lie inside the grid.
    centre : (float, float), optional
        Its centre ``(x, y)``.
    threshold : float, optional
    samples : int, optional
        Points on the circle (bilinear interpolation of ``alpha``).

    Returns
    -------
    ndarray
        Directions in degrees in [0, 360), counter-clockwise from the x axis, in the order
        met from the first intact point; empty if the circle is all intact or all broken.
    """
    from scipy.interpolate import RegularGridInterpolator

    theta = np.linspace(0.0, 2 * np.pi, samples, endpoint=False)
    points = np.c_[centre[1] + radius * np.sin(theta), centre[0] + radius * np.cos(theta)]
    ring = RegularGridInterpolator((np.asarray(y), np.asarray(x)), np.asarray(alpha))(points)
    broken = ring >= threshold
    if broken.all() or not broken.any():
        return np.array([])
    start = np.argmin(broken)  # an intact point: arcs do not wrap past it
    broken, theta = np.roll(broken, -start), np.roll(theta, -start)
    edges = np.flatnonzero(np.diff(np.r_[broken, False].astype(int)))
    return np.degrees([np.angle(np.exp(1j * theta[a + 1:b + 1]).mean()) % (2 * np.pi)
                       for a, b in zip(edges[::2], edges[1::2])])
