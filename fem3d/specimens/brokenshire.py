"""Brokenshire's torsion test (the dissertation's section 3.5.4, Fig. 3.16), meshed by gmsh:
a notched concrete prism twisted through two steel frames, lengths in mm.

Coordinates
-----------
The prism is ``0 <= x <= length`` (its axis), ``-50 <= y <= 50``, ``0 <= z <= 100`` (z up: the
load is vertical). The notch is cut from the top face at mid-length: a slot of ``notch_width``
through the whole width, ``notch_depth`` deep (its flat floor at z = 100 - notch_depth), whose
mid-plane contains the vertical and makes ``notch_angle`` with the axis (counterclockwise
seen from above, the plane through (length / 2, 0) along ``(cos a, sin a, 0)``).

Each end is held in a steel frame: a collar, ``FRAME_LENGTH`` = 25 mm long along x, 12.5 mm
thick around the section (``-62.5 <= y <= 62.5, -12.5 <= z <= 112.5`` minus the prism), and an
arm 25 x 25 mm at mid-height (``37.5 <= z <= 62.5``) reaching ``|y| = lever`` (125 mm). The
four points where the rig holds or pushes the frames are the centres of the arms' end faces,
``(x_f, +-lever, 50)`` with ``x_f = 12.5`` and ``length - 12.5``:

=========================  ==========================  ==================================
group                      point                       role in the case file
=========================  ==========================  ==================================
``support_a``              (12.5, -lever, 50)          held (x, y, z): pushes up
``support_b``              (12.5, +lever, 50)          held (x, z): holds down
``support_c``              (length - 12.5, +lever, 50) held (z): pushes up
``load_point``             (length - 12.5, -lever, 50) pushed down, u_z = -t
=========================  ==========================  ==================================

Six components held, a statically determinate support of the rigid motions: the reactions
are +P, -P, +P at a, b, c for a force P at the load point, so the prism between the frames
carries a pure torque ``2 lever P`` about x, with the far end turning positively about +x.
That turn opens the notch at 45 deg (on the top face the tension is normal to it: its faces
move apart); with ``notch_angle = 135`` the same load closes it (the gap shrinks as much).

Sources of the dimensions
-------------------------
The dissertation gives none; its Fig. 3.16 keeps only the labels 25, 100, 45 deg, 5, 50, 25,
delta, 200, 75, 100, 75, 25 (mm). Taken from the literature on
Brokenshire's test (D. R. Brokenshire, PhD thesis, Cardiff University, 1996, as re-analysed):

* the prism, 400 mm long with a 100 x 100 mm section: the MoFEM benchmark of the test
  (``mofem/meshes/torsion.jou`` in the MoFEM repository: ``brick x 100 y 100 z 400``), which
  matches the figure's 100 and 200 (half the length, the notch at mid-length) labels;
* the notch, 5 mm wide and 50 mm deep, at 45 deg to the axis: the MoFEM wiki page "Concrete
  torsion test" ("5 mm wide and 50 mm deep machined at 45 deg to the length direction
  centre-line"), and the figure's 5, 50 and 45 deg labels;
* the frames: the same page ("restrained at each end in a two-part loading collar which
  features lugs [on] spherical ended load applicators positioned at each corner"; at two
  diagonally opposite corners the specimen is held on the underside of the lugs) and the
  MoFEM journal (a 125 x 125 x 25 mm collar and a 25 x 25 mm arm at each end, steel); the
  arms' reach 75 + 100 + 75 = 250 mm is the figure's 75, 100, 75 labels (the MoFEM journal's
  arm is 210 mm: we follow the dissertation's figure), the collar's 25 mm length its 25 labels.

Where the sources differ or are silent, our reading: the lever 125 mm (the figure, not the
journal's 105 mm); the applicators as single nodes at the centres of the arms' end faces (the
journal uses vertices of the frames' edges); the frames bonded to the prism (the collars clamp
it);
which corner is loaded, chosen so that the notch opens (mirror images of each other
otherwise). The MoFEM page also describes lengths of 270 and 450 mm; 400 mm is the journal's
length and the one usually quoted for the test.

Why steel frames rather than loads on the prism: the frames carry the torque into the end
25 mm of the prism over the collar's whole perimeter, as the rig does; loads on the prism's
corners would put the lever arm at 50 mm instead of 125 mm and concentrate the stress where
the dissertation's gray frame has none. They cost little: about 0.44e6 mm^3 meshed at
``h_coarse``, damage held at 0 (the scene's ``buffers = {frame = E_steel}``).

Mesh size: ``h`` (the tetrahedra's median edge, see
:data:`fem3d.specimens.gmsh_tools.TET_EDGE_RATIO`) in the band ``|x - length / 2| <= refine``
(the scene's ``band``) over the whole section, where the notch is and the crack runs, growing
at the rate ``grading`` to ``h_coarse`` elsewhere (the module docstring of
:mod:`fem3d.specimens.gmsh_tools`). One gmsh session per call, deterministic.
"""

from __future__ import annotations

import math

import numpy as np

from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_nonnegative, check_positive, check_sizes
from fem3d.specimens.gmsh_tools import GRADING, TET_EDGE_RATIO, box_field, physical, read_model, session
from fem3d.specimens.specimen import NO_FRONT, Extent, Groups, Specimen, number

__all__ = ["brokenshire", "SPECIMEN", "SECTION", "FRAME_LENGTH", "COLLAR", "ARM", "notch_normal", "notch_distance"]

#: Side of the prism's square section (mm).
SECTION = 100.0
#: Length of each frame along the prism's axis (mm).
FRAME_LENGTH = 25.0
#: Thickness of the collars around the section (mm): 125 x 125 mm outside.
COLLAR = 12.5
#: Side of the arms' square section (mm), centred at mid-height.
ARM = 25.0

#: Defaults of the scene keys (mm, degrees): the prism's length, the notch's angle with the axis,
#: depth and width, the lever of the load and support points, the half-length of the refined
#: band, the length of the prism's gray ends.
LENGTH = 400.0
NOTCH_ANGLE = 45.0
NOTCH_DEPTH = 50.0
NOTCH_WIDTH = 5.0
LEVER = 125.0
BAND = 75.0
GRAY = 75.0


def notch_normal(notch_angle):
    """The unit normal (3,) of the notch's mid-plane for ``notch_angle`` (degrees)."""
    a = math.radians(notch_angle)
    return np.array([-math.sin(a), math.cos(a), 0.0])


def notch_distance(points, length=LENGTH, notch_angle=NOTCH_ANGLE):
    """Signed distance (mm) of ``points`` (shape (n, >= 2)) from the notch's mid-plane."""
    n = notch_normal(notch_angle)
    return (points[:, 0] - 0.5 * length) * n[0] + points[:, 1] * n[1]


def brokenshire(h=6.25, h_coarse=25.0, length=LENGTH, notch_angle=NOTCH_ANGLE, notch_depth=NOTCH_DEPTH,
                notch_width=NOTCH_WIDTH, lever=LEVER, refine=BAND, gray=GRAY, *, grading=GRADING) -> Mesh:
    """The notched prism of Brokenshire's torsion test in its two steel frames, tetrahedra
    (module docstring: coordinates, points, sources).

    Parameters
    ----------
    h : float
        Median edge (mm) in the band ``|x - length / 2| <= refine``. The dissertation: 2.5 mm
        near the notch.
    h_coarse : float
        Edge (mm) far from the band and in the frames, ``>= h``.
    length : float
        The prism's length (mm), > 2 (``gray`` + 25) and > 2 ``refine``.
    notch_angle : float
        Angle (degrees) of the notch's mid-plane with the axis, in (10, 170).
    notch_depth : float
        Depth (mm) of the notch from the top face, in (0, 100).
    notch_width : float
        Width (mm) of the notch, in (0, 20).
    lever : float
        Distance (mm) from the axis to the load and support points, > 62.5 + 12.5.
    refine : float
        Half-length (mm) of the refined band about mid-length.
    gray : float
        Length (mm) of the prism's ends (from each end face) where the damage is to be held
        at 0 (the ``"gray"`` group): the collars (25 mm) and beyond, where the torque enters.
    grading : float
        Growth rate of the edge away from the band (mm per mm).

    Returns
    -------
    Mesh
        With the groups

        * cells: ``"specimen"`` (the concrete prism) and ``"frame"`` (the two steel frames), a
          partition; ``"gray"`` (prism cells with centroid within ``gray`` of an end face) and
          ``"refined"`` (centroid in the band), which overlap ``"specimen"``;
        * facets: ``"notch"`` (the slot's two faces and its floor), ``"top"`` (z = 100, the
          notch's mouth excepted), ``"bottom"`` (z = 0);
        * nodes: ``"support_a"``, ``"support_b"``, ``"support_c"``, ``"load_point"`` (one node
          each, module docstring) and ``"notch_floor"`` (the nodes of the notch's floor).

    Raises
    ------
    ValueError
        Naming the parameter, if a value is out of range.
    """
    h, h_coarse, grading = check_sizes(h, h_coarse, grading)
    length = check_positive("length", length)
    notch_angle, notch_depth = float(notch_angle), check_positive("notch_depth", notch_depth)
    notch_width, lever = check_positive("notch_width", notch_width), check_positive("lever", lever)
    refine, gray = check_positive("refine", refine), check_nonnegative("gray", gray)
    if not (math.isfinite(notch_angle) and 10.0 < notch_angle < 170.0):
        raise ValueError(f"brokenshire: notch_angle = {notch_angle!r} must be in (10, 170) degrees")
    if not notch_depth < SECTION:
        raise ValueError(f"brokenshire: notch_depth = {notch_depth!r} must be < {SECTION:g} mm")
    if not notch_width < 20.0:
        raise ValueError(f"brokenshire: notch_width = {notch_width!r} must be < 20 mm")
    half, outer = 0.5 * SECTION, 0.5 * SECTION + COLLAR
    if not lever > outer + ARM / 2:
        raise ValueError(f"brokenshire: lever = {lever!r} must be > {outer + ARM / 2:g} mm (beyond the collar)")
    # the notch's footprint spans x = length/2 +- (half / tan(angle) + width); it must stay
    # clear of the frames and of the gray ends
    reach = half / abs(math.tan(math.radians(notch_angle))) + notch_width
    if not length > 2.0 * (max(gray, FRAME_LENGTH) + reach):
        raise ValueError(f"brokenshire: length = {length!r} must be > 2 (max(gray, {FRAME_LENGTH:g}) + "
                         f"{reach:.4g}) mm: the notch must not reach the frames or the gray ends")
    if not refine < 0.5 * length:
        raise ValueError(f"brokenshire: refine = {refine!r} must be < length / 2 = {0.5 * length:g} mm")

    mid, floor = 0.5 * length, SECTION - notch_depth
    arm_z = (0.5 * SECTION - 0.5 * ARM, 0.5 * SECTION + 0.5 * ARM)
    frame_x = (0.5 * FRAME_LENGTH, length - 0.5 * FRAME_LENGTH)
    points = {"support_a": (frame_x[0], -lever), "support_b": (frame_x[0], lever),
              "support_c": (frame_x[1], lever), "load_point": (frame_x[1], -lever)}
    normal = notch_normal(notch_angle)
    tol = 1e-6 * length

    with session("brokenshire") as gmsh:
        occ = gmsh.model.occ
        prism = occ.addBox(0.0, -half, 0.0, length, SECTION, SECTION)
        slot_length = 2.0 * (SECTION / abs(math.sin(math.radians(notch_angle))) + notch_width)
        slot = occ.addBox(mid - 0.5 * slot_length, -0.5 * notch_width, floor, slot_length, notch_width,
                          notch_depth + SECTION)
        occ.rotate([(3, slot)], mid, 0.0, 0.0, 0.0, 0.0, 1.0, math.radians(notch_angle))
        pieces = [(3, prism)]
        pieces, _ = occ.cut(pieces, [(3, slot)])
        frames = []
        for x0 in (0.0, length - FRAME_LENGTH):
            collar = occ.addBox(x0, -outer, -COLLAR, FRAME_LENGTH, 2 * outer, SECTION + 2 * COLLAR)
            arm = occ.addBox(x0, -lever, arm_z[0], FRAME_LENGTH, 2 * lever, ARM)
            hole = occ.addBox(x0 - 1.0, -half, 0.0, FRAME_LENGTH + 2.0, SECTION, SECTION)
            frame, _ = occ.fuse([(3, collar)], [(3, arm)])
            frame, _ = occ.cut(frame, [(3, hole)])
            frames += frame
        occ.fragment(pieces, frames)
        occ.synchronize()

        # The frames reach beyond the prism's section; the prism's pieces do not.
        specimen, frame = [], []
        for _, tag in gmsh.model.getEntities(3):
            x0, y0, z0, x1, y1, z1 = gmsh.model.getBoundingBox(3, tag)
            inside = y0 >= -half - tol and y1 <= half + tol and z0 >= -tol and z1 <= SECTION + tol
            (specimen if inside else frame).append(tag)
        gmsh.model.addPhysicalGroup(3, specimen, name="specimen")
        gmsh.model.addPhysicalGroup(3, frame, name="frame")

        # The notch's faces: the boundary surfaces all of whose vertices lie in the slot.
        notch = []
        for _, tag in gmsh.model.getEntities(2):
            corners = gmsh.model.getBoundary([(2, tag)], combined=False, recursive=True)
            xyz = np.array([gmsh.model.getValue(0, p, []) for _, p in corners])
            d = (xyz[:, 0] - mid) * normal[0] + xyz[:, 1] * normal[1]
            if np.all(np.abs(d) <= 0.5 * notch_width + tol) and np.all(xyz[:, 2] >= floor - tol):
                notch.append(tag)
        gmsh.model.addPhysicalGroup(2, notch, name="notch")
        # (the prism's faces inside the collars are interfaces, not boundaries)
        free = (FRAME_LENGTH, length - FRAME_LENGTH)
        physical(gmsh, 2, "top", free, (-half, half), (SECTION, SECTION), tol)
        physical(gmsh, 2, "bottom", free, (-half, half), (0.0, 0.0), tol)
        floor_faces = [tag for tag in notch if abs(gmsh.model.getBoundingBox(2, tag)[5] - floor) <= tol]
        gmsh.model.addPhysicalGroup(2, floor_faces, name="notch_floor_faces")

        # The applicators: points embedded in the arms' end faces.
        for name, (x, y) in points.items():
            z = 0.5 * SECTION
            faces = gmsh.model.getEntitiesInBoundingBox(x - FRAME_LENGTH, y - tol, z - ARM, x + FRAME_LENGTH,
                                                        y + tol, z + ARM, 2)
            point = occ.addPoint(x, y, z)
            occ.synchronize()
            gmsh.model.mesh.embed(0, [point], 2, faces[0][1])
            gmsh.model.addPhysicalGroup(0, [point], name=name)

        box_field(gmsh, h, h_coarse, (mid - refine, mid + refine, -half, half), (0.0, SECTION), grading,
                   TET_EDGE_RATIO)
        gmsh.model.mesh.generate(3)
        mesh = read_model(gmsh, "brokenshire")

    facets = dict(mesh.facet_groups)
    nodes = dict(mesh.node_groups)
    nodes["notch_floor"] = np.unique(facets.pop("notch_floor_faces"))
    cells = dict(mesh.cell_groups)
    in_prism = np.zeros(mesh.n_cells, dtype=bool)
    in_prism[cells["specimen"]] = True
    x = mesh.points[mesh.cells].mean(axis=1)[:, 0]
    cells["gray"] = np.flatnonzero(in_prism & ((x <= gray) | (x >= length - gray)))
    cells["refined"] = np.flatnonzero(in_prism & (np.abs(x - mid) <= refine))
    return Mesh(mesh.points, mesh.cells, cells, facets, nodes)


def extent(dim, value):
    """The prism's and frames' :class:`~fem3d.specimens.specimen.Extent`, fine in the band
    ``|x - length / 2| <= band``."""
    length, lever = value("length"), value("lever")
    outer = SECTION + 2.0 * COLLAR
    frames = 2.0 * FRAME_LENGTH * (outer**2 - SECTION**2 + 2.0 * ARM * max(lever - outer / 2.0, 0.0))
    lower, upper = (0.0, -lever, -COLLAR), (length, lever, SECTION + COLLAR)
    return Extent(lower, upper, length * SECTION**2 + frames, min(2.0 * value("band"), length) * SECTION**2)


SPECIMEN = Specimen(
    name="brokenshire", dims=(3,), mesh=brokenshire,
    doc="Brokenshire's torsion test (mm): the notched prism `0 <= x <= length`, `-50 <= y <= 50`, `0 <= z <= 100` in"
        " its two steel frames",
    keys=(number("length", LENGTH, "the prism's length"),
          number("notch_angle", NOTCH_ANGLE, "the notch's angle with the axis", units="degree"),
          number("notch_depth", NOTCH_DEPTH, "the notch's depth from the top face"),
          number("notch_width", NOTCH_WIDTH, "the notch's width"),
          number("lever", LEVER, "distance from the axis to the load and support points"),
          number("band", BAND, "half-length of the refined band about mid-length", argument="refine"),
          number("gray", GRAY, "length of the prism's ends in the region `gray`")),
    groups=Groups(cells=("specimen", "frame", "gray", "refined"), facets=("notch", "top", "bottom"),
                  nodes=("support_a", "support_b", "support_c", "load_point", "notch_floor")),
    front=NO_FRONT, extent=extent)
