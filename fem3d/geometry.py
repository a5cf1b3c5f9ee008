"""Parametric geometries of the dissertation's chapter-3 experiments, meshed by gmsh, and the
reading of gmsh ``.msh`` files.

Every function returns a :class:`fem3d.mesh.Mesh`: P1 triangles (points of shape (n, 2)) or
tetrahedra (shape (n, 3)), positively oriented, with the named groups listed in its docstring.

Coordinate conventions
----------------------
* L-shaped panel (:func:`lpanel`), lengths in mm: origin at the lower left corner; the vertical
  leg is ``0 <= x <= 250, 0 <= y <= 500``, the horizontal arm ``250 <= x <= 500,
  250 <= y <= 500``, the re-entrant corner is at (250, 250). In 3D the panel is extruded along z
  from 0 to its thickness.
* Three-point bending beam (:func:`three_point_bending`), lengths in inches: origin at the
  bottom of mid-span, the beam is ``-10 <= x <= 10, 0 <= y <= 8``. The dissertation's plots use
  the same origin with the unit L0 = 10 in.

Reading of the dissertation's figures
-------------------------------------
* L-panel, the dissertation's Fig. 3.1 ("all sizes in mm"; labels 300, 200, 300, 250, 30, 200,
  2 x 250): the outer square 2 x 250 mm each way with its lower right quarter removed (Winkler's
  panel); the load on the underside of the arm, 30 mm from its end (x = 470 mm). The gray region
  (damage held at 0, coarse mesh) is read as everything outside the brittle window
  ``0 <= x <= 300, 200 <= y <= 500`` (the labels 300 | 200 along x and 200 | 300 along y): the
  lower 200 mm of the leg and the outer 200 mm of the arm, which holds the load point. That
  window is our reading, hence a parameter. The load is applied through a jacket: the boundary
  strip ``load`` (465 to 475 mm by default, a choice) is its own curve, its midpoint the load
  point. The panel is 100 mm thick ("10 cm in width" in the text).
* 3D L-panel (the dissertation's Fig. 3.5): about 187,000 tetrahedra of edge 2.5 mm "in the brittle
  part", which cannot fill a 100 mm thick brittle window (they fill about 3.4e5 mm^3); the fine
  zone of the 3D run is unknown. Our choice: the whole 100 mm thickness, refined in the same box
  as in 2D over the whole thickness. At h = 2.5 mm that makes about 2.6 million tetrahedra, 14
  times the dissertation's count: a thinner slab or a smaller box are the parameters to change.
* Beam, the dissertation's Fig. 3.6 ("all sizes in inches"; labels f, 0.25, 1.25, T, 2, M, 2, B,
  a, 1, 9, b, b, 9, 1) and Table 3.4: the beam is 20 x 8 in (1 + 9 + 9 + 1 along x), supported
  on its bottom edge 1 in from each end (x = -9 and 9 in) and loaded at the top of mid-span;
  three holes of radius 0.25 in, 2 in apart, the top one 1.25 in below the top edge (y = 6.75,
  4.75, 2.75 in); a notch from the bottom edge at b = 6 in left of mid-span, of depth a = 1 in
  (configuration I) or 2.5 in (configuration II). Table 3.4 gives (a, b); the captions of the dissertation's
  Figs. 3.7-3.11 swap them, the figure labels agree with the table. Not in the dissertation, taken
  from the canonical (Bittencourt-Ingraffea) beam the experiment follows: the holes' abscissa
  x = -4 in and the notch width 0.1 in (a slot with a flat end: our choice of shape).

Mesh size
---------
The dissertation's ``h`` is the average edge length. A gmsh Box field prescribes the edge length
``h`` inside a box (``refine``), and, outside it, a length growing linearly with the distance to
the box at the rate ``grading`` (length per length) up to ``h_coarse``: the transition is
``(h_coarse - h) / grading`` wide. The default rate 0.1 is our choice: a transition about 10
``h_coarse`` wide, gradual enough for the triangles to stay nearly equilateral (minimum quality
0.73, 4 sqrt(3) area over the sum of the squared edges), at the cost of 14 % more triangles than
the refined box holds at h = 0.625 mm (28 % at 1.25 mm).
The size comes from the field only: not from the geometry's points nor extended from the
boundary. With Frontal-Delaunay triangles the median edge in the box is within 1 % of ``h``.
gmsh's tetrahedra are about 1.38 times as long as the size they are asked for: in 3D the field
prescribes ``h / 1.38`` (:data:`TET_EDGE_RATIO`), so that ``h`` is the median edge of the
tetrahedra, the dissertation's meaning (a choice: it makes about 2.5 times as many tetrahedra as
the uncorrected field; the boundary triangles are then 0.72 ``h`` long).

Determinism
-----------
Each call opens and closes its own gmsh session (``gmsh.initialize(readConfigFiles=False,
interruptible=False)``: no configuration file is read and Python's Ctrl-C handler is left alone;
``General.Terminal = 0``: nothing printed) and sets every meshing option that matters
(:data:`GMSH_OPTIONS`: one thread, fixed algorithms and random seed), so the same arguments give
bit-identical meshes with the same gmsh version. A call made while gmsh is initialized elsewhere
in the process is refused rather than closing that session.
"""

from __future__ import annotations

import math
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from fem3d.mesh import Mesh

__all__ = ["lpanel", "three_point_bending", "from_file", "GMSH_OPTIONS", "GRADING", "TET_EDGE_RATIO",
           "NOTCH_DEPTH", "HOLES", "HOLE_RADIUS"]

#: gmsh options set in every session: one thread (parallel meshing is not guaranteed to give the
#: same mesh twice), fixed 2D and 3D algorithms, random seed and optimization passes, and the
#: mesh size taken from the size field only.
GMSH_OPTIONS = {
    "General.NumThreads": 1,
    "Mesh.MaxNumThreads1D": 1,
    "Mesh.MaxNumThreads2D": 1,
    "Mesh.MaxNumThreads3D": 1,
    "Mesh.Algorithm": 6,  # Frontal-Delaunay: near-equilateral triangles, as fast as Delaunay here
    "Mesh.Algorithm3D": 10,  # HXT: 5 times as fast as Delaunay (1) here, same quality
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

#: Default growth rate of the mesh size away from the refined box (length per length).
GRADING = 0.1

#: Median edge of gmsh's tetrahedra over the edge length prescribed by the size field (HXT,
#: gmsh 4.15, measured on the 3D L-panel at h = 2.5 and 5 mm: 1.38). gmsh's 3D meshes are
#: coarser than the size they are asked for (triangles are not): 3D size fields prescribe
#: ``h / TET_EDGE_RATIO`` so that ``h`` is the tetrahedra's edge, as in the dissertation.
TET_EDGE_RATIO = 1.38

#: Notch depth a (in) of the beam's two configurations (the dissertation's Table 3.4).
NOTCH_DEPTH = {"I": 1.0, "II": 2.5}

#: The beam's holes: name -> (x, y) of the centre, in inches; radius :data:`HOLE_RADIUS`.
HOLES = {"hole_B": (-4.0, 2.75), "hole_M": (-4.0, 4.75), "hole_T": (-4.0, 6.75)}
HOLE_RADIUS = 0.25

# The L-panel (mm): the outer square's side, the re-entrant corner.
_PANEL = 500.0
_CORNER = (250.0, 250.0)
# The beam (in): half-length, height, the supports' abscissae, the notch's abscissa.
_BEAM_HALF = 10.0
_BEAM_HEIGHT = 8.0
_SUPPORT_X = 9.0
_NOTCH_X = -6.0

# gmsh element types: 2-node line, 3-node triangle, 4-node tetrahedron; by dimension.
_SIMPLEX_TYPE = {1: 1, 2: 2, 3: 4}


# --- public geometries -------------------------------------------------------------------------

def lpanel(dim=2, h=0.625, h_coarse=12.5, refine=(0.0, 265.0, 240.0, 360.0),
           window=(0.0, 300.0, 200.0, 500.0), load=(465.0, 475.0), near_load=20.0,
           thickness=100.0, *, grading=GRADING) -> Mesh:
    """Winkler's L-shaped panel (the dissertation's Figs. 3.1 and 3.5), lengths in mm.

    The 500 x 500 mm square with its lower right 250 x 250 mm quarter removed, origin at the
    lower left corner, re-entrant corner at (250, 250); in 3D extruded along z from 0 to
    ``thickness``. The arm's underside (y = 250) is split at ``load[0]``, at the load point
    ``x_load = (load[0] + load[1]) / 2`` and at ``load[1]``, so that the loaded strip is made of
    boundary facets with nodes at both ends and a node at the load point. (Splitting the curve
    at the load point gives the mesh that embedding the point would; our choice, because the
    extrusion then carries the load line into 3D as an edge of the geometry.)

    Parameters
    ----------
    dim : {2, 3}
        Triangles in the plane, or tetrahedra of the extruded panel.
    h : float
        Edge length (mm) inside ``refine``, where the crack runs from the corner to the left edge
        (in 3D the tetrahedra's median edge, see :data:`TET_EDGE_RATIO`). The dissertation's
        runs: 0.625 and 0.3125 mm (2D), 2.5 mm (3D).
    h_coarse : float
        Edge length (mm) far from ``refine``, ``>= h``.
    refine : (x0, x1, y0, y1)
        The refined box (mm); in 3D over the whole thickness.
    window : (x0, x1, y0, y1)
        The brittle window (mm), where damage is free; the rest is gray.
    load : (x0, x1)
        The loaded strip of the arm's underside (mm), inside ``250 < x < 500``.
    near_load : float
        Radius (mm) of the ``"near_load"`` cell group around the load point (in 3D around the
        load line, distance in the x-y plane).
    thickness : float
        Thickness (mm) of the 3D panel; unused in 2D.
    grading : float
        Growth rate of the edge length away from ``refine`` (mm per mm); the transition to
        ``h_coarse`` is ``(h_coarse - h) / grading`` wide.

    Returns
    -------
    Mesh
        With the groups

        * cells: ``"window"`` (centroid in ``window``, bounds included) and ``"gray"`` (the
          others): a partition; ``"near_load"`` (centroid within ``near_load`` of the load
          point), which overlaps them;
        * facets: ``"bottom"`` (the leg's bottom, y = 0, 0 <= x <= 250; in 3D the face y = 0),
          ``"load"`` (y = 250, ``load[0] <= x <= load[1]``; in 3D over the whole thickness);
        * nodes: ``"load_point"`` (the node at (x_load, 250); in 3D the nodes of the line
          x = x_load, y = 250), ``"corner"`` (the node at (250, 250); in 3D the nodes of the
          re-entrant edge).

    Raises
    ------
    ValueError
        Naming the parameter, if a value is out of range.
    """
    dim = _check_dim(dim)
    h, h_coarse, grading = _check_sizes(h, h_coarse, grading)
    refine = _check_box("refine", refine)
    window = _check_box("window", window)
    near_load = _check_nonnegative("near_load", near_load)
    thickness = _check_positive("thickness", thickness)
    load = tuple(float(v) for v in _check_sequence("load", load, 2))
    xc, yc = _CORNER
    if not xc < load[0] < load[1] < _PANEL:
        raise ValueError(f"lpanel: load = {load!r} must satisfy {xc:g} < load[0] < load[1] < {_PANEL:g}"
                         " (a strip of the arm's underside)")
    x_load = 0.5 * (load[0] + load[1])
    z = (0.0, thickness) if dim == 3 else (0.0, 0.0)

    with _session("lpanel") as gmsh:
        geo = gmsh.model.geo
        outline = [(0.0, 0.0), (xc, 0.0), (xc, yc), (load[0], yc), (x_load, yc), (load[1], yc),
                   (_PANEL, yc), (_PANEL, _PANEL), (0.0, _PANEL)]
        surface = _polygon(geo, outline)
        if dim == 3:
            geo.extrude([(2, surface)], 0.0, 0.0, thickness)
        geo.synchronize()
        tol = 1e-6 * _PANEL
        _physical(gmsh, dim - 1, "bottom", (0.0, xc), (0.0, 0.0), z, tol)
        _physical(gmsh, dim - 1, "load", load, (yc, yc), z, tol)
        _physical(gmsh, dim - 2, "load_point", (x_load, x_load), (yc, yc), z, tol)
        _physical(gmsh, dim - 2, "corner", (xc, xc), (yc, yc), z, tol)
        _box_field(gmsh, h, h_coarse, refine, z, grading, TET_EDGE_RATIO if dim == 3 else 1.0)
        gmsh.model.mesh.generate(dim)
        mesh = _read_model(gmsh, "lpanel")

    centroids = mesh.points[mesh.cells].mean(axis=1)
    in_window = _in_box(centroids, window)
    distance = np.hypot(centroids[:, 0] - x_load, centroids[:, 1] - yc)
    cell_groups = {"window": np.flatnonzero(in_window), "gray": np.flatnonzero(~in_window),
                   "near_load": np.flatnonzero(distance <= near_load)}
    return Mesh(mesh.points, mesh.cells, cell_groups, mesh.facet_groups, mesh.node_groups)


def three_point_bending(configuration="I", h=0.01, h_coarse=0.25, refine=(-7.0, -2.5, 0.0, 8.0),
                        notch_width=0.1, gray=0.5, *, grading=GRADING) -> Mesh:
    """The asymmetric three-point bending beam with three holes (the dissertation's Fig. 3.6),
    lengths in inches, triangles.

    The beam ``-10 <= x <= 10, 0 <= y <= 8`` (origin at the bottom of mid-span); a notch from
    the bottom edge centred at x = -6, of depth ``a`` = :data:`NOTCH_DEPTH` [configuration] and
    width ``notch_width`` (a slot with a flat end); three holes of radius 0.25 centred at
    x = -4, y = 2.75 (B), 4.75 (M), 6.75 (T) (:data:`HOLES`); the supports (-9, 0) and (9, 0)
    and the load point (0, 8) are vertices of the boundary (its edges are split there, which
    gives the mesh that embedding the points would).

    Parameters
    ----------
    configuration : {"I", "II"}
        Notch depth 1 in (I) or 2.5 in (II) (the dissertation's Table 3.4).
    h : float
        Edge length (in) inside ``refine``; the dissertation's run: 0.01 in.
    h_coarse : float
        Edge length (in) far from ``refine``, ``>= h``.
    refine : (x0, x1, y0, y1)
        The refined box (in): by default from left of the notch to right of the holes, over the
        whole height.
    notch_width : float
        Width of the notch (in), in ``(0, 2)``.
    gray : float
        Radius (in) of the gray disks around the supports and the load point, where damage is
        held at 0 to keep the point loads from cracking the beam.
    grading : float
        Growth rate of the edge length away from ``refine`` (in per in).

    Returns
    -------
    Mesh
        With the groups

        * cells: ``"gray"`` (centroid within ``gray`` of a support or of the load point) and
          ``"beam"`` (the others): a partition; and ``"refined"`` (centroid in ``refine``)
          and ``"coarse"`` (the others), another (a scene may hold the damage at 0 in the
          coarse part, where the mesh cannot resolve a crack band);
        * facets: ``"top"`` (y = 8), ``"bottom"`` (y = 0, the notch's mouth excepted),
          ``"notch"`` (its two sides and its flat end), ``"hole_T"``, ``"hole_M"``,
          ``"hole_B"`` (the holes' boundaries);
        * nodes: ``"support_left"`` (-9, 0), ``"support_right"`` (9, 0), ``"load_point"``
          (0, 8).

    Raises
    ------
    ValueError
        Naming the parameter, if a value is out of range.
    """
    if configuration not in NOTCH_DEPTH:
        raise ValueError(f"three_point_bending: configuration = {configuration!r} must be one of "
                         f"{sorted(NOTCH_DEPTH)}")
    h, h_coarse, grading = _check_sizes(h, h_coarse, grading)
    refine = _check_box("refine", refine)
    notch_width = _check_positive("notch_width", notch_width)
    if not notch_width < 2.0:
        raise ValueError(f"three_point_bending: notch_width = {notch_width!r} must be < 2 in")
    gray = _check_nonnegative("gray", gray)
    depth = NOTCH_DEPTH[configuration]
    L, H, xs, xn = _BEAM_HALF, _BEAM_HEIGHT, _SUPPORT_X, _NOTCH_X
    xn0, xn1 = xn - 0.5 * notch_width, xn + 0.5 * notch_width
    z = (0.0, 0.0)

    with _session("three_point_bending") as gmsh:
        geo = gmsh.model.geo
        outline = [(-L, 0.0), (-xs, 0.0), (xn0, 0.0), (xn0, depth), (xn1, depth), (xn1, 0.0),
                   (xs, 0.0), (L, 0.0), (L, H), (0.0, H), (-L, H)]
        holes = [_circle(geo, x, y, HOLE_RADIUS) for x, y in HOLES.values()]
        _polygon(geo, outline, holes)
        geo.synchronize()
        tol = 1e-6 * L
        _physical(gmsh, 1, "top", (-L, L), (H, H), z, tol)
        _physical(gmsh, 1, "bottom", (-L, L), (0.0, 0.0), z, tol)
        _physical(gmsh, 1, "notch", (xn0, xn1), (0.0, depth), z, tol)
        for name, (x, y) in HOLES.items():
            r = HOLE_RADIUS
            _physical(gmsh, 1, name, (x - r, x + r), (y - r, y + r), z, tol)
        points = {"support_left": (-xs, 0.0), "support_right": (xs, 0.0), "load_point": (0.0, H)}
        for name, (x, y) in points.items():
            _physical(gmsh, 0, name, (x, x), (y, y), z, tol)
        _box_field(gmsh, h, h_coarse, refine, z, grading, 1.0)
        gmsh.model.mesh.generate(2)
        mesh = _read_model(gmsh, "three_point_bending")

    centroids = mesh.points[mesh.cells].mean(axis=1)
    near = np.zeros(mesh.n_cells, dtype=bool)
    for x, y in points.values():
        near |= np.hypot(centroids[:, 0] - x, centroids[:, 1] - y) <= gray
    refined = _in_box(centroids, refine)
    cell_groups = {"gray": np.flatnonzero(near), "beam": np.flatnonzero(~near),
                   "refined": np.flatnonzero(refined), "coarse": np.flatnonzero(~refined)}
    return Mesh(mesh.points, mesh.cells, cell_groups, mesh.facet_groups, mesh.node_groups)


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
    with _session("from_file") as gmsh:
        try:
            gmsh.open(str(path))
        except Exception as error:  # gmsh raises a bare Exception with its last error message
            raise ValueError(f"from_file: gmsh cannot read {str(path)!r}: {error}") from None
        return _read_model(gmsh, str(path))


# --- gmsh session and geometry helpers ---------------------------------------------------------

@contextmanager
def _session(name):
    """A fresh gmsh session with :data:`GMSH_OPTIONS` and an empty model ``name``; finalized
    on exit, also after an error."""
    import gmsh  # here, so that importing the module does not load gmsh's library

    if gmsh.isInitialized():
        raise RuntimeError("fem3d.geometry: gmsh is already initialized in this process; the "
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


def _polygon(geo, outline, holes=()):
    """The plane surface bounded by the closed polygon ``outline`` ((x, y) vertices, counter-
    clockwise) minus the curve loops ``holes``; returns its tag."""
    points = [geo.addPoint(x, y, 0.0) for x, y in outline]
    lines = [geo.addLine(a, b) for a, b in zip(points, points[1:] + points[:1])]
    return geo.addPlaneSurface([geo.addCurveLoop(lines), *holes])


def _circle(geo, x, y, r):
    """The curve loop of the circle of centre (x, y) and radius r, in four quarter arcs (the
    built-in kernel's arcs must be shorter than a half circle); returns its tag."""
    centre = geo.addPoint(x, y, 0.0)
    points = [geo.addPoint(x + r * c, y + r * s, 0.0) for c, s in ((1, 0), (0, 1), (-1, 0), (0, -1))]
    arcs = [geo.addCircleArc(a, centre, b) for a, b in zip(points, points[1:] + points[:1])]
    return geo.addCurveLoop(arcs)


def _physical(gmsh, dim, name, x, y, z, tol):
    """The physical group ``name`` of the entities of dimension ``dim`` lying in the box
    ``x`` x ``y`` x ``z`` (closed intervals, widened by ``tol``)."""
    entities = gmsh.model.getEntitiesInBoundingBox(x[0] - tol, y[0] - tol, z[0] - tol,
                                                   x[1] + tol, y[1] + tol, z[1] + tol, dim)
    if not entities:  # a geometry bug, not a user error: every group is built to exist
        raise RuntimeError(f"fem3d.geometry: no entity of dimension {dim} for group {name!r}")
    gmsh.model.addPhysicalGroup(dim, sorted(tag for _, tag in entities), name=name)


def _box_field(gmsh, h, h_coarse, box, z, grading, ratio):
    """Edge length ``h`` in ``box`` x ``z``, growing at the rate ``grading`` with the distance
    to it up to ``h_coarse``: the background mesh size, the lengths prescribed to gmsh divided
    by ``ratio`` (gmsh's edge over the size it is given)."""
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

def _read_model(gmsh, source) -> Mesh:
    """The current gmsh model's mesh and physical groups as a :class:`Mesh` (see
    :func:`from_file` for the rules); ``source`` names the model in error messages."""
    mesh_api = gmsh.model.mesh
    types = [int(t) for t in mesh_api.getElementTypes()]
    properties = {t: mesh_api.getElementProperties(t) for t in types}  # (name, dim, order, ...)
    dim = max((properties[t][1] for t in types), default=0)
    if dim < 2:
        raise ValueError(f"{source}: no triangles or tetrahedra in the mesh")
    others = sorted(properties[t][0] for t in types if properties[t][1] == dim and t != _SIMPLEX_TYPE[dim])
    if others:
        raise ValueError(f"{source}: only 3-node triangles (2D) and 4-node tetrahedra (3D) are "
                         f"supported, the mesh also has {others}")

    node_tags, coords, _ = mesh_api.getNodes(returnParametricCoord=False)
    order = np.argsort(node_tags, kind="stable")
    node_tags = np.asarray(node_tags, dtype=np.int64)[order]
    coords = np.asarray(coords, dtype=np.float64).reshape(-1, 3)[order]
    cell_tags, cell_nodes = mesh_api.getElementsByType(_SIMPLEX_TYPE[dim])
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

    cells = _oriented(points, node_index(cell_nodes, "a cell"), source)
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
            if t != _SIMPLEX_TYPE[cell_dim]:
                raise ValueError(f"{source}: group {name!r} has elements of gmsh type {t}")
            out.append(np.asarray(tag_list, dtype=np.int64))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _element_nodes(gmsh, dim, entities, source, name):
    """The node tags of the simplices of dimension ``dim`` on ``entities``, flat."""
    out = []
    for entity in entities:
        types, _, nodes = gmsh.model.mesh.getElements(dim, entity)
        for t, node_list in zip(types, nodes):
            if t != _SIMPLEX_TYPE[dim]:
                raise ValueError(f"{source}: facet group {name!r} has elements of gmsh type {t} "
                                 f"(only 2-node lines and 3-node triangles are supported)")
            out.append(np.asarray(node_list, dtype=np.int64))
    return np.concatenate(out) if out else np.zeros(0, dtype=np.int64)


def _merge(groups, name, values):
    groups[name] = np.concatenate([groups[name], values]) if name in groups else values


def _oriented(points, cells, source):
    """``cells`` with the last two vertices swapped where the signed area (volume) is negative.

    Raises
    ------
    ValueError
        If a cell has zero measure.
    """
    edges = points[cells[:, 1:]] - points[cells[:, :1]]  # shape (m, dim, dim): rows are edges
    signed = np.linalg.det(edges)
    if np.any(signed == 0.0):
        raise ValueError(f"{source}: {int(np.sum(signed == 0.0))} degenerate cells (zero measure)")
    cells = cells.copy()
    flip = signed < 0.0
    cells[flip, -2:] = cells[flip, -1:-3:-1]
    return cells


# --- argument checks ---------------------------------------------------------------------------

def _check_dim(dim):
    if isinstance(dim, bool) or dim not in (2, 3):
        raise ValueError(f"dim = {dim!r} must be 2 or 3")
    return int(dim)


def _check_positive(name, value):
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} = {value!r} must be finite and > 0")
    return value


def _check_nonnegative(name, value):
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} = {value!r} must be finite and >= 0")
    return value


def _check_sizes(h, h_coarse, grading):
    h = _check_positive("h", h)
    h_coarse = _check_positive("h_coarse", h_coarse)
    if h_coarse < h:
        raise ValueError(f"h_coarse = {h_coarse!r} must be >= h = {h!r}")
    return h, h_coarse, _check_positive("grading", grading)


def _check_sequence(name, value, n):
    value = tuple(value)
    if len(value) != n or not all(math.isfinite(float(v)) for v in value):
        raise ValueError(f"{name} = {value!r} must be {n} finite numbers")
    return value


def _check_box(name, box):
    x0, x1, y0, y1 = (float(v) for v in _check_sequence(name, box, 4))
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"{name} = {box!r} must be (x0, x1, y0, y1) with x0 < x1 and y0 < y1")
    return x0, x1, y0, y1


def _in_box(xy, box):
    """Which of the points ``xy`` (shape (n, >= 2)) lie in ``box`` = (x0, x1, y0, y1), bounds
    included."""
    x0, x1, y0, y1 = box
    return (xy[:, 0] >= x0) & (xy[:, 0] <= x1) & (xy[:, 1] >= y0) & (xy[:, 1] <= y1)
