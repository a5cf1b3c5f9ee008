"""Checks of a simplicial mesh read from a user's file, before anything is built on it.

A mesh from a ``.msh`` file is judged when it is read: finite coordinates, cells of nonzero
measure, a conforming cover (no two cells overlap), and its element size measured rather than
trusted (``docs/scenes.md#your-own-mesh``). Every check raises :class:`ValueError` with one
line saying what is wrong; the scene reader turns it into a refusal naming the file.

Why the cover is checked through facets: once every cell is positively oriented, a
conforming mesh without overlaps has each facet in one cell (the boundary) or in two cells
lying on opposite sides of it. A cell that was inverted in the file and overlaps its
neighbours ("tangled") shares a facet with a neighbour on the same side, and a facet in three
or more cells is a fold or a duplicated cell. This finds every overlap between cells that
share a facet; pieces that overlap without sharing any facet are not detected.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["oriented_cells", "check_cover", "element_sizes", "fine_size", "DEGENERATE", "FINE_PERCENTILE"]

#: The percentile of the cells' sizes (:func:`element_sizes`) taken as a mesh's fine size: its
#: ``h`` where it is finest, robust to a few small cells in corners and on curves.
FINE_PERCENTILE = 5.0

#: A cell whose measure is below this fraction of its longest edge to the power ``dim`` is
#: degenerate: its vertices are collinear (coplanar) to rounding, and its stiffness would be
#: singular or dominated by rounding.
DEGENERATE = 1e-10


def _edge_lengths(points, cells):
    """``(n_cells, n_edges)`` lengths of every edge of every cell."""
    k = cells.shape[1]
    pairs = [(a, b) for a in range(k) for b in range(a + 1, k)]
    return np.stack([np.linalg.norm(points[cells[:, a]] - points[cells[:, b]], axis=1) for a, b in pairs], axis=1)


def oriented_cells(points, cells):
    """The cells with two vertices swapped where the signed measure is negative.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, dim)
    cells : ndarray, shape (n_cells, dim + 1), int

    Returns
    -------
    ndarray, shape (n_cells, dim + 1), int64
        A new array, every cell of positive signed area (volume).

    Raises
    ------
    ValueError
        If a coordinate is not finite, or a cell is degenerate (:data:`DEGENERATE`).
    """
    points = np.asarray(points, dtype=np.float64)
    if not np.all(np.isfinite(points)):
        bad = int(np.sum(~np.all(np.isfinite(points), axis=1)))
        raise ValueError(f"{bad} node(s) with a coordinate that is not a finite number (NaN or inf)")
    cells = np.array(cells, dtype=np.int64)
    if cells.size == 0:
        raise ValueError("no cells")
    dim = points.shape[1]
    edges = points[cells[:, 1:]] - points[cells[:, :1]]        # (m, dim, dim): rows are edges
    signed = np.linalg.det(edges)
    longest = _edge_lengths(points, cells).max(axis=1)
    degenerate = np.abs(signed) <= DEGENERATE * longest**dim * math.factorial(dim)
    if np.any(degenerate):
        first = int(np.flatnonzero(degenerate)[0])
        raise ValueError(f"{int(degenerate.sum())} degenerate cell(s) of zero {'area' if dim == 2 else 'volume'}"
                         f" (collapsed or with collinear vertices; the first: cell {first}, nodes"
                         f" {cells[first].tolist()})")
    flip = signed < 0.0
    cells[flip, -2:] = cells[flip, -1:-3:-1]
    return cells


def check_cover(points, cells):
    """Refuse a mesh whose cells overlap or fold: every facet must lie in one cell (boundary)
    or in two cells on opposite sides of it.

    Parameters
    ----------
    points : ndarray, shape (n_nodes, dim)
    cells : ndarray, shape (n_cells, dim + 1), int
        Positively oriented (:func:`oriented_cells`).

    Raises
    ------
    ValueError
        Naming how many facets are shared wrongly and one of their cells.
    """
    points = np.asarray(points, dtype=np.float64)
    cells = np.asarray(cells, dtype=np.int64)
    m, k = cells.shape
    dim = k - 1
    # every (cell, opposite vertex) facet, its vertices sorted so equal facets compare equal
    local = np.array([[j for j in range(k) if j != i] for i in range(k)])
    facets = np.sort(cells[:, local].reshape(m * k, dim), axis=1)
    opposite = cells.reshape(m * k)
    order = np.lexsort(facets.T[::-1])
    sorted_facets = facets[order]
    new = np.ones(m * k, dtype=bool)
    new[1:] = np.any(sorted_facets[1:] != sorted_facets[:-1], axis=1)
    ids = np.cumsum(new) - 1
    counts = np.bincount(ids)
    if np.any(counts > 2):
        first = int(order[np.flatnonzero(counts[ids] > 2)[0]]) // k
        raise ValueError(f"{int(np.sum(counts > 2))} facet(s) shared by three or more cells (a fold or a"
                         f" duplicated cell; one of them: cell {first}, nodes {cells[first].tolist()})")
    # side of the opposite vertex relative to the facet's sorted vertices: sign of a determinant
    f = sorted_facets
    base = points[f[:, 0]]
    rows = [points[f[:, j]] - base for j in range(1, dim)] + [points[opposite[order]] - base]
    side = np.sign(np.linalg.det(np.stack(rows, axis=1)))
    shared = np.flatnonzero(counts == 2)
    start = np.searchsorted(ids, shared)        # the pair's two rows are adjacent after sorting
    same = side[start] == side[start + 1]
    if np.any(same):
        first = int(order[start[np.flatnonzero(same)[0]]]) // k
        raise ValueError(f"{int(same.sum())} facet(s) with both their cells on one side: the cells overlap (a"
                         f" tangled mesh, e.g. an inverted cell; one of them: cell {first}, nodes"
                         f" {cells[first].tolist()})")


def element_sizes(points, cells):
    """Each cell's size: its longest edge (the ``h`` of the scene files).

    Parameters
    ----------
    points : ndarray, shape (n_nodes, dim)
    cells : ndarray, shape (n_cells, dim + 1), int

    Returns
    -------
    ndarray, shape (n_cells,)
        Lengths, in the mesh's unit.
    """
    return _edge_lengths(np.asarray(points, dtype=np.float64), np.asarray(cells, dtype=np.int64)).max(axis=1)


def fine_size(sizes):
    """The mesh's element size where it is finest: the :data:`FINE_PERCENTILE` percentile of
    its cells' sizes ``sizes`` (:func:`element_sizes`; a length, the mesh's unit)."""
    return float(np.percentile(sizes, FINE_PERCENTILE))
