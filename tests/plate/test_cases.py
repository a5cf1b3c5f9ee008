"""Plate scenes end to end: the regularized film against the exact evolution, and bad input."""

import json
from pathlib import Path

import h5py
import numpy as np
import pytest

from onedim.evolution import evolve
from thinfilm.cli import main
from thinfilm.plate.cracks import centre_line, crack_positions
from thinfilm.engine import AltMinOptions, Engine, StepRecord
from thinfilm.plate.kind import build_grid, make_model, resolution_warnings
from thinfilm.scene import load_scene, parse_scene

from tests.helpers import CASES, load_case  # noqa: E402


def _events(path):
    return json.loads(Path(path).read_text())["events"]


def test_fig2_5_regression(tmp_path):
    assert main(["compare", str(CASES / "fig2_5.toml"), "--out", str(tmp_path), "--quiet"]) == 0
    events = _events(tmp_path / "summary.json")
    exact = evolve(0.5, 10.0, 0.05, cells=1000, t_max=3.0)
    dt = 3.0 / 100
    assert [len(e["cracks"]) for e in events] == [1, 3]
    for found, ref in zip(events, exact):
        assert abs(found["t"] - ref.t) <= dt + 1e-12
        assert np.max(np.abs(np.array(found["cracks"]) - ref.cracks)) < 4 * 0.5 / 800
    report = json.loads((tmp_path / "compare.json").read_text())
    t = np.array(report["energy_relative_error"]["t"])
    error = np.abs(report["energy_relative_error"]["error"])
    after = np.array([all(abs(ti - e.t) > dt for e in exact) for ti in t]) & (t > exact[0].t)
    assert np.max(error[after]) < 0.01  # total energy within 1% after each event
    with h5py.File(tmp_path / "results.h5") as f:
        assert f.attrs["kind"] == "plate"
        assert f["fields/alpha"].shape == (101, 801) and f["fields/u"].shape == (101, 801)
        assert f["grid/x"].shape == (801,)
        alpha = f["fields/alpha"][()]
        assert np.all(np.diff(alpha, axis=0) >= 0.0)  # irreversibility, every step
        assert f["steps/trials"][()].sum() > 0
        assert np.all(f["steps/iterations"][()] >= 1)
    assert (tmp_path / "compare.png").exists() and (tmp_path / "alpha.png").exists()


def test_fig2_6_regression_asymmetric(tmp_path):
    # The exact asymmetric sequence (or its mirror image), each event within one load step.
    assert main(["run", str(CASES / "fig2_6.toml"), "--out", str(tmp_path), "--quiet"]) == 0
    events = _events(tmp_path / "summary.json")
    exact = evolve(0.8, 10.0, 0.05, cells=1280, t_max=1.5)
    assert [len(e["cracks"]) for e in events] == [1, 2, 3]
    sign = -1.0 if (events[0]["cracks"][0] > 0) != (exact[0].cracks[0] > 0) else 1.0
    for found, ref in zip(events, exact):
        assert abs(found["t"] - ref.t) <= 1.5 / 100 + 1e-12
        got = np.sort(sign * np.array(found["cracks"]))
        assert np.max(np.abs(got - np.array(ref.cracks))) < 0.01


PLATE = """
[model]
kind = "plate"
lam = 10.0
toughness = 0.05
eta_dx = 10
[domain]
x = [-0.25, 0.25]
cells = 200
[load]
t_max = 1.0
steps = 10
"""


@pytest.mark.parametrize("text, message", [
    (PLATE.replace("eta_dx = 10", "eta_dx = 10\neta = 0.01"), "give exactly one of model.eta and model.eta_dx"),
    (PLATE.replace("cells = 200", "cells = 200\ny = [-0.1, 0.1]"), "domain.cells = 200: must be [nx, ny]"),
    (PLATE.replace("x = [-0.25, 0.25]", "x = [0.25, -0.25]"), "domain.x = [0.25, -0.25]: must be an interval"),
    (PLATE.replace("lam = 10.0", "lam = 10.0\nnu = 0.7"), "model.nu = 0.7: must be in (-1, 0.5)"),
    (PLATE.replace("lam = 10.0", "lam = 10.0\nat = 3"), "model.at = 3: must be 1 (AT1) or 2 (AT2)"),
    (PLATE + '[solver]\nbacktrack = "always"\n', 'solver.backtrack = "always": must be one of "none", "standard", "deep"'),
    (PLATE + "[solver]\nomega = 0.5\n", "solver.omega = 0.5: must be in [1, 64]"),
    (PLATE + "[solver]\nsearch = 1\n", "solver.search = 1: must be true or false"),
    (PLATE + "[solver]\nserach = true\n", "solver.serach: unknown key; did you mean 'search'?"),
    (PLATE.replace('[load]', '[load]\nkind = "twist"'), 'load.kind = "twist": must be one of "bending"'),
    (PLATE + "[output]\nsnapshots = [0.5, 4.0]\n",
     "output.snapshots = [0.5, 4.0]: must be a list of 1 to 12 loads in [0, load.t_max = 1]"),
    (PLATE + "[output]\nsnapshot = [0.5]\n", "output.snapshot: unknown key; did you mean 'snapshots'?"),
])
def test_bad_plate_input(tmp_path, capsys, text, message):
    scene = tmp_path / "bad.toml"
    scene.write_text(text)
    assert main(["run", str(scene)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.toml"]


def test_resolution_warnings():
    assert resolution_warnings(load_scene(CASES / "fig2_5.toml")) == []
    coarse = parse_scene(PLATE.replace("lam = 10.0", "lam = 31.62").replace("eta_dx = 10", "eta = 0.02"))
    assert any("eta * lam" in w for w in resolution_warnings(coarse))
    thin = parse_scene(PLATE.replace("eta_dx = 10", "eta_dx = 1.5"))
    assert any("less than 2 grid cells" in w for w in resolution_warnings(thin))


FIG2_7_GRIDS = [
    pytest.param([300, 60], id="300x60"),
    # The same eta = 1/120 on a grid twice as fine (eta = 5 dx): about 2.5 minutes.
    pytest.param([600, 120], id="600x120-fixed-eta", marks=pytest.mark.slow),
]


@pytest.mark.parametrize("cells", FIG2_7_GRIDS)
def test_over_relaxation_halves_the_nucleation_burst_of_the_fig2_7_strip(cells):
    # Without backtracking the strip stays elastic (alpha = 0) up to t = 6.4 and all nine
    # cracks form at t = 6.5, one pair after the other: 124 plain iterations on 300 x 60,
    # 119 on 600 x 120. Over-relaxation must at least halve them and end at the same energy
    # (within 0.5%) on both grids.
    scene = load_case("fig2_7", {"model.eta_dx": None, "model.eta": 1 / 120, "domain.cells": cells})
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    zero = np.zeros(model.n_alpha)
    results = {}
    for acceleration in ("none", "overrelax"):
        engine = Engine(model, AltMinOptions(acceleration=acceleration, omega=scene.solver.altmin.omega))
        record = StepRecord(65, 6.5)
        state = engine.alternate_minimization(6.5, zero, zero, None, record, 65)
        history = np.array(record.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * history[0])
        x, line = centre_line(grid, state.alpha)
        assert len(crack_positions(x, line)) == 9
        results[acceleration] = record.iterations, state.total
    (n_plain, e_plain), (n_fast, e_fast) = results["none"], results["overrelax"]
    assert n_fast <= 0.5 * n_plain
    assert abs(e_fast - e_plain) <= 5e-3 * e_plain


@pytest.mark.slow
def test_fig2_7_strip_nine_cracks(tmp_path):
    # About 2 minutes: pytest -m slow. Nine through-width cracks within 0.015 of 0, +-0.1,
    # ..., +-0.4, first nucleation within 5% of t = 5.36, energy per unit width within 3%.
    assert main(["compare", str(CASES / "fig2_7.toml"), "--out", str(tmp_path), "--quiet"]) == 0
    events = _events(tmp_path / "summary.json")
    first = next(e for e in events if len(e["cracks"]) >= 9)
    assert len(events[0]["cracks"]) == 9 and abs(events[0]["t"] - 5.36068) < 0.05 * 5.36068
    assert np.max(np.abs(np.array(first["cracks"]) - np.arange(-0.4, 0.41, 0.1))) < 0.015
    report = json.loads((tmp_path / "compare.json").read_text())
    t = np.array(report["energy_relative_error"]["t"])
    error = np.abs(report["energy_relative_error"]["error"])
    assert np.max(error[t >= events[0]["t"]]) < 0.03
