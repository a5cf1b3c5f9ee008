"""Time of a whole alternate-minimization iteration of a finite-element run, this tree against
an older one, in the same session.

Where ``benchmarks/bench_elements.py`` times the element-dependent parts of an iteration, this
times what a user waits for: ``thinfilm run`` of the 2D L-panel (``cases/lpanel.toml``: P1,
107,183 nodes, PARDISO) through the first steps of its crack (loads 0, 0.2, 0.2425 and 0.25 mm:
the elastic step, the nucleation and growth), and the time per iteration read from its
``results.h5`` (the steps' ``time_total`` over their ``iterations``). Each tree runs the same
scene in its own process, the runs alternating between the trees, one thread per library
(``OMP/MKL/OPENBLAS/NUMBA_NUM_THREADS = 1``, ``--threads 1``); a row is a run, the summary the
minimum over the repeats, and the ratio new over old. The iteration counts of the two trees
must agree (the same evolution).

Usage (from the repository root; make the old tree first)::

    git worktree add /tmp/elements_base a70cdd5
    python -m benchmarks.bench_fem_iteration --old /tmp/elements_base            # ~6 min

Writes ``benchmarks/results/fem_iteration.md`` and ``.csv`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
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
LOADS = "[0, 0.2, 0.2425, 0.25]"
THREADS = {name: "1" for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS",
                                  "NUMBA_NUM_THREADS")}


def run(tree, out, scene):
    """``thinfilm run`` of ``scene`` with ``tree`` first on the path; returns (seconds per
    iteration, iterations, wall seconds)."""
    env = dict(os.environ, PYTHONPATH=str(tree), **THREADS)
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "thinfilm", "run", str(scene), "--out", str(out), "--force", "--quiet",
                    "--threads", "1", "--set", f"load.t={LOADS}", "--set", "output.snapshots=[0.25]"],
                   cwd=tree, env=env, check=True)
    wall = time.perf_counter() - start
    with h5py.File(Path(out) / "results.h5") as f:
        total, iterations = f["steps/time_total"][()], f["steps/iterations"][()]
    return float(total.sum() / iterations.sum()), int(iterations.sum()), wall


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--old", required=True, help="an older checkout of the repository")
    parser.add_argument("--old-label", default="old")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--out", default=str(ROOT / "benchmarks" / "results"))
    args = parser.parse_args(argv)
    trees = {"new": ROOT, args.old_label: Path(args.old).resolve()}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.repeats):
            for label, tree in trees.items():
                per, iterations, wall = run(tree, Path(tmp) / label, tree / "cases" / "lpanel.toml")
                rows.append({"repeat": k, "tree": label, "s_per_iteration": per, "iterations": iterations,
                             "wall_s": wall})
                print(f"{label}: {per * 1e3:.1f} ms per iteration, {iterations} iterations, {wall:.1f} s", flush=True)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "fem_iteration.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    best = {label: min(r["s_per_iteration"] for r in rows if r["tree"] == label) for label in trees}
    counts = {label: sorted({r["iterations"] for r in rows if r["tree"] == label}) for label in trees}
    load = os.getloadavg()[0]
    lines = ["# A whole alternate-minimization iteration of the 2D L-panel, new against old"
             " (`python -m benchmarks.bench_fem_iteration`)", "",
             f"{platform.machine()}, python {platform.python_version()}; `thinfilm run cases/lpanel.toml` (P1, 107,183"
             f" nodes, PARDISO) at the loads {LOADS} mm, one thread per library; {args.repeats} alternating repeats,"
             f" the minimum; load average {load:.2f} at the end; old code {args.old_label}.", "",
             "| tree | iterations | time per iteration [ms] (min) | all repeats [ms] |", "|---|---|---|---|"]
    for label in trees:
        every = ", ".join(f"{r['s_per_iteration'] * 1e3:.1f}" for r in rows if r["tree"] == label)
        lines.append(f"| {label} | {', '.join(map(str, counts[label]))} | {best[label] * 1e3:.1f} | {every} |")
    ratio = best["new"] / best[args.old_label]
    lines += ["", f"new / {args.old_label}: **{ratio:.3f}**"]
    (out / "fem_iteration.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0 if counts["new"] == counts[args.old_label] else 1


if __name__ == "__main__":
    sys.exit(main())
