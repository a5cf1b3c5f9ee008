"""``kill -9`` at any instant costs at most the step in flight: runs killed at random moments
and at their write instants resume to the uninterrupted run, bit for bit; a scan killed in
the middle of a step's write resumes to the same table, its cut run continued, not started
over (``docs/results.md#stopping-and-resuming``, ``thinfilm/results/journal.py``).

The runs are forked from a server process that has imported thinfilm once
(``multiprocessing``'s forkserver), so a kill costs no interpreter start-up. Half the kills
fall at a write instant chosen at random among all of a run's
(:func:`thinfilm.results.journal.kill_at_event`: the process kills itself with SIGKILL
there, a write cut in the middle), half at a random moment after the file is made."""

import json
import multiprocessing
import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.results.reader import finished_steps, open_results

from tests.helpers import CASES, ROOT

#: The 1D film of tests/core/test_resume.py, shorter: backtracking (so a resume must restore
#: the history it reads) and a crack at t = 0.7.
FILM = {"model.eta_dx": 8, "domain.cells": 160, "load.t_max": 1.0, "load.steps": 30, "solver.search": False}
KILLS = 24
#: What differs between two runs of one scene: wall-clock timers and the threads chosen.
TIMERS = ("time_u", "time_alpha", "time_total", "threads")


def _argv(out, *options):
    return ["run", str(CASES / "fig2_5.toml"), "--out", str(out), "--quiet", "--threads", "1", *options] + [
        f"--set={key}={json.dumps(value)}" for key, value in FILM.items()]


def _child(argv, kill_at, events_file, mkl_rt):
    """A run in a forked process: killed at its ``kill_at``-th I/O event if not 0; writes
    the number of events to ``events_file`` if given, and the index of each step stored
    (once ``write_step`` has returned) to ``stored.txt`` in the run directory."""
    from thinfilm.results import journal
    from thinfilm.results.writer import ResultsWriter
    from thinfilm.run import EvolutionKind

    write_step = ResultsWriter.write_step

    def logged(self, record, state, observed=None, mesh=None):
        write_step(self, record, state, observed, mesh=mesh)
        with open(self.path.parent / "stored.txt", "a") as log:
            log.write(f"{record.index}\n")

    ResultsWriter.write_step = logged

    if mkl_rt:  # pypardiso looks for MKL at each solver it makes (a glob over sys.prefix, 0.6 s)
        os.environ["PYPARDISO_MKL_RT"] = mkl_rt

    journal.kill_at_event(journal.io_events() + kill_at if kill_at else 0)
    EvolutionKind.plot = lambda self, *args, **kwargs: []  # the figures are not what is tested
    status = main(argv)
    if events_file:
        Path(events_file).write_text(str(journal.io_events()))
    os._exit(status)


@pytest.fixture(scope="module")
def fork():
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(["thinfilm.cli", "thinfilm.plate.kind", "thinfilm.plate.resources", "thinfilm.run",
                                    "thinfilm.solvers.linear", "h5py", "pypardiso", "threadpoolctl"])
    try:
        import pypardiso

        mkl_rt = pypardiso.PyPardisoSolver().libmkl._name
    except Exception:  # found by each solver, the slow way
        mkl_rt = None

    def start(argv, kill_at=0, events_file=None):
        process = context.Process(target=_child, args=(argv, kill_at, events_file, mkl_rt))
        process.start()
        return process

    return start


def _content(path):
    with h5py.File(path, "r") as f:
        steps = {name: ds[()] for name, ds in f["steps"].items() if name not in TIMERS}
        return steps, f["fields/u"][()], f["fields/alpha"][()]


def _same(got, ref, n=None):
    """The first ``n`` steps (all: None) of two runs agree to the last bit."""
    (steps, u, alpha), (ref_steps, ref_u, ref_alpha) = got, ref
    n = len(ref_steps["t"]) if n is None else n
    assert steps.keys() == ref_steps.keys() and len(steps["t"]) >= n
    for name in ref_steps:
        np.testing.assert_array_equal(steps[name][:n], ref_steps[name][:n], err_msg=name)
    np.testing.assert_array_equal(u[:n], ref_u[:n])
    np.testing.assert_array_equal(alpha[:n], ref_alpha[:n])


@pytest.fixture(scope="module")
def twin(fork, tmp_path_factory):
    """The uninterrupted run: its contents, its I/O events, its duration from the file's creation."""
    tmp = tmp_path_factory.mktemp("twin")
    process = fork(_argv(tmp / "out"), events_file=tmp / "events")
    while not (tmp / "out" / "results.h5").exists():
        assert process.is_alive() or process.exitcode == 0
        time.sleep(0.002)
    start = time.monotonic()
    process.join(120)
    duration = time.monotonic() - start
    assert process.exitcode == 0
    content = _content(tmp / "out" / "results.h5")
    assert content[0]["surface"][-1] > 0 and content[0]["backtracks"].sum() > 0  # cracked, backtracked
    return content, int((tmp / "events").read_text()), duration


def test_runs_killed_at_any_instant_resume_to_the_uninterrupted_run(fork, twin, tmp_path):
    reference, events, duration = twin
    backtracked = set(np.flatnonzero(reference[0]["backtracks"]).tolist())
    rng = random.Random(20261205)
    outcomes = []
    for k in range(KILLS):
        out = tmp_path / f"run{k}"
        results = out / "results.h5"
        at_write = k % 2 == 0
        process = fork(_argv(out), kill_at=rng.randint(1, events) if at_write else 0)
        if not at_write:
            deadline = time.monotonic() + 60
            while not results.exists() and process.is_alive() and time.monotonic() < deadline:
                time.sleep(0.001)
            time.sleep(rng.uniform(0.0, 0.9 * duration))
            process.kill()    # SIGKILL (nothing if the run has already ended)
        process.join(120)
        if process.exitcode == 0:     # the run finished before the moment drawn
            outcomes.append("finished")
            continue
        assert process.exitcode == -signal.SIGKILL
        n = 0
        stored = [int(k) for k in (out / "stored.txt").read_text().split()] if (out / "stored.txt").exists() else []
        if results.exists():         # made under another name and renamed: whole, or not there
            with open_results(results) as f:   # (its steps are the evolution so far, which a later
                n = finished_steps(f)          # backtrack would have rewritten: not compared)
                assert n == 0 or f["steps/t"][n - 1] == reference[0]["t"][n - 1]
        if stored:
            # every step stored before the kill is there (and perhaps the step in flight),
            # unless that one was a backtrack, which cuts the later steps
            assert stored[-1] + 1 <= n <= stored[-1] + 2 or n - 1 in backtracked, (stored[-1], n)
        else:
            assert n <= 1        # none, or the first step, in flight at the kill
        resumed = fork(_argv(out, "--resume"))
        resumed.join(120)
        assert resumed.exitcode == 0
        _same(_content(results), reference)
        assert not (out / "results.h5.journal").exists()
        outcomes.append(n)
    kills = [o for o in outcomes if o != "finished"]
    assert len(kills) >= KILLS * 3 // 4 and max(kills) > 0, outcomes


#: A scan of two short runs of the coated cantilever: a crack by t = 1.
SCAN = """\
base = "{base}"
mode = "product"
[vary]
"model.winkler" = [3e6, 6e6]
[set]
"load.t_max" = 1.2
"load.steps" = 60
[collect]
metrics = ["first_event_t", "cracks_at_t_max", "total_at_t_max"]
"""


def test_a_scan_killed_in_a_write_resumes_to_the_same_table(tmp_path):
    """The scan (its cluster and workers) killed at once while a run's step is being written
    (its journal is there): resumed, the cut run continues from its last finished step and
    the table is the uninterrupted scan's."""
    from thinfilm.scan.plan import load_plan
    from thinfilm.scan.table import TABLE, read_table, run_dir
    from thinfilm.scan.task import read_record

    scan = tmp_path / "scan.toml"
    scan.write_text(SCAN.format(base=CASES / "scans" / "cantilever_film_1d.toml"))
    command = [sys.executable, "-m", "thinfilm", "scan", str(scan), "--workers", "1", "--quiet"]
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    done = subprocess.run(command + ["--out", str(tmp_path / "reference")], cwd=ROOT, env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    reference = read_table(tmp_path / "reference" / TABLE)

    out = tmp_path / "scan"
    plan = load_plan(scan)
    journals = [run_dir(out, spec.name) / "results.h5.journal" for spec in plan.runs]
    process = subprocess.Popen(command + ["--out", str(out)], cwd=ROOT, env=env, start_new_session=True)
    try:
        deadline = time.monotonic() + 300
        cut = None
        while cut is None and process.poll() is None and time.monotonic() < deadline:
            cut = next((j.parent for j in journals if j.exists()), None)
            time.sleep(0.0005 if cut is None else 0)
    finally:
        os.killpg(process.pid, signal.SIGKILL)        # the scan, its cluster and its worker at once
        process.wait()
    assert cut is not None, "no write was caught"
    assert read_record(cut) is None
    resumed = subprocess.run(command + ["--out", str(out), "--resume"], cwd=ROOT, env=env, capture_output=True,
                             text=True, timeout=300)
    assert resumed.returncode == 0, resumed.stderr
    record = read_record(cut)
    assert not any("started over" in line for line in record["warnings"]), record
    strip = [{k: v for k, v in r.items() if k not in ("wall_s", "worker")} for r in read_table(out / TABLE)]
    assert strip == [{k: v for k, v in r.items() if k not in ("wall_s", "worker")} for r in reference]
    with h5py.File(cut / "results.h5", "r") as a, \
            h5py.File(tmp_path / "reference" / "runs" / cut.name / "results.h5", "r") as b:
        np.testing.assert_array_equal(a["fields/alpha"][()], b["fields/alpha"][()])
        np.testing.assert_array_equal(a["steps/total"][()], b["steps/total"][()])


# --- the journal itself ---------------------------------------------------------------------------

_WRITER = """
import os, sys
import h5py, numpy as np
from thinfilm.results.journal import JournaledFile
path, steps, die = sys.argv[1], int(sys.argv[2]), sys.argv[3] == "die"
with h5py.File(path, "w") as f:
    f.create_dataset("fields/alpha", shape=(0, 1000), maxshape=(None, 1000), dtype=np.float64, chunks=(1, 1000))
    f.create_dataset("steps/t", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(256,))
journaled = JournaledFile(path)
f = h5py.File(journaled, "r+")
for k in range(steps + 1):
    for name, value in (("fields/alpha", np.full(1000, k / 7)), ("steps/t", k / 10)):
        ds = f[name]
        ds.resize(k + 1, axis=0)
        ds[k] = value
    f.flush()
    if k < steps:
        journaled.commit()
        with open(path + ".committed", "wb") as out, open(path, "rb") as now:
            out.write(now.read())
if die:
    os._exit(0)  # dies with a step written and flushed, not committed
"""


def _journaled_file(tmp_path, steps):
    """A results-like file written through the journal by a process that died with
    ``steps`` committed steps and one more written and flushed, not committed. Returns the
    path and the committed bytes."""
    path = tmp_path / "results.h5"
    subprocess.run([sys.executable, "-c", _WRITER, str(path), str(steps), "die"], cwd=ROOT, check=True,
                   env=dict(os.environ, PYTHONPATH=str(ROOT)))
    return path, Path(str(path) + ".committed").read_bytes()


def test_a_rollback_restores_the_committed_bytes(tmp_path):
    """A step written and flushed but not committed: readers see the committed state through
    the journal without changing anything; recovery writes it back byte for byte, and again
    (a recovery killed half-way) changes nothing more; a torn last entry is ignored."""
    from thinfilm.results.journal import RolledBack, journal_path, read_journal, recover

    path, committed = _journaled_file(tmp_path, 3)
    assert path.read_bytes() != committed and journal_path(path).exists()
    view = RolledBack(path)
    with h5py.File(view, "r") as g:
        assert len(g["steps/t"]) == 3 and g.filename == str(path)
        np.testing.assert_array_equal(g["fields/alpha"][2], np.full(1000, 2 / 7))
    view.close()
    size, entries = read_journal(path)
    assert size == len(committed) and entries
    saved = journal_path(path).read_bytes()
    journal_path(path).write_bytes(saved + saved[-10:])      # a torn entry after the valid ones
    assert recover(path) and path.read_bytes() == committed and not journal_path(path).exists()
    journal_path(path).write_bytes(saved)                    # as if the recovery were killed
    assert recover(path) and path.read_bytes() == committed
    with h5py.File(path, "r") as g:
        assert g["steps/t"][()].tolist() == [0.0, 0.1, 0.2]


def test_the_journal_of_a_replaced_file_is_ignored(tmp_path):
    """A journal left beside results.h5 applies to that file only: a new results.h5 renamed
    into its place is read and opened as it is."""
    from thinfilm.results.journal import journal_path, recover
    from thinfilm.results.reader import open_committed

    path, committed = _journaled_file(tmp_path, 2)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["steps/t"] = np.arange(5.0)
    os.replace(other, path)
    assert journal_path(path).exists()
    with open_committed(path) as f:
        assert len(f["steps/t"]) == 5
    before = path.read_bytes()
    assert recover(path) and path.read_bytes() == before and not journal_path(path).exists()


def test_a_second_writer_is_refused(tmp_path):
    from thinfilm.results.journal import JournaledFile, JournalError

    path, _ = _journaled_file(tmp_path, 1)
    first = JournaledFile(path)   # rolls the step in flight back
    with pytest.raises(JournalError, match="being written by another process"):
        JournaledFile(path)
    first.close()
    JournaledFile(path).close()


def test_a_failed_write_is_not_committed(tmp_path, monkeypatch):
    """The disk fills up in the middle of a step: nothing after the last commit is
    committed, and the file returns to it."""
    import errno

    from thinfilm.results.journal import JournaledFile, journal_path, recover
    from thinfilm.results.reader import open_committed

    path = tmp_path / "results.h5"
    with h5py.File(path, "w") as f:
        f.create_dataset("fields/alpha", shape=(0, 5000), maxshape=(None, 5000), dtype=np.float64, chunks=(1, 5000))
    journaled = JournaledFile(path)
    f = h5py.File(journaled, "r+")
    ds = f["fields/alpha"]
    ds.resize(1, axis=0)
    ds[0] = 1.0
    f.flush()
    journaled.commit()
    committed = path.read_bytes()
    pwrite = os.pwrite

    def full(fd, data, offset):
        if fd == journaled.fd:
            raise OSError(errno.ENOSPC, "No space left on device")
        return pwrite(fd, data, offset)

    monkeypatch.setattr(os, "pwrite", full)
    with pytest.raises(OSError):
        ds.resize(2, axis=0)
        ds[1] = 2.0
        f.flush()
    monkeypatch.undo()
    try:
        f.close()              # HDF5 may refuse to after a failed flush
    except (OSError, RuntimeError):
        pass
    journaled.commit()         # refused: the journal stays
    journaled.close()
    assert journal_path(path).exists()
    with open_committed(path) as g:
        assert len(g["fields/alpha"]) == 1
    assert recover(path) and path.read_bytes() == committed
