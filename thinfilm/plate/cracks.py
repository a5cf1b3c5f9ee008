"""Reading cracks off a damage field.

A crack of the regularized model is a band where ``alpha`` rises to 1; its position along a
line is the local maximum of ``alpha`` (the middle of a plateau of equal values), and the
cracks that leave a point cross a circle about it as arcs of high damage. On a 2D grid the
broken nodes (``alpha >= 0.9``) fall into separate cracks (their 8-connected components) and
cut the film into fragments (the 4-connected components of the rest: the complement of an
8-connected line must be taken 4-connected, or a diagonal crack would not separate its two
sides). About a centre, circular cracks are the radii where ``alpha`` averaged over the
circle peaks, and radial cracks cut the circles between them.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

#: Damage above which a local maximum counts as a crack.
CRACK_THRESHOLD = 0.9

#: Damage below which a node is sound: a fragment holds at least one sound node, a pocket of
#: damaged film between two cracks closer than about ``eta`` (``alpha`` stays above 1/2
#: between their AT1 profiles) does not.
SOUND_THRESHOLD = 0.5

#: 8-connectivity (the cracks) and 4-connectivity (the fragments) for scipy.ndimage.label.
_EIGHT = np.ones((3, 3), dtype=bool)
_FOUR = np.array([[0, 1, 0], [1, 1, 1], [0, 1, 0]], dtype=bool)


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


def count_cracks(alpha, threshold=CRACK_THRESHOLD):
    """The number of separate cracks: the 8-connected components of the nodes with
    ``alpha >= threshold``.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a 2D grid (``[j, i]`` order).
    threshold : float, optional

    Returns
    -------
    int
        Crossing or branching cracks are one; so are two bands close enough for their broken
        cores to touch.
    """
    from scipy import ndimage

    return int(ndimage.label(np.asarray(alpha) >= threshold, structure=_EIGHT)[1])


def count_fragments(alpha, threshold=CRACK_THRESHOLD, sound=SOUND_THRESHOLD):
    """The pieces the cracks cut the film into: the 4-connected components of the nodes with
    ``alpha < threshold``, and how many of them hold a sound node.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a 2D grid (``[j, i]`` order).
    threshold : float, optional
    sound : float, optional
        Damage below which a node is sound.

    Returns
    -------
    fragments : int
        All components (1 for an intact film, 0 for a film broken everywhere).
    intact : int
        Those with a node of ``alpha < sound``; the others are pockets of damaged film
        enclosed in a wide broken band, often a node or a few.
    """
    from scipy import ndimage

    alpha = np.asarray(alpha)
    labels, n = ndimage.label(alpha < threshold, structure=_FOUR)
    return int(n), int(np.unique(labels[(alpha < sound) & (labels > 0)]).size)


def inscribed_radius(x, y, centre=(0.0, 0.0)):
    """The radius of the largest circle about ``centre`` inside the grid (units of L; 0 if
    the centre is outside)."""
    return max(0.0, float(min(centre[0] - x[0], x[-1] - centre[0], centre[1] - y[0], y[-1] - centre[1])))


def circle_means(alpha, x, y, radii, centre=(0.0, 0.0)):
    """The damage averaged over circles about ``centre``: the radial profile of ``alpha``.

    Each circle is sampled every half grid spacing (at least 16 points), ``alpha``
    interpolated bilinearly between the nodes.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a uniform 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
        Node coordinates, equally spaced.
    radii : ndarray, shape (k,)
        Radii of the circles (units of L); they must lie inside the grid.
    centre : (float, float), optional

    Returns
    -------
    ndarray, shape (k,)
    """
    from scipy import ndimage

    x, y, alpha = np.asarray(x), np.asarray(y), np.asarray(alpha, dtype=float)
    hx, hy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    step = 0.5 * min(hx, hy)
    means = np.empty(len(radii))
    for k, r in enumerate(radii):
        theta = np.linspace(0.0, 2 * np.pi, max(16, int(np.ceil(2 * np.pi * r / step))), endpoint=False)
        rows = (centre[1] + r * np.sin(theta) - y[0]) / hy
        cols = (centre[0] + r * np.cos(theta) - x[0]) / hx
        means[k] = ndimage.map_coordinates(alpha, [rows, cols], order=1, mode="nearest").mean()
    return means


def ring_radii(alpha, x, y, centre=(0.0, 0.0), threshold=CRACK_THRESHOLD):
    """Radii of the circular cracks about ``centre``: the local maxima of the radial profile
    (:func:`circle_means`) with damage ``>= threshold`` all round on average.

    The profile is sampled every half grid spacing from the centre to the largest circle
    inside the grid; a plateau gives its middle (:func:`crack_positions`), so a ring is found
    within about a grid spacing. Radial cracks raise the profile between rings only by the
    fraction of the circle they cover.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a uniform 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
    centre : (float, float), optional
    threshold : float, optional

    Returns
    -------
    ndarray
        Increasing radii (units of L).
    """
    x, y = np.asarray(x), np.asarray(y)
    step = 0.5 * min((x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1))
    radii = np.arange(0.0, inscribed_radius(x, y, centre) + 0.5 * step, step)
    if len(radii) < 2:
        return np.array([])
    return crack_positions(radii, circle_means(alpha, x, y, radii, centre), threshold)


def radial_cracks(alpha, x, y, rings, centre=(0.0, 0.0), threshold=CRACK_THRESHOLD):
    """The radial cracks between circular ones: the cracks that cut the middle circle of each
    gap between neighbouring rings.

    The gaps run from the centre to the first ring, from ring to ring, and from the last ring
    to the largest circle inside the grid; a radial crack is counted in a gap if it crosses
    the gap's middle radius (:func:`arms` on that circle, sampled every half grid spacing).

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a uniform 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
    rings : sequence of float
        Radii of the circular cracks, increasing (:func:`ring_radii`).
    centre : (float, float), optional
    threshold : float, optional

    Returns
    -------
    list of (float, float, int)
        ``(inner, outer, count)`` per gap, from the centre outwards.
    """
    x, y = np.asarray(x), np.asarray(y)
    step = 0.5 * min((x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1))
    edge = inscribed_radius(x, y, centre)
    bounds = [0.0, *[float(r) for r in rings if r < edge], edge]
    out = []
    for inner, outer in zip(bounds[:-1], bounds[1:]):
        middle = 0.5 * (inner + outer)
        if middle <= 0.0:
            continue
        samples = max(720, int(np.ceil(2 * np.pi * middle / step)))
        out.append((inner, outer, len(arms(alpha, x, y, middle, centre, threshold, samples))))
    return out
