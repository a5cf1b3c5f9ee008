"""Nested meshes made by hand, and results files of runs whose mesh is refined as they go,
written through :class:`thinfilm.results.writer.ResultsWriter` as a run writes them.

A pass bisects given edges: each new vertex is the midpoint of its edge, appended after the
existing vertices, and every cell holding that edge is split in two in its place (the half
that keeps the edge's first vertex first). The edges of a pass never share a cell, so each
pass leaves a conforming mesh:

* :func:`square_meshes`: the unit square of two triangles; pass 1 bisects the diagonal (vertex
  4 at the centre, 4 triangles), pass 2 the bottom and right edges (6 triangles), pass 3 the
  top and left edges (8 triangles, 9 vertices);
* :func:`tetrahedra_meshes`: two tetrahedra sharing a face; pass 1 bisects an edge of that
  face (4 tetrahedra), pass 2 an edge of the first tetrahedron (6).
"""

from __future__ import annotations

import numpy as np

from thinfilm.discretization import Refinement, SimplexMesh
from tests.helpers import load_case
from thinfilm.engine.records import State, StepRecord
from thinfilm.results.writer import ResultsWriter

__all__ = ["bisect", "square_meshes", "tetrahedra_meshes", "linear", "scene", "open_writer", "write_run",
           "step_values", "OBSERVABLES"]

#: The observables the written runs record (the finite-element kind's force figure reads them).
OBSERVABLES = ("force", "displacement")


def bisect(mesh, edges):
    """The mesh after one refinement pass bisecting ``edges`` (pairs of vertices, no two in one cell).

    Returns
    -------
    SimplexMesh
        With its :class:`Refinement`: ``mesh``'s extended by this pass.
    """
    refinement = mesh.refinement or Refinement.initial(mesh.n_nodes)
    n = mesh.n_nodes
    edges = np.asarray(edges, dtype=np.int64).reshape(-1, 2)
    points = np.vstack([mesh.points, 0.5 * (mesh.points[edges[:, 0]] + mesh.points[edges[:, 1]])])
    cells, marked = [], []
    for c, cell in enumerate(np.asarray(mesh.cells)):
        holding = [e for e, (a, b) in enumerate(edges) if a in cell and b in cell]
        assert len(holding) <= 1, "two bisected edges in one cell"
        if not holding:
            cells.append(cell)
            continue
        e = holding[0]
        a, b = edges[e]
        marked.append(c)
        cells.append(np.where(cell == b, n + e, cell))   # the half with a
        cells.append(np.where(cell == a, n + e, cell))   # the half with b
    parents = np.vstack([refinement.parents, edges])
    pass_nodes = np.append(refinement.pass_nodes, n + len(edges))
    return SimplexMesh(points, np.array(cells, dtype=np.int64),
                       Refinement(parents, pass_nodes, refinement.marked + (np.array(marked, dtype=np.int64),)))


def _versions(first, passes):
    meshes = [SimplexMesh(first.points, first.cells, Refinement.initial(first.n_nodes))]
    for edges in passes:
        meshes.append(bisect(meshes[-1], edges))
    return meshes


def square_meshes():
    """Versions 0 to 3 of the refined unit square (module docstring): 4, 5, 7, 9 vertices."""
    points = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    first = SimplexMesh(points, np.array([[0, 1, 2], [0, 2, 3]]))
    return _versions(first, [[(0, 2)], [(0, 1), (1, 2)], [(2, 3), (3, 0)]])


def tetrahedra_meshes():
    """Versions 0 to 2 of the two refined tetrahedra (module docstring): 5, 6, 7 vertices."""
    points = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]])
    first = SimplexMesh(points, np.array([[0, 1, 2, 3], [1, 2, 3, 4]]))
    return _versions(first, [[(1, 2)], [(0, 3)]])


def linear(points, components=1):
    """A linear field at ``points``, flat (node by node), of ``components`` values per node."""
    x = np.asarray(points, dtype=float)
    gradients = np.array([[2.0, -3.0, 0.5], [-1.0, 0.25, 4.0], [0.5, 1.5, -2.0]])[:components, : x.shape[1]]
    offsets = np.array([1.0, -0.5, 0.25])[:components]
    return (x @ gradients.T + offsets).ravel()


def scene(dim):
    """A finite-element scene of ``dim`` dimensions (the L-panel's) with loads ``0.1 k``, k = 0..10:
    what the written runs store as theirs (the figures read its parameters)."""
    loads = {"load.t": [0.1 * k for k in range(11)]} if dim == 2 else {"load.t_max": 1.0, "load.steps": 10}
    return load_case("lpanel" if dim == 2 else "lpanel_3d", {**loads, "output.snapshots": [0.1, 0.4]})


def open_writer(path, meshes, resume=False):
    """The results writer of a run on ``meshes`` (its first mesh ``meshes[0]``, version 0),
    new or resumed."""
    from fem3d.kind import KIND

    first = meshes[0]
    run_scene = scene(first.dim)
    return ResultsWriter(path, run_scene, KIND.parameters(run_scene), first, components={"u": first.dim},
                         observables=OBSERVABLES, resume=resume)


def step_values(mesh, k):
    """``(u, alpha)`` written at step ``k`` on ``mesh``: distinct per step and node."""
    rng = np.random.default_rng(1000 + k)
    return rng.standard_normal(mesh.n_nodes * mesh.dim), rng.uniform(0.0, 1.0, mesh.n_nodes)


def write_run(writer, meshes, versions, start=0):
    """Write steps ``start, start + 1, ...`` on ``meshes[versions[i]]``, at loads ``0.1 k``.

    Returns
    -------
    list of tuple
        ``(u, alpha)`` of each step written.
    """
    written = []
    for i, version in enumerate(versions):
        k = start + i
        mesh = meshes[version]
        t = 0.1 * k
        u, alpha = step_values(mesh, k)
        record = StepRecord(k, t, elastic=t * t, surface=0.05 * k, total=t * t + 0.05 * k, iterations=1 + k,
                            u_solves=1 + k)
        writer.write_step(record, State(t, u, alpha, t * t, 0.05 * k), {"force": 2.0 * t, "displacement": t},
                          mesh=mesh)
        written.append((u, alpha))
    return written


def extends(fine, coarse):
    """Whether refinement ``fine`` is ``coarse`` followed by zero or more passes."""
    p = coarse.passes
    return (p <= fine.passes and np.array_equal(fine.pass_nodes[: p + 1], coarse.pass_nodes)
            and np.array_equal(fine.parents[: coarse.n_nodes], coarse.parents)
            and all(np.array_equal(a, b) for a, b in zip(fine.marked, coarse.marked)))
