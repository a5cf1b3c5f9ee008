"""The double-torsion specimen of the dissertation's chapter 4 (Fig. 4.1, Table 4.1), meshed by
gmsh (OpenCASCADE kernel) in P1 tetrahedra, lengths in mm.

Coordinates (docs/cases.md#double-torsion): x along the length, the notched end at x = 0 and the
far end at x = L; y across the width, the crack plane y = 0; z through the thickness, the bottom
(supported, tensile near y = 0) face z = 0, the top (loaded, compressed) face z = T. The plate
is ``0 <= x <= L, -W/2 <= y <= W/2, 0 <= z <= T``.

Readings adopted
----------------
* Dimensions, Table 4.1 (Madjoubi's soda-lime glass): L = 80, W = 40, T = 3, Wm = 17 mm. The
  table's ``Ls = 7 mm`` is read as the starter-notch length a0: it is the only length the
  table could give for a0, which every plot uses and nothing else defines (the other
  candidate, the spacing of the loading points, would leave a0 undefined).
* Wm is the distance of each support from the mid-line (half the support spacing), as Fig. 4.1's
  ``2 Wm`` and the scan's "distance of the support from the center line" say; the text's
  "distance between the supports" would be 2 Wm.
* The starter notch is a slot through the thickness, of width ``notch_width`` (0.5 mm, our
  choice: a thin saw cut; the dissertation gives no width), centred on y = 0, from x = 0 to
  x = a0, with a flat end.
* The explicit crack (``crack`` = a > 0, the elastic runs of Fig. 4.2) is straight and through
  the thickness: the rectangle ``a0 <= x <= a0 + a, y = 0``, of zero width. The mesh is made
  conforming to it and gmsh's ``Crack`` plugin then duplicates its nodes, so that the two lips
  are separate boundaries; the nodes of the crack front (x = a0 + a) are not duplicated (the
  crack closes there), those of its top and bottom edges and of its edge on the notch's end are
  (it opens onto these boundaries). A zero-width crack needs no mesh size of its own, unlike a
  slot of width ~h, and the geometry does not depend on h.
* Loading and supports: the earlier finite-element studies the dissertation cites loaded four
  nodes at the notched end, two on top and two at the supports ``(0, +-Wm, 0)``; the lateral
  coordinate of the top pair is lost in the PDF. We put the two loading points at
  ``(0, +-load_offset, T)`` with ``load_offset = notch_width / 2`` by default: the top corners of the
  notch's mouth, as close to the mid-line as the notch allows, so that the moment arm of each
  torsion arm, ``Wm - load_offset`` = 16.75 mm, is nearly the Wm of (4.1)-(4.2) (which takes the
  loading points on the mid-line; :func:`fem3d.torsion_theory.compliance` takes the offset).
* Boundary conditions, option A (docs/cases.md#double-torsion; the one the case files use):
  prescribed vertical displacement ``-delta`` at the two loading points, zero vertical
  displacement at the two supports, the far-end point ``(L, 0, T/2)`` fixed in x, y and z. These
  remove five of the six rigid motions; the sixth, the rotation about the z axis through the
  far-end point, moves no point vertically and needs one horizontal constraint more: ``u_x = 0``
  at the point ``(L, W/2, T/2)`` (``"far_side"``). Every reaction of the far-end points is
  exactly zero, in the discrete problem too: the loads are vertical forces at x = 0 only, so the
  x and y force balances and the moment balance about z leave the three horizontal reactions
  nothing to carry, and the moment balance about the y axis through the far-end point makes the
  four vertical reactions at x = 0 sum to zero, so that the far point's vertical one vanishes.
  The far constraints only fix the rigid position; the compliance is the loading points'
  displacement over the force they carry. Option B (supports as lines along the whole length)
  has its node groups too (``"support_lines"``).

Mesh
----
The strip ``|y| <= strip`` (the whole length and thickness, where the crack runs) is meshed
with the tetrahedra's median edge ``h``; outside, the edge grows at the rate ``grading`` with
the distance to the strip up to ``h_coarse`` (:func:`fem3d.specimens.gmsh_tools.box_field`,
with :data:`fem3d.specimens.gmsh_tools.TET_EDGE_RATIO`). The strip's sides and, with
``buffer > 0``, the bottom of its top layer are faces of the geometry, so that the cell groups
are exact (the mesh conforms to them). The torsion arms' shear varies linearly through the
thickness: with P1 their energy needs ``h_coarse`` a fraction of T (measured, with the meshes'
quality: docs/cases.md#double-torsion).

Determinism as in :mod:`fem3d.specimens.gmsh_tools` (one gmsh session per call, the same
options).
"""

from __future__ import annotations

import numpy as np

from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_nonnegative, check_positive, check_sizes
from fem3d.specimens.gmsh_tools import TET_EDGE_RATIO, box_field, read_model, session
from fem3d.specimens.specimen import Extent, Front, Groups, Specimen, number

__all__ = ["double_torsion", "SPECIMEN", "TABLE_4_1", "GRADING"]

#: Table 4.1 (Madjoubi's soda-lime glass), in mm, MPa and N/mm: length L, width W, thickness T,
#: support distance from the mid-line Wm, starter notch a0 (the table's Ls), Young's modulus E,
#: Poisson ratio nu, toughness Gc.
TABLE_4_1 = {"L": 80.0, "W": 40.0, "T": 3.0, "Wm": 17.0, "a0": 7.0, "E": 72000.0, "nu": 0.22, "Gc": 0.0068}

#: Growth rate of the edge length away from the strip (length per length). Larger than the
#: panels' 0.1 (:data:`fem3d.specimens.gmsh_tools.GRADING`): the arms are only 20 mm wide,
#: and the transition ``(h_coarse - h) / grading`` must fit in them.
GRADING = 0.3

#: Defaults of the other scene keys (mm): the notch's width, the explicit crack's length, the
#: strip's half-width, the buffer layer's thickness, the radius of the gray zones.
NOTCH_WIDTH = 0.5
CRACK = 0.0
STRIP = 3.0
BUFFER = 0.0
GRAY = 2.0


def double_torsion(h=0.5, h_coarse=1.0, length=TABLE_4_1["L"], width=TABLE_4_1["W"], thickness=TABLE_4_1["T"],
                   support=TABLE_4_1["Wm"], load_offset=None, notch=TABLE_4_1["a0"], notch_width=NOTCH_WIDTH,
                   crack=CRACK, strip=STRIP, buffer=BUFFER, gray=GRAY, *, grading=GRADING) -> Mesh:
    """The double-torsion plate with its starter notch and an optional explicit straight crack.

    Parameters
    ----------
    h : float
        Median tetrahedron edge (mm) in the strip ``|y| <= strip``.
    h_coarse : float
        Edge length (mm) far from the strip, ``>= h``.
    length, width, thickness : float
        L, W, T (mm); Table 4.1 by default.
    support : float
        Wm (mm): the supports are at ``y = +-support`` on the bottom face, ``< width / 2``.
    load_offset : float or None
        Distance (mm) of the two loading points from the mid-line, on the top face at x = 0;
        None: ``notch_width / 2`` (the corners of the notch's mouth). Must be ``< support`` and
        either ``notch_width / 2`` or more than it.
    notch : float
        Starter-notch length a0 (mm), ``> 0``.
    notch_width : float
        Width of the notch slot (mm), ``< 2 strip``.
    crack : float
        Length a (mm) of the explicit straight crack continuing the notch (0: none);
        ``notch + crack < length``.
    strip : float
        Half-width (mm) of the refined strip around y = 0, ``< width / 2``.
    buffer : float
        Thickness (mm) of the strip's top layer ``z >= T - buffer, x >= notch`` (beyond the
        notch, so that the loading points stay on the specimen's own material; the dissertation's
        buffer layer, T/3 or T/4 thick); 0: no such layer.
    gray : float
        Radius (mm) of the ``"gray"`` zones around the four loading and support points.
    grading : float
        Growth rate of the edge length away from the strip (mm per mm).

    Returns
    -------
    Mesh
        Tetrahedra, with the groups

        * cells: ``"strip"`` (``|y| <= strip``) and ``"arms"`` (the rest): a partition;
          ``"buffer"`` (the strip's top layer, only if ``buffer > 0``); ``"gray"`` (centroid
          within ``gray`` of a loading or support point), which overlaps them;
        * facets: ``"top"`` (z = T), ``"bottom"`` (z = 0), ``"notch"`` (the slot's walls and end),
          ``"end"`` (the far end x = L), ``"crack_plus"``, ``"crack_minus"`` (the explicit
          crack's lips, facing y > 0 and y < 0, only if ``crack > 0``);
        * nodes: ``"load_points"`` (the two loading points ``(0, +-load_offset, T)``),
          ``"load_plus"``, ``"load_minus"`` (each alone), ``"supports"`` (``(0, +-Wm, 0)``),
          ``"support_plus"``, ``"support_minus"``, ``"far_end"`` (``(L, 0, T/2)``),
          ``"far_side"`` (``(L, W/2, T/2)``), ``"support_lines"`` (the nodes of the bottom lines
          ``y = +-Wm``, ``0 <= x <= L``: option B, supports as lines).

    Raises
    ------
    ValueError
        Naming the parameter, if a value is out of range.
    """
    h, h_coarse, grading = check_sizes(h, h_coarse, grading)
    L, W, T = (check_positive(name, v) for name, v in (("length", length), ("width", width),
                                                          ("thickness", thickness)))
    Wm = check_positive("support", support)
    a0 = check_positive("notch", notch)
    nw = check_positive("notch_width", notch_width)
    a = check_nonnegative("crack", crack)
    strip = check_positive("strip", strip)
    buffer = check_nonnegative("buffer", buffer)
    gray = check_nonnegative("gray", gray)
    lo = 0.5 * nw if load_offset is None else check_nonnegative("load_offset", load_offset)
    if not Wm < 0.5 * W:
        raise ValueError(f"double_torsion: support = {Wm!r} must be < width / 2 = {0.5 * W!r}")
    if not strip < 0.5 * W:
        raise ValueError(f"double_torsion: strip = {strip!r} must be < width / 2 = {0.5 * W!r}")
    if not 0.5 * nw < strip:
        raise ValueError(f"double_torsion: notch_width = {nw!r} must be < 2 strip = {2 * strip!r}")
    if not a0 + a < L:
        raise ValueError(f"double_torsion: notch + crack = {a0 + a!r} must be < length = {L!r}")
    if not buffer < T:
        raise ValueError(f"double_torsion: buffer = {buffer!r} must be < thickness = {T!r}")
    tol = 1e-6 * L
    if not (lo < Wm and (abs(lo - 0.5 * nw) <= tol or lo > 0.5 * nw)):
        raise ValueError(f"double_torsion: load_offset = {lo!r} must be notch_width / 2 = {0.5 * nw!r} or more,"
                         f" and < support = {Wm!r}")
    if abs(lo - 0.5 * nw) <= tol:
        lo = 0.5 * nw

    points = {"load_plus": (0.0, lo, T), "load_minus": (0.0, -lo, T), "support_plus": (0.0, Wm, 0.0),
              "support_minus": (0.0, -Wm, 0.0), "far_end": (L, 0.0, 0.5 * T), "far_side": (L, 0.5 * W, 0.5 * T)}

    with session("double_torsion") as gmsh:
        occ = gmsh.model.occ
        # The plate cut into the strip, the arms and the buffer layer (faces of the geometry
        # where the groups meet), then the notch removed from all of them.
        tools = [(3, occ.addBox(0.0, -strip, 0.0, L, 2 * strip, T))]
        if buffer > 0.0:
            # from the notch's end on: the loading points at its mouth stay on stiff material
            tools.append((3, occ.addBox(a0, -strip, T - buffer, L - a0, 2 * strip, buffer)))
        pieces, _ = occ.fragment([(3, occ.addBox(0.0, -0.5 * W, 0.0, L, W, T))], tools)
        pieces, _ = occ.cut(pieces, [(3, occ.addBox(0.0, -0.5 * nw, 0.0, a0, nw, T))])
        # The crack's rectangle, the support lines and the named points become entities of the
        # volumes' mesh (fragmenting embeds them).
        embedded = [(0, occ.addPoint(*p)) for p in points.values()]
        for s in (1.0, -1.0):
            embedded.append((1, occ.addLine(occ.addPoint(0.0, s * Wm, 0.0), occ.addPoint(L, s * Wm, 0.0))))
        if a > 0.0:
            # built in the plane y = 0 (a turned rectangle would be off it by rounding)
            corners = [occ.addPoint(x, 0.0, z) for x, z in ((a0, 0.0), (a0 + a, 0.0), (a0 + a, T), (a0, T))]
            sides = [occ.addLine(p, q) for p, q in zip(corners, corners[1:] + corners[:1])]
            embedded.append((2, occ.addPlaneSurface([occ.addCurveLoop(sides)])))
        occ.fragment(pieces, embedded)
        occ.synchronize()

        model = gmsh.model
        volumes = {"strip": [], "arms": [], "buffer": []}
        for _, tag in model.getEntities(3):
            _, y, z = occ.getCenterOfMass(3, tag)
            if abs(y) > strip:
                volumes["arms"].append(tag)
            elif buffer > 0.0 and z > T - buffer:
                volumes["buffer"].append(tag)
            else:
                volumes["strip"].append(tag)
        for name in ("strip", "arms", "buffer"):
            tags = volumes[name] + (volumes["buffer"] if name == "strip" else [])
            if tags:
                model.addPhysicalGroup(3, sorted(tags), name=name)

        def inside(dim, x, y, z):
            found = model.getEntitiesInBoundingBox(x[0] - tol, y[0] - tol, z[0] - tol, x[1] + tol, y[1] + tol,
                                                   z[1] + tol, dim)
            if not found:  # a geometry bug, not a user error: every group is built to exist
                raise RuntimeError(f"double_torsion: no entity of dimension {dim} in {x} x {y} x {z}")
            return sorted(tag for _, tag in found)

        half = (-0.5 * W, 0.5 * W)
        model.addPhysicalGroup(2, inside(2, (0.0, L), half, (T, T)), name="top")
        model.addPhysicalGroup(2, inside(2, (0.0, L), half, (0.0, 0.0)), name="bottom")
        model.addPhysicalGroup(2, inside(2, (L, L), half, (0.0, T)), name="end")
        notch_faces = (set(inside(2, (0.0, a0), (-0.5 * nw, -0.5 * nw), (0.0, T)))
                       | set(inside(2, (0.0, a0), (0.5 * nw, 0.5 * nw), (0.0, T)))
                       | set(inside(2, (a0, a0), (-0.5 * nw, 0.5 * nw), (0.0, T))))
        model.addPhysicalGroup(2, sorted(notch_faces), name="notch")
        tags = {name: inside(0, (x, x), (y, y), (z, z)) for name, (x, y, z) in points.items()}
        for name, tag in tags.items():
            model.addPhysicalGroup(0, tag, name=name)
        model.addPhysicalGroup(0, tags["load_plus"] + tags["load_minus"], name="load_points")
        model.addPhysicalGroup(0, tags["support_plus"] + tags["support_minus"], name="supports")
        lines = inside(1, (0.0, L), (Wm, Wm), (0.0, 0.0)) + inside(1, (0.0, L), (-Wm, -Wm), (0.0, 0.0))
        model.addPhysicalGroup(1, lines, name="support_lines")

        box_field(gmsh, h, h_coarse, (0.0, L, -strip, strip), (0.0, T), grading, TET_EDGE_RATIO)
        model.mesh.generate(3)
        if a > 0.0:
            _open_crack(gmsh, a0, a, T, tol)
        mesh = read_model(gmsh, "double_torsion")

    centroids = mesh.points[mesh.cells].mean(axis=1)
    near = np.zeros(mesh.n_cells, dtype=bool)
    for name in ("load_plus", "load_minus", "support_plus", "support_minus"):
        near |= np.linalg.norm(centroids - np.asarray(points[name]), axis=1) <= gray
    cell_groups = dict(mesh.cell_groups, gray=np.flatnonzero(near))
    facet_groups = dict(mesh.facet_groups)
    if a > 0.0:
        facet_groups.update(_crack_lips(mesh, a0, a, tol))
    return Mesh(mesh.points, mesh.cells, cell_groups, facet_groups, mesh.node_groups)


def _open_crack(gmsh, a0, a, T, tol):
    """Duplicate the nodes of the crack rectangle ``a0 <= x <= a0 + a, y = 0`` (gmsh's ``Crack``
    plugin): every node but the front's (x = a0 + a), whose lips stay joined. The physical
    groups the plugin needs are removed after it."""
    model = gmsh.model
    box = (a0 - tol, -tol, -tol, a0 + a + tol, tol, T + tol)
    faces = sorted(tag for _, tag in model.getEntitiesInBoundingBox(*box, 2))
    # The crack opens onto its top and bottom edges and onto the notch's end; not its front.
    open_edges = []
    for _, tag in model.getEntitiesInBoundingBox(*box, 1):
        x0, _, z0, x1, _, z1 = model.getBoundingBox(1, tag)
        if z1 <= tol or z0 >= T - tol or x1 <= a0 + tol:
            open_edges.append(tag)
    crack = model.addPhysicalGroup(2, faces)
    edges = model.addPhysicalGroup(1, sorted(open_edges))
    gmsh.plugin.setNumber("Crack", "Dimension", 2)
    gmsh.plugin.setNumber("Crack", "PhysicalGroup", crack)
    gmsh.plugin.setNumber("Crack", "OpenBoundaryPhysicalGroup", edges)
    gmsh.plugin.run("Crack")
    model.removePhysicalGroups([(2, crack), (1, edges)])


def _crack_lips(mesh, a0, a, tol):
    """The boundary facets on the crack rectangle, split by the side of the cell they belong
    to: ``{"crack_plus": (k, 3), "crack_minus": (k, 3)}``."""
    cells = mesh.cells
    faces = np.concatenate([np.delete(cells, i, axis=1) for i in range(4)])
    owner = np.tile(np.arange(len(cells)), 4)
    key = np.sort(faces, axis=1)
    _, index, counts = np.unique(key, axis=0, return_index=True, return_counts=True)
    boundary = index[counts == 1]
    p = mesh.points[faces[boundary]]
    on = (np.all(np.abs(p[..., 1]) <= tol, axis=1) & np.all(p[..., 0] >= a0 - tol, axis=1)
          & np.all(p[..., 0] <= a0 + a + tol, axis=1))
    lips = boundary[on]
    side = mesh.points[cells[owner[lips]]].mean(axis=1)[:, 1]
    return {"crack_plus": faces[lips[side > 0.0]], "crack_minus": faces[lips[side < 0.0]]}


def extent(dim, value):
    """The plate's :class:`~fem3d.specimens.specimen.Extent`, fine in the strip
    ``|y| <= strip`` (the graded transition beyond it counted coarse)."""
    L, W, T = value("length"), value("width"), value("thickness")
    return Extent((0.0, -W / 2.0, 0.0), (L, W / 2.0, T), L * W * T, L * min(2.0 * value("strip"), W) * T)


SPECIMEN = Specimen(
    name="double_torsion", dims=(3,), mesh=double_torsion,
    doc="the double-torsion plate of the dissertation's chapter 4 (mm), `0 <= x <= length`, `-width/2 <= y <= width/2`,"
        " `0 <= z <= thickness`, with a starter notch along y = 0 and an optional explicit straight crack",
    keys=(number("length", TABLE_4_1["L"], "L, the plate's length"),
          number("width", TABLE_4_1["W"], "W, the plate's width"),
          number("thickness", TABLE_4_1["T"], "T, the plate's thickness"),
          number("support", TABLE_4_1["Wm"], "Wm, each support's distance from the mid-line"),
          number("notch", TABLE_4_1["a0"], "a0, the starter notch's length"),
          number("notch_width", NOTCH_WIDTH, "the notch slot's width"),
          number("strip", STRIP, "half-width of the strip about y = 0 meshed at `h`"),
          number("grading", GRADING, "growth rate of the edge length away from the strip", units=""),
          number("load_offset", None, "the loading points' distance from the mid-line (default `notch_width / 2`)",
                 exclusive=False),
          number("crack", CRACK, "a, the explicit straight crack's length beyond the notch (0: none)", exclusive=False),
          number("buffer", BUFFER, "thickness of the strip's top layer, the region `buffer` (0: none)",
                 exclusive=False),
          number("gray", GRAY, "radius of the region `gray` about the loading and support points", exclusive=False)),
    groups=Groups(cells=("strip", "arms", "buffer", "gray"),
                  facets=("top", "bottom", "notch", "end", "crack_plus", "crack_minus"),
                  nodes=("load_points", "load_plus", "load_minus", "supports", "support_plus", "support_minus",
                         "far_end", "far_side", "support_lines")),
    front=Front(width="thickness", start="notch"), extent=extent)
