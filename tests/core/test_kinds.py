"""A new model kind is one registered folder: the AT1 bar of ``examples/bar`` run through the
toolkit's scene reader, engine, results file, XDMF index, figures and command line.

None of these modules knows the bar (``tests/core/test_imports.py`` checks that the core
imports no kind); the kind is registered and gets everything a film run gets, on a 1D
mesh instead of a grid, with an observable of its own (the axial force).
"""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest

from examples.bar.kind import BarKind
from examples.bar.model import Bar
from tests.helpers import ROOT
from thinfilm import kinds
from thinfilm.cli import main
from thinfilm.scene import SceneError, parse_scene

SCENE = """\
[model]
kind = "bar"
L = 1.0
E = 1.0
Gc = 1.0
ell = 0.05
elements = 100
[load]
t_max = 3.0
steps = 15
[solver]
backtrack = "standard"
"""


@pytest.fixture
def bar_kind():
    """The bar registered as ``kind = "bar"`` for one test."""
    kinds.register(BarKind())
    yield kinds.get("bar")
    kinds.unregister("bar")


@pytest.fixture
def bar_run(bar_kind, tmp_path):
    scene = tmp_path / "bar.toml"
    scene.write_text(SCENE)
    assert main(["run", str(scene), "--quiet"]) == 0
    return tmp_path / "bar"


def test_unknown_kinds_are_refused_naming_the_known_ones():
    with pytest.raises(SceneError, match='model.kind = "bar": must be one of "exact1d", "plate", "fem"'):
        parse_scene(SCENE)


def test_a_registered_kind_is_known_by_name(bar_kind):
    assert "bar" in kinds.names()
    scene = parse_scene(SCENE)
    assert scene.kind == "bar" and scene.solver.backtrack.kind == "standard"
    with pytest.raises(SceneError, match="model.elements = 99: must be even"):
        parse_scene(SCENE.replace("elements = 100", "elements = 99"))
    with pytest.raises(SceneError, match="solver.omega = 100.0: must be in \\[1, 64\\]"):
        parse_scene(SCENE + "omega = 100\n")


def test_the_run_writes_the_mesh_the_fields_and_the_force(bar_run):
    bar = Bar(ell=0.05, n=100)
    with h5py.File(bar_run / "results.h5") as f:
        assert f.attrs["kind"] == "bar"
        assert f["mesh"].attrs["dim"] == 1 and f["mesh/cells"].shape == (100, 2)
        np.testing.assert_array_equal(f["mesh/points"][:, 0], bar.x)
        t, force, total = f["steps/t"][()], f["steps/force"][()], f["steps/total"][()]
        alpha = f["fields/alpha"][()]
    assert len(t) == 16
    elastic = alpha.max(axis=1) == 0.0
    # Elastic steps: the force of a uniform bar, (1 + k_res) E t / L, to round-off.
    np.testing.assert_allclose(force[elastic], (1.0 + bar.k_res) * bar.E * t[elastic] / bar.L, rtol=1e-12)
    # The film breaks once, between the Griffith load sqrt(2 L Gc_w / E) (backtracking) and
    # t_c; after that the force is what the residual stiffness and the crack's shoulders carry.
    cracked = ~elastic
    assert cracked.any() and elastic[: np.argmax(cracked)].all()
    assert np.sqrt(2 * bar.L * bar.Gc_weak / bar.E) <= t[np.argmax(cracked)] <= bar.critical_load() + 0.1
    assert np.all(force[cracked] < 0.1 * force[elastic].max())
    assert abs(total[-1] - bar.Gc_weak) < 0.2 * bar.Gc_weak
    summary = json.loads((bar_run / "summary.json").read_text())
    assert summary["kind"] == "bar" and summary["steps"]["total"] == pytest.approx(total.tolist(), rel=0, abs=0)


def test_the_generic_outputs_work_for_the_new_kind(bar_run, capsys):
    for name in ("energy.png", "alpha.png", "alpha_snapshots.png", "u_snapshots.png", "iterations.png"):
        assert (bar_run / name).stat().st_size > 0, name
    root = ET.parse(bar_run / "results.xdmf").getroot()
    topology = root.find(".//Grid/Grid/Topology")
    assert topology.get("TopologyType") == "Polyline" and topology.get("NumberOfElements") == "100"
    assert len(root.findall(".//Grid/Grid")) == 16
    assert main(["info", str(bar_run)]) == 0
    out = capsys.readouterr().out
    assert "kind = bar" in out and "mesh: 1D, 101 nodes, 100 segments" in out and "steps finished: 16 of 16" in out
    assert main(["plot", str(bar_run), "--t", "0.5", "3.0", "--animate"]) == 0
    assert (bar_run / "alpha.gif").stat().st_size > 0


def test_the_example_scene_runs_as_a_user_runs_it(tmp_path):
    """``examples/bar/bar.toml`` through ``python -m examples.bar run`` (the kind registered,
    then ``thinfilm``'s own command line), in a process of its own as a user starts it from
    the repository's root; the results file read back: the elastic steps' force, one crack
    between the Griffith load and ``t_c``, and ``info`` on the run."""
    out = tmp_path / "bar"
    command = [sys.executable, "-m", "examples.bar", "run", "examples/bar/bar.toml", "--out", str(out), "--quiet"]
    # From the root, ``python -m`` finds ``examples`` (and an uninstalled toolkit) there.
    done = subprocess.run(command, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    bar = Bar(ell=0.05, n=200)
    with h5py.File(out / "results.h5") as f:
        assert f.attrs["kind"] == "bar" and f["mesh/cells"].shape == (200, 2)
        parameters = dict(f["parameters"].attrs)
        assert parameters.pop("snapshots").tolist() == [1.0, 1.5, 3.0]
        assert parameters == {"L": 1.0, "E": 1.0, "Gc": 1.0, "ell": 0.05, "elements": 200, "t_max": 3.0, "steps": 30}
        t, force = f["steps/t"][()], f["steps/force"][()]
        alpha = f["fields/alpha"][()]
    np.testing.assert_array_equal(t, np.arange(31) / 10)
    elastic = alpha.max(axis=1) == 0.0
    np.testing.assert_allclose(force[elastic], (1.0 + bar.k_res) * bar.E * t[elastic] / bar.L, rtol=1e-12)
    first = np.argmax(~elastic)
    assert elastic[:first].all() and not elastic[first:].any()
    assert np.sqrt(2 * bar.L * bar.Gc_weak / bar.E) <= t[first] <= bar.critical_load()
    assert np.argmax(alpha[-1]) == bar.m
    for name in ("summary.json", "energy.png", "alpha_snapshots.png", "results.xdmf"):
        assert (out / name).stat().st_size > 0, name
    info = subprocess.run([sys.executable, "-m", "examples.bar", "info", str(out)], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)
    assert info.returncode == 0 and "steps finished: 31 of 31" in info.stdout, info.stderr
