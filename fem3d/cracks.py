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

__all__ = ["BROKEN", "crack_tip", "initial_direction", "crack_through_depth", "holes_reached"]

#: Damage at which a node counts as broken (the dissertation draws cracks as 0.9 <= alpha <= 1).
BROKEN = 0.9


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
