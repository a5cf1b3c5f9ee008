"""Brokenshire's torsion test (dissertation section 3.5.4): the geometry of
:mod:`fem3d.specimens.brokenshire` and coarse runs of ``cases/brokenshire.toml``.

The geometry is checked exactly (volumes, areas, where the groups are). The runs check what
the dissertation reports (qualitative; docs/cases.md#brokenshire-torsion): the crack leaves the notch's floor
and, running down the ligament, twists. The measure of twist is the trace of the broken set
(alpha >= 0.9) on horizontal sections (:func:`fem3d.cracks.trace_angles`): the notch is at 45
degrees to the axis; below it the trace turns towards 90 degrees, more near the side faces than
in the middle (docs/cases.md#brokenshire-torsion).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fem3d.specimens.brokenshire import ARM, COLLAR, FRAME_LENGTH, SECTION, brokenshire, notch_distance, notch_normal
from fem3d.cracks import trace_angles, twist
from fem3d.plots import crack_sections_figure
from tests.helpers import load_case
from thinfilm.results.reader import Results
from thinfilm.run import run

SLOT = 5.0 * 50.0 * SECTION / math.sin(math.radians(45.0))   # the notch's volume (mm^3)
FRAMES = 2 * (FRAME_LENGTH * ((SECTION + 2 * COLLAR) ** 2 - SECTION ** 2)
              + 2 * (125.0 - SECTION / 2 - COLLAR) * ARM * FRAME_LENGTH)


def volumes(mesh):
    edges = mesh.points[mesh.cells[:, 1:]] - mesh.points[mesh.cells[:, :1]]
    return np.linalg.det(edges) / 6.0


def areas(mesh, facets):
    p = mesh.points[facets]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def boundary_facets(mesh):
    faces = np.concatenate([np.delete(mesh.cells, i, axis=1) for i in range(4)])
    faces, counts = np.unique(np.sort(faces, axis=1), axis=0, return_counts=True)
    return {tuple(f) for f in faces[counts == 1]}


@pytest.fixture(scope="module")
def mesh():
    return brokenshire(h=12.5, h_coarse=25.0)


def test_volumes_and_regions(mesh):
    v = volumes(mesh)
    assert np.all(v > 0.0)
    assert np.array_equal(np.unique(mesh.cells), np.arange(mesh.n_nodes))
    specimen, frame = mesh.cell_groups["specimen"], mesh.cell_groups["frame"]
    assert len(specimen) + len(frame) == mesh.n_cells and not set(specimen) & set(frame)
    assert v[specimen].sum() == pytest.approx(400.0 * SECTION ** 2 - SLOT, rel=1e-9)
    assert v[frame].sum() == pytest.approx(FRAMES, rel=1e-9)    # 437,500 mm^3
    centroids = mesh.points[mesh.cells].mean(axis=1)
    outside = (np.abs(centroids[:, 1]) > SECTION / 2) | (centroids[:, 2] < 0.0) | (centroids[:, 2] > SECTION)
    assert np.array_equal(np.flatnonzero(outside), np.sort(frame))
    x = centroids[:, 0]
    gray, refined = mesh.cell_groups["gray"], mesh.cell_groups["refined"]
    assert set(gray) <= set(specimen) and set(refined) <= set(specimen)
    assert np.all((x[gray] <= 75.0) | (x[gray] >= 325.0)) and np.all(np.abs(x[refined] - 200.0) <= 75.0)
    assert v[gray].sum() == pytest.approx(2 * 75.0 * SECTION ** 2, rel=0.05)


def test_boundaries_and_points(mesh):
    boundary = boundary_facets(mesh)
    for name, facets in mesh.facet_groups.items():
        assert {tuple(f) for f in np.sort(facets, axis=1)} <= boundary, name
    notch = mesh.facet_groups["notch"]
    p = mesh.points[notch].reshape(-1, 3)
    assert np.all(np.abs(notch_distance(p)) <= 2.5 + 1e-9) and p[:, 2].min() == pytest.approx(50.0)
    # two faces 50 mm deep and a 5 mm floor, each 100 / sin 45 mm long
    assert areas(mesh, notch).sum() == pytest.approx((2 * 50.0 + 5.0) * SECTION * math.sqrt(2.0), rel=1e-9)
    free = 400.0 - 2 * FRAME_LENGTH
    assert areas(mesh, mesh.facet_groups["top"]).sum() == pytest.approx(free * SECTION - 5.0 * SECTION * math.sqrt(2))
    assert areas(mesh, mesh.facet_groups["bottom"]).sum() == pytest.approx(free * SECTION)
    expected = {"support_a": (12.5, -125.0, 50.0), "support_b": (12.5, 125.0, 50.0),
                "support_c": (387.5, 125.0, 50.0), "load_point": (387.5, -125.0, 50.0)}
    for name, xyz in expected.items():
        assert len(mesh.node_groups[name]) == 1
        assert mesh.points[mesh.node_groups[name][0]] == pytest.approx(xyz)
    floor = mesh.points[mesh.node_groups["notch_floor"]]
    assert np.all(floor[:, 2] == 50.0) and np.all(np.abs(notch_distance(floor)) <= 2.5 + 1e-9)


def test_deterministic_and_checked(mesh):
    again = brokenshire(h=12.5, h_coarse=25.0)
    assert np.array_equal(mesh.points, again.points) and np.array_equal(mesh.cells, again.cells)
    for kwargs in ({"notch_angle": 5.0}, {"notch_depth": 100.0}, {"lever": 60.0}, {"length": 200.0},
                   {"h": 10.0, "h_coarse": 5.0}):
        with pytest.raises(ValueError, match=next(iter(kwargs))):
            brokenshire(**{"h": 12.5, "h_coarse": 25.0, **kwargs})


def _run(tmp_path, overrides):
    scene = load_case("brokenshire", overrides)
    summary = json.loads(run(scene, tmp_path)["summary"].read_text())
    return scene, Results(tmp_path / "results.h5"), summary


def _check_crack(scene, res, k_jump):
    """Before the jump the damage peaks on the notch's floor; after it the broken set fills the
    ligament under the notch, from face to face and down to the bottom. Returns the section
    angles (z = 45 ... 5 mm)."""
    h = scene.mesh.h
    points = res.discretization.points
    before = res.field("alpha", k_jump - 1)
    peak = points[np.argmax(before)]
    assert peak[2] == pytest.approx(50.0, abs=h) and abs(notch_distance(peak[None])[0]) <= 2.5 + h
    alpha = res.field("alpha", k_jump)
    broken = points[alpha >= 0.9]
    assert broken[:, 2].max() <= 50.0 + h and broken[:, 2].min() <= h          # floor to bottom
    assert broken[:, 1].min() <= -50.0 + h and broken[:, 1].max() >= 50.0 - h   # face to face
    assert np.all(np.abs(notch_distance(broken)) <= 50.0)
    rows = trace_angles(points, alpha, [45.0, 35.0, 25.0, 15.0, 5.0], h)
    assert all(count >= 6 and flatness < 0.3 for _, _, count, flatness in rows), rows
    return rows


def test_coarse_crack_leaves_the_notch_and_twists(tmp_path):
    # eps = 25 mm, h = 12.5 mm (3,800 nodes, direct solver; about 10 s): the crack crosses the
    # ligament at once at t = 0.8 mm (force 3.9 kN before, 0.1 kN after).
    overrides = {"model.eps": 25.0, "mesh.h": 12.5, "load.t": [0.0, 0.4, 0.6, 0.7, 0.75, 0.8],
                 "output.snapshots": None}
    scene, res, summary = _run(tmp_path, overrides)
    try:
        area = np.asarray(res.steps["surface"]) / scene.model.Gc
        k = int(np.argmax(np.diff(area))) + 1
        assert res.t[k] == 0.8 and area[k] - area[k - 1] > 0.8 * 50.0 * 100.0   # the ligament, at once
        assert res.steps["force"][k] < 0.1 * res.steps["force"][k - 1]
        # the load opens the notch: near the top its faces move apart along its normal
        points, u = res.discretization.points, res.field("u", 1)
        d, top = notch_distance(points), points[:, 2] >= 75.0
        gap = [float(np.mean(u[top & (np.abs(d - side * 2.5) < 1e-6)] @ notch_normal(45.0))) for side in (1, -1)]
        assert gap[0] - gap[1] > 0.0, gap
        rows = _check_crack(scene, res, k)
        angles = [angle for _, angle, _, _ in rows]
        # the trace leaves the notch near its 45 deg and turns towards 90 deg on the way down
        assert 40.0 <= angles[0] <= 70.0, angles
        assert twist(angles)[1] >= 5.0, angles
        figure = crack_sections_figure(res, tmp_path / "sections.png", [45.0, 25.0, 5.0], xlim=(120.0, 280.0))
        assert figure.stat().st_size > 0
    finally:
        res.close()


@pytest.mark.slow
def test_case_eps_twisted_crack(tmp_path):
    # The case's eps = 12.5 mm at h = 6.25 mm (18,319 nodes, AMG; 30 s on an idle core): the
    # crack crosses the ligament at once at t = 0.88 mm; its trace stays near 45 deg in the
    # middle third of the width and turns to 70-90 deg in the outer thirds (a propeller).
    overrides = {"mesh.h": 6.25, "load.t": [0.0, 0.4, 0.6, 0.7, 0.75, 0.8, 0.84, 0.88], "output.snapshots": None}
    scene, res, summary = _run(tmp_path, overrides)
    try:
        area = np.asarray(res.steps["surface"]) / scene.model.Gc
        k = int(np.argmax(np.diff(area))) + 1
        assert area[k] - area[k - 1] > 0.8 * 50.0 * 100.0
        rows = _check_crack(scene, res, k)
        assert twist([angle for _, angle, _, _ in rows])[1] >= 5.0
        points, alpha = res.discretization.points, res.field("alpha", k)
        levels, h = [35.0, 25.0, 15.0, 5.0], scene.mesh.h
        middle = np.abs(points[:, 1]) < 25.0
        for side in (points[:, 1] < -25.0, points[:, 1] > 25.0):
            outer = trace_angles(points[side], alpha[side], levels, h)
            inner = trace_angles(points[middle], alpha[middle], levels, h)
            for (_, a, _, _), (_, b, _, _) in zip(outer, inner):
                assert a - b >= 10.0, (a, b)
    finally:
        res.close()
