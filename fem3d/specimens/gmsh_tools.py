"""The gmsh plumbing of the specimens: a deterministic session, polygons and circles of the
built-in kernel, physical groups found by bounding box, the box size field, and the reading of
the gmsh model (or of a ``.msh`` file) into a :class:`fem3d.mesh.Mesh`.

Determinism
-----------
Each mesh function opens and closes its own gmsh session (:func:`session`:
``gmsh.initialize(readConfigFiles=False, interruptible=False)``: no configuration file is read
and Python's Ctrl-C handler is left alone; ``General.Terminal = 0``: nothing printed) and sets
every meshing option that matters (:data:`GMSH_OPTIONS`: one thread, fixed algorithms and
random seed), so the same arguments give bit-identical meshes with the same gmsh version. A
session asked for while gmsh is initialized elsewhere in the process is refused rather than
closing that session.

Mesh size
---------
A specimen's ``h`` is the average edge length (the dissertation's meaning). :func:`box_field`
prescribes the edge length ``h`` inside a box and, outside it, a length growing linearly with
the distance to the box at the rate ``grading`` (length per length) up to ``h_coarse``: the
transition is ``(h_coarse - h) / grading`` wide. The size comes from the field only, not from
the geometry's points nor extended from the boundary. In 3D the field prescribes
``h / TET_EDGE_RATIO`` so that ``h`` is the tetrahedra's median edge. How the default grading
and the ratio were chosen, and what they cost: ``docs/cases.md#specimen-meshes``.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import numpy as np

from fem3d.mesh import Mesh
from fem3d.mesh_check import check_cover, oriented_cells

__all__ = ["GMSH_OPTIONS", "GRADING", "TET_EDGE_RATIO", "SIMPLEX_TYPE", "session", "polygon", "circle", "physical",
           "box_field", "read_model", "from_file", "oriented", "in_box"]

#: gmsh options set in every session: one thread (parallel meshing is not guaranteed to give the
#: same mesh twice), fixed 2D and 3D algorithms, random seed and optimization passes, and the
#: mesh size taken from the size field only.
GMSH_OPTIONS = {
    "General.NumThreads": 1,
    "Mesh.MaxNumThreads1D": 1,
    "Mesh.MaxNumThreads2D": 1,
    "Mesh.MaxNumThreads3D": 1,
    "Mesh.Algorithm": 6,  # Frontal-Delaunay: near-equilateral triangles
    "Mesh.Algorithm3D": 10,  # HXT: faster than Delaunay (1), same quality (docs/cases.md#specimen-meshes)
    "Mesh.RandomSeed": 1,
    "Mesh.RandomFactor": 1e-9,
    "Mesh.Optimize": 1,
    "Mesh.OptimizeNetgen": 0,
    "Mesh.Smoothing": 1,
    "Mesh.ElementOrder": 1,
    "Mesh.Renumber": 1,
    "Mesh.MeshSizeFromPoints": 0,
    "Mesh.MeshSizeExtendFromBoundary": 0,
    "Mesh.MeshSizeFromCurvature": 0,
}

#: Default growth rate of the mesh size away from the refined box (length per length): a
#: transition about 10 ``h_coarse`` wide (docs/cases.md#specimen-meshes).
GRADING = 0.1

#: Median edge of gmsh's tetrahedra over the edge length prescribed by the size field (HXT,
#: gmsh 4.15; measured: docs/cases.md#specimen-meshes). gmsh's 3D meshes are coarser than the
#: size they are asked for (triangles are not): 3D size fields prescribe ``h / TET_EDGE_RATIO``
#: so that ``h`` is the tetrahedra's edge, as in the dissertation.
TET_EDGE_RATIO = 1.38

#: gmsh element types by dimension: 2-node line, 3-node triangle, 4-node tetrahedron.
SIMPLEX_TYPE = {1: 1, 2: 2, 3: 4}


# --- session and geometry ---------------------------------------------------------------------

@contextmanager
def session(name):
    """A fresh gmsh session with :data:`GMSH_OPTIONS` and an empty model ``name``; finalized
    on exit, also after an error.

    Parameters
    ----------
    name : str
        The gmsh model's name.

    Yields
    ------
    module
        The ``gmsh`` module, initialized.

    Raises
    ------
    RuntimeError
        If gmsh is already initialized in this process (that session is left alone).
    """
    import gmsh  # here, so that importing the module does not load gmsh's library

    if gmsh.isInitialized():
        raise RuntimeError("fem3d.specimens: gmsh is already initialized in this process; the "
                           "geometry functions open and close their own session (finalize it first)")
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        for key, value in GMSH_OPTIONS.items():
            gmsh.option.setNumber(key, value)
        gmsh.model.add(name)
        yield gmsh
    finally:
        gmsh.finalize()


def polygon(geo, outline, holes=()):
    """The plane surface bounded by a closed polygon, minus holes (built-in kernel, z = 0).

    Parameters
    ----------
    geo : module
        ``gmsh.model.geo``.
    outline : sequence of (float, float)
        The polygon's vertices (x, y), counter-clockwise, the last joined to the first.
    holes : sequence of int
        Tags of curve loops to cut out (:func:`circle`).

    Returns
    -------
    int
        The surface's tag.
    """
    points = [geo.addPoint(x, y, 0.0) for x, y in outline]
    lines = [geo.addLine(a, b) for a, b in zip(points, points[1:] + points[:1])]
    return geo.addPlaneSurface([geo.addCurveLoop(lines), *holes])


def circle(geo, x, y, r):
    """The curve loop of a circle in the plane z = 0, in four quarter arcs (the built-in
    kernel's arcs must be shorter than a half circle).

    Parameters
    ----------
    geo : module
        ``gmsh.model.geo``.
    x, y, r : float
        Centre and radius.

    Returns
    -------
    int
        The curve loop's tag.
    """
    centre = geo.addPoint(x, y, 0.0)
    points = [geo.addPoint(x + r * c, y + r * s, 0.0) for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1))]
    arcs = [geo.addCircleArc(a, centre, b) for a, b in zip(points, points[1:] + points[:1])]
    return geo.addCurveLoop(arcs)


def physical(gmsh, dim, name, x, y, z, tol):
    """Add the physical group ``name`` of the entities of dimension ``dim`` lying in a box.

    Parameters
    ----------
    gmsh : module
        The session's ``gmsh`` (:func:`session`), its model synchronized.
    dim : int
        The entities' dimension (0 points, 1 curves, 2 surfaces, 3 volumes).
    name : str
        The group's name.
    x, y, z : (float, float)
        The box: closed intervals, each widened by ``tol``.
    tol : float
        Tolerance, in the model's length unit.

    Raises
    ------
    RuntimeError
        If no entity lies in the box (a bug of the geometry: every group is built to exist).
    """
    entities = gmsh.model.getEntitiesInBoundingBox(x[0] - tol, y[0] - tol, z[0] - tol,
                                                   x[1] + tol, y[1] + tol, z[1] + tol, dim)
    if not entities:  # a geometry bug, not a user error: every group is built to exist
        raise RuntimeError(f"fem3d.specimens: no entity of dimension {dim} for group {name!r}")
    gmsh.model.addPhysicalGroup(dim, sorted(tag for _, tag in entities), name=name)


def box_field(gmsh, h, h_coarse, box, z, grading, ratio):
    """Set the background mesh size: edge length ``h`` in a box, growing at the rate
    ``grading`` with the distance to it up to ``h_coarse`` (module docstring).

    Parameters
    ----------
    gmsh : module
        The session's ``gmsh`` (:func:`session`).
    h, h_coarse : float
        Edge lengths inside the box and far from it (length).
    box : (float, float, float, float)
        ``(x0, x1, y0, y1)``.
    z : (float, float)
        The box's extent in z; ``(0, 0)`` in 2D (a slab around the plane is used).
    grading : float
        Growth rate of the length away from the box (length per length).
    ratio : float
        gmsh's edge over the size it is given: the lengths prescribed are divided by it
        (:data:`TET_EDGE_RATIO` in 3D, 1 in 2D).
    """
    field = gmsh.model.mesh.field
    tag = field.add("Box")
    x0, x1, y0, y1 = box
    # In 2D the points have z = 0: a slab around it, so that rounding cannot put them outside.
    z0, z1 = (z[0], z[1]) if z[1] > z[0] else (-1.0, 1.0)
    values = {"VIn": h / ratio, "VOut": h_coarse / ratio, "XMin": x0, "XMax": x1, "YMin": y0,
              "YMax": y1, "ZMin": z0, "ZMax": z1, "Thickness": (h_coarse - h) / grading}
    for key, value in values.items():
        field.setNumber(tag, key, value)
    field.setAsBackgroundMesh(tag)


# --- reading the mesh and its physical groups --------------------------------------------------

def read_model(gmsh, source) -> Mesh:
    """The current gmsh model's mesh and physical groups as a :class:`Mesh` (the rules of
    :func:`from_file`).

    Parameters
    ----------
    gmsh : module
        The session's ``gmsh``, its model meshed.
    source : str
        The model's name in error messages.

    Returns
    -------
    Mesh

    Raises
    ------
    ValueError
        As :func:`from_file`.
    """
    mesh_api = gmsh.model.mesh
    types = [int(t) for t in mesh_api.getElementTypes()]
    properties = {t: mesh_api.getElementProperties(t) for t in types}  # (name, dim, order, ...)
    dim = max((properties[t][1] for t in types), default=0)
    if dim < 2:
        raise ValueError(f"{source}: no triangles or tetrahedra in the mesh")
    others = sorted(properties[t][0] for t in types if properties[t][1] == dim and t != SIMPLEX_TYPE[dim])
    if others:
        raise ValueError(f"{source}: only 3-node triangles (2D) and 4-node tetrahedra (3D) are "
                         f"supported, the mesh also has {others}")

    node_tags, coords, _ = mesh_api.getNodes(returnParametricCoord=False)
    order = np.argsort(node_tags, kind="stable")
    node_tags = np.asarray(node_tags, dtype=np.int64)[order]
    coords = np.asarray(coords, dtype=np.float64).reshape(-1, 3)[order]
    cell_tags, cell_nodes = mesh_api.getElementsByType(SIMPLEX_TYPE[dim])
    cell_tags = np.asarray(cell_tags, dtype=np.int64)
    cell_nodes = np.asarray(cell_nodes, dtype=np.int64).reshape(-1, dim + 1)

    # Keep the nodes of the cells only, numbered in the order of their tags.
    used = np.unique(cell_nodes)
    position = np.searchsorted(node_tags, used)
    if np.any(position >= len(node_tags)) or np.any(node_tags[np.minimum(position, len(node_tags) - 1)]
                                                    != used):
        raise ValueError(f"{source}: cells refer to nodes that are not in the mesh")
    points = coords[position]
    if dim == 2:
        if np.any(points[:, 2] != 0.0):
            raise ValueError(f"{source}: a triangle mesh must lie in the plane z = 0 "
                             f"(|z| up to {np.abs(points[:, 2]).max():g})")
        points = points[:, :2]
    points = np.ascontiguousarray(points)

    def node_index(tags, what):
        tags = np.asarray(tags, dtype=np.int64)
        i = np.searchsorted(used, tags)
        ok = (i < len(used)) & (used[np.minimum(i, len(used) - 1)] == tags)
        if not np.all(ok):
            raise ValueError(f"{source}: {what} has nodes that belong to no cell")
        return i

    cells = oriented(points, node_index(cell_nodes, "a cell"), source)
    cell_order = np.argsort(cell_tags, kind="stable")

    cell_groups, facet_groups, node_groups = {}, {}, {}
    for gdim, tag in sorted(gmsh.model.getPhysicalGroups()):
        name = gmsh.model.getPhysicalName(gdim, tag) or f"group{tag}"
        entities = gmsh.model.getEntitiesForPhysicalGroup(gdim, tag)
        if gdim == dim:
            tags = _element_tags(gmsh, gdim, entities, dim, source, name)
            i = np.searchsorted(cell_tags[cell_order], tags)
            _merge(cell_groups, name, np.unique(cell_order[i]))
        elif gdim == dim - 1:
            nodes = _element_nodes(gmsh, gdim, entities, source, name)
            _merge(facet_groups, name, node_index(nodes, f"facet group {name!r}").reshape(-1, dim))
        else:
            nodes, _ = mesh_api.getNodesForPhysicalGroup(gdim, tag)
            _merge(node_groups, name, np.unique(node_index(nodes, f"node group {name!r}")))
    for group in (cell_groups, node_groups):
        for name in group:
            group[name] = np.unique(group[name])
    return Mesh(points, cells, cell_groups, facet_groups, node_groups)


def _element_tags(gmsh, dim, entities, cell_dim, source, name):
    """The tags of the cells (simplices of dimension ``dim``) on ``entities``."""
    out = []
    for entity in entities:
        types, tags, _ = gmsh.model.mesh.getElements(dim, entity)
        for t, tag_list in zip(types, tags):
            if t != SIMPLEX_TYPE[cell_dim]:
                raise ValueError(f"{source}: group {name!r} has elements of gmsh type {t}")
            out.append(np.asarray(tag_list, dtype=np.int64))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _element_nodes(gmsh, dim, entities, source, name):
    """The node tags of the simplices of dimension ``dim`` on ``entities``, flat."""
    out = []
    for entity in entities:
        types, _, nodes = gmsh.model.mesh.getElements(dim, entity)
        for t, node_list in zip(types, nodes):
            if t != SIMPLEX_TYPE[dim]:
                raise ValueError(f"{source}: facet group {name!r} has elements of gmsh type {t} "
                                 f"(only 2-node lines and 3-node triangles are supported)")
            out.append(np.asarray(node_list, dtype=np.int64))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _merge(groups, name, values):
    groups[name] = np.concatenate([groups[name], values]) if name in groups else values


def oriented(points, cells, source):
    """``cells`` checked (:mod:`fem3d.mesh_check`: finite coordinates, no degenerate cell, a
    conforming cover without overlaps) and positively oriented, the last two vertices
    swapped where the signed area (volume) is negative.

    Parameters
    ----------
    points : ndarray, shape (n, d)
        Node coordinates, d = 2 or 3.
    cells : ndarray of int, shape (m, d + 1)
        Triangles or tetrahedra.
    source : str
        The mesh's name in error messages.

    Returns
    -------
    ndarray of int, shape (m, d + 1)
        A copy, positively oriented.

    Raises
    ------
    ValueError
        ``"<source>: <what is wrong>"`` if a check fails.
    """
    try:
        cells = oriented_cells(points, cells)
        check_cover(points, cells)
    except ValueError as error:
        raise ValueError(f"{source}: {error}") from None
    return cells


def from_file(path) -> Mesh:
    """A mesh read from a gmsh ``.msh`` file (formats 2.2 and 4.x), with its named groups.

    The cells are the file's triangles, or its tetrahedra if it has any; the mesh's dimension
    is theirs. Physical groups become groups by dimension: of the mesh's dimension cell
    groups, of one less facet groups, of lower dimensions (points; in 3D also curves) node
    groups. A physical group without a name is called ``"group<tag>"``; groups of one kind
    sharing a name are merged. Nodes that belong to no cell (such as the centres of circles)
    are dropped; cells are made positively oriented by swapping two vertices.

    Parameters
    ----------
    path : str or path-like
        The ``.msh`` file.

    Returns
    -------
    Mesh
        Points of shape (n, 2) for triangles (the file's z must then be 0), (n, 3) for
        tetrahedra; node order: the file's node tags, ascending.

    Raises
    ------
    FileNotFoundError
        If there is no such file.
    ValueError
        If the file is not a ``.msh`` file gmsh can read, has no triangles or tetrahedra, has
        other cells of their dimension (quadrangles, second-order elements...), has triangles
        off the plane z = 0 without tetrahedra, has degenerate cells, or a group with nodes in
        no cell.
    """
    path = Path(path)
    if path.suffix.lower() != ".msh":
        raise ValueError(f"from_file: path = {str(path)!r} must be a gmsh .msh file")
    if not path.is_file():
        raise FileNotFoundError(f"from_file: no file {str(path)!r}")
    with session("from_file") as gmsh:
        try:
            gmsh.open(str(path))
        except Exception as error:  # gmsh raises a bare Exception with its last error message
            raise ValueError(f"from_file: gmsh cannot read {str(path)!r}: {error}") from None
        return read_model(gmsh, str(path))


def in_box(xy, box):
    """Which points lie in a box, bounds included.

    Parameters
    ----------
    xy : ndarray, shape (n, >= 2)
        Points (their x and y are used).
    box : (float, float, float, float)
        ``(x0, x1, y0, y1)``.

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    x0, x1, y0, y1 = box
    return (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
