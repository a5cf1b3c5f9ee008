"""Faults: a failing run, a worker killed mid-run, the scan killed mid-way, the table rebuilt
from the files, and a separately started Dask cluster. Each ends with the table of an
uninterrupted scan (:func:`same_table`)."""

import json
import os
import signal
import subprocess
import sys
import threading
import time

import h5py
import psutil
import pytest
from distributed import Client

from thinfilm.cli import main
from thinfilm.scan.execute import execute
from thinfilm.scan.plan import load_plan
from thinfilm.scan.table import TABLE, read_table, run_dir
from thinfilm.scan.task import read_record
from tests.helpers import CASES, ROOT

SPACING = CASES / "scans" / "cantilever_spacing.toml"
#: What differs between two scans of the same runs: who ran them and how long they took.
CIRCUMSTANTIAL = ("wall_s", "worker")


def same_table(rows, reference):
    """Two tables agree in every column but the circumstantial ones, bit for bit."""
    strip = [{k: v for k, v in r.items() if k not in CIRCUMSTANTIAL} for r in rows]
    return strip == [{k: v for k, v in r.items() if k not in CIRCUMSTANTIAL} for r in reference]


def continued_or_started_over(record, step):
    """A run that was cut: continued from at least ``step``, or started over because the cut
    fell in the middle of a write (its warning says so)."""
    if record["resumed_after_step"] is not None:
        return record["resumed_after_step"] >= step
    return any("started over" in line for line in record["warnings"])


def finished(path):
    """Finished steps in a results.h5 being written (0 if it cannot be read yet)."""
    try:
        with h5py.File(path, "r", locking=False) as f:
            return min(ds.shape[0] for ds in f["steps"].values())
    except (OSError, KeyError, ValueError):
        return 0


def wait_for_a_run_midway(out, plan, steps, timeout=120):
    """The name of a run with at least ``steps`` finished steps and no record yet."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        for spec in plan.runs:
            rundir = run_dir(out, spec.name)
            if read_record(rundir) is None and finished(rundir / "results.h5") >= steps:
                return spec.name
        time.sleep(0.05)
    raise TimeoutError("no run reached the step")


def test_a_failing_run_is_recorded_and_the_others_finish(client, tmp_path, capsys):
    scan = tmp_path / "scan.toml"
    scan.write_text(f'base = "{CASES / "scans" / "cantilever_film_1d.toml"}"\nmode = "zip"\n[vary]\n'
                    '"model.winkler" = [3e6, 6e6]\n"solver.max_iter" = [2000, 2]\n[set]\n"load.t_max" = 1.6\n'
                    '"load.steps" = 80\n[collect]\nmetrics = ["first_event_t", "cracks_at_t_max"]\n')
    # submitted to the running cluster by its address, as to any other
    status = main(["scan", str(scan), "--out", str(tmp_path / "out"), "--scheduler", client.scheduler.address,
                   "--quiet"])
    assert status == 1                              # not every run finished
    done, failed = read_table(tmp_path / "out" / TABLE)
    assert done["status"] == "done" and done["error"] == "" and float(done["first_event_t"]) == 1.0
    assert failed["status"] == "failed" and failed["first_event_t"] == "nan"
    assert failed["error"].startswith("EvolutionError: step ") and "did not converge in 2 iterations" in failed["error"]
    assert failed["worker"].startswith("tcp://")


def test_a_killed_worker_s_run_is_retried_and_resumed(client, spacing_scan, tmp_path):
    plan, _, reference, _ = spacing_scan
    out = tmp_path / "scan"
    killed = {}

    def kill_the_worker_of_a_run_midway():
        name = wait_for_a_run_midway(out, plan, steps=20)
        results = str(run_dir(out, name) / "results.h5")
        for process in psutil.Process().children(recursive=True):
            try:
                if any(f.path == results for f in process.open_files()):
                    killed.update(name=name, pid=process.pid, steps=finished(results))
                    process.send_signal(signal.SIGKILL)
                    return
            except psutil.Error:
                continue

    killer = threading.Thread(target=kill_the_worker_of_a_run_midway)
    killer.start()
    table, _, counts = execute(plan, out, client=client)
    killer.join()
    assert killed, "no worker was killed"
    assert not psutil.pid_exists(killed["pid"]) or psutil.Process(killed["pid"]).status() == psutil.STATUS_ZOMBIE
    record = read_record(run_dir(out, killed["name"]))
    # Dask gave the task again to a worker, which continued the run from its last step (a
    # kill during a write costs that step only: thinfilm/results/journal.py)
    assert record["status"] == "done" and killed["steps"] >= 20
    assert continued_or_started_over(record, killed["steps"] - 2)
    assert counts == {"done": 5} and same_table(read_table(table), reference)


def test_a_killed_scan_resumes_to_the_same_table(spacing_scan, tmp_path):
    plan, _, reference, _ = spacing_scan
    out = tmp_path / "scan"
    command = [sys.executable, "-m", "thinfilm", "scan", str(SPACING), "--out", str(out), "--workers", "2", "--quiet"]
    scan = subprocess.Popen(command, cwd=ROOT, start_new_session=True)
    try:
        midway = wait_for_a_run_midway(out, plan, steps=30)
        done_before = {s.name: read_record(run_dir(out, s.name)) for s in plan.runs}
    finally:
        os.killpg(scan.pid, signal.SIGKILL)          # the scan, its cluster and its workers at once
        scan.wait()
    done_before = {name: r for name, r in done_before.items() if r is not None}
    assert read_record(run_dir(out, midway)) is None
    # a new scan would overwrite: refused without --resume or --force
    assert subprocess.run(command, cwd=ROOT, capture_output=True).returncode == 2
    resumed = subprocess.run(command + ["--resume"], cwd=ROOT, capture_output=True, text=True)
    assert resumed.returncode == 0, resumed.stderr
    for name, record in done_before.items():      # finished runs were kept, not run again
        assert read_record(run_dir(out, name)) == record
    assert continued_or_started_over(read_record(run_dir(out, midway)), 29)
    assert same_table(read_table(out / TABLE), reference)


def test_collect_rebuilds_the_table_from_the_files_alone(spacing_scan, tmp_path, capsys):
    plan, out, reference, _ = spacing_scan
    before = (out / TABLE).read_text()
    (out / TABLE).unlink()
    (out / "scan.png").unlink()
    assert main(["scan", "--collect", str(out)]) == 0
    assert (out / TABLE).read_text() == before and (out / "scan.png").exists()
    assert "5 runs: 5 done" in capsys.readouterr().out


def test_a_separately_started_cluster_gives_the_same_table(exact1d_scan, tmp_path):
    _, _, reference, _ = exact1d_scan
    address_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    # the scheduler unpickles the tasks too: both need thinfilm importable, as on any cluster
    quiet = dict(cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                 env=dict(os.environ, PYTHONPATH=str(ROOT)))
    processes = [subprocess.Popen(dask + ["scheduler", "--scheduler-file", str(address_file), "--port", "0",
                                          "--no-dashboard"], **quiet)]
    try:
        deadline = time.monotonic() + 60
        while not address_file.exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        processes += [subprocess.Popen(dask + ["worker", "--scheduler-file", str(address_file), "--nthreads", "1",
                                               "--no-dashboard"], **quiet) for _ in range(2)]
        address = json.loads(address_file.read_text())["address"]
        with Client(address, timeout="60s") as waiting:
            waiting.wait_for_workers(2, timeout=60)
        out = tmp_path / "scan"
        assert main(["scan", str(CASES / "scans" / "exact1d_lam.toml"), "--out", str(out), "--scheduler", address,
                     "--quiet"]) == 0
        rows = read_table(out / TABLE)
        assert len({r["worker"] for r in rows}) == 2        # both workers ran runs
        assert same_table(rows, reference)
    finally:
        for process in processes:
            process.terminate()
        for process in processes:
            try:
                process.wait(timeout=20)
            except subprocess.TimeoutExpired:
                process.kill()


def test_ctrl_c_stops_the_scan_cleanly_with_status_130(spacing_scan, tmp_path):
    plan = spacing_scan[0]
    out = tmp_path / "scan"
    command = [sys.executable, "-m", "thinfilm", "scan", str(SPACING), "--out", str(out), "--workers", "1"]
    # a terminal's foreground job: SIGINT at its default, whatever this process inherited (a
    # shell's background job, as CI may run the suite, starts with SIGINT ignored)
    scan = subprocess.Popen(command, cwd=ROOT, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                            text=True)
    try:
        wait_for_a_run_midway(out, plan, steps=5)
    finally:
        os.killpg(scan.pid, signal.SIGINT)            # a terminal's Ctrl-C: the scan and its workers
        _, err = scan.communicate(timeout=60)
    assert scan.returncode == 130
    assert "Traceback" not in err and "KeyboardInterrupt" not in err     # the workers left it to the scan
    assert err.strip().splitlines()[-1] == (f"thinfilm: interrupted; the finished runs and steps are kept in {out};"
                                            f" continue with: thinfilm scan {SPACING} --resume --out {out}")


def test_a_run_cut_in_the_middle_of_a_write_starts_over(tmp_path, capsys):
    # A file damaged other than by a kill (cut short by a copy: the journal cannot mend that)
    # cannot be resumed. The command says so; a scan's task starts the run over, to the same
    # numbers.
    from thinfilm.scan.task import run_task

    base = CASES / "fig2_5.toml"
    overrides = {"domain.cells": 160, "model.eta_dx": 8, "load.steps": 20, "solver.search": False}
    out = tmp_path / "run"
    first = run_task(str(base), overrides, str(out), "cut")
    with h5py.File(out / "results.h5", "r") as f:
        total = f["steps/total"][()]
    (out / "run.json").unlink()
    data = (out / "results.h5").read_bytes()
    (out / "results.h5").write_bytes(data[: len(data) * 2 // 3])
    sets = [f"--set={k}={json.dumps(v)}" for k, v in overrides.items()]
    assert main(["run", str(base), "--out", str(out), "--resume", "--quiet", *sets]) == 2
    assert "--force to start over" in capsys.readouterr().err
    again = run_task(str(base), overrides, str(out), "cut")
    assert first["status"] == again["status"] == "done" and again["resumed_after_step"] is None
    assert any("started over" in line for line in again["warnings"])
    with h5py.File(out / "results.h5", "r") as f:
        assert (f["steps/total"][()] == total).all()
