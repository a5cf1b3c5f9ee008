"""The force conjugate to a film's load: its formula, the recorded values against the recorded
energies, the closed forms of a rigid film under the indenter and of the elastic cantilever,
and what a run writes (docs/model.md#force-conjugate-to-the-load)."""

import json
import math

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.engine import Engine
from thinfilm.plate.kind import KIND, build_grid, make_load, make_model
from thinfilm.plate.model import crack_profile
from thinfilm.plate.results import PlateResults
from thinfilm.plots import axis_label
from thinfilm.scene import load_scene

from tests.helpers import CASES, load_case

#: The 1D coated cantilever of the crack-spacing scan.
CANTILEVER_1D = CASES / "scans" / "cantilever_film_1d.toml"


def _cantilever_1d(overrides):
    from thinfilm.scene import load_scene

    return load_scene(CANTILEVER_1D, overrides=overrides)


def _model(scene):
    grid = build_grid(scene.domain)
    return grid, make_model(scene, grid), make_load(scene, grid)


def _run(scene, t_values):
    """Drive the engine as a run does and keep, per step, ``(t, total energy, observed, alpha)``:
    the values a run writes to ``/steps`` (:meth:`PlateKind.setup`'s observer)."""
    setup = KIND.setup(scene)
    steps = []

    def on_step(record, state):
        if record.index < len(steps):          # a backtrack rewrites the later steps
            del steps[record.index:]
        steps.append((record.t, record.total, setup.observe(state.u, state.alpha, state.t), state.alpha.copy()))

    Engine.from_options(setup.model, scene.solver).run(t_values, on_step=on_step)
    return setup.model, steps


@pytest.mark.parametrize("name, overrides, t", [
    ("indentation", {"domain.cells": [40, 40], "model.eta": 0.04}, 0.437),
    ("cantilever_6e6", {"domain.cells": [60, 6], "output.snapshots": [1.0]}, 0.8),
    ("fig2_7", {"domain.cells": [60, 12]}, 3.0),
])
def test_force_is_the_derivative_of_the_energy_in_t_at_fixed_u_and_alpha(name, overrides, t):
    # Any u and a damaged film: only the foundation depends on t, and F = dE/dt exactly (a
    # quadratic in t for a proportional load; for the indenter no node crosses the contact
    # circle between t - dt and t + dt, checked).
    grid, model, load = _model(load_case(name, overrides))
    rng = np.random.default_rng(1)
    u = 0.05 * rng.standard_normal(grid.n_nodes) * np.max(np.abs(load.w(t)))
    x = grid.coordinates
    alpha = crack_profile(np.abs(x[0] - 0.5 * (x[0].min() + x[0].max())), model.eta, 1)
    dt = 1e-6 if name == "indentation" else 1e-3
    if name == "indentation":
        r2 = x[0] ** 2 + x[1] ** 2
        assert np.array_equal(r2 < 0.09 * (t - dt) * (2 - t + dt), r2 < 0.09 * (t + dt) * (2 - t - dt))

    def energy(s):
        return sum(model.energies(u, alpha, s))

    derivative = (energy(t + dt) - energy(t - dt)) / (2 * dt)
    assert model.force(u, t) == pytest.approx(derivative, rel=1e-7)


def test_indentation_force_balances_the_recorded_energy():
    # Loads in pairs (t, t + 1e-3): within a pair the recorded energies must rise by the
    # recorded force times the depth increment, dE = F dd (envelope theorem at fixed damage;
    # energy balance while the damage grows). On the grid the indenter is affine in the
    # depth while no node enters the contact disk, so at fixed damage E is quadratic there
    # and the trapezoidal rule exact: agreement to round-off. A node entering the disk
    # switches its foundation term on (a jump of F by k omega u_n), hence pairs across an
    # entry are left out (1-3% of F). While the crack rings grow the balance holds to the
    # alternate-minimization tolerance: measured 9e-6..1.1e-4 of F.
    scene = load_case("indentation", {"model.winkler": 4e4, "domain.cells": [40, 40], "model.eta": 0.04})
    delta = 1e-3
    starts = np.array([0.05, 0.1, 0.15, 0.3, 0.5, 0.9])
    model, steps = _run(scene, np.concatenate([[0.0], np.column_stack([starts, starts + delta]).ravel()]))
    x, y = model.grid.coordinates
    R = scene.load.radius
    elastic, damaged = [], []
    for (ta, Ea, a, alpha_a), (tb, Eb, b, alpha_b) in zip(steps[1::2], steps[2::2]):
        assert b["displacement"] - a["displacement"] == pytest.approx(R * delta, rel=1e-9)
        if not np.array_equal(x**2 + y**2 < R**2 * ta * (2 - ta), x**2 + y**2 < R**2 * tb * (2 - tb)):
            continue
        mismatch = (Eb - Ea) / (b["displacement"] - a["displacement"]) / (0.5 * (a["force"] + b["force"])) - 1
        (elastic if alpha_b.max() == 0.0 else damaged).append(abs(mismatch))
    assert len(elastic) >= 2 and len(damaged) >= 2
    assert max(elastic) < 1e-10
    assert max(damaged) < 1e-3
    assert steps[-1][3].max() > 0.99          # the film did crack
    # pressing in is positive work: the force is positive throughout
    assert all(s[2]["force"] > 0 for s in steps[1:])


def test_cantilever_force_balances_the_recorded_energy():
    # A proportional load: between steps whose damage is the same the minimized energy is
    # C t^2 and the force 2 C t / s (s = 2 lx^3, the tip deflection per unit t), so the
    # trapezoidal rule is exact, and F d = 2 P (Clapeyron) at every such step: both hold to
    # the u-solve's residual tolerance (measured 7.5e-8). Steps where the damage moves (by
    # more than the tolerance, the crack bands settling) balance to 5e-4, the steps of a
    # new crack not at all (the energy released).
    scene = _cantilever_1d({"model.winkler": 4e4, "domain.cells": 200, "load.t_max": 2.4, "load.steps": 40})
    _, steps = _run(scene, np.linspace(0.0, 2.4, 41))
    t = np.array([s[0] for s in steps])
    E = np.array([s[1] for s in steps])
    F = np.array([s[2]["force"] for s in steps])
    d = np.array([s[2]["displacement"] for s in steps])
    np.testing.assert_allclose(d, 2.0 * t, rtol=1e-15)
    same = np.array([np.array_equal(a[3], b[3]) for a, b in zip(steps[:-1], steps[1:])])
    mismatch = np.diff(E) / np.diff(d) / (0.5 * (F[1:] + F[:-1])) - 1
    assert same.sum() >= 8 and np.abs(mismatch[same]).max() < 1e-6
    elastic = np.array([s[3].max() == 0.0 for s in steps]) & (t > 0)
    P = np.array([s[1] for s in steps])       # no surface energy while alpha = 0
    assert elastic.sum() >= 8
    np.testing.assert_allclose(F[elastic] * d[elastic], 2.0 * P[elastic], rtol=1e-6)
    assert max(s[3].max() for s in steps) > 0.99           # cracks did form


def test_rigid_film_under_the_indenter_carries_the_foundation_alone():
    # A film much stiffer than its foundation (winkler = 0.01 on a domain of size 0.8) stays
    # flat and sinks as a whole to the mean substrate displacement -V/A (free edges, no tilt
    # by symmetry), V = pi d^2 (3R - d)/3 the sphere cap below the film, A the domain's area.
    # The springs under the contact disk (area pi r_c^2) then push back with
    # F = k (V - pi r_c^2 V / A) = k V (1 - pi r_c^2 / A).
    k = 0.01
    grid, model, load = _model(load_case("indentation", {"model.winkler": k, "domain.cells": [64, 64],
                                                         "model.eta": 0.025}))
    R, area = 0.3, 0.8**2
    for t in (0.2, 0.5, 0.8):
        u = model.solve_u(np.zeros(grid.n_nodes), t, None, 1e-12)
        force = model.force(u, t) / load.displacement_scale
        d, rc2 = R * t, R**2 * t * (2 - t)
        cap = math.pi * d**2 * (3 * R - d) / 3
        # the continuous closed form; the grid's contact disk is a lattice-point count, its
        # area converges erratically (measured -0.16%, +0.17%, -0.15% at 64^2 cells)
        assert force == pytest.approx(k * cap * (1 - math.pi * rc2 / area), rel=4e-3)
        # the same limit on the grid: u = the weighted mean of w (measured 0.8e-5..2.5e-5: the
        # film's flexibility, O(k), and the round-off of a nearly singular u-problem)
        w, omega = load.w(t), grid.weights
        flat = -k * omega @ ((omega @ w / omega.sum() - w) * load.dw(t)) / load.displacement_scale
        assert force == pytest.approx(flat, rel=1e-4)


def _tip_stiffness(lam, length):
    """Tip force over tip deflection of the elastic 1D coated cantilever (docs/model.md)."""
    x = lam * length
    phi = (math.sinh(2 * x) - math.sin(2 * x)) / (math.cosh(2 * x) + math.cos(2 * x) + 2)
    return 3.0 / length**3 - 4.5 * phi / (lam**3 * length**6)


def test_cantilever_tip_force_against_the_elastic_closed_form():
    # 1D film clamped at 0 on a foundation of winkler = 4 lam^4, substrate t s^2 (3 l - s):
    # F / w_t(l) = 3/l^3 - 4.5 phi(lam l) / (lam^3 l^6). lam = 2.5 makes the foundation's
    # part a tenth of the film's. Second order in dx (errors 1.66e-4, 4.09e-5 at 50, 100 cells).
    lam, t = 2.5, 0.01
    exact = _tip_stiffness(lam, 1.0)
    errors = []
    for cells in (50, 100):
        grid, model, load = _model(_cantilever_1d({"model.winkler": 4 * lam**4, "domain.cells": cells}))
        u = model.solve_u(np.zeros(grid.n_nodes), t, None, 1e-12)
        errors.append(model.force(u, t) / load.displacement_scale**2 / t / exact - 1)
    assert abs(errors[1]) < 6e-5 and 3.5 < errors[0] / errors[1] < 4.5
    # The 2D strip with nu = 0 bends as the 1D film, per unit width (0.1); with nu = 0.3 its
    # free long edges make it 7% softer (a narrow beam: between D (1 - nu^2) and D).
    for nu, ratio in ((0.0, 1.0), (0.3, 0.927)):
        grid, model, load = _model(load_case("cantilever_6e6", {"model.winkler": 4 * lam**4, "model.nu": nu,
                                                                "domain.cells": [100, 4], "output.snapshots": [1.0]}))
        u = model.solve_u(np.zeros(grid.n_nodes), t, None, 1e-12)
        stiffness = model.force(u, t) / load.displacement_scale**2 / t / 0.1
        assert stiffness / exact == pytest.approx(ratio * (1 + errors[1]), rel=1e-6 if nu == 0 else 2e-3)


def test_a_run_writes_summarizes_reports_and_draws_the_force(tmp_path, capsys):
    # The ITO indentation in physical units, coarse: /steps/force and /steps/displacement
    # (non-dimensional) and their SI values, summary.json, the report, thinfilm info and
    # force_displacement.png.
    out = tmp_path / "ito"
    assert main(["run", str(CASES / "ito_indentation.toml"), "--out", str(out), "--quiet",
                 "--set", "domain.cells=[32, 32]", "--set", "model.eta=0.05", "--set", "load.steps=4",
                 "--set", "load.t_max=0.4", "--set", "output.snapshots=[0.4]"]) == 0
    with h5py.File(out / "results.h5") as f:
        steps = {name: f["steps"][name][()] for name in ("t", "force", "displacement", "force_si", "displacement_si")}
        material = dict(f["material"].attrs)
    np.testing.assert_allclose(steps["displacement"], 0.3 * steps["t"], rtol=1e-15)
    assert steps["force"][0] == 0.0 and np.all(steps["force"][1:] > 0)
    D, L = material["rigidity"], material["L"]
    np.testing.assert_allclose(steps["force_si"], steps["force"] * D / L, rtol=1e-12)
    np.testing.assert_allclose(steps["displacement_si"], steps["displacement"] * L, rtol=1e-12)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["steps"]["force"] == pytest.approx(steps["force"].tolist(), rel=0, abs=0)
    assert summary["steps"]["force_si"] == pytest.approx(steps["force_si"].tolist(), rel=0, abs=0)
    assert (out / "force_displacement.png").stat().st_size > 1000
    k = int(np.argmax(steps["force"]))
    capsys.readouterr()
    assert main(["info", str(out)]) == 0
    info = capsys.readouterr().out
    assert f"peak force {steps['force'][k]:.6g} at t = {steps['t'][k]:.6g}" in info
    assert f"in SI units: {steps['force_si'][k]:.6g} N" in info
    # energies and lengths in SI beside the non-dimensional ones: one unit of energy is the
    # flexural rigidity D = E h^3 / (12 (1 - nu^2)), one of length L (docs/model.md#physical-units)
    m = load_scene(CASES / "ito_indentation.toml").material
    D_scene = m.E * m.h**3 / (12.0 * (1.0 - m.nu**2))
    units = summary["units"]
    assert units["energy"] == pytest.approx(D_scene, rel=1e-12) and units["length"] == m.L
    assert units["force"] == pytest.approx(D_scene / m.L, rel=1e-12)
    for name in ("elastic", "surface", "total"):
        np.testing.assert_allclose(summary["steps"][f"{name}_si"], np.array(summary["steps"][name]) * D_scene,
                                   rtol=1e-12)
    np.testing.assert_allclose(summary["steps"]["crack_length_si"], np.array(summary["steps"]["crack_length"]) * m.L,
                               rtol=1e-12)
    for event in summary["events"]:
        np.testing.assert_allclose(event["cracks_si"], np.array(event["cracks"]) * m.L, rtol=1e-12)
    total = summary["steps"]["total"][-1] * D_scene
    assert "energies at the last finished step in SI units:" in info and f"total {total:.6g} J" in info
    with PlateResults(out / "results.h5") as res:  # the field figures' axes give L in SI
        assert axis_label(res, "x") == "x (L = 1.88 µm)"
