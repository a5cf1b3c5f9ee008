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
    grid : thinfilm.plate.grid.Grid
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


def branch_points(alpha, x, y, radius, within=None, threshold=CRACK_THRESHOLD):
    """Points where cracks branch or cross: the clusters of broken nodes about which three or
    more cracks cut a circle of radius ``radius``.

    About a node on a single crack the circle is cut twice (or once at a tip); about a node
    within ``radius`` of a junction it is cut by every crack that leaves the junction. Such
    nodes form one cluster per junction, about ``radius`` across, so two junctions closer than
    about ``2 radius`` read as one, with all their arms (two Y junctions a short way apart read
    as a cross).

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
        Node coordinates.
    radius : float
        Radius of the circles (units of L): larger than the width of a crack's broken core
        and of the blob of damage at a junction, smaller than the junctions' spacing to be
        resolved. Circles must lie inside the grid.
    within : ndarray of bool, shape (ny + 1, nx + 1), optional
        The nodes to look at (default: all nodes at least ``radius`` from the grid's edge).
    threshold : float, optional
        Damage from which a node is broken.

    Returns
    -------
    list of (float, float, int)
        ``(x, y, arms)`` per junction: the mean position of its cluster and the largest number
        of cracks that cut a circle about one of its nodes, sorted by distance from the origin.
    """
    from scipy import ndimage

    x, y, alpha = np.asarray(x), np.asarray(y), np.asarray(alpha)
    X, Y = np.meshgrid(x, y)
    inside = ((X - x[0] >= radius) & (x[-1] - X >= radius) & (Y - y[0] >= radius) & (y[-1] - Y >= radius))
    candidates = (alpha >= threshold) & inside & (within if within is not None else True)
    count = np.zeros(alpha.shape, dtype=int)
    for j, i in zip(*np.nonzero(candidates)):
        count[j, i] = len(arms(alpha, x, y, radius, centre=(x[i], y[j]), threshold=threshold, samples=240))
    labels, n = ndimage.label(count >= 3, structure=np.ones((3, 3)))
    found = []
    for k in range(1, n + 1):
        member = labels == k
        found.append((float(X[member].mean()), float(Y[member].mean()), int(count[member].max())))
    return sorted(found, key=lambda p: np.hypot(p[0], p[1]))


def branch_spacing(points):
    """The largest distance between two branch points (units of L): how far apart the branch
    points of one crack pattern lie, 0 for fewer than two.

    Parameters
    ----------
    points : list of (float, float, int)
        Branch points as :func:`branch_points` returns them.
    """
    return max((float(np.hypot(a[0] - b[0], a[1] - b[1])) for a in points for b in points), default=0.0)
