"""Winkler's L-shaped panel (the dissertation's Figs. 3.1 and 3.5), meshed by gmsh, lengths in mm.

Coordinates: origin at the lower left corner; the vertical leg is ``0 <= x <= 250,
0 <= y <= 500``, the horizontal arm ``250 <= x <= 500, 250 <= y <= 500``, the re-entrant corner
is at (250, 250). In 3D the panel is extruded along z from 0 to its thickness.

Reading of the dissertation's Fig. 3.1 ("all sizes in mm"; labels 300, 200, 300, 250, 30, 200,
2 x 250): the outer square 2 x 250 mm each way with its lower right quarter removed (Winkler's
panel); the load on the underside of the arm, 30 mm from its end (x = 470 mm). The gray region
(damage held at 0, coarse mesh) is read as everything outside the brittle window
``0 <= x <= 300, 200 <= y <= 500`` (the labels 300 | 200 along x and 200 | 300 along y): the
lower 200 mm of the leg and the outer 200 mm of the arm, which holds the load point. That
window is our reading, hence a parameter. The load is applied through a jacket: the boundary
strip ``load`` (465 to 475 mm by default, a choice) is its own curve, its midpoint the load
point. The panel is 100 mm thick ("10 cm in width" in the text). In 3D the refined box covers
the whole thickness (the dissertation's 3D fine zone is unknown:
docs/cases.md#l-shaped-panel-in-3d).
"""

from __future__ import annotations

import numpy as np

from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_box, check_dim, check_nonnegative, check_positive, check_sequence, check_sizes
from fem3d.specimens.gmsh_tools import (GRADING, TET_EDGE_RATIO, box_field, in_box, physical, polygon, read_model,
                                        session)
from fem3d.specimens.specimen import DIMS, Extent, Front, Groups, Specimen, box_area, number, numbers

__all__ = ["lpanel", "SPECIMEN", "SIDE", "CORNER"]

#: The outer square's side (mm).
SIDE = 500.0
#: The re-entrant corner (mm).
CORNER = (250.0, 250.0)
#: Defaults of the scene keys (mm): the refined box where the crack runs, the brittle window,
#: the loaded strip, the radius of ``"near_load"``, the 3D panel's thickness.
REFINE = (0.0, 265.0, 240.0, 360.0)
WINDOW = (0.0, 300.0, 200.0, 500.0)
LOAD = (465.0, 475.0)
NEAR_LOAD = 20.0
THICKNESS = 100.0


def lpanel(dim=2, h=0.625, h_coarse=12.5, refine=REFINE, window=WINDOW, load=LOAD, near_load=NEAR_LOAD,
           thickness=THICKNESS, *, grading=GRADING) -> Mesh:
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
    dim = check_dim(dim)
    h, h_coarse, grading = check_sizes(h, h_coarse, grading)
    refine = check_box("refine", refine)
    window = check_box("window", window)
    near_load = check_nonnegative("near_load", near_load)
    thickness = check_positive("thickness", thickness)
    load = tuple(float(v) for v in check_sequence("load", load, 2))
    xc, yc = CORNER
    if not xc < load[0] < load[1] < SIDE:
        raise ValueError(f"lpanel: load = {load!r} must satisfy {xc:g} < load[0] < load[1] < {SIDE:g}"
                         " (a strip of the arm's underside)")
    x_load = 0.5 * (load[0] + load[1])
    z = (0.0, thickness) if dim == 3 else (0.0, 0.0)

    with session("lpanel") as gmsh:
        geo = gmsh.model.geo
        outline = [(0.0, 0.0), (xc, 0.0), (xc, yc), (load[0], yc), (x_load, yc), (load[1], yc),
                   (SIDE, yc), (SIDE, SIDE), (0.0, SIDE)]
        surface = polygon(geo, outline)
        if dim == 3:
            geo.extrude([(2, surface)], 0.0, 0.0, thickness)
        geo.synchronize()
        tol = 1e-6 * SIDE
        physical(gmsh, dim - 1, "bottom", (0.0, xc), (0.0, 0.0), z, tol)
        physical(gmsh, dim - 1, "load", load, (yc, yc), z, tol)
        physical(gmsh, dim - 2, "load_point", (x_load, x_load), (yc, yc), z, tol)
        physical(gmsh, dim - 2, "corner", (xc, xc), (yc, yc), z, tol)
        box_field(gmsh, h, h_coarse, refine, z, grading, TET_EDGE_RATIO if dim == 3 else 1.0)
        gmsh.model.mesh.generate(dim)
        mesh = read_model(gmsh, "lpanel")

    centroids = mesh.points[mesh.cells].mean(axis=1)
    in_window = in_box(centroids, window)
    distance = np.hypot(centroids[:, 0] - x_load, centroids[:, 1] - yc)
    cell_groups = {"window": np.flatnonzero(in_window), "gray": np.flatnonzero(~in_window),
                   "near_load": np.flatnonzero(distance <= near_load)}
    return Mesh(mesh.points, mesh.cells, cell_groups, mesh.facet_groups, mesh.node_groups)


def extent(dim, value):
    """The panel's :class:`~fem3d.specimens.specimen.Extent`: the L of side SIDE (extruded by
    ``depth`` in 3D), fine in the ``refine`` box."""
    lower, upper = (0.0, 0.0), (SIDE, SIDE)
    area = SIDE**2 - (SIDE - CORNER[0]) * (SIDE - CORNER[1])
    fine = min(box_area(value("refine"), lower, upper), area)
    if dim == 2:
        return Extent(lower, upper, area, fine)
    depth = value("depth")
    return Extent(lower + (0.0,), upper + (depth,), area * depth, fine * depth)


SPECIMEN = Specimen(
    name="lpanel", dims=DIMS, mesh=lpanel, takes_dim=True,
    doc="Winkler's L-shaped panel (mm): the 500 x 500 mm square without its lower right 250 x 250 mm quarter,"
        " re-entrant corner at (250, 250); in 3D extruded in z over `depth`",
    keys=(numbers("refine", 4, REFINE, "the refined box [x0, x1, y0, y1] where the crack runs"),
          numbers("window", 4, WINDOW, "the brittle window [x0, x1, y0, y1]; the rest is the region `gray`"),
          numbers("load", 2, LOAD, "the loaded strip [x0, x1] of the arm's underside"),
          number("near_load", NEAR_LOAD, "radius of the region `near_load` about the load point"),
          number("depth", THICKNESS, "the 3D panel's extrusion in z", argument="thickness", dims=(3,),
                 note="is the 3D panel's extrusion (model.dim = 3); a 2D panel's thickness is model.thickness")),
    groups=Groups(cells=("window", "gray", "near_load"), facets=("bottom", "load"), nodes=("load_point", "corner")),
    front=Front(width="depth"), extent=extent)
