"""Threads of the numerical libraries on an idle and on a busy machine: ``--threads 1``, the
machine's cores, and ``auto`` (:mod:`thinfilm.threads`).

Each scene below is run with ``thinfilm run --threads N`` in a fresh process, with no thread
variable in its environment (the governor decides), under three loads made by this script:
no other process, one process spinning on a core, and as many spinning processes as the
machine has cores (every core taken). The spinners are plain Python loops; they start before
the run and stop after it. For each run: the wall time, the summed step times and u-solve
times the results record, and the threads each step used.

Scenes (small versions of the cases, so that the 27 runs take about a quarter of an hour):

* ``fig2_5``: the 1D film of Fig. 2.5, 800 cells, 100 steps (PARDISO on 800 unknowns: the
  case whose time tripled on a busy machine with MKL's default threads);
* ``indentation``: the main job's film on 200 x 200 cells, 10 steps (PARDISO, Numba kernels);
* ``lpanel``: the 2D L-panel, h = 2.5 mm, eps = 10 mm, 5 loads (PARDISO on 14k unknowns).

Writes ``benchmarks/results/threads.csv`` and ``threads.md`` (times, and each setting's time
against one thread under the same load). Run it on an otherwise idle machine::

    python -m benchmarks.bench_threads [--scenes fig2_5 lpanel] [--repeat 1]
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import h5py
import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = Path(__file__).resolve().parent / "results"
CASES = ROOT / "cases"
THREAD_VARIABLES = ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS",
                    "MKL_DYNAMIC")

SCENES = {
    "fig2_5": ("fig2_5.toml", []),
    "indentation": ("indentation.toml", ["domain.cells=[200, 200]", "load.steps=10"]),
    "lpanel": ("lpanel.toml", ["mesh.h=2.5", "model.eps=10.0", "load.t=[0, 0.2, 0.3, 0.4, 0.5]",
                               "output.snapshots=[0.5]", 'solver.linear="direct"']),
}
SPIN = "while True: pass"


def cores():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def run_once(scene, setting, spinners, workdir):
    """One ``thinfilm run`` under ``spinners`` spinning processes; its times and threads."""
    case, overrides = SCENES[scene]
    env = {k: v for k, v in os.environ.items() if k not in THREAD_VARIABLES}
    env["PYTHONPATH"] = str(ROOT)
    out = Path(workdir) / f"{scene}_{setting}_{spinners}"
    command = [sys.executable, "-m", "thinfilm", "run", str(CASES / case), "--out", str(out), "--force", "--quiet",
               "--threads", str(setting)] + [f"--set={o}" for o in overrides]
    spin = [subprocess.Popen([sys.executable, "-c", SPIN]) for _ in range(spinners)]
    try:
        time.sleep(1.0 if spinners else 0.0)  # the spinners running before the run starts
        start = time.perf_counter()
        done = subprocess.run(command, env=env, capture_output=True, text=True)
        wall = time.perf_counter() - start
    finally:
        for p in spin:
            p.kill()
            p.wait()
    if done.returncode != 0:
        raise RuntimeError(f"{scene} --threads {setting}: {done.stderr}")
    with h5py.File(out / "results.h5", "r") as f:
        steps = {k: f["steps"][k][()] for k in ("time_total", "time_u", "threads")}
    used = {int(n): int(np.count_nonzero(steps["threads"] == n)) for n in np.unique(steps["threads"])}
    return {"scene": scene, "setting": str(setting), "spinners": spinners, "wall_s": round(wall, 3),
            "steps_s": round(float(steps["time_total"].sum()), 3), "u_s": round(float(steps["time_u"].sum()), 3),
            "threads_used": json.dumps(used)}


def table(rows, n_cores):
    """The markdown table: times, and each setting's step time against one thread's under the
    same load."""
    lines = ["| scene | other processes spinning | `--threads` | wall (s) | steps (s) | u-solves (s) |"
             " steps against 1 thread | threads used (count: steps) |",
             "|---|---|---|---|---|---|---|---|"]
    base = {(r["scene"], r["spinners"]): r["steps_s"] for r in rows if r["setting"] == "1"}
    for r in rows:
        ratio = r["steps_s"] / base[(r["scene"], r["spinners"])]
        lines.append(f"| {r['scene']} | {r['spinners']} of {n_cores} cores | {r['setting']} | {r['wall_s']:.1f} |"
                     f" {r['steps_s']:.1f} | {r['u_s']:.1f} | {ratio:.2f} | {r['threads_used']} |")
    return "\n".join(lines)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", nargs="+", default=list(SCENES), choices=list(SCENES))
    parser.add_argument("--repeat", type=int, default=1, help="runs of each combination (the median is kept)")
    args = parser.parse_args(argv)
    n = cores()
    settings = ["1", str(n), "auto"]
    rows = []
    with tempfile.TemporaryDirectory() as workdir:
        # a first run compiles and caches the Numba kernels, so that no measured run pays it
        for scene in args.scenes:
            run_once(scene, 1, 0, workdir)
        for scene in args.scenes:
            for spinners in (0, 1, n):
                for setting in settings:
                    runs = [run_once(scene, setting, spinners, workdir) for _ in range(args.repeat)]
                    runs.sort(key=lambda r: r["steps_s"])
                    rows.append(runs[len(runs) // 2])
                    print(rows[-1], flush=True)
    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "threads.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    text = [
        "# Threads on an idle and a busy machine",
        "",
        f"`python -m benchmarks.bench_threads` on {platform.node() or 'this machine'}: {n} cores,"
        f" Python {platform.python_version()}, {time.strftime('%Y-%m-%d')}. Each run a fresh"
        " `thinfilm run --threads N` with no thread variable set; 'other processes spinning' are"
        " plain Python loops started before the run. 'steps' is the sum of the steps' times the"
        " results record (the evolution, without imports, set-up and figures); the ratio is"
        " against `--threads 1` under the same load, in the same session.",
        "",
        table(rows, n),
        "",
    ]
    (RESULTS / "threads.md").write_text("\n".join(text))
    print(f"wrote {RESULTS / 'threads.md'}")


if __name__ == "__main__":
    main()
