"""Reading cracks off a damage field.

A crack of the regularized model is a band where ``alpha`` rises to 1; its position along a
line is the local maximum of ``alpha`` (the middle of a plateau of equal values).
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
