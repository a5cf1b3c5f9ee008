"""Threads of the numerical libraries (:mod:`thinfilm.threads`): chosen from the machine's
idle cores, set where the libraries take them, recorded, and never changing a result."""

from __future__ import annotations

import json
import subprocess
import sys
import time

import h5py
import numba
import numpy as np
import pytest
from threadpoolctl import threadpool_info

from tests.helpers import CASES, ROOT, load_case
from thinfilm.resume import check_resume
from thinfilm.results.reader import attrs_dict
from thinfilm.run import run
from thinfilm.scan.plan import run_name
from thinfilm.threads import IdleCores, ThreadChoice, ThreadGovernor, limit_threads, parse_threads, usable_cores

SPIN = "import time\nend = time.monotonic() + {s}\nwhile time.monotonic() < end: pass\n"


def _library_threads():
    """``{internal_api: num_threads}`` of the loaded libraries, and Numba's count."""
    out = {}
    for lib in threadpool_info():
        out.setdefault(lib["internal_api"], set()).add(lib["num_threads"])
    out["numba"] = {numba.get_num_threads()}
    return out


@pytest.fixture
def restore_threads():
    yield
    limit_threads(1)  # the suite's setting (tests/conftest.py)


def test_the_count_is_the_idle_cores_at_least_one(monkeypatch):
    governor = ThreadGovernor("auto")
    governor.cores = governor.cap = 2
    for others, expected in ((0.0, 2), (0.4, 2), (0.6, 1), (1.6, 1), (7.0, 1)):
        monkeypatch.setattr(governor._idle, "others", lambda: others)
        assert governor._choose() == ThreadChoice(expected, others)
    governor.cap = 1  # MKL_NUM_THREADS=1 in the environment: "auto" stays below it
    assert governor._choose() == ThreadChoice(1, 7.0)
    monkeypatch.setattr(governor._idle, "others", lambda: 0.0)
    assert governor._choose() == ThreadChoice(1, 0.0)
    assert ThreadGovernor(3)._choose() == ThreadChoice(3)  # a fixed count, whatever the machine
    assert [parse_threads(v) for v in ("auto", " AUTO ", "2", 2, 0, "0", -1, "two", True, 1.5)] == [
        "auto", "auto", 2, 2, None, None, None, None, None, None]


def test_the_other_processes_load_is_measured_without_this_ones():
    """The idle cores come from the machine's CPU time less this process's own: a process that
    keeps a core busy counts, this process's own work does not."""
    idle = IdleCores()
    time.sleep(0.6)
    baseline = idle.others()
    if baseline > usable_cores() - 1.3:
        pytest.skip(f"no idle core to measure on: other processes keep {baseline:.1f} of {usable_cores()} busy")
    end = time.monotonic() + 0.6
    while time.monotonic() < end:  # this process keeps one core busy
        pass
    own = idle.others()
    spinner = subprocess.Popen([sys.executable, "-c", SPIN.format(s=1.5)])
    try:
        time.sleep(0.3)  # the interpreter's start
        idle.others()
        time.sleep(0.8)
        other = idle.others()
    finally:
        spinner.wait()
    assert own < baseline + 0.4, (baseline, own)
    assert other > baseline + 0.6, (baseline, other)


def test_the_libraries_take_the_count(restore_threads):
    from thinfilm.solvers.linear import pardiso_available

    loaded = ("mkl", "openmp") if pardiso_available() else ()  # MKL, with its OpenMP, loaded now
    limit_threads(2)
    threads = _library_threads()
    assert threads["numba"] == {min(2, numba.config.NUMBA_NUM_THREADS)}
    assert threads.get("openblas", {1}) == {1}  # always one: its threads change the bits
    for api in loaded:
        assert threads[api] == {2}
    limit_threads(1)
    assert all(v == {1} for v in _library_threads().values())


def _run_twice(tmp_path, name, overrides):
    out = []
    for n in (1, 2):
        outdir = tmp_path / f"{name}_{n}"
        run(load_case(name, overrides), outdir, threads=n)
        with h5py.File(outdir / "results.h5", "r") as f:
            out.append(({k: f["steps"][k][()] for k in f["steps"]}, f["fields/alpha"][()], f["fields/u"][()],
                        json.loads(f.attrs["threads"])))
    return out


@pytest.mark.parametrize("name, overrides", [
    # the film's operator in Numba kernels, AMG-CG (whose coarsest level OpenBLAS factorizes:
    # 3.6e-12 apart in alpha with OpenBLAS on two threads)
    ("indentation", {"domain.cells": [80, 80], "load.steps": 6, "solver.linear": "amg"}),
    # a solid's u-solve by PARDISO
    ("lpanel", {"mesh.h": 5.0, "model.eps": 15.0, "load.t": [0, 0.3, 0.4, 0.5], "output.snapshots": [0.5],
                "solver.linear": "direct"}),
])
def test_one_or_two_threads_give_the_same_bits(tmp_path, restore_threads, name, overrides):
    (steps1, alpha1, u1, rec1), (steps2, alpha2, u2, rec2) = _run_twice(tmp_path, name, overrides)
    assert (rec1["setting"], rec2["setting"]) == (1, 2)
    assert set(steps1["threads"]) == {1} and set(steps2["threads"]) == {2}
    assert steps1["surface"][-1] > 0 and steps1["iterations"].max() > 5  # cracks: damage solves matter
    for key in steps1:
        if not key.startswith("time_") and key != "threads":
            np.testing.assert_array_equal(steps2[key], steps1[key], err_msg=key)
    np.testing.assert_array_equal(alpha2, alpha1)
    np.testing.assert_array_equal(u2, u1)


def test_threads_are_recorded_and_may_change_on_resume(tmp_path, restore_threads):
    scene = load_case("fig2_5", {"load.steps": 10})
    run(scene, tmp_path, threads=2)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["threads"]["setting"] == 2 and summary["threads"]["steps"] == {"2": 11}
    assert summary["threads"]["openblas"] == 1
    other = load_case("fig2_5", {"load.steps": 10, "solver.threads": 1})
    with h5py.File(tmp_path / "results.h5", "r") as f:
        check_resume(tmp_path / "results.h5", attrs_dict(f), other)  # accepted: threads change no result
    base = (CASES / "fig2_5.toml").read_text()
    assert "[solver]" in base  # a scan's run keeps its name whatever threads its base scene gives
    assert run_name(base, {}) == run_name(base.replace("[solver]", "[solver]\nthreads = 2"), {})


def test_the_command_line_sets_and_checks_threads(tmp_path):
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "thinfilm", "run", str(CASES / "fig2_15.toml"), "--out", str(out),
                           "--quiet", "--threads", "two"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 2 and "--threads: 'two': must be \"auto\" or an integer >= 1" in done.stderr
    assert not out.exists()
    done = subprocess.run([sys.executable, "-m", "thinfilm", "run", str(CASES / "fig2_5.toml"), "--out", str(out),
                           "--threads", "auto", "--set", "load.steps=2",
                           "--set", "domain.cells=200"], cwd=ROOT, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "threads: " in done.stderr and "for MKL, OpenMP and Numba (auto: " in done.stderr
    with h5py.File(out / "results.h5", "r") as f:
        assert json.loads(f.attrs["threads"])["setting"] == "auto"
        assert set(f["steps/threads"][()]) <= set(range(1, json.loads(f.attrs["threads"])["cores"] + 1))


def test_pardiso_solves_correctly_after_the_threads_change(restore_threads):
    """PARDISO's analysis holds for the MKL thread count it was made with: a factorization on
    another count solved this L-panel's u-problem to a relative residual of 2e-2 (and every
    later one too) until the direct solver redid its analysis when the count changes."""
    pytest.importorskip("pypardiso")
    from thinfilm.kinds import get

    scene = load_case("lpanel", {"mesh.h": 5.0, "model.eps": 15.0, "load.t": [0, 0.3, 0.5],
                                 "output.snapshots": [0.5], "solver.linear": "direct"})
    for first, second in ((2, 1), (1, 2)):
        limit_threads(first)
        model = get("fem").setup(scene).model  # the solver's analysis on `first` threads
        alpha = np.zeros(model.n_alpha)
        model.solve_u(alpha, 0.3, None, 1e-10)
        limit_threads(second)
        for t in (0.3, 0.5):
            model.solve_u(alpha, t, None, 1e-10)  # raises LinearSolverError if the residual is not met
            assert model.last_solve_info.iterations == 0  # the factorization alone solved it
            assert model.last_solve_info.residual < 1e-12
