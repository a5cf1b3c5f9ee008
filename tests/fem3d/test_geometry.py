"""The gmsh specimens of :mod:`fem3d.specimens.lpanel` and :mod:`fem3d.specimens.three_point_bending`
and :func:`fem3d.specimens.gmsh_tools.from_file`: measures, groups, mesh sizes, orientation,
determinism, and the reading of ``.msh`` files.

Meshes are coarse (h = 5 mm for the panel, 0.05 in for the beam) to keep the module fast; the
dissertation's sizes are measured by the studies, not here.
"""

from __future__ import annotations

import math

import gmsh
import numpy as np
import pytest

from fem3d.specimens.gmsh_tools import from_file
from fem3d.specimens.lpanel import lpanel
from fem3d.specimens.three_point_bending import HOLE_RADIUS, HOLES, NOTCH_DEPTH, three_point_bending
from tests.fem3d.checks import check_common, edge_lengths, facet_measures, signed_measures

T = 100.0  # the panel's thickness (mm)


# --- helpers -------------------------------------------------------------------------------------

def same_mesh(a, b):
    """Bit-identical arrays and groups."""
    assert np.array_equal(a.points, b.points) and np.array_equal(a.cells, b.cells)
    for kind in ("cell_groups", "facet_groups", "node_groups"):
        ga, gb = getattr(a, kind), getattr(b, kind)
        assert list(ga) == list(gb)
        for name in ga:
            assert np.array_equal(ga[name], gb[name]), (kind, name)


@pytest.fixture(scope="module")
def panel2():
    return lpanel(h=5.0, h_coarse=25.0)


@pytest.fixture(scope="module")
def panel3():
    return lpanel(dim=3, h=20.0, h_coarse=50.0, thickness=T)


# --- the L-shaped panel --------------------------------------------------------------------------

def test_lpanel_2d_area_and_groups(panel2):
    m = panel2
    check_common(m)
    assert m.dim == 2
    assert math.isclose(signed_measures(m).sum(), 500.0**2 - 250.0**2, rel_tol=1e-12)
    assert m.group_names() == {"cells": ["gray", "near_load", "window"], "facets": ["bottom", "load"],
                               "nodes": ["corner", "load_point"]}
    # window and gray: a partition, by the centroids.
    window, gray = m.cell_groups["window"], m.cell_groups["gray"]
    assert len(np.intersect1d(window, gray)) == 0 and len(window) + len(gray) == m.n_cells
    c = m.points[m.cells].mean(axis=1)
    assert np.all((c[window, 0] <= 300.0) & (c[window, 1] >= 200.0))
    assert np.all((c[gray, 0] > 300.0) | (c[gray, 1] < 200.0))
    # bottom: y = 0 over the leg's width.
    bottom = m.points[m.facet_groups["bottom"]]
    assert np.all(bottom[..., 1] == 0.0)
    assert bottom[..., 0].min() == 0.0 and bottom[..., 0].max() == 250.0
    assert math.isclose(facet_measures(m, m.facet_groups["bottom"]).sum(), 250.0, rel_tol=1e-12)
    # load: exactly the strip [465, 475] at y = 250, the load point a node of it.
    load = m.points[m.facet_groups["load"]]
    assert np.all(load[..., 1] == 250.0)
    assert load[..., 0].min() == 465.0 and load[..., 0].max() == 475.0
    assert math.isclose(facet_measures(m, m.facet_groups["load"]).sum(), 10.0, rel_tol=1e-12)
    assert m.points[m.node_groups["load_point"]].tolist() == [[470.0, 250.0]]
    assert m.node_groups["load_point"][0] in m.facet_groups["load"]
    assert m.points[m.node_groups["corner"]].tolist() == [[250.0, 250.0]]
    near = m.cell_groups["near_load"]
    assert len(near) > 0
    assert np.all(np.hypot(c[near, 0] - 470.0, c[near, 1] - 250.0) <= 20.0)
    others = np.setdiff1d(np.arange(m.n_cells), near)
    assert np.all(np.hypot(c[others, 0] - 470.0, c[others, 1] - 250.0) > 20.0)


def test_lpanel_3d_volume_and_groups(panel3):
    m = panel3
    check_common(m)
    assert m.dim == 3
    assert math.isclose(signed_measures(m).sum(), (500.0**2 - 250.0**2) * T, rel_tol=1e-12)
    assert m.group_names() == {"cells": ["gray", "near_load", "window"], "facets": ["bottom", "load"],
                               "nodes": ["corner", "load_point"]}
    assert len(m.cell_groups["window"]) + len(m.cell_groups["gray"]) == m.n_cells
    assert len(np.intersect1d(m.cell_groups["window"], m.cell_groups["gray"])) == 0
    bottom = m.points[m.facet_groups["bottom"]]
    assert np.all(bottom[..., 1] == 0.0)
    assert math.isclose(facet_measures(m, m.facet_groups["bottom"]).sum(), 250.0 * T, rel_tol=1e-12)
    load = m.points[m.facet_groups["load"]]
    assert np.all(load[..., 1] == 250.0)
    assert load[..., 0].min() == 465.0 and load[..., 0].max() == 475.0
    assert math.isclose(facet_measures(m, m.facet_groups["load"]).sum(), 10.0 * T, rel_tol=1e-12)
    for name, x in (("load_point", 470.0), ("corner", 250.0)):
        p = m.points[m.node_groups[name]]
        assert np.all(p[:, :2] == [x, 250.0]), name
        assert p[:, 2].min() == 0.0 and p[:, 2].max() == T and len(p) >= 3, name
    c = m.points[m.cells].mean(axis=1)
    near = m.cell_groups["near_load"]
    assert len(near) > 0 and np.all(np.hypot(c[near, 0] - 470.0, c[near, 1] - 250.0) <= 20.0)


def test_lpanel_mesh_size():
    h, h_coarse, grading = 5.0, 25.0, 0.25
    m = lpanel(h=h, h_coarse=h_coarse, grading=grading)
    c = m.points[m.cells].mean(axis=1)
    x0, x1, y0, y1 = 0.0, 265.0, 240.0, 360.0
    inside = (c[:, 0] >= x0) & (c[:, 0] <= x1) & (c[:, 1] >= y0) & (c[:, 1] <= y1)
    distance = np.hypot(np.maximum(0.0, np.maximum(x0 - c[:, 0], c[:, 0] - x1)),
                        np.maximum(0.0, np.maximum(y0 - c[:, 1], c[:, 1] - y1)))
    far = distance > (h_coarse - h) / grading + h_coarse
    assert inside.sum() > 100 and far.sum() > 100
    lengths = edge_lengths(m)
    assert abs(np.median(lengths[inside]) / h - 1.0) < 0.2
    assert abs(np.median(lengths[far]) / h_coarse - 1.0) < 0.2


def test_lpanel_mesh_size_3d():
    h, h_coarse, grading = 12.5, 25.0, 0.5
    m = lpanel(dim=3, h=h, h_coarse=h_coarse, grading=grading)
    c = m.points[m.cells].mean(axis=1)
    inside = (c[:, 0] <= 265.0) & (c[:, 1] >= 240.0) & (c[:, 1] <= 360.0)
    reach = (h_coarse - h) / grading + h_coarse  # beyond it, the size is h_coarse
    far = (c[:, 0] > 265.0 + reach) | (c[:, 1] < 240.0 - reach)
    assert inside.sum() > 100 and far.sum() > 100
    lengths = edge_lengths(m)
    assert abs(np.median(lengths[inside]) / h - 1.0) < 0.2
    assert abs(np.median(lengths[far]) / h_coarse - 1.0) < 0.2


def test_lpanel_deterministic(panel2, panel3):
    same_mesh(panel2, lpanel(h=5.0, h_coarse=25.0))
    same_mesh(panel3, lpanel(dim=3, h=20.0, h_coarse=50.0, thickness=T))


def test_gmsh_prints_nothing(capfd):
    lpanel(dim=3, h=25.0, h_coarse=50.0)
    three_point_bending(h=0.2, h_coarse=0.25)
    assert capfd.readouterr() == ("", "")


def test_lpanel_rejects_bad_arguments():
    for kwargs in (dict(dim=1), dict(h=0.0), dict(h=10.0, h_coarse=5.0), dict(refine=(0, 1, 2)),
                   dict(window=(300.0, 0.0, 200.0, 500.0)), dict(load=(240.0, 260.0)),
                   dict(load=(480.0, 470.0)), dict(near_load=-1.0), dict(thickness=0.0),
                   dict(grading=0.0)):
        with pytest.raises(ValueError):
            lpanel(**kwargs)
    assert not gmsh.isInitialized()


def test_refuses_a_running_gmsh_session():
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        with pytest.raises(RuntimeError, match="already initialized"):
            lpanel(h=25.0, h_coarse=50.0)
        assert gmsh.isInitialized()  # the caller's session is left alone
    finally:
        gmsh.finalize()


# --- the three-point bending beam ----------------------------------------------------------------

def polygon_area(mesh, facets, centre, r):
    """Area of the polygon inscribed in the circle (centre, r) whose sides are ``facets``,
    from the chords: the disk minus the circular segments cut off by the chords."""
    chords = facet_measures(mesh, facets)
    theta = 2.0 * np.arcsin(np.minimum(1.0, chords / (2.0 * r)))
    p = mesh.points[facets]
    assert np.allclose(np.hypot(p[..., 0] - centre[0], p[..., 1] - centre[1]), r, rtol=1e-12, atol=0.0)
    assert math.isclose(theta.sum(), 2.0 * math.pi, rel_tol=1e-10)  # the sides close the circle
    return math.pi * r**2 - np.sum(0.5 * r**2 * (theta - np.sin(theta)))


@pytest.mark.parametrize("configuration", ["I", "II"])
def test_beam_area_and_groups(configuration):
    width = 0.1
    m = three_point_bending(configuration, h=0.1, h_coarse=0.25, notch_width=width)
    check_common(m)
    assert m.dim == 2
    assert m.group_names() == {"cells": ["beam", "coarse", "gray", "refined"],
                               "facets": ["bottom", "hole_B", "hole_M", "hole_T", "notch", "top"],
                               "nodes": ["load_point", "support_left", "support_right"]}
    a = NOTCH_DEPTH[configuration]
    holes = 0.0
    for name, centre in HOLES.items():
        polygon = polygon_area(m, m.facet_groups[name], centre, HOLE_RADIUS)
        # Within the chord error of the disk: the segment cut by a chord of angle theta is at
        # most r^2 theta^3 / 12.
        theta = 2.0 * np.arcsin(facet_measures(m, m.facet_groups[name]) / (2.0 * HOLE_RADIUS))
        assert 0.0 < math.pi * HOLE_RADIUS**2 - polygon <= np.sum(HOLE_RADIUS**2 * theta**3 / 12.0)
        holes += polygon
    assert math.isclose(signed_measures(m).sum(), 20.0 * 8.0 - width * a - holes, rel_tol=1e-12)
    notch = m.points[m.facet_groups["notch"]]
    assert notch[..., 1].min() == 0.0 and notch[..., 1].max() == a
    assert np.allclose([notch[..., 0].min(), notch[..., 0].max()], [-6.0 - width / 2, -6.0 + width / 2],
                       rtol=0.0, atol=1e-14)
    assert math.isclose(facet_measures(m, m.facet_groups["notch"]).sum(), 2 * a + width, rel_tol=1e-12)
    for name, y, length in (("top", 8.0, 20.0), ("bottom", 0.0, 20.0 - width)):
        p = m.points[m.facet_groups[name]]
        assert np.all(p[..., 1] == y), name
        assert math.isclose(facet_measures(m, m.facet_groups[name]).sum(), length, rel_tol=1e-12), name
    points = {"support_left": (-9.0, 0.0), "support_right": (9.0, 0.0), "load_point": (0.0, 8.0)}
    c = m.points[m.cells].mean(axis=1)
    distance = np.min([np.hypot(c[:, 0] - x, c[:, 1] - y) for x, y in points.values()], axis=0)
    for name, xy in points.items():
        assert m.points[m.node_groups[name]].tolist() == [list(xy)], name
    gray, beam = m.cell_groups["gray"], m.cell_groups["beam"]
    assert len(gray) > 0 and len(gray) + len(beam) == m.n_cells
    assert np.all(distance[gray] <= 0.5) and np.all(distance[beam] > 0.5)
    # "refined" and "coarse": the cells whose centroid is inside the refined box, and the rest
    refined, coarse = m.cell_groups["refined"], m.cell_groups["coarse"]
    assert len(refined) > 0 and len(coarse) > 0
    np.testing.assert_array_equal(np.sort(np.concatenate([refined, coarse])), np.arange(m.n_cells))
    inside = (c[:, 0] >= -7.0) & (c[:, 0] <= -2.5) & (c[:, 1] >= 0.0) & (c[:, 1] <= 8.0)
    np.testing.assert_array_equal(np.flatnonzero(inside), refined)


def test_beam_mesh_size_and_determinism():
    h, h_coarse, grading = 0.05, 0.25, 0.1
    m = three_point_bending("II", h=h, h_coarse=h_coarse, grading=grading)
    c = m.points[m.cells].mean(axis=1)
    inside = (c[:, 0] >= -7.0) & (c[:, 0] <= -2.5)
    far = (c[:, 0] > -2.5 + (h_coarse - h) / grading + h_coarse)
    lengths = edge_lengths(m)
    assert abs(np.median(lengths[inside]) / h - 1.0) < 0.2
    assert abs(np.median(lengths[far]) / h_coarse - 1.0) < 0.2
    same_mesh(m, three_point_bending("II", h=h, h_coarse=h_coarse, grading=grading))


def test_beam_rejects_bad_arguments():
    for args, kwargs in ((("III",), {}), ((), dict(notch_width=0.0)), ((), dict(notch_width=2.0)),
                         ((), dict(gray=-0.1)), ((), dict(h=0.5, h_coarse=0.25))):
        with pytest.raises(ValueError):
            three_point_bending(*args, **kwargs)


# --- from_file -----------------------------------------------------------------------------------

def write_msh(path, dim, version, binary):
    """Mesh a 2 x 1 rectangle (2D) or a 2 x 1 x 1 box (3D) with gmsh, with physical groups of
    every dimension (one of them unnamed, tag 7), write it to ``path`` in format ``version``
    (ASCII or binary);
    returns the nodes (sorted by tag, those of the cells) and the number of cells."""
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.3)
        gmsh.option.setNumber("Mesh.MshFileVersion", version)
        gmsh.option.setNumber("Mesh.Binary", int(binary))
        gmsh.model.add("test")
        if dim == 2:
            gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, 2.0, 1.0)
        else:
            gmsh.model.occ.addBox(0.0, 0.0, 0.0, 2.0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        box = lambda d, x0, x1: [t for _, t in gmsh.model.getEntitiesInBoundingBox(  # noqa: E731
            x0 - 1e-6, -1e-6, -1e-6, x1 + 1e-6, 1 + 1e-6, 1 + 1e-6, d)]
        gmsh.model.addPhysicalGroup(dim, box(dim, 0.0, 2.0), name="solid")
        gmsh.model.addPhysicalGroup(dim - 1, box(dim - 1, 0.0, 0.0), name="left")
        gmsh.model.addPhysicalGroup(dim - 1, box(dim - 1, 2.0, 2.0), tag=7)
        origin = gmsh.model.getEntitiesInBoundingBox(-1e-6, -1e-6, -1e-6, 1e-6, 1e-6, 1e-6, 0)
        gmsh.model.addPhysicalGroup(0, [t for _, t in origin], name="origin")
        if dim == 3:
            gmsh.model.addPhysicalGroup(1, box(1, 2.0, 2.0), name="right_edges")
        gmsh.model.mesh.generate(dim)
        tags, coords, _ = gmsh.model.mesh.getNodes(returnParametricCoord=False)
        cell_tags, cell_nodes = gmsh.model.mesh.getElementsByType(2 if dim == 2 else 4)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()
    used = np.unique(cell_nodes)
    coords = coords.reshape(-1, 3)[np.argsort(tags)][np.searchsorted(np.sort(tags), used)]
    return coords[:, :dim], len(cell_tags)


@pytest.mark.parametrize("dim, version, binary", [(2, 2.2, False), (2, 4.1, True), (3, 2.2, True),
                                                 (3, 4.1, False)])
def test_from_file_reads_gmsh_meshes(tmp_path, dim, version, binary):
    path = tmp_path / "box.msh"
    points, n_cells = write_msh(path, dim, version, binary)
    m = from_file(path)
    assert not gmsh.isInitialized()
    check_common(m)
    assert m.dim == dim and m.n_cells == n_cells
    # ASCII files hold 16 significant digits: the last bit may differ.
    np.testing.assert_allclose(m.points, points, rtol=0.0, atol=0.0 if binary else 1e-15)
    assert m.group_names() == {"cells": ["solid"], "facets": ["group7", "left"],
                               "nodes": ["origin"] + (["right_edges"] if dim == 3 else [])}
    assert np.array_equal(m.cell_groups["solid"], np.arange(n_cells))
    assert np.all(m.points[m.facet_groups["left"]][..., 0] == 0.0)
    assert np.all(m.points[m.facet_groups["group7"]][..., 0] == 2.0)
    assert math.isclose(facet_measures(m, m.facet_groups["left"]).sum(), 1.0, rel_tol=1e-12)
    assert math.isclose(signed_measures(m).sum(), 2.0, rel_tol=1e-12)
    assert m.points[m.node_groups["origin"]].tolist() == [[0.0] * dim]
    if dim == 3:
        p = m.points[m.node_groups["right_edges"]]
        assert len(p) >= 4 and np.all(p[:, 0] == 2.0)


# Two triangles of the unit square, the second one clockwise; a free node (tag 9) in no cell.
MSH_22 = """$MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
2
1 3 "edge"
2 1 "square"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
9 5 5 0
$EndNodes
$Elements
5
1 15 2 4 1 1
2 1 2 3 1 1 2
3 1 2 3 1 2 3
4 2 2 1 1 1 2 3
5 2 2 5 2 1 4 3
$EndElements
"""


def test_from_file_orients_and_names(tmp_path):
    path = tmp_path / "square.msh"
    path.write_text(MSH_22)
    m = from_file(path)
    assert m.points.tolist() == [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
    assert np.all(signed_measures(m) > 0.0)
    assert sorted(map(sorted, m.cells.tolist())) == [[0, 1, 2], [0, 2, 3]]
    assert m.group_names() == {"cells": ["group5", "square"], "facets": ["edge"], "nodes": ["group4"]}
    assert m.cell_groups["square"].tolist() == [0] and m.cell_groups["group5"].tolist() == [1]
    assert m.facet_groups["edge"].tolist() == [[0, 1], [1, 2]]
    assert m.node_groups["group4"].tolist() == [0]


def test_from_file_rejects_bad_files(tmp_path):
    quads = MSH_22.replace("5\n1 15", "6\n1 15").replace("$EndElements", "6 3 2 1 1 1 2 3 4\n$EndElements")
    (tmp_path / "quads.msh").write_text(quads)
    with pytest.raises(ValueError, match="triangles"):
        from_file(tmp_path / "quads.msh")
    assert not gmsh.isInitialized()
    (tmp_path / "tilted.msh").write_text(MSH_22.replace("\n3 1 1 0\n", "\n3 1 1 0.5\n"))
    with pytest.raises(ValueError, match="z = 0"):
        from_file(tmp_path / "tilted.msh")
    (tmp_path / "garbage.msh").write_text("$MeshFormat\nnonsense\n")
    with pytest.raises(ValueError, match="cannot read"):
        from_file(tmp_path / "garbage.msh")
    assert not gmsh.isInitialized()
    with pytest.raises(FileNotFoundError):
        from_file(tmp_path / "missing.msh")
    (tmp_path / "square.geo").write_text("Point(1) = {0, 0, 0};\n")
    with pytest.raises(ValueError, match=".msh"):
        from_file(tmp_path / "square.geo")
