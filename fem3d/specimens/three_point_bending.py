"""The asymmetric three-point bending beam with three holes (the dissertation's Fig. 3.6),
meshed by gmsh in triangles, lengths in inches.

Coordinates: origin at the bottom of mid-span, the beam is ``-10 <= x <= 10, 0 <= y <= 8``. The
dissertation's plots use the same origin with the unit L0 = 10 in.

Reading of the dissertation's Fig. 3.6 ("all sizes in inches"; labels f, 0.25, 1.25, T, 2, M,
2, B, a, 1, 9, b, b, 9, 1) and Table 3.4: the beam is 20 x 8 in (1 + 9 + 9 + 1 along x),
supported on its bottom edge 1 in from each end (x = -9 and 9 in) and loaded at the top of
mid-span; three holes of radius 0.25 in, 2 in apart, the top one 1.25 in below the top edge
(y = 6.75, 4.75, 2.75 in); a notch from the bottom edge at b = 6 in left of mid-span, of depth
a = 1 in (configuration I) or 2.5 in (configuration II). Table 3.4 gives (a, b); the captions
of the dissertation's Figs. 3.7-3.11 swap them, the figure labels agree with the table. Not in
the dissertation, taken from the canonical (Bittencourt-Ingraffea) beam the experiment
follows: the holes' abscissa x = -4 in and the notch width 0.1 in (a slot with a flat end: our
choice of shape).
"""

from __future__ import annotations

import numpy as np

from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_box, check_nonnegative, check_positive, check_sizes
from fem3d.specimens.gmsh_tools import GRADING, box_field, circle, in_box, physical, polygon, read_model, session
from fem3d.specimens.specimen import Extent, Groups, Specimen, box_area, choice, number, numbers

__all__ = ["three_point_bending", "SPECIMEN", "NOTCH_DEPTH", "HOLES", "HOLE_RADIUS"]

#: Notch depth a (in) of the beam's two configurations (the dissertation's Table 3.4).
NOTCH_DEPTH = {"I": 1.0, "II": 2.5}

#: The beam's holes: name -> (x, y) of the centre, in inches; radius :data:`HOLE_RADIUS`.
HOLES = {"hole_B": (-4.0, 2.75), "hole_M": (-4.0, 4.75), "hole_T": (-4.0, 6.75)}
HOLE_RADIUS = 0.25

#: The beam (in): half-length, height, the supports' abscissae, the notch's abscissa.
HALF_LENGTH = 10.0
HEIGHT = 8.0
SUPPORT_X = 9.0
NOTCH_X = -6.0

#: Defaults of the scene keys: the configuration, the refined box (in), the notch's width (in),
#: the radius of the gray disks (in).
CONFIGURATION = "I"
REFINE = (-7.0, -2.5, 0.0, 8.0)
NOTCH_WIDTH = 0.1
GRAY = 0.5


def three_point_bending(configuration=CONFIGURATION, h=0.01, h_coarse=0.25, refine=REFINE, notch_width=NOTCH_WIDTH,
                        gray=GRAY, *, grading=GRADING) -> Mesh:
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
    h, h_coarse, grading = check_sizes(h, h_coarse, grading)
    refine = check_box("refine", refine)
    notch_width = check_positive("notch_width", notch_width)
    if not notch_width < 2.0:
        raise ValueError(f"three_point_bending: notch_width = {notch_width!r} must be < 2 in")
    gray = check_nonnegative("gray", gray)
    depth = NOTCH_DEPTH[configuration]
    L, H, xs, xn = HALF_LENGTH, HEIGHT, SUPPORT_X, NOTCH_X
    xn0, xn1 = xn - 0.5 * notch_width, xn + 0.5 * notch_width
    z = (0.0, 0.0)

    with session("three_point_bending") as gmsh:
        geo = gmsh.model.geo
        outline = [(-L, 0.0), (-xs, 0.0), (xn0, 0.0), (xn0, depth), (xn1, depth), (xn1, 0.0),
                   (xs, 0.0), (L, 0.0), (L, H), (0.0, H), (-L, H)]
        holes = [circle(geo, x, y, HOLE_RADIUS) for x, y in HOLES.values()]
        polygon(geo, outline, holes)
        geo.synchronize()
        tol = 1e-6 * L
        physical(gmsh, 1, "top", (-L, L), (H, H), z, tol)
        physical(gmsh, 1, "bottom", (-L, L), (0.0, 0.0), z, tol)
        physical(gmsh, 1, "notch", (xn0, xn1), (0.0, depth), z, tol)
        for name, (x, y) in HOLES.items():
            r = HOLE_RADIUS
            physical(gmsh, 1, name, (x - r, x + r), (y - r, y + r), z, tol)
        points = {"support_left": (-xs, 0.0), "support_right": (xs, 0.0), "load_point": (0.0, H)}
        for name, (x, y) in points.items():
            physical(gmsh, 0, name, (x, x), (y, y), z, tol)
        box_field(gmsh, h, h_coarse, refine, z, grading, 1.0)
        gmsh.model.mesh.generate(2)
        mesh = read_model(gmsh, "three_point_bending")

    centroids = mesh.points[mesh.cells].mean(axis=1)
    near = np.zeros(mesh.n_cells, dtype=bool)
    for x, y in points.values():
        near |= np.hypot(centroids[:, 0] - x, centroids[:, 1] - y) <= gray
    refined = in_box(centroids, refine)
    cell_groups = {"gray": np.flatnonzero(near), "beam": np.flatnonzero(~near),
                   "refined": np.flatnonzero(refined), "coarse": np.flatnonzero(~refined)}
    return Mesh(mesh.points, mesh.cells, cell_groups, mesh.facet_groups, mesh.node_groups)


def extent(dim, value):
    """The beam's :class:`~fem3d.specimens.specimen.Extent` (holes and notch neglected), fine in
    the ``refine`` box."""
    lower, upper = (-HALF_LENGTH, 0.0), (HALF_LENGTH, HEIGHT)
    return Extent(lower, upper, 2.0 * HALF_LENGTH * HEIGHT, box_area(value("refine"), lower, upper))


SPECIMEN = Specimen(
    name="three_point_bending", dims=(2,), mesh=three_point_bending,
    doc="the 20 x 8 in beam with three holes of the dissertation's Fig. 3.6 (in), origin at the bottom of mid-span",
    keys=(choice("configuration", tuple(NOTCH_DEPTH), CONFIGURATION, "the notch: 1 in deep (I) or 2.5 in (II)"),
          numbers("refine", 4, REFINE, "the refined box [x0, x1, y0, y1]"),
          number("notch_width", NOTCH_WIDTH, "the notch's width"),
          number("gray", GRAY, "radius of the region `gray` about the supports and the load point")),
    groups=Groups(cells=("gray", "beam", "refined", "coarse"),
                  facets=("top", "bottom", "notch", "hole_T", "hole_M", "hole_B"),
                  nodes=("support_left", "support_right", "load_point")),
    extent=extent)
