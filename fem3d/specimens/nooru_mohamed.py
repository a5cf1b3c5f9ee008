"""Nooru-Mohamed's double-edge-notched concrete specimen with its two loading platens (the
dissertation's section 3.5.3, Fig. 3.12), meshed by gmsh; lengths in mm.

Geometry and where each dimension comes from
---------------------------------------------
* The specimen: a square 200 x 200 mm (the dissertation's Fig. 3.12, labels "200, 200"), origin
  at its lower left corner, so it is ``0 <= x <= 200, 0 <= y <= 200``.
* Two notches, one on each vertical side at mid-height, 25 mm deep and 5 mm wide (Fig. 3.12,
  labels "25, 5"): ``0 <= x <= 25`` (left) and ``175 <= x <= 200`` (right), both
  ``97.5 <= y <= 102.5``, slots with flat ends; the ligament between their ends is 150 mm.
  Their tips (the middles of the flat ends) are :data:`NOTCH_TIPS`.
* The thickness, 50 mm, is not in the dissertation; it is the
  experiment's (Nooru-Mohamed 1992, the dissertation's reference [87]) and a scene key
  (``model.thickness``), not a geometry one.
* The platens. Fig. 3.12 draws them gray ("rigid") without dimensions. Their layout is the
  usual one of the 4b test (docs/cases.md#nooru-mohamed-load-path-4b): an L-shaped platen glued to the top edge and
  to the upper part of the left side, which the shear force and the normal displacement move
  (``"upper_platen"``), and a fixed one glued to the bottom edge and the lower part of the
  right side (``"lower_platen"``). Nooru-Mohamed's thesis and the re-analyses (Bobinski and
  Tejchman 2014, di Prisco et al.) were not at hand; two public scripts of the test found by
  code search hold the same supports (a FemLab.jl input: the bottom edge and the right side
  below mid-height held, the shear on the left side above mid-height, the normal displacement
  on the top edge; a MATLAB cohesive-crack script, 50 mm thick). Each arm covers the side
  from the specimen's corner to the notch (``arm`` = 97.5 mm by default: glued wherever the
  notch leaves the side, our reading). The platens' thickness (``platen`` = 20 mm) is ours.

Rigid platens as stiff elastic regions
--------------------------------------
The dissertation's platens are rigid. Here each is an elastic region glued to the specimen
(the two share nodes on their interface) whose Young's modulus the scene sets a thousand times
the concrete's (``[model] buffers = {upper_platen = 3e7, lower_platen = 3e7}``, damage held at
0 there). A glued body of modulus ``E_b`` deforms, under the tractions the specimen exerts on
it, ``E / E_b`` times as much as a concrete body of its shape would: the error against rigid
platens is of order ``E / E_b`` (measured: docs/cases.md#nooru-mohamed-load-path-4b). The
loads act on the platens' outer faces: the shear force on ``"upper_left"``, the normal
displacement on ``"upper_top"``, the lower platen held on ``"lower_bottom"`` and
``"lower_right"``.

Mesh
----
Edge length ``h`` in the box ``refine`` (by default the central band 60 <= y <= 140 mm across
the whole width, where the cracks run from the notches), growing to ``h_coarse`` away from it
at the rate ``grading`` (:func:`fem3d.specimens.gmsh_tools.box_field`; see
:mod:`fem3d.specimens.gmsh_tools` on mesh size and determinism: the same arguments give the
same mesh). ``symmetry = "half_turn"`` makes a mesh that is its own image by the half-turn
about the centre (:func:`nooru_mohamed`).
"""

from __future__ import annotations

import numpy as np

from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_box, check_positive, check_sizes
from fem3d.specimens.gmsh_tools import GRADING, box_field, physical, read_model, session
from fem3d.specimens.specimen import Extent, Groups, Specimen, box_area, choice, number, numbers

__all__ = ["nooru_mohamed", "SPECIMEN", "platen_area", "specimen_area", "SIDE", "NOTCH_DEPTH", "NOTCH_WIDTH",
           "NOTCH_TIPS"]

#: The specimen's side (mm).
SIDE = 200.0
#: Depth and width of the two notches (mm).
NOTCH_DEPTH = 25.0
NOTCH_WIDTH = 5.0
#: The middles of the notches' flat ends (mm): where the cracks start.
NOTCH_TIPS = {"left": (NOTCH_DEPTH, 0.5 * SIDE), "right": (SIDE - NOTCH_DEPTH, 0.5 * SIDE)}


#: Defaults of the scene keys (mm): the refined box, the platens' thickness, the length of the
#: side glued to each platen's arm; the mesh's symmetry.
REFINE = (0.0, 200.0, 60.0, 140.0)
PLATEN = 20.0
ARM = 97.5
SYMMETRY = "none"


def nooru_mohamed(h=0.5, h_coarse=10.0, refine=REFINE, platen=PLATEN, arm=ARM, symmetry=SYMMETRY, *,
                  grading=GRADING) -> Mesh:
    """The double-edge-notched specimen and its two L-shaped platens (module docstring), in mm.

    Parameters
    ----------
    h : float
        Edge length (mm) inside ``refine``; the dissertation's run: 0.5 mm.
    h_coarse : float
        Edge length (mm) far from ``refine``, ``>= h``.
    refine : (x0, x1, y0, y1)
        The refined box (mm).
    platen : float
        The platens' thickness (mm), > 0.
    arm : float
        Length (mm) of the side glued to each platen's arm, from the specimen's corner: the
        upper platen holds the left side for ``200 - arm <= y <= 200``, the lower one the right
        side for ``0 <= y <= arm``; in ``(0, 97.5]`` (97.5: down to the notch).
    symmetry : {"none", "half_turn"}
        ``"half_turn"``: the mesh is its own image by the half-turn about the centre (100,
        100), as the geometry and the loads nearly are: the half below the diagonal x + y =
        200 is meshed and turned about the centre, the two halves sharing the nodes of the
        diagonal (a seam across the cracks' paths, not along them). Then the two cracks of a
        run differ only if the evolution makes them (the dissertation leaves open whether its
        cracks' difference comes from the mesh or from non-uniqueness). The box ``refine``
        then sizes the lower left half only (its image sizes the other): give a box that is
        its own image, such as the default.
    grading : float
        Growth rate of the edge length away from ``refine`` (mm per mm).

    Returns
    -------
    Mesh
        Triangles, with the groups

        * cells: ``"specimen"``, ``"upper_platen"`` (``-platen <= x <= 200``, ``200 <= y <=
          200 + platen`` and ``-platen <= x <= 0``, ``200 - arm <= y <= 200``),
          ``"lower_platen"`` (its image by the half-turn about the centre): a partition;
        * facets: ``"upper_left"`` (x = -platen, the upper platen's left face),
          ``"upper_top"`` (y = 200 + platen, its top face), ``"lower_bottom"`` (y =
          -platen), ``"lower_right"`` (x = 200 + platen), ``"notch_left"``,
          ``"notch_right"`` (each notch's two faces and its end).

    Raises
    ------
    ValueError
        Naming the parameter, if a value is out of range.
    """
    h, h_coarse, grading = check_sizes(h, h_coarse, grading)
    refine = check_box("refine", refine)
    p = check_positive("platen", platen)
    arm = check_positive("arm", arm)
    L, a, half = SIDE, NOTCH_DEPTH, 0.5 * NOTCH_WIDTH
    low, high = 0.5 * L - half, 0.5 * L + half      # the notches' faces
    if not arm <= low:
        raise ValueError(f"nooru_mohamed: arm = {arm!r} must be in (0, {low:g}] (the side from the corner to"
                         " the notch)")

    if symmetry not in ("none", "half_turn"):
        raise ValueError(f'nooru_mohamed: symmetry = {symmetry!r} must be "none" or "half_turn"')
    if symmetry == "half_turn":
        return _half_turn(h, h_coarse, refine, p, arm, grading)

    specimen = _dedupe([(0.0, 0.0), (L, 0.0), (L, arm), (L, low), (L - a, low), (L - a, high), (L, high),
                        (L, L), (0.0, L), (0.0, L - arm), (0.0, high), (a, high), (a, low), (0.0, low)])
    upper = [(-p, L - arm), (0.0, L - arm), (0.0, L), (L, L), (L, L + p), (-p, L + p)]
    lower = [(0.0, -p), (L + p, -p), (L + p, arm), (L, arm), (L, 0.0), (0.0, 0.0)]
    z = (0.0, 0.0)

    with session("nooru_mohamed") as gmsh:
        geo = gmsh.model.geo
        tags = _surfaces(geo, [specimen, upper, lower])
        geo.synchronize()
        for name, tag in zip(("specimen", "upper_platen", "lower_platen"), tags):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        tol = 1e-6 * L
        physical(gmsh, 1, "upper_left", (-p, -p), (L - arm, L + p), z, tol)
        physical(gmsh, 1, "upper_top", (-p, L), (L + p, L + p), z, tol)
        physical(gmsh, 1, "lower_bottom", (0.0, L + p), (-p, -p), z, tol)
        physical(gmsh, 1, "lower_right", (L + p, L + p), (-p, arm), z, tol)
        physical(gmsh, 1, "notch_left", (0.0, a), (low, high), z, tol)
        physical(gmsh, 1, "notch_right", (L - a, L), (low, high), z, tol)
        box_field(gmsh, h, h_coarse, refine, z, grading, 1.0)
        gmsh.model.mesh.generate(2)
        mesh = read_model(gmsh, "nooru_mohamed")
    return mesh


def _half_turn(h, h_coarse, refine, p, arm, grading):
    """The mesh of :func:`nooru_mohamed` made point-symmetric: the half below the diagonal
    x + y = 200 (through the centre and the specimen's upper left and lower right corners;
    the cracks do not run along it) meshed by gmsh, its pieces of the diagonal on either side
    of the centre meshed as each other's image (periodic constraints), then the half and its
    image by the half-turn about the centre joined along the diagonal."""
    L, a, half = SIDE, NOTCH_DEPTH, 0.5 * NOTCH_WIDTH
    low, high, c = 0.5 * L - half, 0.5 * L + half, 0.5 * L
    specimen = _dedupe([(0.0, 0.0), (L, 0.0), (c, c), (0.0, L), (0.0, L - arm), (0.0, high), (a, high), (a, low),
                        (0.0, low)])
    upper = [(-p, L - arm), (0.0, L - arm), (0.0, L), (-p, L + p)]    # the upper platen's part: its left arm
    lower = [(0.0, -p), (L + p, -p), (L, 0.0), (0.0, 0.0)]           # the lower platen's: most of its bottom arm
    z = (0.0, 0.0)
    turn = [-1.0, 0.0, 0.0, L, 0.0, -1.0, 0.0, L, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]

    with session("nooru_mohamed") as gmsh:
        geo = gmsh.model.geo
        lines = {}
        tags = _surfaces(geo, [specimen, upper, lower], lines)
        geo.synchronize()
        for name, tag in zip(("specimen", "upper_part", "lower_part"), tags):
            gmsh.model.addPhysicalGroup(2, [tag], name=name)
        tol = 1e-6 * L
        physical(gmsh, 1, "upper_left", (-p, -p), (L - arm, L + p), z, tol)
        physical(gmsh, 1, "lower_bottom", (0.0, L + p), (-p, -p), z, tol)
        physical(gmsh, 1, "notch_left", (0.0, a), (low, high), z, tol)

        seam = [lines[((L, 0.0), (c, c))], lines[((c, c), (0.0, L))], lines[((L + p, -p), (L, 0.0))],
                lines[((0.0, L), (-p, L + p))]]
        gmsh.model.mesh.setPeriodic(1, [seam[1]], [seam[0]], turn)
        gmsh.model.mesh.setPeriodic(1, [seam[3]], [seam[2]], turn)
        gmsh.model.addPhysicalGroup(1, seam, name="seam")
        box_field(gmsh, h, h_coarse, refine, z, grading, 1.0)
        gmsh.model.mesh.generate(2)
        part = read_model(gmsh, "nooru_mohamed")

    n = part.n_nodes
    image = L - part.points                       # the half-turn about (L/2, L/2)
    # The seam's nodes are their own images' (the periodic constraints): join the two halves there.
    on_seam = np.unique(part.facet_groups["seam"])
    key = {tuple(np.round(part.points[i], 6)): i for i in on_seam}
    renumber = np.empty(2 * n, dtype=np.int64)
    renumber[:n] = np.arange(n)
    keep = np.ones(n, dtype=bool)
    keep[on_seam] = False
    renumber[n:][keep] = n + np.arange(int(keep.sum()))
    for i in on_seam:
        j = key.get(tuple(np.round(image[i], 6)))
        if j is None:
            raise RuntimeError(f"nooru_mohamed: the image of the seam node at {part.points[i]} is not a node")
        renumber[n + i] = j
    points = np.concatenate([part.points, image[keep]])
    cells = np.concatenate([part.cells, renumber[n + part.cells]])   # a rotation keeps the orientation
    m, groups, facets = part.n_cells, part.cell_groups, part.facet_groups
    cell_groups = {"specimen": np.concatenate([groups["specimen"], m + groups["specimen"]]),
                   "upper_platen": np.concatenate([groups["upper_part"], m + groups["lower_part"]]),
                   "lower_platen": np.concatenate([groups["lower_part"], m + groups["upper_part"]])}
    facet_groups = {"upper_left": facets["upper_left"], "upper_top": renumber[n + facets["lower_bottom"]],
                    "lower_bottom": facets["lower_bottom"], "lower_right": renumber[n + facets["upper_left"]],
                    "notch_left": facets["notch_left"], "notch_right": renumber[n + facets["notch_left"]]}
    return Mesh(points, cells, cell_groups, facet_groups, {})


def _dedupe(outline):
    """``outline`` without consecutive repeated vertices (``arm`` = 97.5 puts the platens' ends
    on the notches' corners)."""
    out = [outline[0]]
    for xy in outline[1:]:
        if xy != out[-1]:
            out.append(xy)
    return out if out[-1] != out[0] else out[:-1]


def _surfaces(geo, polygons, lines=None):
    """Plane surfaces bounded by ``polygons`` (counter-clockwise (x, y) vertices), sharing the
    points and lines they have in common, so that the mesh is conforming across them; returns
    their tags. ``lines``, if given, is filled with ``{(start, end): line tag}``."""
    points = {}
    lines = {} if lines is None else lines

    def point(xy):
        if xy not in points:
            points[xy] = geo.addPoint(xy[0], xy[1], 0.0)
        return points[xy]

    def line(a, b):
        if (b, a) in lines:
            return -lines[(b, a)]
        if (a, b) not in lines:
            lines[(a, b)] = geo.addLine(point(a), point(b))
        return lines[(a, b)]

    tags = []
    for outline in polygons:
        loop = [line(a, b) for a, b in zip(outline, outline[1:] + outline[:1])]
        tags.append(geo.addPlaneSurface([geo.addCurveLoop(loop)]))
    return tags


def platen_area(platen=20.0, arm=97.5):
    """The area (mm^2) of one platen: its arm along the edge and its arm along the side."""
    return platen * (SIDE + platen) + platen * arm


def specimen_area():
    """The specimen's area (mm^2): the square less the two notches."""
    return SIDE * SIDE - 2.0 * NOTCH_DEPTH * NOTCH_WIDTH


def extent(dim, value):
    """The specimen's and platens' :class:`~fem3d.specimens.specimen.Extent`, fine in the
    ``refine`` box."""
    p = value("platen")
    lower, upper = (-p, -p), (SIDE + p, SIDE + p)
    measure = specimen_area() + 2.0 * platen_area(p, value("arm"))
    return Extent(lower, upper, measure, box_area(value("refine"), (0.0, 0.0), (SIDE, SIDE)))


SPECIMEN = Specimen(
    name="nooru_mohamed", dims=(2,), mesh=nooru_mohamed,
    doc="Nooru-Mohamed's double-edge-notched specimen (mm), `0 <= x, y <= 200`, with two L-shaped platens",
    keys=(numbers("refine", 4, REFINE, "the refined box [x0, x1, y0, y1]"),
          number("platen", PLATEN, "the platens' thickness"),
          number("arm", ARM, "the side each platen covers from the specimen's corner"),
          choice("symmetry", ("none", "half_turn"), SYMMETRY,
                 "`half_turn`: a mesh that is its own image by the half-turn about the centre")),
    groups=Groups(cells=("specimen", "upper_platen", "lower_platen"),
                  facets=("upper_left", "upper_top", "lower_bottom", "lower_right", "notch_left", "notch_right")),
    extent=extent)
