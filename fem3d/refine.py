r"""Local refinement of a simplicial mesh by conforming longest-edge bisection, in 2D and 3D.

One refinement pass (:func:`refine`) takes the cells to refine and returns a conforming mesh
in which each of them is cut at least once; others are cut only as far as conformity needs
(docs/adaptivity.md#refinement):

1. *Closure.* The longest edge of every marked cell is to be split. A cell with an edge to be
   split must be bisected, which it does across its own longest edge: that edge is added to
   the set, and so on until no cell adds one (the longest-edge propagation of Rivara's
   algorithm).
2. *Bisection rounds.* Each edge of the set gets its midpoint as a new vertex; every cell with
   an edge of the set is cut in two across its longest edge (the vertex at one end of the
   edge replaced by the midpoint in one child, the other in the other: both children keep
   the parent's orientation). A child may still hold a split edge: the closure and a round
   are repeated until no cell has one. The mesh is then conforming: every split edge is split
   in every cell around it.

"Longest" is decided by one total order of edges, their squared length and then their
vertex pair, computed the same way in every cell, so that neighbours agree. A boundary facet
is cut exactly as the cell on it is (the cell cuts the facet only across an edge of the facet,
which is then the cell's and so the facet's longest edge): the named boundaries are refined by
bisecting each facet across its longest edge while it has a split edge. Children of a cell
belong to its regions; named points keep their vertices. Vertices keep their numbers; new ones
are appended in the order they are made, each the exact midpoint of its two parents, so that a
P1 field is carried to the new mesh exactly by averaging the parents' values
(:func:`thinfilm.discretization.prolong`). The two-dimensional algorithm keeps every angle
above half the smallest angle of the first mesh; in 3D the bisection has no such proof, and the
tests measure the quality it keeps.

Written with NumPy rather than taken from scikit-fem: its adaptive refinement drops named
boundaries and regions and does not report which edge each new vertex halves, which is what
the exact transfer and the replay of a run's refinement need.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fem3d.mesh import Mesh

__all__ = ["RefinedMesh", "refine", "cell_sizes", "LOCAL_EDGES"]

#: The edges of a simplex as pairs of local vertices, for 1, 2 and 3 dimensions.
LOCAL_EDGES = {
    1: np.array([[0, 1]]),
    2: np.array([[0, 1], [1, 2], [0, 2]]),
    3: np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]]),
}

_SHIFT = np.int64(32)   # an edge's key: low vertex << 32 | high vertex (vertex numbers < 2^31)


@dataclass(frozen=True, eq=False)
class RefinedMesh:
    """What one pass of :func:`refine` made.

    Attributes
    ----------
    mesh : Mesh
        The refined mesh (groups carried over).
    parents : ndarray of int64, shape (n_new, 2)
        The two vertices whose midpoint each new vertex is (new vertex ``n_old + i`` for row
        ``i``; a parent may itself be new, of a lower number).
    cell_parent : ndarray of int64, shape (n_cells,)
        The cell of the old mesh each new cell lies in.
    """

    mesh: Mesh
    parents: np.ndarray
    cell_parent: np.ndarray


def _edge_keys(cells, pairs):
    """Keys of every local edge of every cell (or facet), shape (n, n_edges)."""
    a, b = cells[:, pairs[:, 0]], cells[:, pairs[:, 1]]
    return (np.minimum(a, b).astype(np.int64) << _SHIFT) | np.maximum(a, b).astype(np.int64)


def cell_sizes(points, cells):
    """Each cell's longest edge, shape (n_cells,) (length)."""
    pairs = LOCAL_EDGES[cells.shape[1] - 1]
    p = points[cells]
    return np.sqrt(np.max(np.sum((p[:, pairs[:, 1]] - p[:, pairs[:, 0]]) ** 2, axis=-1), axis=1))


def _bisect(cells, pairs, best, mid):
    """The two children of each cell, cut across local edge ``best`` at vertex ``mid``."""
    rows = np.arange(cells.shape[0])
    i, j = pairs[best, 0], pairs[best, 1]
    first, second = cells.copy(), cells.copy()
    first[rows, j] = mid
    second[rows, i] = mid
    return first, second


def _edges(points, cells, pairs):
    """The edges of some simplices (a mesh's cells, or facets): their sorted keys (n_edges,),
    each simplex's edges as indices into them (n, n_local), and each simplex's longest one as a
    local index (n,).

    Lengths are computed once per edge, so every simplex around an edge sees the same number;
    ties are broken by the key. The order (squared length, key) is a total order, the same for
    any set of simplices: a facet and the cell on it agree on which of the facet's edges is
    longest."""
    keys, ids = np.unique(_edge_keys(cells, pairs), return_inverse=True)
    ids = ids.reshape(cells.shape[0], pairs.shape[0])
    low, high = keys >> _SHIFT, keys & np.int64(0xFFFFFFFF)
    length2 = np.sum((points[high] - points[low]) ** 2, axis=-1)
    # the rank of each edge in the order (squared length, key): its longest is its largest rank
    rank = np.empty(keys.size, dtype=np.int64)
    rank[np.lexsort((keys, length2))] = np.arange(keys.size)
    best = np.argmax(rank[ids], axis=1)
    return keys, ids, best


def refine(mesh: Mesh, marked) -> RefinedMesh:
    """One pass of conforming longest-edge bisection (module docstring).

    Parameters
    ----------
    mesh : Mesh
    marked : array_like of int or bool
        Cells to refine (indices, or a mask of shape (n_cells,)); none: the mesh is returned
        as it is.

    Returns
    -------
    RefinedMesh
    """
    marked = np.asarray(marked)
    if marked.dtype == bool:
        marked = np.flatnonzero(marked)
    marked = np.unique(marked.astype(np.int64))
    if marked.size and (marked[0] < 0 or marked[-1] >= mesh.n_cells):
        raise IndexError(f"marked cells must lie in 0 .. {mesh.n_cells - 1}")
    if mesh.n_nodes >= 2 ** 31:
        raise ValueError("refine handles meshes of fewer than 2^31 vertices")
    pairs = LOCAL_EDGES[mesh.dim]
    points, cells = mesh.points, mesh.cells.copy()
    cell_parent = np.arange(mesh.n_cells, dtype=np.int64)
    # the split edges, by key, and their midpoints: sorted by key
    split_keys = np.empty(0, dtype=np.int64)
    split_mid = np.empty(0, dtype=np.int64)
    parents = []
    keys, ids, best = _edges(points, cells, pairs)
    pending = keys[ids[marked, best[marked]]]   # the longest edges of the marked cells
    while True:
        # closure: a cell with a split edge is cut across its longest, which is then split too
        had = np.isin(keys, split_keys)
        split = had | np.isin(keys, pending)
        longest = ids[np.arange(cells.shape[0]), best]
        while True:
            touched = split[ids].any(axis=1)
            add = longest[touched]
            add = add[~split[add]]
            if add.size == 0:
                break
            split[add] = True
        new = keys[split & ~had]
        if new.size:
            a, b = new >> _SHIFT, new & np.int64(0xFFFFFFFF)
            mids = np.arange(points.shape[0], points.shape[0] + new.size, dtype=np.int64)
            points = np.concatenate([points, 0.5 * (points[a] + points[b])])
            parents.append(np.stack([a, b], axis=1))
            merged = np.concatenate([split_keys, new])
            order = np.argsort(merged, kind="stable")
            split_keys, split_mid = merged[order], np.concatenate([split_mid, mids])[order]
        touched = np.flatnonzero(touched)
        if touched.size == 0:
            break
        cut = keys[longest[touched]]
        first, second = _bisect(cells[touched], pairs, best[touched], split_mid[np.searchsorted(split_keys, cut)])
        cells[touched] = first
        cells = np.concatenate([cells, second])
        cell_parent = np.concatenate([cell_parent, cell_parent[touched]])
        pending = np.empty(0, dtype=np.int64)
        keys, ids, best = _edges(points, cells, pairs)
    facet_groups = {name: _refine_facets(points, facets, split_keys, split_mid)
                    for name, facets in mesh.facet_groups.items()}
    cell_groups = {name: np.flatnonzero(np.isin(cell_parent, group)) for name, group in mesh.cell_groups.items()}
    refined = Mesh(points, cells, cell_groups=cell_groups, facet_groups=facet_groups,
                   node_groups=dict(mesh.node_groups))
    parents = np.concatenate(parents) if parents else np.empty((0, 2), dtype=np.int64)
    return RefinedMesh(refined, parents, cell_parent)


def _refine_facets(points, facets, split_keys, split_mid):
    """A named boundary's facets cut as the cells on them were: each across its longest edge
    while it has a split edge."""
    facets = np.asarray(facets, dtype=np.int64)
    if facets.size == 0 or split_keys.size == 0:
        return facets.copy()
    pairs = LOCAL_EDGES[facets.shape[1] - 1]
    while True:
        keys, ids, best = _edges(points, facets, pairs)
        touched = np.flatnonzero(np.isin(keys, split_keys)[ids].any(axis=1))
        if touched.size == 0:
            return facets
        cut = keys[ids[touched, best[touched]]]
        at = np.searchsorted(split_keys, cut)
        if not np.all(split_keys[np.minimum(at, split_keys.size - 1)] == cut):
            raise RuntimeError("a boundary facet holds a split edge but its longest edge was not split:"
                               " the cells' and the facets' orders of edges disagree")
        first, second = _bisect(facets[touched], pairs, best[touched], split_mid[at])
        facets = facets.copy()
        facets[touched] = first
        facets = np.concatenate([facets, second])
