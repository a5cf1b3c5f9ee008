"""The double-torsion specimen (dissertation chapter 4): its mesh and groups, the classical
formulas (4.1)-(4.4) against (4.1)-(4.4) and Table 4.1, and the elastic compliance of the
case file against the two-torsion-bar model.

Meshes are coarse (h = 1.5 mm, two tetrahedra through the 3 mm thickness) to keep the module
fast; the compliance at the scan's resolution is a slow test, and the resolution study is
``studies/double_torsion_compliance``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fem3d import torsion_theory as theory
from fem3d.specimens.double_torsion import TABLE_4_1, double_torsion
from tests.fem3d.checks import boundary_facets, check_common, edge_lengths, facet_measures, signed_measures
from tests.helpers import load_case

L, W, T, WM, A0 = (TABLE_4_1[k] for k in ("L", "W", "T", "Wm", "a0"))
E, NU = TABLE_4_1["E"], TABLE_4_1["nu"]
NOTCH_WIDTH = 0.5          # the geometry's default
LOAD_OFFSET = 0.25         # notch_width / 2: the loading points at the notch mouth's corners


# --- the mesh ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def cracked():
    """Coarse mesh with a 20 mm explicit crack and a 1 mm buffer layer."""
    return double_torsion(h=1.5, h_coarse=1.5, crack=20.0, buffer=1.0)


def test_volume_groups_and_points(cracked):
    m = cracked
    check_common(m)
    volume = signed_measures(m)
    # the plate minus the notch slot (the crack has no width)
    assert math.isclose(volume.sum(), L * W * T - A0 * NOTCH_WIDTH * T, rel_tol=1e-12)
    assert m.group_names() == {
        "cells": ["arms", "buffer", "gray", "strip"],
        "facets": ["bottom", "crack_minus", "crack_plus", "end", "notch", "top"],
        "nodes": ["far_end", "far_side", "load_minus", "load_plus", "load_points", "support_lines", "support_minus",
                  "support_plus", "supports"]}
    strip, arms, buffer = (m.cell_groups[k] for k in ("strip", "arms", "buffer"))
    np.testing.assert_array_equal(np.sort(np.concatenate([strip, arms])), np.arange(m.n_cells))
    c = m.points[m.cells].mean(axis=1)
    assert np.all(np.abs(c[strip, 1]) < 3.0) and np.all(np.abs(c[arms, 1]) > 3.0)
    # the strip's sides and the buffer's bottom are faces of the geometry: the groups are exact
    assert math.isclose(volume[strip].sum(), L * 6.0 * T - A0 * NOTCH_WIDTH * T, rel_tol=1e-12)
    assert np.all(np.isin(buffer, strip)) and np.all(c[buffer, 2] > T - 1.0) and np.all(c[buffer, 0] > A0)
    # beyond the notch only: the loading points at its mouth stay on the glass
    assert math.isclose(volume[buffer].sum(), (L - A0) * 6.0 * 1.0, rel_tol=1e-12)
    points = {"load_plus": (0.0, LOAD_OFFSET, T), "load_minus": (0.0, -LOAD_OFFSET, T),
              "support_plus": (0.0, WM, 0.0), "support_minus": (0.0, -WM, 0.0), "far_end": (L, 0.0, T / 2),
              "far_side": (L, W / 2, T / 2)}
    for name, xyz in points.items():
        assert m.points[m.node_groups[name]].tolist() == [list(xyz)], name
    assert set(m.node_groups["load_points"]) == {m.node_groups["load_plus"][0], m.node_groups["load_minus"][0]}
    assert set(m.node_groups["supports"]) == {m.node_groups["support_plus"][0], m.node_groups["support_minus"][0]}
    lines = m.points[m.node_groups["support_lines"]]
    assert np.all((np.abs(lines[:, 1]) == WM) & (lines[:, 2] == 0.0)) and np.ptp(lines[:, 0]) == L
    gray = m.cell_groups["gray"]
    near = np.min([np.linalg.norm(c - p, axis=1) for k, p in points.items() if "far" not in k], axis=0)
    np.testing.assert_array_equal(np.flatnonzero(near <= 2.0), gray)
    for name, z in (("top", T), ("bottom", 0.0)):
        assert np.all(m.points[m.facet_groups[name]][..., 2] == z)
        area = L * W - A0 * NOTCH_WIDTH
        assert math.isclose(facet_measures(m, m.facet_groups[name]).sum(), area, rel_tol=1e-12), name
    assert math.isclose(facet_measures(m, m.facet_groups["notch"]).sum(), (2 * A0 + NOTCH_WIDTH) * T,
                        rel_tol=1e-12)


def test_the_explicit_crack_is_open_to_its_front(cracked):
    m = cracked
    a = 20.0
    plus, minus = np.unique(m.facet_groups["crack_plus"]), np.unique(m.facet_groups["crack_minus"])
    shared = np.intersect1d(plus, minus)
    for name, side in (("crack_plus", 1.0), ("crack_minus", -1.0)):
        lip = m.facet_groups[name]
        p = m.points[lip]
        assert np.all(p[..., 1] == 0.0) and p[..., 0].min() == A0 and p[..., 0].max() == A0 + a
        assert math.isclose(facet_measures(m, lip).sum(), a * T, rel_tol=1e-12)
        # the lip's own nodes belong to the cells of its side only
        cells = m.cells[np.isin(m.cells, np.setdiff1d(lip, shared)).any(axis=1)]
        assert len(cells) > 0 and np.all(side * m.points[cells].mean(axis=1)[:, 1] > 0.0), name
    # the lips share exactly the front's nodes (x = a0 + a), each other node is there twice
    assert len(shared) >= 3 and np.all(m.points[shared, 0] == A0 + a)
    front = m.points[plus][:, 0] == A0 + a
    assert len(shared) == front.sum() and len(plus) == len(minus)
    assert {tuple(f) for f in np.sort(m.facet_groups["crack_plus"], axis=1)} <= boundary_facets(m)


def test_mesh_size_in_the_strip_and_outside():
    h, h_coarse = 1.0, 2.0
    m = double_torsion(h=h, h_coarse=h_coarse)
    lengths = edge_lengths(m)
    c = m.points[m.cells].mean(axis=1)
    # TET_EDGE_RATIO makes h the median edge in the strip; the size reaches h_coarse beyond
    # (h_coarse - h) / grading + h_coarse from it
    far = np.abs(c[:, 1]) > 3.0 + (h_coarse - h) / 0.3 + h_coarse
    assert far.sum() > 100
    assert abs(np.median(lengths[m.cell_groups["strip"]]) / h - 1.0) < 0.1
    assert abs(np.median(lengths[far]) / h_coarse - 1.0) < 0.2


def test_bad_arguments_are_refused():
    for kwargs in (dict(h=0.0), dict(h=2.0, h_coarse=1.0), dict(support=20.0), dict(strip=20.0),
                   dict(notch_width=7.0), dict(crack=73.0), dict(buffer=3.0), dict(load_offset=0.1),
                   dict(load_offset=17.0), dict(notch=0.0), dict(gray=-1.0)):
        with pytest.raises(ValueError):
            double_torsion(**kwargs)


# --- the classical model -------------------------------------------------------------------------

def test_fuller_psi_against_the_table():
    # (4.3)-(4.4) (docs/model.md#double-torsion): psi(T/W), psi(2T/W) for W/T = 9 ... 12 and Madjoubi's 13.33
    table = {9: (0.9300, 0.8600), 10: (0.9370, 0.8740), 11: (0.9427, 0.8854), 12: (0.9475, 0.8950),
             40 / 3: (0.9527, 0.9055)}
    for ratio, (printed, arm) in table.items():
        assert theory.psi(ratio, 1.0, "T/W") == pytest.approx(printed, abs=5e-5)
        assert theory.psi(ratio, 1.0) == pytest.approx(arm, abs=5e-5)   # 2T/W, the default
    with pytest.raises(ValueError):
        theory.psi(10.0, 1.0, "W/T")


def test_table_4_1_slopes_and_critical_load():
    # Table 4.1, in mm, N, MPa: dC/da = 2.72e-5 1/N (Fuller 2.86e-5, 3.00e-5); P = 38.7 N
    # at G = Gc (Fuller 37.8, 36.9 N)
    args = (E, NU, W, T, WM)
    assert theory.compliance_slope(*args) == pytest.approx(2.72e-5, rel=2e-3)
    assert theory.compliance_slope(*args, fuller="T/W") == pytest.approx(2.86e-5, rel=2e-3)
    assert theory.compliance_slope(*args, fuller="2T/W") == pytest.approx(3.00e-5, rel=2e-3)
    Gc = TABLE_4_1["Gc"]
    assert theory.critical_load(Gc, *args) == pytest.approx(38.7, abs=0.05)
    assert theory.critical_load(Gc, *args, fuller="T/W") == pytest.approx(37.8, abs=0.05)
    assert theory.critical_load(Gc, *args, fuller="2T/W") == pytest.approx(36.9, abs=0.05)
    # (4.1) with the factor a and (4.2) = P^2 / (2T) dC/da, independent of a
    assert theory.compliance(30.0, *args) == pytest.approx(30.0 * theory.compliance_slope(*args), rel=1e-15)
    P = theory.critical_load(Gc, *args)
    assert theory.release_rate(P, *args) == pytest.approx(Gc, rel=1e-12)
    assert theory.release_rate(1.0, *args) == pytest.approx(3 * WM**2 * (1 + NU) / (W * T**4 * E), rel=1e-12)
    # the loading points off the mid-line shorten the moment arm
    assert theory.compliance_slope(*args, load_offset=1.0) == pytest.approx(
        theory.compliance_slope(*args) * (16.0 / 17.0) ** 2, rel=1e-12)


def test_scan_geometries_classical_loads():
    # Fig. 4.12's plates: L = 1, E = Gc = 1, nu = 0.22, Wm = 0.45 W; P at G = 1 for W/T = 9 ... 12
    expected = {2: (5.07e-3, 4.11e-3, 3.39e-3, 2.85e-3), 3: (2.76e-3, 2.24e-3, 1.85e-3, 1.55e-3)}
    for ratio, loads in expected.items():
        width = 1.0 / ratio
        for w_over_t, P in zip((9, 10, 11, 12), loads):
            got = theory.critical_load(1.0, 1.0, 0.22, width, width / w_over_t, 0.45 * width)
            assert got == pytest.approx(P, abs=0.006e-3)


# --- the elastic compliance ----------------------------------------------------------------------

def elastic_compliance(overrides):
    """Load-point compliance (mm/N) of ``cases/double_torsion_elastic.toml`` with ``overrides``,
    from one u-solve (no results file), and the model and solution."""
    from fem3d.kind import build_mesh, build_model

    scene = load_case("double_torsion_elastic", overrides)
    mesh = build_mesh(scene)
    model = build_model(scene, mesh)
    alpha = np.zeros(model.n_alpha)
    t = scene.load.t_max
    u = model.solve_u(alpha, t, None, 1e-10)
    return t / model.forces(u, alpha, t)["load_points"], model, u, alpha, t


def saint_venant_slope():
    """dC/da of the two-torsion-bar model with Saint-Venant's torsion constant of each arm (Fuller's
    2T/W reading) and the moment arm Wm - load_offset: the slope of a converged elastic
    solution over mid-length cracks, 2.92e-5 1/N."""
    return theory.compliance_slope(E, NU, W, T, WM, LOAD_OFFSET, fuller="2T/W")


MID_LENGTH = (16.0, 32.0, 48.0)   # mm of crack beyond the notch: a + a0 = 23, 39, 55 mm


def slopes(compliances):
    return np.diff(compliances) / np.diff(MID_LENGTH)


@pytest.fixture(scope="module")
def coarse():
    """The case file at h = 1.5 mm (two tetrahedra through T) with the cracks MID_LENGTH:
    ``[(C, model, u, alpha, t), ...]``."""
    return [elastic_compliance({"mesh.h": 1.5, "mesh.h_coarse": 1.5, "geometry.crack": a}) for a in MID_LENGTH]


def test_far_constraints_carry_no_force(coarse):
    # Option A: the far-end point and u_x at (L, W/2, T/2) only fix the rigid position; the
    # supports carry the load, P/2 each
    C, model, u, alpha, t = coarse[1]
    loads, mesh = model.loads, model.mesh
    reactions = model.elasticity.reactions(alpha, u, loads.force_at(t))
    position = {dof: i for i, dof in enumerate(loads.constrained)}

    def reaction(group, component):
        return sum(reactions[position[node * 3 + component]] for node in mesh.node_groups[group])

    P = t / C
    for group, components in (("far_end", (0, 1, 2)), ("far_side", (0,))):
        for c in components:
            assert abs(reaction(group, c)) < 1e-9 * P, (group, c)
    # the supports push the plate up, the loading points down
    assert reaction("load_points", 2) == pytest.approx(-P, rel=1e-12)
    for name in ("support_plus", "support_minus"):
        assert reaction(name, 2) == pytest.approx(P / 2, rel=0.02)
    assert reaction("supports", 2) == pytest.approx(P, rel=1e-9)


def test_coarse_compliance_is_linear_in_a_and_below_the_torsion_bars(coarse):
    # Two P1 tetrahedra through the thickness (h = 1.5 mm) over mid-length cracks
    # (a + a0 = 23 ... 55 mm): C(a) is linear (slopes of the two halves within 3%) with a
    # slope of 0.663 of the two-torsion-bar value with Saint-Venant's torsion constant
    # (2.92e-5 1/N; the converged elastic slope is 1.02 of it), below (4.1) without any
    # correction. P1 tetrahedra are stiff in the arms' through-thickness shear: one constant
    # strain per layer against a stress that varies linearly across T, an error of order
    # (h/T)^2. The measured h-sequence 1.5, 1, 0.75, 0.5, 0.375 mm gives 0.663, 0.832, 0.899,
    # 0.964, 0.987 of it (studies/double_torsion_compliance), so at this mesh the band is
    # 0.63-0.70: the measured value with room for another gmsh mesh of the same size (two
    # constructions of the crack gave meshes whose slopes differ by 0.1%; another gmsh
    # version may differ more), not for another resolution (h = 1 mm gives 0.83).
    s = slopes([run[0] for run in coarse])
    assert abs(s[1] / s[0] - 1.0) < 0.03
    ratio = s.mean() / saint_venant_slope()
    assert 0.63 < ratio < 0.70
    assert s.mean() < theory.compliance_slope(E, NU, W, T, WM)


@pytest.mark.slow
def test_scan_resolution_compliance_approaches_the_torsion_bars():
    # The scan's mesh (h = 0.75 mm, four tetrahedra through T): 0.899 of the two-torsion-bar
    # slope with Saint-Venant's constant, still below it (40 s)
    s = slopes([elastic_compliance({"mesh.h": 0.75, "mesh.h_coarse": 0.75, "geometry.crack": a})[0]
                for a in MID_LENGTH])
    assert abs(s[1] / s[0] - 1.0) < 0.03
    assert 0.87 < s.mean() / saint_venant_slope() < 0.93


@pytest.mark.slow
def test_p2_compliance_is_fuller_2t_over_w_and_above_p1(coarse):
    # P2 on the coarse test's mesh (1.5 min): its linear strains resolve the arms' torsion
    # through the thickness, and the slope is the converged one (P2 at h = 1 mm: 0.1% more),
    # 0.993 of Fuller's psi(2T/W) slope (the acceptance: P2 within 10% of the Fuller value), 1.10
    # of (4.1): the elastic specimen follows the 2T/W reading. P1 on the same mesh is below it.
    C = [elastic_compliance({"mesh.h": 1.5, "mesh.h_coarse": 1.5, "geometry.crack": a, "model.element": "P2"})[0]
         for a in (MID_LENGTH[0], MID_LENGTH[-1])]
    slope = (C[1] - C[0]) / (MID_LENGTH[-1] - MID_LENGTH[0])
    arm, printed = (theory.compliance_slope(E, NU, W, T, WM, fuller=r) for r in ("2T/W", "T/W"))
    assert abs(slope / arm - 1.0) < 0.03
    assert abs(slope - arm) < 0.25 * abs(slope - printed)   # measured 0.17: far nearer 2T/W than T/W
    assert all(p1[0] < p2 for p1, p2 in zip((coarse[0], coarse[-1]), C))
    assert slopes([run[0] for run in coarse]).mean() < slope


def test_fracture_case_coarse_releases_the_toughness(tmp_path):
    # The fracture case (double_torsion.toml, (4.11) with a T/3 buffer of E/1e3) on a coarse
    # mesh (two tetrahedra through T, eps = T): the crack starts at the notch and grows stably,
    # and G from (4.17) equals Gc within 1 % at every step of growth once the crack has left
    # the notch by eps, the width over which its front forms (the step before: 0.91 Gc; the
    # dissertation's Fig. 4.12 asks 5 %; the case's finer runs: 0.3 %, docs/cases.md).
    from fem3d.release import energy_release_rate
    from thinfilm.results.reader import Results
    from thinfilm.run import run

    scene = load_case("double_torsion", {"mesh.h": 1.5, "mesh.h_coarse": 1.5, "model.eps": 3.0, "geometry.strip": 6.0,
                                         "geometry.buffer": 1.0, "model.buffers.buffer": 72.0,
                                         "load.t_max": None, "load.steps": None,
                                         "load.t": [0.0, 0.02, 0.025, 0.03, 0.035, 0.04, 0.045], "output": None})
    run(scene, tmp_path)
    with Results(tmp_path / "results.h5") as res:
        G, a = energy_release_rate(res.t, res.steps["elastic"], res.steps["surface"], 0.0068, 3.0, a0=A0, da_min=1.5)
        force = np.asarray(res.steps["force"])
    assert a[-1] > A0 + 5.0                       # it grew from the notch
    assert np.all(np.diff(force[1:]) > 0)         # stably: the force still rises
    grown = np.isfinite(G) & (a > A0 + scene.model.eps)
    assert grown.sum() >= 3
    np.testing.assert_allclose(G[grown] / 0.0068, 1.0, atol=0.01)


@pytest.mark.slow   # 3 min
def test_fracture_case_adaptive_releases_the_toughness(tmp_path):
    # The same run from a uniform mesh of 1.5 mm refined down to 0.75 mm where the crack goes
    # (4-7 corrector passes per step): every step refines, so G is differenced from the
    # previous step re-solved on the step's own mesh (StepRecord.elastic_previous), and it
    # equals Gc within 1 % past the notch's eps as on a fixed mesh (measured: 0.975 at the
    # first step, then 0.9983-1.0003; differenced across the refinements instead it read
    # 1.09-1.18, docs/adaptivity.md#the-energy-release-rate).
    from fem3d.kind import release_rate
    from thinfilm.results.reader import Results
    from thinfilm.run import run

    scene = load_case("double_torsion", {"mesh.h": 0.75, "mesh.h_coarse": 1.5, "mesh.adapt": True, "model.eps": 3.0,
                                         "geometry.strip": 6.0, "geometry.buffer": 1.0, "model.buffers.buffer": 72.0,
                                         "load.t_max": None, "load.steps": None,
                                         "load.t": [0.0, 0.02, 0.025, 0.03, 0.035, 0.04, 0.045], "output": None})
    run(scene, tmp_path)
    with Results(tmp_path / "results.h5") as res:
        G, a = release_rate(res)
        refined = np.asarray(res.steps["refinements"])
    assert a[-1] > A0 + 5.0
    grown = np.isfinite(G) & (a > A0 + scene.model.eps)
    assert grown.sum() >= 3 and np.all(refined[grown] > 0)
    np.testing.assert_allclose(G[grown] / 0.0068, 1.0, atol=0.01)
