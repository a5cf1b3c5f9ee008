"""The memory a finite-element run needs, from its scene alone (:mod:`thinfilm.resources`),
before anything is meshed.

The nodes are the specimen's estimate from its keys and sizes
(:meth:`fem3d.specimens.specimen.Specimen.nodes_estimate`), or a mesh file's own count (the
scene reader has read it). With ``N`` of them, ``d`` the dimension and ``S + 1`` load steps::

    memory = BASE_BYTES + N NODE_BYTES[d] P + (S + 1) (8 (d + 1) N P + STEP_BYTES)

* ``NODE_BYTES``: the peak per node of a run (mesh, the elasticity and damage operators, the
  linear solver's factors or AMG hierarchy, the engine's fields), from the peak resident
  memory of whole runs (docs/scenes.md#sizes): the 2D L-panel at 107k nodes in 0.88 GB
  (sparse direct), the Brokenshire prism at about 200k nodes in 2.8 GB (AMG);
* ``P``: the displacement's nodes per vertex, 1 for P1, :data:`P2_NODES` for P2 (the edge
  midpoints: about 3 edges per vertex in 2D, 7 in 3D);
* ``8 (d + 1) N P`` per step: ``u`` and ``alpha`` of every finished step, which the engine keeps
  (backtracking may return to any of them).

A run's time depends on its iterations, which the scene does not tell: only its memory is
estimated.
"""

from __future__ import annotations

from thinfilm.resources import BASE_BYTES, STEP_BYTES, Estimate, Size, count, size, steps_estimate

__all__ = ["NODE_BYTES", "P2_NODES", "nodes", "estimate"]

#: Peak bytes per mesh node of a run, by dimension.
NODE_BYTES = {2: 4.0e3, 3: 12.0e3}
#: Displacement nodes per mesh vertex of P2 (vertices and edge midpoints), by dimension.
P2_NODES = {2: 4.0, 3: 8.0}


def nodes(scene):
    """The mesh's nodes: exact for a mesh file (read by the scene reader, kept), else the
    specimen's estimate; None for a specimen without an extent."""
    from fem3d import specimens
    from fem3d.specimens.file import read

    g, m = scene.geometry, scene.model
    if g.file is not None:
        return float(read(g.file).n_nodes)
    return specimens.get(g.kind).nodes_estimate(m.dim, scene.mesh.h, scene.mesh.h_coarse, g.options)


def estimate(scene):
    """What the run of ``scene`` needs (from its steps alone for a specimen without an
    extent: :func:`thinfilm.resources.steps_estimate`).

    Returns
    -------
    thinfilm.resources.Estimate
        Blamed on ``mesh.h`` (``geometry.file`` for a mesh file) or on ``load.steps``.
    """
    d = scene.model.dim
    n = nodes(scene)
    if n is None:
        return steps_estimate(scene)
    per_vertex = P2_NODES[d] if scene.model.element == "P2" else 1.0
    steps = scene.load.steps + 1
    model = n * NODE_BYTES[d] * per_vertex
    fields = steps * 8.0 * (d + 1) * n * per_vertex
    memory = BASE_BYTES + model + fields + steps * STEP_BYTES
    what = f"about {count(n)} nodes x {size(NODE_BYTES[d] * per_vertex)}, and {count(steps)} steps of fields"
    # each key's own need: its value with the other at its least (two steps; a tiny mesh)
    alone = BASE_BYTES + model + 2.0 * (fields / steps + STEP_BYTES)
    if scene.geometry.kind == "file":
        mesh_key = Size("geometry.file", scene.geometry.file, alone, model + fields, remedy="use a coarser mesh")
    else:
        mesh_key = Size("mesh.h", scene.mesh.h, alone, model + fields, remedy="use a larger h")
    values = getattr(scene.load, "values", None)
    key, value = ("load.t", list(values)) if values is not None else ("load.steps", scene.load.steps)
    step_key = Size(key, value, BASE_BYTES + steps * STEP_BYTES, fields + steps * STEP_BYTES, remedy="use fewer steps")
    return Estimate(memory, what, (mesh_key, step_key))
