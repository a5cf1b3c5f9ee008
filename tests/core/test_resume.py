"""Runs that survive: kill and resume to the same results, Ctrl-C, refusing to overwrite."""

import json
import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from thinfilm.cli import main

from tests.helpers import CASES, ROOT

# A 1D film with backtracking (so resuming must restore the history the backtracking test
# reads), small enough to run in about a second: Fig. 2.5's film (cases/fig2_5.toml), coarser,
# without the search. A run is named by the case file and its overrides, given to the command
# line as --set options (a resumed run must be given the same).
FILM = {"model.eta_dx": 8, "domain.cells": 160, "load.t_max": 2.0, "load.steps": 60, "solver.search": False}


def _args(scene, out, *options):
    """``thinfilm run`` arguments of ``scene = (case file, overrides)``."""
    path, overrides = scene
    return ["run", str(path), "--out", str(out), "--quiet", *options] + [
        f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]


def _steps_done(results):
    try:
        with h5py.File(results, "r", locking=False) as f:
            return len(f["steps/t"])
    except (OSError, KeyError):
        return 0


# Runs whose fields are compared run in their own process on one thread: a threaded sparse
# direct solver (PARDISO) need not sum in the same order twice, and then two runs of one
# evolution agree only to round-off. On one thread, a resumed run must give the same bits.
_ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def _command(scene, out, *options):
    return [sys.executable, "-m", "thinfilm", *_args(scene, out, *options)]


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT), **_ONE_THREAD)


def _start(scene, out):
    return subprocess.Popen(_command(scene, out), env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _run(scene, out, *options):
    """Run to the end in a process of its own; its exit status."""
    done = subprocess.run(_command(scene, out, *options), env=_env(), capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done.returncode


def _stop_after(proc, results, steps, sig):
    """Deliver ``sig`` once ``steps`` steps are saved, while the evolution still runs.

    The process is frozen (SIGSTOP) as soon as the steps are seen, so that it cannot finish
    the evolution between that check and the signal.
    """
    deadline = time.monotonic() + 120
    while _steps_done(results) < steps:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.02)
    proc.send_signal(signal.SIGSTOP)
    assert _steps_done(results) < 61, "the run finished before it could be interrupted"
    proc.send_signal(sig)
    proc.send_signal(signal.SIGCONT)
    return proc.communicate(timeout=60)


def _fields(results):
    with h5py.File(results, "r") as f:
        return {k: v[()] for k, v in f["steps"].items()}, f["fields/alpha"][()], f["fields/u"][()]


def _reference(tmp_path_factory, overrides):
    tmp = tmp_path_factory.mktemp("reference")
    scene = (CASES / "fig2_5.toml", overrides)
    _run(scene, tmp / "out")
    return scene, _fields(tmp / "out" / "results.h5")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    return _reference(tmp_path_factory, FILM)


@pytest.fixture(scope="module")
def reference_mirror(tmp_path_factory):
    # The same film restricted to fields even in x: the resumed run must rebuild the same
    # restriction and continue from the stored (full-size) fields.
    return _reference(tmp_path_factory, {**FILM, "domain.symmetry": "mirror_x"})


@pytest.mark.parametrize("name, stop", [("reference", 10), ("reference", 30), ("reference_mirror", 30)])
def test_killed_run_resumes_to_the_same_results(name, stop, request, tmp_path):
    scene, (steps, alpha, u) = request.getfixturevalue(name)
    out = tmp_path / "out"
    proc = _start(scene, out)
    _stop_after(proc, out / "results.h5", stop, signal.SIGKILL)
    done = _steps_done(out / "results.h5")
    assert stop <= done < 61  # a valid file with the finished steps
    if stop == 10:
        # before the first crack: the next step rescales the last u instead of solving, and the
        # resumed run must rescale the very same numbers (steps/u_rescalable restores them)
        assert steps["u_rescalable"][done - 1] == 1 and steps["u_solves_skipped"][done] >= 1
    assert main(_args(scene, out)) == 2  # refuses to overwrite
    _run(scene, out, "--resume")
    got_steps, got_alpha, got_u = _fields(out / "results.h5")
    assert len(got_steps["t"]) == 61
    # The same evolution, bit for bit.
    for name in ("t", "total", "surface"):
        np.testing.assert_array_equal(got_steps[name], steps[name])
    np.testing.assert_array_equal(got_alpha, alpha)
    np.testing.assert_array_equal(got_u, u)


def test_ctrl_c_saves_and_exits_130(reference, tmp_path):
    scene, _ = reference
    out = tmp_path / "out"
    proc = _start(scene, out)
    _, err = _stop_after(proc, out / "results.h5", 10, signal.SIGINT)
    assert proc.returncode == 130
    assert "interrupted" in err and "--resume" in err
    assert _steps_done(out / "results.h5") >= 10
    with h5py.File(out / "results.h5", "r") as f:  # closed cleanly: opens with locking
        assert len(f["fields/alpha"]) == len(f["steps/t"])


def test_existing_results_need_force_or_resume(reference, tmp_path, capsys):
    scene, _ = reference
    out = tmp_path / "out"
    (out).mkdir()
    (out / "results.h5").write_bytes(b"")
    assert main(_args(scene, out)) == 2
    err = capsys.readouterr().err.strip()
    assert "already holds results.h5" in err and "--force" in err and "\n" not in err
    assert main(_args(scene, out, "--resume", "--force")) == 2
    assert main(_args(scene, out, "--force")) == 0
    assert _steps_done(out / "results.h5") == 61


def test_resume_refuses_a_different_scene(reference, tmp_path, capsys):
    scene, _ = reference
    out = tmp_path / "out"
    assert main(_args(scene, out)) == 0
    # Another value of one key, and the same file without the overrides, are other scenes.
    for other in ((scene[0], {**scene[1], "model.toughness": 0.06}), (scene[0], {})):
        assert main(_args(other, out, "--resume")) == 2
        assert "different scene" in capsys.readouterr().err


def test_resume_a_file_written_before_the_stability_records(reference, tmp_path):
    """A results file without /steps/lowest_curvature and saddles_left (written before they
    existed) resumes: the new records are added, unrecorded (NaN, 0) for its old steps."""
    scene, (steps, alpha, _) = reference
    out = tmp_path / "out"
    _run(scene, out)
    with h5py.File(out / "results.h5", "r+") as f:
        for name in ("lowest_curvature", "saddles_left"):
            del f["steps"][name]
        for ds in f["steps"].values():
            ds.resize((30,))
        for name in ("u", "alpha"):
            f["fields"][name].resize((30, f["fields"][name].shape[1]))
    _run(scene, out, "--resume")
    got_steps, got_alpha, _ = _fields(out / "results.h5")
    np.testing.assert_array_equal(got_steps["total"], steps["total"])
    np.testing.assert_array_equal(got_alpha, alpha)
    assert np.all(np.isnan(got_steps["lowest_curvature"])) and not got_steps["saddles_left"].any()
