"""Reading a crack off the damage field: its tip, length and angle as the experiments measure them.

The dissertation does not say how it measured the initial crack length and angle of its
L-panel (Table 3.2); the reading adopted here (``docs/cases.md#l-shaped-panel``): the crack is
the set of nodes with ``alpha >= 0.9``; its tip is the broken node farthest from the point the
crack starts from (the re-entrant corner), its length the distance between them and its angle
that of the chord. The crack length from the surface energy (``S / (Gc T)``) is the other
measure, and it counts the damage's whole profile. A crack that curves has a chord flatter
than its start: :func:`initial_direction` reads the direction it leaves the corner in (the
median direction of the broken nodes near it).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["BROKEN", "crack_distance", "crack_tip", "initial_direction", "crack_through_depth", "holes_reached",
           "trace_angles", "twist", "cracks_from"]

#: Damage at which a node counts as broken (the dissertation draws cracks as 0.9 <= alpha <= 1).
BROKEN = 0.9


def crack_distance(points_a, alpha_a, points_b, alpha_b, threshold=BROKEN):
    """How far apart two cracks are, each on its own mesh: the symmetric Hausdorff distance
    between their nodes with ``alpha >= threshold`` (length); NaN if either has none.

    Parameters
    ----------
    points_a, points_b : ndarray, shape (n_a, d), (n_b, d)
    alpha_a, alpha_b : ndarray, shape (n_a,), (n_b,)
    """
    from scipy.spatial import cKDTree

    a, b = points_a[np.asarray(alpha_a) >= threshold], points_b[np.asarray(alpha_b) >= threshold]
    if len(a) == 0 or len(b) == 0:
        return math.nan
    return float(max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()))


def crack_tip(points, alpha, origin, threshold=BROKEN):
    """The broken node farthest from ``origin``, its distance and the chord's direction.

    Parameters
    ----------
    points : ndarray, shape (n, dim)
    alpha : ndarray, shape (n,)
    origin : sequence of float, length 2 or 3
        Where the crack starts (in 3D, compare the in-plane coordinates: pass 2 values and
        only x, y are used).
    threshold : float

    Returns
    -------
    tip : ndarray, shape (len(origin),) or None
        None if no node is broken.
    length : float
        Distance from ``origin`` to ``tip`` (0 if none).
    angle : float
        Direction of ``tip - origin`` in degrees, counterclockwise from +x (NaN if none).
    """
    origin = np.asarray(origin, dtype=float)
    xy = np.asarray(points)[:, : origin.size]
    broken = np.flatnonzero(np.asarray(alpha) >= threshold)
    if broken.size == 0:
        return None, 0.0, math.nan
    distance = np.linalg.norm(xy[broken] - origin, axis=1)
    k = broken[int(np.argmax(distance))]
    d = xy[k] - origin
    return xy[k], float(np.linalg.norm(d)), math.degrees(math.atan2(d[1], d[0]))


def initial_direction(points, alpha, origin, radius, threshold=BROKEN):
    """The direction a crack leaves ``origin`` in: the median direction of the broken nodes
    within ``radius`` of it.

    Parameters
    ----------
    points : ndarray, shape (n, dim)
    alpha : ndarray, shape (n,)
    origin : sequence of float, length 2
        Where the crack starts (only x, y are compared).
    radius : float
        How far from ``origin`` the start is read (a few eps: beyond the corner's own
        damage, before the path bends).
    threshold : float

    Returns
    -------
    float
        Degrees counterclockwise from +x of the median of ``atan2`` over those nodes, taken
        about the direction of their mean so that it does not wrap; NaN if there are none.
    """
    origin = np.asarray(origin, dtype=float)
    d = np.asarray(points)[:, : origin.size][np.asarray(alpha) >= threshold] - origin
    d = d[np.linalg.norm(d, axis=1) <= radius]
    if len(d) == 0:
        return math.nan
    mean = math.atan2(d[:, 1].sum(), d[:, 0].sum())
    turn = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - mean)))
    return math.degrees(mean + float(np.median(turn)))


def crack_through_depth(points, alpha, origin, depths, width, threshold=BROKEN):
    """A 3D crack read slice by slice: :func:`crack_tip` in slabs across the depth (z).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    alpha : ndarray, shape (n,)
    origin : sequence of float, length 2
        Where the crack starts in (x, y), along the z axis (the L-panel's re-entrant edge).
    depths : sequence of float
        The slabs' mid-planes z.
    width : float
        The slabs' width (a mesh size or two: each must hold nodes).

    Returns
    -------
    list of tuple (z, start, length, angle)
        For each slab: its z; ``start``, the distance in (x, y) from ``origin`` to the nearest
        broken node (``inf`` if none); ``length`` and ``angle`` of :func:`crack_tip` (0 and
        NaN if none).
    """
    points, alpha = np.asarray(points), np.asarray(alpha)
    origin = np.asarray(origin, dtype=float)
    out = []
    for z in depths:
        slab = np.abs(points[:, 2] - z) <= width / 2
        broken = points[slab & (alpha >= threshold), :2]
        start = float(np.min(np.linalg.norm(broken - origin, axis=1))) if broken.size else math.inf
        _, length, angle = crack_tip(points[slab], alpha[slab], origin, threshold)
        out.append((float(z), start, length, angle))
    return out


def holes_reached(points, alpha, holes, radius, margin, threshold=BROKEN):
    """The holes a crack has reached: those with a broken node within ``margin`` of their rim.

    Parameters
    ----------
    points : ndarray, shape (n, 2)
    alpha : ndarray, shape (n,)
    holes : dict of str -> (x, y)
        The holes' centres.
    radius : float
        Their radius.
    margin : float
        How close to the rim a broken node must be (a few element sizes).

    Returns
    -------
    list of str
        The names of the holes reached, from the lowest to the highest (a crack rising from a
        bottom notch reaches them in this order).
    """
    broken = np.asarray(points)[np.asarray(alpha) >= threshold]
    out = []
    for name, centre in sorted(holes.items(), key=lambda item: item[1][1]):
        if broken.size and np.min(np.linalg.norm(broken[:, :2] - np.asarray(centre), axis=1)) <= radius + margin:
            out.append(name)
    return out


def trace_angles(points, alpha, levels, width, axis=2, threshold=BROKEN, min_nodes=6):
    """A 3D crack surface read section by section: the direction of its trace on planes across
    ``axis``.

    In each slab ``|x_axis - level| <= width / 2`` the broken nodes' coordinates in the two
    other axes (in increasing order: (x, y) for ``axis = 2``) are fitted by a line, their
    principal axis (the first right singular vector of the centred coordinates). A planar
    crack gives the same angle on every section; a twisted one (Brokenshire's torsion test) a
    trace that turns from one section to the next.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    alpha : ndarray, shape (n,)
    levels : sequence of float
        The sections' coordinates along ``axis``.
    width : float
        The slabs' width (a mesh size or two: each must hold a layer of nodes).
    axis : {0, 1, 2}
    threshold : float
    min_nodes : int
        Fewer broken nodes in a slab give no angle.

    Returns
    -------
    list of tuple (level, angle, count, flatness)
        ``angle``: the trace's direction in degrees in [0, 180), counterclockwise from the
        first in-plane axis (NaN with fewer than ``min_nodes``); ``count``: the slab's broken
        nodes; ``flatness``: the second singular value over the first (0 for nodes on a line;
        near 1 for a blob, whose angle means nothing).
    """
    points, alpha = np.asarray(points), np.asarray(alpha)
    plane = [a for a in range(3) if a != axis]
    broken = points[alpha >= threshold]
    out = []
    for level in levels:
        xy = broken[np.abs(broken[:, axis] - level) <= width / 2][:, plane]
        if len(xy) < min_nodes:
            out.append((float(level), math.nan, len(xy), math.nan))
            continue
        _, s, vt = np.linalg.svd(xy - xy.mean(axis=0), full_matrices=False)
        angle = math.degrees(math.atan2(vt[0, 1], vt[0, 0])) % 180.0
        out.append((float(level), angle, len(xy), float(s[1] / s[0]) if s[0] > 0 else math.nan))
    return out


def twist(angles):
    """The turn of a crack's trace across sections: ``angles`` (degrees, modulo 180, from
    :func:`trace_angles`, NaN skipped) unwrapped so that consecutive ones differ by at most
    90 degrees.

    Returns
    -------
    unwrapped : ndarray
        The defined angles, unwrapped (the first kept as it is).
    total : float
        Last minus first (degrees, signed; 0 for a planar crack, NaN with fewer than two).
    """
    a = np.asarray(angles, dtype=float)
    a = a[np.isfinite(a)]
    if len(a) < 2:
        return a, math.nan
    steps = (np.diff(a) + 90.0) % 180.0 - 90.0
    unwrapped = np.concatenate([a[:1], a[0] + np.cumsum(steps)])
    return unwrapped, float(unwrapped[-1] - unwrapped[0])


def cracks_from(points, cells, alpha, origins, reach, threshold=BROKEN):
    """The crack leaving each of ``origins`` (e.g. a specimen's notch tips): the broken nodes
    connected, through mesh edges whose two ends are broken, to a broken node within ``reach``
    of the origin.

    Parameters
    ----------
    points : ndarray, shape (n, 2)
    cells : ndarray, shape (m, 3)
        The triangles (their edges connect the nodes).
    alpha : ndarray, shape (n,)
    origins : sequence of (x, y)
        Where the cracks start.
    reach : float
        How close to its origin a crack's nearest broken node must be (a notch's half width
        plus a mesh size or two).
    threshold : float

    Returns
    -------
    list of dict, one per origin
        ``"nodes"``: the crack's nodes (sorted; empty if none); ``"tip"``: its node farthest
        from the origin (None if none); ``"length"``: the chord from the origin to the tip, as
        :func:`crack_tip` (0 if none); ``"angle"``: the chord's direction in degrees from +x
        (NaN if none); ``"path"``: the length along the crack, from the origin to its nearest
        node, then the shortest way through the crack's edges to the tip (a zig-zag on the
        mesh: at most about 15 % above the arc length on near-equilateral triangles; 0 if
        none). A crack that joins two origins is the crack of both.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components, dijkstra

    points, alpha = np.asarray(points, dtype=float), np.asarray(alpha)
    broken = alpha >= threshold
    cells = np.asarray(cells)
    pairs = np.concatenate([cells[:, [0, 1]], cells[:, [1, 2]], cells[:, [2, 0]]])
    pairs = pairs[broken[pairs[:, 0]] & broken[pairs[:, 1]]]
    lengths = np.linalg.norm(points[pairs[:, 0]] - points[pairs[:, 1]], axis=1)
    n = len(points)
    graph = coo_matrix((lengths, (pairs[:, 0], pairs[:, 1])), shape=(n, n)).tocsr()
    graph = graph.maximum(graph.T)
    _, label = connected_components(graph, directed=False)
    out = []
    for origin in origins:
        origin = np.asarray(origin, dtype=float)
        distance = np.linalg.norm(points - origin, axis=1)
        near = np.flatnonzero(broken & (distance <= reach))
        if near.size == 0:
            out.append({"nodes": np.zeros(0, dtype=np.int64), "tip": None, "length": 0.0, "angle": math.nan,
                        "path": 0.0})
            continue
        nodes = np.flatnonzero(broken & np.isin(label, np.unique(label[near])))
        tip = nodes[int(np.argmax(distance[nodes]))]
        start = near[int(np.argmin(distance[near]))]
        along = dijkstra(graph, directed=False, indices=start)[tip]
        d = points[tip] - origin
        out.append({"nodes": nodes, "tip": points[tip].copy(), "length": float(distance[tip]),
                    "angle": math.degrees(math.atan2(d[1], d[0])),
                    "path": float(distance[start] + along) if np.isfinite(along) else float(distance[tip])})
    return out
