"""Reading a crack off the damage field: its tip, length and angle as the experiments measure them.

The dissertation does not say how it measured the initial crack length and angle of its
L-panel (Table 3.2); the reading adopted here (``docs/cases.md#l-shaped-panel``): the crack is
the set of nodes with ``alpha >= 0.9``; its tip is the broken node farthest from the point the
crack starts from (the re-entrant corner), its length the distance between them and its angle
that of the chord. The crack length from the surface energy (``S / (Gc T)``) is the other
measure, and it counts the damage's whole profile.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["BROKEN", "crack_tip"]

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
