"""Nooru-Mohamed's tension-shear test, load path 4b (dissertation section 3.5.3): the specimen
and its platens (fem3d/specimens/nooru_mohamed.py), the crack leaving each notch (fem3d.cracks.cracks_from),
and the case file on a coarse mesh (docs/cases.md#nooru-mohamed-load-path-4b).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from fem3d.cracks import cracks_from
from fem3d.kind import build_mesh
from fem3d.specimens.nooru_mohamed import NOTCH_TIPS, NOTCH_WIDTH, nooru_mohamed, platen_area, specimen_area
from tests.helpers import load_case
from thinfilm.results.reader import Results
from thinfilm.run import run


def _areas(mesh):
    edges = mesh.points[mesh.cells[:, 1:]] - mesh.points[mesh.cells[:, :1]]
    return np.linalg.det(edges) / 2.0


def _boundary(mesh):
    faces = np.sort(np.concatenate([mesh.cells[:, [0, 1]], mesh.cells[:, [1, 2]], mesh.cells[:, [2, 0]]]), axis=1)
    faces, counts = np.unique(faces, axis=0, return_counts=True)
    return faces[counts == 1]


@pytest.mark.parametrize("symmetry", ["none", "half_turn"])
def test_specimen_platens_and_their_faces(symmetry):
    mesh = nooru_mohamed(h=5.0, h_coarse=10.0, symmetry=symmetry)
    area = _areas(mesh)
    assert np.all(area > 0.0)
    groups = mesh.cell_groups
    assert sorted(groups) == ["lower_platen", "specimen", "upper_platen"]
    # a partition of the cells
    assert np.array_equal(np.sort(np.concatenate(list(groups.values()))), np.arange(mesh.n_cells))
    assert area[groups["specimen"]].sum() == pytest.approx(200.0 * 200.0 - 2 * 25.0 * 5.0, rel=1e-12)
    assert specimen_area() == 39750.0
    for name in ("upper_platen", "lower_platen"):
        assert area[groups[name]].sum() == pytest.approx(platen_area(), rel=1e-12)   # 20 x 220 + 20 x 97.5
    centroids = mesh.points[mesh.cells].mean(axis=1)
    assert centroids[groups["upper_platen"], 1].min() > 102.5 and centroids[groups["lower_platen"], 1].max() < 97.5
    # each face on the boundary, where and as long as it should be
    boundary = {tuple(f) for f in _boundary(mesh)}
    where = {"upper_left": (-20.0, None, 117.5), "upper_top": (None, 220.0, 220.0),
             "lower_bottom": (None, -20.0, 220.0), "lower_right": (220.0, None, 117.5),
             "notch_left": (None, None, 55.0), "notch_right": (None, None, 55.0)}
    for name, (x, y, length) in where.items():
        facets = mesh.facet_groups[name]
        assert all(tuple(sorted(f)) in boundary for f in facets), name
        p = mesh.points[facets]
        assert np.linalg.norm(p[:, 1] - p[:, 0], axis=1).sum() == pytest.approx(length, rel=1e-12), name
        if x is not None:
            assert np.all(p[..., 0] == x), name
        if y is not None:
            assert np.all(p[..., 1] == y), name
    assert mesh.points[mesh.facet_groups["notch_left"]][..., 0].max() == 25.0
    assert mesh.points[mesh.facet_groups["notch_right"]][..., 0].min() == 175.0
    if symmetry == "half_turn":
        # every node's image by the half-turn about (100, 100) is a node
        from scipy.spatial import cKDTree

        distance, _ = cKDTree(mesh.points).query(200.0 - mesh.points)
        assert distance.max() < 1e-9


def test_the_case_file_meshes_with_the_groups_it_names():
    scene = load_case("nooru_mohamed_4b", {"mesh.h": 5.0})
    mesh = build_mesh(scene)
    assert {name for name, _ in scene.model.buffers} == {"upper_platen", "lower_platen"}
    assert set(scene.load.fixed) | set(scene.load.loaded) | {g for g, _ in scene.load.constant_force} <= set(
        mesh.facet_groups)
    assert not scene.load.proportional and scene.load.constant_force == (("upper_left", (10000.0, 0.0)),)
    with pytest.raises(ValueError, match="arm"):
        nooru_mohamed(h=5.0, arm=100.0)
    with pytest.raises(ValueError, match="symmetry"):
        nooru_mohamed(h=5.0, symmetry="mirror")


def test_stiff_platens_stand_for_rigid_ones():
    # The case file's platens (E_b = 1000 E) against 100 times stiffer ones, sound specimen,
    # h = 2.5 mm: the normal stiffness within 0.3 % (1/E_b: docs/cases.md measures 0.17 % at
    # h = 1.25 mm), the specimen's top edge moving rigidly to within 1 % of the load.
    from fem3d.kind import build_model

    t, out = 0.02, {}
    for factor in (1e3, 1e5):
        E_b = 30000.0 * factor
        scene = load_case("nooru_mohamed_4b", {"mesh.h": 2.5, "model.buffers": {"upper_platen": E_b,
                                                                                 "lower_platen": E_b}})
        mesh = build_mesh(scene)
        model = build_model(scene, mesh)
        alpha = np.zeros(mesh.n_nodes)
        u, u0 = (model.solve_u(alpha, s, None, 1e-12) for s in (t, 0.0))
        stiffness = (model.forces(u, alpha, t)["upper_top"] - model.forces(u0, alpha, 0.0)["upper_top"]) / t
        top = np.intersect1d(mesh.nodes_of("specimen"), mesh.nodes_of("upper_platen"))
        x = mesh.points[top]
        rigid = np.zeros((2 * len(top), 3))
        rigid[0::2, 0], rigid[1::2, 1], rigid[0::2, 2], rigid[1::2, 2] = 1.0, 1.0, -x[:, 1], x[:, 0]
        motion = u.reshape(-1, 2)[top].ravel()
        fit, *_ = np.linalg.lstsq(rigid, motion, rcond=None)
        out[factor] = stiffness, np.abs(motion - rigid @ fit).max()
    assert 1.40e6 < out[1e5][0] < 1.50e6                          # N/mm: about E T
    assert 0.0 < 1.0 - out[1e3][0] / out[1e5][0] < 3e-3
    assert out[1e3][1] < 0.01 * t and out[1e5][1] < 1e-4 * t


def _band(points, start, end, width):
    """Nodes within ``width`` of the segment from ``start`` to ``end``."""
    a, b = np.asarray(start, float), np.asarray(end, float)
    s = np.clip(((points - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
    return np.linalg.norm(points - (a + s[:, None] * (b - a)), axis=1) <= width


def test_cracks_from_follows_each_crack_from_its_origin():
    # a structured grid of triangles, 1 mm; two bands of broken nodes from (0, 0) and (60, 40)
    n = 61
    x, y = np.meshgrid(np.arange(n, dtype=float), np.arange(41, dtype=float))
    points = np.column_stack([x.ravel(), y.ravel()])
    k = np.arange(n * 41).reshape(41, n)[:-1, :-1].ravel()
    cells = np.concatenate([np.column_stack([k, k + 1, k + n + 1]), np.column_stack([k, k + n + 1, k + n])])
    alpha = np.zeros(len(points))
    alpha[_band(points, (0.0, 0.0), (30.0, 10.0), 0.6)] = 1.0      # 31.6 mm long, rising
    alpha[_band(points, (60.0, 40.0), (40.0, 40.0), 0.6)] = 0.95   # 20 mm, along the top
    left, right, none = cracks_from(points, cells, alpha, [(0.0, 0.0), (60.0, 40.0), (0.0, 40.0)], 1.5)
    assert left["length"] == pytest.approx(math.hypot(30.0, 10.0), abs=1.0)
    assert left["angle"] == pytest.approx(math.degrees(math.atan2(10.0, 30.0)), abs=2.0)
    assert left["length"] <= left["path"] <= 1.15 * left["length"]
    assert right["length"] == pytest.approx(20.0) and right["path"] == pytest.approx(20.0)
    assert right["angle"] == pytest.approx(180.0)
    assert not np.intersect1d(left["nodes"], right["nodes"]).size
    assert none["tip"] is None and none["length"] == 0.0 and math.isnan(none["angle"])
    # joined, the two are one crack, the crack of both origins
    alpha[_band(points, (30.0, 10.0), (40.0, 40.0), 0.6)] = 1.0
    joined = cracks_from(points, cells, alpha, [(0.0, 0.0), (60.0, 40.0)], 1.5)
    assert np.array_equal(joined[0]["nodes"], joined[1]["nodes"])


#: The case file coarsened: eps = 2.5 mm as the dissertation's but h = 1.25 mm (eps/h = 2,
#: 18,000 nodes), on a mesh that is its own image by the half-turn about the centre, loaded to
#: just after the cracks appear. At eps = 5 mm the two cracks join at once and the specimen is
#: cut (docs/cases.md), so the dissertation's eps is kept.
COARSE = {"mesh.h": 1.25, "geometry.symmetry": "half_turn",
          "load.t": [0.0, 0.03, 0.04, 0.044, 0.045, 0.046, 0.0465, 0.047, 0.0475, 0.048],
          "output.snapshots": [0.048]}


def test_coarse_two_cracks_nucleate_together_and_curve(tmp_path):
    scene = load_case("nooru_mohamed_4b", COARSE)
    summary = json.loads(run(scene, tmp_path)["summary"].read_text())
    events = summary["events"]
    assert len(events) == 1
    t_c = events[0]["t"]
    # Measured 0.0475 mm (last sound step 0.047 mm, 66.6 kN). The dissertation's window,
    # 0.015-0.025 mm, is not reproduced (docs/cases.md): this band is a regression bound.
    assert 0.044 <= t_c <= 0.05
    with Results(tmp_path / "results.h5") as res:
        points, cells = res.discretization.points, res.discretization.cells
        k = int(np.flatnonzero(res.t == t_c)[0])
        reach = NOTCH_WIDTH / 2 + 2 * scene.mesh.h
        before = cracks_from(points, cells, res.field("alpha", k - 1), list(NOTCH_TIPS.values()), reach)
        left, right = cracks_from(points, cells, res.field("alpha", k), list(NOTCH_TIPS.values()), reach)
    # both notches crack in the same step: nothing before, two long cracks after
    assert max(c["length"] for c in before) < 5.0
    assert min(left["length"], right["length"]) > 50.0
    # two cracks, not one cutting the ligament, of lengths within 15 % of each other (the
    # dissertation's "nearly symmetric"; measured: 74 and 82 mm)
    assert not np.intersect1d(left["nodes"], right["nodes"]).size
    assert abs(left["length"] - right["length"]) <= 0.15 * max(left["length"], right["length"])
    assert abs(left["path"] - right["path"]) <= 0.15 * max(left["path"], right["path"])
    # curving as in 4b: the left crack turns down, the right one up, each ending short of the
    # other notch's half of the specimen
    assert left["tip"][1] < 90.0 and right["tip"][1] > 110.0
    assert -35.0 < left["angle"] < -5.0 and 145.0 < right["angle"] < 175.0
