"""A finite-element run through the command line: resume, plot, info.

Resuming a ``kind = "fem"`` run from a results file cut after some steps gives the same
results, bit for bit, as the uninterrupted run (both on one thread, in processes of their
own: a threaded direct solver need not sum in the same order twice).
"""

import json
import os
import shutil
import subprocess
import sys

import h5py
import numpy as np

from thinfilm.cli import main

from tests.helpers import CASES, ROOT

#: The L-panel on a very coarse mesh, through the crack's appearance (about 0.27 mm).
COARSE = {"model.eps": 25.0, "mesh.h": 10.0, "mesh.h_coarse": 50.0,
          "load.t": [round(0.02 * k, 2) for k in range(16)], "output.snapshots": [0.3]}
_ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def _args(out, *options):
    return ["run", str(CASES / "lpanel.toml"), "--out", str(out), "--quiet", *options] + [
        f"--set={key}={json.dumps(value)}" for key, value in COARSE.items()]


def _run(out, *options):
    env = dict(os.environ, PYTHONPATH=str(ROOT), **_ONE_THREAD)
    done = subprocess.run([sys.executable, "-m", "thinfilm", *_args(out, *options)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr


def _read(path):
    with h5py.File(path, "r") as f:
        return {f"steps/{k}": v[()] for k, v in f["steps"].items()} | {
            f"fields/{k}": v[()] for k, v in f["fields"].items()}


def test_a_cut_fem_run_resumes_to_the_same_results(tmp_path, capsys):
    full, cut = tmp_path / "full", tmp_path / "cut"
    _run(full)
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


def test_steps_that_cannot_fit_the_memory_are_refused_at_once(tmp_path, capsys):
    # Its mesh is only known once gmsh has made it: the steps alone are estimated.
    scene = tmp_path / "beam.toml"
    scene.write_text((CASES / "three_point_bending_I.toml").read_text())
    assert main(["run", str(scene), "--set", "load.steps=10000000000"]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert lines[0].startswith(f"thinfilm: error: {scene}: load.steps = 10000000000: the run needs about 200 TB of memory (1e+10 steps x 20 kB)")
    assert "available on this machine; use fewer steps" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["beam.toml"]
