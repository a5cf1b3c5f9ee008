"""The skeleton of a set of grid nodes: the set thinned to lines one node wide, and their length.

A crack's broken core (the nodes with ``alpha >= 0.9``) is a band a few nodes wide; thinning
it to its centre line gives a curve whose length is measured along the chain of nodes, each
step between 8-neighbours counted as the distance between them (``hx``, ``hy`` or
``sqrt(hx^2 + hy^2)``).

The thinning is Guo and Hall's two-subiteration parallel algorithm (Guo, Hall, "Parallel
thinning with two-subiteration algorithms", Commun. ACM 32, 1989, algorithm A1), written with
:mod:`scipy.ndimage` and a lookup table of the 256 neighbourhoods. It keeps the topology of
the set (components, holes) and the end points of lines, and it leaves lines that are
8-connected without redundant corner nodes, so that a diagonal line is measured as a chain of
diagonal steps and not as a staircase.

The length of such a chain converges to a curve's length only for directions along the grid
lines and the diagonals: a straight line at angle ``theta`` in [0, 45] degrees from a grid
line gets ``cos(theta) + (sqrt(2) - 1) sin(theta)`` times its length (up to 8.2 % more, at
22.5 degrees), a circle of radius ``r`` gets ``16 (sqrt(2) - 1) r``, the perimeter of the
circumscribed regular octagon (5.5 % more than ``2 pi r``).

Written here rather than taken from scikit-image (whose ``morphology.thin`` is the same
algorithm): it is the one image operation the toolkit needs, about 40 lines on
:mod:`scipy.ndimage`, against a dependency of its own with several more.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

__all__ = ["thin", "length", "junctions"]

#: Offsets ``(dj, di)`` of the 8 neighbours of a node in ``[j, i]`` order (j along y), in Guo
#: and Hall's order x1 ... x8: east, then counter-clockwise.
_NEIGHBOURS = ((0, 1), (1, 1), (1, 0), (1, -1), (0, -1), (-1, -1), (-1, 0), (-1, 1))

#: Correlating a 0/1 array with this kernel gives each node the code ``sum_k x_k 2^(k-1)`` of
#: its neighbourhood (the node itself has weight 0).
_CODE = np.zeros((3, 3), dtype=np.int32)
for _k, (_dj, _di) in enumerate(_NEIGHBOURS):
    _CODE[1 + _dj, 1 + _di] = 1 << _k


def _removal_tables():
    """The nodes each subiteration removes, as two boolean tables indexed by the code.

    A node is removed if its neighbours form one run around it (condition G1, Hilditch's
    crossing number ``X_H = 1``: removing it disconnects nothing and opens no hole), if
    ``min(n1, n2)``, its neighbours counted by pairs in two ways, is 2 or 3 (G2: 1 would be the
    end point of a line, which is kept), and if it lies on the side of the set that its
    subiteration takes (G3: east and north in the first, west and south in the second, so
    that a band is eaten from both sides and its centre line stays).
    """
    first, second = np.zeros(256, dtype=bool), np.zeros(256, dtype=bool)
    for code in range(256):
        x = [None] + [(code >> k) & 1 for k in range(8)]
        x.append(x[1])  # x9 = x1: the neighbourhood is a ring
        crossings = sum(1 for i in (1, 2, 3, 4) if not x[2 * i - 1] and (x[2 * i] or x[2 * i + 1]))
        n1 = sum(x[2 * k - 1] or x[2 * k] for k in (1, 2, 3, 4))
        n2 = sum(x[2 * k] or x[2 * k + 1] for k in (1, 2, 3, 4))
        removable = crossings == 1 and 2 <= min(n1, n2) <= 3
        first[code] = removable and not ((x[2] or x[3] or not x[8]) and x[1])
        second[code] = removable and not ((x[6] or x[7] or not x[4]) and x[5])
    return first, second


_REMOVE = _removal_tables()


def thin(mask):
    """The skeleton of a set of nodes: the set thinned to lines one node wide.

    Parameters
    ----------
    mask : ndarray of bool, shape (ny + 1, nx + 1)
        The set (``[j, i]`` order); nodes beyond the grid count as outside it.

    Returns
    -------
    ndarray of bool, same shape
        A subset of ``mask`` with the same 8-connected components and the same holes
        (4-connected components of the complement), lines 8-connected and one node wide,
        their end points kept.
    """
    mask = np.asarray(mask, dtype=bool)
    out = np.zeros_like(mask)
    rows, cols = np.nonzero(mask)
    if rows.size == 0:
        return out
    # Only the set's bounding box is worked on (a crack pattern often covers a small part of
    # the grid); one layer of background around it stands for the outside.
    j0, j1, i0, i1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    m = np.pad(mask[j0:j1, i0:i1], 1).astype(np.int32)
    changed = True
    while changed:
        changed = False
        for table in _REMOVE:
            code = ndimage.correlate(m, _CODE, mode="constant", cval=0)
            remove = table[code] & (m == 1)
            if remove.any():
                m[remove] = 0
                changed = True
    out[j0:j1, i0:i1] = m[1:-1, 1:-1].astype(bool)
    return out


def length(skeleton, hx, hy):
    """The length of a skeleton: its steps between 8-neighbours, each of its own length.

    Steps along x count ``hx``, along y ``hy``, diagonal steps ``sqrt(hx^2 + hy^2)`` unless the
    two nodes are also joined through a common 4-neighbour in the skeleton (a corner, measured
    by its two orthogonal steps, not three times).

    Parameters
    ----------
    skeleton : ndarray of bool, shape (ny + 1, nx + 1)
        Lines one node wide (:func:`thin`).
    hx, hy : float
        Grid spacings (units of L).

    Returns
    -------
    float
        Units of L. See the module's notes for its bias on lines that are not along a grid
        line or a diagonal.
    """
    s = np.asarray(skeleton, dtype=bool)
    straight = hx * np.count_nonzero(s[:, 1:] & s[:, :-1]) + hy * np.count_nonzero(s[1:, :] & s[:-1, :])
    lower_left, lower_right, upper_left, upper_right = s[:-1, :-1], s[:-1, 1:], s[1:, :-1], s[1:, 1:]
    rising = lower_left & upper_right & ~lower_right & ~upper_left
    falling = lower_right & upper_left & ~lower_left & ~upper_right
    return float(straight + np.hypot(hx, hy) * (np.count_nonzero(rising) + np.count_nonzero(falling)))


def junctions(skeleton):
    """The nodes of a skeleton with three or more skeleton neighbours: where lines meet.

    Parameters
    ----------
    skeleton : ndarray of bool, shape (ny + 1, nx + 1)

    Returns
    -------
    ndarray of bool, same shape
        A few nodes at each junction of lines (and at the foot of each spur thinning left).
    """
    s = np.asarray(skeleton, dtype=bool)
    ring = np.ones((3, 3), dtype=np.int32)
    ring[1, 1] = 0
    return s & (ndimage.correlate(s.astype(np.int32), ring, mode="constant", cval=0) >= 3)
