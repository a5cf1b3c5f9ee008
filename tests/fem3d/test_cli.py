"""A finite-element run through the command line: resume, extend, plot, info.

Resuming a ``kind = "fem"`` run from a results file cut after some steps, or extending a
finished run with more loads, gives the same results, bit for bit, as the uninterrupted run
(all on one thread, in processes of their own, as the scans run).
"""

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest

from thinfilm.cli import main

from tests.helpers import CASES, ROOT

#: The L-panel on a very coarse mesh, through the crack's appearance (about 0.27 mm).
COARSE = {"model.eps": 25.0, "mesh.h": 10.0, "mesh.h_coarse": 50.0,
          "load.t": [round(0.02 * k, 2) for k in range(16)], "output.snapshots": [0.3]}
_ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def _args(out, *options, overrides=COARSE):
    return ["run", str(CASES / "lpanel.toml"), "--out", str(out), "--quiet", *options] + [
        f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]


def _run(out, *options, overrides=COARSE):
    env = dict(os.environ, PYTHONPATH=str(ROOT), **_ONE_THREAD)
    done = subprocess.run([sys.executable, "-m", "thinfilm", *_args(out, *options, overrides=overrides)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


def _read(path):
    with h5py.File(path, "r") as f:
        return {f"steps/{k}": v[()] for k, v in f["steps"].items()} | {
            f"fields/{k}": v[()] for k, v in f["fields"].items()}


@pytest.fixture(scope="module")
def full(tmp_path_factory):
    """The uninterrupted run's directory."""
    out = tmp_path_factory.mktemp("fem") / "full"
    _run(out)
    return out


def test_a_cut_fem_run_resumes_to_the_same_results(full, tmp_path, capsys):
    cut = tmp_path / "cut"
    reference = _read(full / "results.h5")
    assert len(reference["steps/t"]) == 16
    assert reference["steps/surface"][-1] > 0   # the crack appeared: resuming crosses damage
    shutil.copytree(full, cut)
    with h5py.File(cut / "results.h5", "r+") as f:   # as if stopped after 9 steps
        for group in ("steps", "fields"):
            for ds in f[group].values():
                if ds.shape and ds.shape[0] == 16:
                    ds.resize(9, axis=0)
    assert main(_args(cut)) == 2   # refuses to overwrite
    capsys.readouterr()
    _run(cut, "--resume")
    resumed = _read(cut / "results.h5")
    assert resumed.keys() == reference.keys()
    for name, value in reference.items():
        if not name.startswith("steps/time_"):   # wall-clock timers
            np.testing.assert_array_equal(resumed[name], value, err_msg=name)

    # The figures again from the file alone, and the run's description.
    assert main(["plot", str(cut / "results.h5"), "--t", "0.3", "--out", str(tmp_path / "plots")]) == 0
    for name in ("force_displacement.png", "alpha_snapshots.png", "energy.png"):
        assert (tmp_path / "plots" / name).stat().st_size > 0, name
    assert main(["info", str(cut / "results.h5")]) == 0
    text = capsys.readouterr().out
    assert "fem" in text and "16" in text


def test_a_fem_run_extended_with_more_loads_is_the_longer_run(full, tmp_path, capsys):
    """The run to the first 10 loads of the list (damage, no crack yet), resumed with the whole
    list (and another snapshot: [output] only draws), is the uninterrupted run; a list that
    changes a computed load is refused, naming load.t, and leaves the results as they were."""
    out = tmp_path / "out"
    short = {**COARSE, "load.t": COARSE["load.t"][:10], "output.snapshots": [0.1]}
    _run(out, overrides=short)
    assert 0 < _read(out / "results.h5")["steps/surface"][-1] < 1e-3 * _read(full / "results.h5")["steps/surface"][-1]
    before = (out / "results.h5").read_bytes()
    moved = {**COARSE, "load.t": COARSE["load.t"][:5] + [0.11] + COARSE["load.t"][6:]}
    capsys.readouterr()
    assert main(_args(out, "--resume", overrides=moved)) == 2
    err = capsys.readouterr().err
    assert "load.t: the loads computed would change (step 5: t = 0.1 -> 0.11)" in err, err
    assert (out / "results.h5").read_bytes() == before
    _run(out, "--resume")
    reference, extended = _read(full / "results.h5"), _read(out / "results.h5")
    assert extended.keys() == reference.keys() and len(extended["steps/t"]) == 16
    for name, value in reference.items():
        if not name.startswith("steps/time_"):
            np.testing.assert_array_equal(extended[name], value, err_msg=name)
    summary, long_summary = (json.loads((d / "summary.json").read_text()) for d in (out, full))
    assert summary["steps"] == long_summary["steps"] and summary["events"] == long_summary["events"]


def test_steps_that_cannot_fit_the_memory_are_refused_at_once(tmp_path, capsys):
    # The mesh's nodes are estimated from the specimen's extent before gmsh makes it; the
    # steps' fields are what cannot fit.
    scene = tmp_path / "beam.toml"
    scene.write_text((CASES / "three_point_bending_I.toml").read_text())
    assert main(["run", str(scene), "--set", "load.steps=10000000000"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert lines[0].startswith(f"thinfilm: error: {scene}: load.steps = 10000000000: the run needs about")
    assert "nodes x 4 kB, and 1e+10 steps of fields)" in lines[0]
    assert "available on this machine; use fewer steps" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["beam.toml"]


def test_an_adaptive_run_extended_is_the_longer_run_bit_for_bit(tmp_path):
    """An adaptive run (the coarse panel from a uniform mesh of 50 mm refined down to 10 mm)
    stopped at 0.18 mm, its corner already refined, then resumed with the whole list (the
    crack and more refinement to come) is the uninterrupted run, bit for bit: every step's
    records and fields, and every stored mesh (the resumed run rebuilds its model by
    replaying the stored passes on the first mesh)."""
    adaptive = {**COARSE, "mesh.adapt": True}
    full, out = tmp_path / "full", tmp_path / "out"
    _run(full, overrides=adaptive)
    _run(out, overrides={**adaptive, "load.t": COARSE["load.t"][:10], "output.snapshots": [0.1]})
    with h5py.File(out / "results.h5", "r") as f:
        assert f["steps/mesh"][-1] > 0   # stopped on a refined mesh
    _run(out, "--resume", overrides=adaptive)

    def read(path):
        with h5py.File(path, "r") as f:
            return _read(path) | {f"meshes/{k}": v[()] for k, v in f["meshes"].items()}

    reference, resumed = read(full / "results.h5"), read(out / "results.h5")
    assert reference["steps/surface"][-1] > 0 and reference["steps/mesh"][-1] > reference["steps/mesh"][9]
    assert resumed.keys() == reference.keys()
    for name, value in reference.items():
        if not name.startswith("steps/time_"):
            np.testing.assert_array_equal(resumed[name], value, err_msg=name)


def test_a_cohesive_run_extended_is_the_longer_run_bit_for_bit(tmp_path):
    """The coarse panel with the cohesive law (its damage steps by bound-constrained Newton),
    stopped after the peak and resumed with the whole list, is the uninterrupted run bit for
    bit: every step's records, the Newton iterations among them, and fields."""
    cohesive = {**COARSE, "model.law": "czm", "model.ft": 2.7, "model.softening": "cornelissen"}
    full, out = tmp_path / "full", tmp_path / "out"
    _run(full, overrides=cohesive)
    _run(out, overrides={**cohesive, "load.t": COARSE["load.t"][:10], "output.snapshots": [0.1]})
    _run(out, "--resume", overrides=cohesive)
    reference, resumed = _read(full / "results.h5"), _read(out / "results.h5")
    assert reference["steps/damage_newton_iterations"][9:].sum() > 0 and reference["steps/surface"][-1] > 0
    assert resumed.keys() == reference.keys()
    for name, value in reference.items():
        if not name.startswith("steps/time_"):
            np.testing.assert_array_equal(resumed[name], value, err_msg=name)
