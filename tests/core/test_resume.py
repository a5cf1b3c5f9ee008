"""Runs that survive: kill and resume to the same results, Ctrl-C, refusing to overwrite;
runs that are extended (a larger load.t_max at the same step spacing) to the results of one
longer run; scenes compared as parsed (comments and formatting do not matter, a changed key
is refused by name); the same scene run twice gives the same bits."""

import hashlib
import json
import os
import shutil
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


# Runs whose fields are compared run in their own process on one thread: the machine's other
# core is often busy, where a second PARDISO thread only slows down. (Threads do not change
# the bits: PARDISO runs with MKL's conditional numerical reproducibility, see
# test_two_runs_on_default_threads_agree_to_the_last_bit.)
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
    return scene, _fields(tmp / "out" / "results.h5"), tmp / "out"


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
    scene, (steps, alpha, u), _ = request.getfixturevalue(name)
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
    scene, _, _ = reference
    out = tmp_path / "out"
    proc = _start(scene, out)
    _, err = _stop_after(proc, out / "results.h5", 10, signal.SIGINT)
    assert proc.returncode == 130
    assert "interrupted" in err and "--resume" in err
    assert _steps_done(out / "results.h5") >= 10
    with h5py.File(out / "results.h5", "r") as f:  # closed cleanly: opens with locking
        assert len(f["fields/alpha"]) == len(f["steps/t"])


def test_existing_results_need_force_or_resume(reference, tmp_path, capsys):
    scene, _, _ = reference
    out = tmp_path / "out"
    (out).mkdir()
    (out / "results.h5").write_bytes(b"")
    assert main(_args(scene, out)) == 2
    err = capsys.readouterr().err.strip()
    assert "already holds results.h5" in err and "--force" in err and "\n" not in err
    assert main(_args(scene, out, "--resume", "--force")) == 2
    assert main(_args(scene, out, "--force")) == 0
    assert _steps_done(out / "results.h5") == 61


def _digest(out):
    """The bytes of a run directory's results and summary."""
    return {name: hashlib.sha256((out / name).read_bytes()).hexdigest() for name in ("results.h5", "summary.json")}


def _copy_run(reference_out, tmp_path):
    out = tmp_path / "out"
    shutil.copytree(reference_out, out)
    return out


@pytest.mark.parametrize("overrides, named", [
    ({"model.toughness": 0.06}, "model.toughness (0.05 -> 0.06)"),
    ({"solver.backtrack": "none"}, 'solver.backtrack ("standard" -> "none")'),
    ({"model.k_res": 1e-5}, "model.k_res (1e-06 -> 1e-05)"),
    # a larger t_max at another spacing, and fewer steps, would change the computed loads
    ({"load.t_max": 3.0}, "load.t_max (2.0 -> 3.0), load.steps (60 -> 60): the loads computed would change"
                          " (step 1: t = 0.03333333333333333 -> 0.05), load.steps = 90 keeps the spacing"),
    ({"load.t_max": 1.0, "load.steps": 30}, "load.t_max (2.0 -> 1.0), load.steps (60 -> 30): fewer loads"),
])
def test_resume_refuses_a_changed_key_naming_it(reference, tmp_path, capsys, overrides, named):
    """Refused in one line that names the key with its old and new values, exit status 2,
    and the results and summary left as they were, byte for byte."""
    scene, _, reference_out = reference
    out = _copy_run(reference_out, tmp_path)
    before = _digest(out)
    assert main(_args((scene[0], {**scene[1], **overrides}), out, "--resume")) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "different scene" in err and named in err and "--force" in err, err
    assert _digest(out) == before


def test_resume_refuses_the_file_without_its_overrides(reference, tmp_path, capsys):
    scene, _, reference_out = reference
    out = _copy_run(reference_out, tmp_path)
    assert main(_args((scene[0], {}), out, "--resume")) == 2
    err = capsys.readouterr().err
    assert "model.eta_dx (8 -> 10)" in err and "domain.cells (160 -> 800)" in err and "solver.search" in err


def _film_text():
    """cases/fig2_5.toml with FILM written into it, reformatted: other comments, tables and
    keys in another order, integers for floats, a default (k_res) left out, and inline tables."""
    return """\
# The 1D film, written another way.
solver = { search = false, backtrack = "standard" }   # inline
[load]
steps = 60
kind   =   "bending"
t_max = 2
[domain]
cells = 160
x = [ -0.25, 0.25 ]
[model]
toughness = 0.05
lam = 10
eta_dx = 8
kind = "plate"
at = 1
"""


def test_resume_accepts_comments_order_and_format(reference, tmp_path):
    """The same scene written otherwise (and its overrides moved into the file) resumes: the
    finished run continues with nothing to compute, and the file now holds the new text."""
    scene, _, reference_out = reference
    out = _copy_run(reference_out, tmp_path)
    other = tmp_path / "film.toml"
    other.write_text(_film_text())
    steps, alpha, u = _fields(out / "results.h5")
    assert main(["run", str(other), "--out", str(out), "--quiet", "--resume"]) == 0
    got_steps, got_alpha, got_u = _fields(out / "results.h5")
    for name in steps:
        np.testing.assert_array_equal(got_steps[name], steps[name], err_msg=name)
    np.testing.assert_array_equal(got_alpha, alpha)
    np.testing.assert_array_equal(got_u, u)
    with h5py.File(out / "results.h5", "r") as f:
        assert f.attrs["scene"] == _film_text() and "scene_overrides" not in f.attrs and "extended" not in f.attrs
    # and back: the case file with its --set overrides
    assert main(_args((scene[0], scene[1]), out, "--resume")) == 0


@pytest.mark.parametrize("stopped_after", [None, 12])
def test_an_extended_run_continues_to_the_longer_run(reference, tmp_path, stopped_after):
    """A run to t_max = 0.6 in 18 steps, finished (or stopped after 12 steps), extended to
    t_max = 2 in 60 steps (the same spacing 1/30), gives the uninterrupted run to 2: the same
    loads, events (the crack at t = 0.7 comes after the first run, with backtracking, which
    reads the history), iteration counts and fields, to the last bit (one thread)."""
    scene, (steps, alpha, u), _ = reference
    out = tmp_path / "out"
    short = (scene[0], {**scene[1], "load.t_max": 0.6, "load.steps": 18})
    _run(short, out)
    if stopped_after is not None:
        with h5py.File(out / "results.h5", "r+") as f:
            for group in ("steps", "fields"):
                for ds in f[group].values():
                    if ds.shape and ds.shape[0] == 19:
                        ds.resize(stopped_after, axis=0)
    assert _steps_done(out / "results.h5") == (stopped_after or 19)
    assert _fields(out / "results.h5")[0]["surface"][-1] == 0  # no crack yet
    _run(scene, out, "--resume")
    got_steps, got_alpha, got_u = _fields(out / "results.h5")
    assert got_steps.keys() == steps.keys() and len(got_steps["t"]) == 61
    for name in steps:
        if not name.startswith("time_") and name != "threads":  # wall-clock timers, the machine's load
            np.testing.assert_array_equal(got_steps[name], steps[name], err_msg=name)
    np.testing.assert_array_equal(got_alpha, alpha)
    np.testing.assert_array_equal(got_u, u)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["parameters"]["t_max"] == 2.0 and summary["parameters"]["steps"] == 60
    assert summary["steps"]["t"] == steps["t"].tolist() and summary["steps"]["total"] == steps["total"].tolist()
    assert summary["events"] and summary["events"][0]["t"] == 0.7
    with h5py.File(out / "results.h5", "r") as f:
        extended = json.loads(f.attrs["extended"])
        assert extended[0]["t_max"] == 0.6 and extended[0]["steps"] == 18
        assert extended[0]["after_step"] == (stopped_after or 19) - 1
        assert f["parameters"].attrs["t_max"] == 2.0 and f["parameters"].attrs["steps"] == 60


#: The Fig. 2.7 strip, small: cracks from t = 3 on, to t = 4 in 20 steps of 0.2.
STRIP = {"domain.cells": [60, 12], "load.t_max": 4.0, "load.steps": 20}


def test_an_extended_2d_run_is_the_longer_run(tmp_path):
    """The strip run to t = 3.4 (cracks already there), extended to 4: the uninterrupted run
    to 4, bit for bit; its summary's loads are the scene's decimals (0.6, not
    0.6000000000000001) and equal to those in results.h5, as are its energies."""
    case = CASES / "fig2_7.toml"
    assert main(_args((case, STRIP), tmp_path / "long")) == 0
    short = {**STRIP, "load.t_max": 3.4, "load.steps": 17}
    assert main(_args((case, short), tmp_path / "out")) == 0
    steps, alpha, u = _fields(tmp_path / "out" / "results.h5")
    assert steps["surface"][-1] > 0
    assert main(_args((case, STRIP), tmp_path / "out", "--resume")) == 0
    ref_steps, ref_alpha, ref_u = _fields(tmp_path / "long" / "results.h5")
    got_steps, got_alpha, got_u = _fields(tmp_path / "out" / "results.h5")
    for name in ref_steps:
        if not name.startswith("time_") and name != "threads":
            np.testing.assert_array_equal(got_steps[name], ref_steps[name], err_msg=name)
    np.testing.assert_array_equal(got_alpha, ref_alpha)
    np.testing.assert_array_equal(got_u, ref_u)
    long_summary = json.loads((tmp_path / "long" / "summary.json").read_text())
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["events"] == long_summary["events"] and summary["steps"] == long_summary["steps"]
    assert summary["steps"]["t"] == [k / 5 for k in range(21)]  # k / 5: the double nearest to 0.2 k
    assert "0.6000000000000001" not in (tmp_path / "out" / "summary.json").read_text()
    for name in ("t", "elastic", "surface", "total", "force"):
        assert summary["steps"][name] == got_steps[name].tolist(), name


#: The exact 1D film of Fig. 2.15 on a coarser grid.
EXACT = {"grid.cells": 200, "load.t_max": 3.0, "load.steps": 150}


def test_an_extended_exact1d_run_is_the_longer_run(tmp_path, capsys):
    """An exact 1D run is computed again in one go when extended: the uninterrupted run's
    results; a changed key is refused as for any kind, the results left as they were."""
    case = CASES / "fig2_15.toml"
    assert main(_args((case, EXACT), tmp_path / "long")) == 0
    out = tmp_path / "out"
    assert main(_args((case, {**EXACT, "load.t_max": 1.0, "load.steps": 50}), out)) == 0
    before = _digest(out)
    assert main(_args((case, {**EXACT, "model.toughness": 0.06}), out, "--resume")) == 2
    assert "model.toughness (0.05 -> 0.06)" in capsys.readouterr().err
    assert _digest(out) == before
    assert main(_args((case, EXACT), out, "--resume")) == 0
    with h5py.File(tmp_path / "long" / "results.h5", "r") as a, h5py.File(out / "results.h5", "r") as b:
        names = []
        a.visit(lambda name: names.append(name) if isinstance(a[name], h5py.Dataset) else None)
        assert len(names) > 10
        for name in names:
            np.testing.assert_array_equal(b[name][()], a[name][()], err_msg=name)
    long_summary = json.loads((tmp_path / "long" / "summary.json").read_text())
    summary = json.loads((out / "summary.json").read_text())
    assert summary["events"] == long_summary["events"] and len(summary["events"]) == 2


def test_resume_a_file_written_before_the_stability_records(reference, tmp_path):
    """A results file without /steps/lowest_curvature and saddles_left (written before they
    existed) resumes: the new records are added, unrecorded (NaN, 0) for its old steps."""
    scene, (steps, alpha, _), _ = reference
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


def test_two_runs_on_default_threads_agree_to_the_last_bit(tmp_path):
    """The same scene run twice, each in a process with the libraries' default threads (two
    on this machine): the same results, bit for bit. A 120 x 24 strip whose u-solves PARDISO
    factorizes on two threads: without MKL's conditional numerical reproducibility (MKL_CBWR
    empty) its alpha differed between two runs by 4e-12 to 5e-12."""
    scene = (CASES / "fig2_7.toml", {"domain.cells": [120, 24], "model.eta_dx": 3, "load.t_max": 6.0,
                                     "load.steps": 6})
    env = {k: v for k, v in os.environ.items() if k not in {*_ONE_THREAD, "OPENBLAS_NUM_THREADS", "MKL_CBWR"}}
    env["PYTHONPATH"] = str(ROOT)
    runs = []
    for name in ("first", "second"):
        done = subprocess.run(_command(scene, tmp_path / name), env=env, capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr
        runs.append(_fields(tmp_path / name / "results.h5"))
    (steps, alpha, u), (steps2, alpha2, u2) = runs
    assert steps["surface"][-1] > 0 and steps["iterations"].max() > 1  # cracks: damage solves matter
    for name in steps:
        if not name.startswith("time_") and name != "threads":  # "auto" may choose other counts
            np.testing.assert_array_equal(steps2[name], steps[name], err_msg=name)
    np.testing.assert_array_equal(alpha2, alpha)
    np.testing.assert_array_equal(u2, u)
