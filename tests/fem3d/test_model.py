"""The finite-element model driven by the engine: a strip in uniaxial tension against closed
forms, the reaction force against the energy's derivative, monotone alternate minimization,
and a 3D run through the whole toolkit."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from fem3d.damage import P1Damage
from fem3d.elasticity import Elasticity
from fem3d.mesh import Mesh
from fem3d.model import FemModel, Loads
from fem3d.scene import Loading
from tests.fem3d.strip import EPS, GC, K_RES, E, H, L, NU, T, strip_mesh
from tests.helpers import load_case
from thinfilm.engine import AltMinOptions, BacktrackOptions, Engine
from thinfilm.run import run
from thinfilm.solvers.linear import make_solver


def strip_model(mesh):
    loading = Loading(t_max=1.0, steps=2, fixed=("pin",), displacement=(("left", 0, 0.0), ("right", 0, 1.0)))
    loads = Loads(mesh, loading, T)
    elasticity = Elasticity(mesh, E, NU, plane="stress", thickness=T, k_res=K_RES, constrained=loads.constrained)
    damage = P1Damage(mesh, GC, EPS, at=1, thickness=T)
    solver = make_solver("direct", elasticity.matrix(np.zeros(mesh.n_nodes)))
    return FemModel(mesh, elasticity, damage, loads, solver)


def test_strip_elastic_phase_and_damage_onset():
    # Uniaxial stress sigma = E t / L (times g(0) = 1 + k_res): the reaction is sigma H T, and
    # AT1 damage appears exactly when sigma reaches sigma_c = sqrt(3 Gc E / (8 eps)) (the
    # driving density C e:e = sigma^2 / E against the threshold 3 Gc / (8 eps)).
    model = strip_model(strip_mesh())
    sigma_c = math.sqrt(3 * GC * E / (8 * EPS))
    t_c = sigma_c * L / E
    t = np.array([0.0, 0.5, 0.9, 0.999, 1.001]) * t_c
    records, states = Engine(model, AltMinOptions(tol=1e-6)).run(t)
    for ti, state in zip(t[:-1], states[:-1]):
        assert state.alpha.max() == 0.0
        force = model.forces(state.u, state.alpha, ti)["right"]
        assert force == pytest.approx((1 + K_RES) * E * ti / L * H * T, rel=1e-10, abs=1e-14)
        assert state.elastic == pytest.approx(0.5 * (1 + K_RES) * E * (ti / L) ** 2 * L * H * T, rel=1e-10, abs=1e-14)
    assert states[-1].alpha.max() > 0.0


def _cracked_state():
    """A small L-panel just after its crack nucleated (eps = 25 mm, h = 12.5 mm)."""
    from fem3d.kind import build_mesh, build_model

    scene = load_case("lpanel", {"model.eps": 25.0, "mesh.h": 12.5, "mesh.h_coarse": 50.0,
                                 "load.t": None, "load.t_max": 0.4, "load.steps": 8, "output": None})
    model = build_model(scene, build_mesh(scene))
    records, states = Engine.from_options(model, scene.solver).run(np.linspace(0.0, 0.4, 9))
    return model, records, states


@pytest.fixture(scope="module")
def cracked():
    return _cracked_state()


def test_reaction_is_the_derivative_of_the_elastic_energy(cracked):
    # At fixed damage the minimized elastic energy P(t) is a quadratic in t; its derivative
    # along the prescribed displacement is the reaction read from the residual.
    model, _, states = cracked
    state = states[-1]
    assert state.alpha.max() > 0.9   # a damaged state, not the trivial elastic one
    t, dt = state.t, 1e-3 * state.t

    def elastic(ti):
        u = model.solve_u(state.alpha, ti, None, 1e-12)
        return model.energies(u, state.alpha, ti)[0]

    derivative = (elastic(t + dt) - elastic(t - dt)) / (2 * dt)
    force = model.forces(model.solve_u(state.alpha, t, None, 1e-12), state.alpha, t)["load"]
    assert force == pytest.approx(derivative, rel=1e-7)


def test_alternate_minimization_never_raises_the_energy(cracked):
    _, records, states = cracked
    assert max(r.iterations for r in records) > 5   # the nucleation step did work
    for record in records:
        history = np.array(record.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * max(1.0, abs(history[0])))
    # Irreversibility and the bounds, exactly.
    alphas = np.array([s.alpha for s in states])
    assert np.all(np.diff(alphas, axis=0) >= 0.0) and alphas.min() >= 0.0 and alphas.max() <= 1.0


def test_undamaged_regions_stay_sound(cracked):
    model, _, states = cracked
    fixed = model.damage.fixed_nodes
    assert fixed.size > 0 and np.all(states[-1].alpha[fixed] == 0.0)


def test_backtracking_runs_on_the_solid():
    # Alg. 3.1 on the strip: the engine's backtracking works unchanged on this model (a
    # proportional load), and its states are admissible.
    model = strip_model(strip_mesh(40, 4))
    t = np.linspace(0.0, 0.1, 6)
    records, states = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard")).run(t)
    assert len(states) == len(t) and all(np.all(s.alpha >= 0.0) for s in states)


def test_a_3d_run_through_the_toolkit(tmp_path):
    scene = load_case("lpanel_3d", {"model.eps": 80.0, "mesh.h": 40.0, "mesh.h_coarse": 80.0,
                                    "load.t_max": 0.05, "load.steps": 2, "output.snapshots": [0.05]})
    out = run(scene, tmp_path)
    with h5py.File(out["results"]) as f:
        assert f["mesh"].attrs["dim"] == 3 and f["mesh/cells"].shape[1] == 4
        assert f["fields/u"].attrs["components"] == 3
        force, alpha = f["steps/force"][()], f["fields/alpha"][()]
    # Still elastic at these loads: a positive force, linear in t.
    assert alpha.max() == 0.0
    assert force[1] > 0 and force[2] == pytest.approx(2 * force[1], rel=1e-10)
    for name in ("force_displacement.png", "crack_length.png", "crack_surface.png", "alpha_slices.png",
                 "energy.png", "iterations.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    root = ET.parse(tmp_path / "results.xdmf").getroot()
    assert root.find(".//Grid/Grid/Topology").get("TopologyType") == "Tetrahedron"
    assert root.find(".//Attribute[@Name='u']").get("AttributeType") == "Vector"


@pytest.mark.parametrize("level", [0.5, 0.37])
def test_slices_cover_the_section(level):
    """The section of a tetrahedral cube by a plane, through nodes (0.5) or not, is the whole
    unit square: the polygons' areas sum to 1 and a linear field is exact on them."""
    from fem3d.plots import slice_polygons

    n = 4
    g = np.linspace(0.0, 1.0, n + 1)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    index = np.arange(points.shape[0]).reshape(n + 1, n + 1, n + 1)
    cells = []
    for i in range(n):
        for j in range(n):
            for k in range(n):
                v = [index[i + a, j + b, k + c] for a, b, c in
                     ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1))]
                # six tetrahedra around the diagonal v0-v6
                for a, b in ((1, 2), (2, 3), (3, 7), (7, 4), (4, 5), (5, 1)):
                    cells.append((v[0], v[a], v[b], v[6]))
    cells = np.array(cells)
    values = points @ np.array([1.0, 2.0, 3.0])
    polygons, means = slice_polygons(points, cells, values, 2, level)

    def area(p):
        return 0.5 * abs(np.dot(p[:, 0], np.roll(p[:, 1], 1)) - np.dot(p[:, 1], np.roll(p[:, 0], 1)))

    assert sum(area(p) for p in polygons) == pytest.approx(1.0, rel=1e-5)
    centres = np.array([p.mean(axis=0) for p in polygons])
    np.testing.assert_allclose(means, centres @ np.array([1.0, 2.0]) + 3.0 * level, atol=1e-4)


def chain_model(nx=20, force=3.0, nu=0.0):
    """The strip one element tall with nu = 0: two bars in series, x = 0 .. L/2 .. L, the left
    end held, the right end pulled by u_x = t, a constant force F along x on the middle nodes."""
    mesh = strip_mesh(nx, 1)
    middle = np.flatnonzero(np.isclose(mesh.points[:, 0], L / 2))
    mesh = Mesh(mesh.points, mesh.cells, facet_groups=mesh.facet_groups,
                node_groups={**mesh.node_groups, "middle": middle})
    loading = Loading(t_max=1.0, steps=2, fixed=("pin",), displacement=(("left", 0, 0.0), ("right", 0, 1.0)),
                      constant_force=(("middle", (force, 0.0)),))
    loads = Loads(mesh, loading, T)
    elasticity = Elasticity(mesh, E, nu, plane="stress", thickness=T, k_res=0.0, constrained=loads.constrained)
    damage = P1Damage(mesh, GC, EPS, at=1, thickness=T)
    solver = make_solver("direct", elasticity.matrix(np.zeros(mesh.n_nodes)))
    return FemModel(mesh, elasticity, damage, loads, solver)


def test_a_constant_force_and_a_growing_displacement_in_closed_form():
    # Each half is a spring k = E H T / (L/2). The middle moves by (F/k + t)/2; the energy at
    # fixed (sound) damage is k t^2/4 - F t/2 - F^2/(4k): constant part B = -F^2/(4k), cross
    # term X = -F t/2 (the constant force's reaction on the pulled end is -F/2), P = k t^2/4.
    F, t = 3.0, 0.02
    model = chain_model(force=F)
    k = E * H * T / (L / 2)
    alpha = np.zeros(model.n_alpha)
    assert not model.proportional and not model.loads.proportional
    u = model.solve_u(alpha, t, None, 1e-12)
    middle = model.mesh.node_groups["middle"]
    np.testing.assert_allclose(u[middle * 2], (F / k + t) / 2, rtol=1e-10)
    elastic, _ = model.energies(u, alpha, t)
    assert elastic == pytest.approx(k * t**2 / 4 - F * t / 2 - F**2 / (4 * k), rel=1e-10)
    B, X, P = model.elastic_along_load(u, alpha, t)
    assert (B, X, P) == pytest.approx((-F**2 / (4 * k), -F * t / 2, k * t**2 / 4), rel=1e-9)
    # the state moved to t/2 along its line is the solution there (same damage: still sound)
    s = 0.5
    assert B + s * X + s**2 * P == pytest.approx(model.energies(model.solve_u(alpha, s * t, None, 1e-12), alpha,
                                                                s * t)[0], rel=1e-10)
    assert model.forces(u, alpha, t)["right"] == pytest.approx(k * t / 2 - F / 2, rel=1e-10)


def test_constant_loads_run_with_backtracking():
    model = chain_model(force=3.0)
    t = np.linspace(0.0, 0.1, 6)
    records, states = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard")).run(t)
    assert len(states) == len(t) and states[0].u[model.mesh.node_groups["middle"] * 2].min() > 0.0
