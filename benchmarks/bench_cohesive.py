"""The cohesive law's damage step against AT1's, on the same L-panel and mesh rule.

Two runs with ``python -m thinfilm run ... --threads 1``: ``cases/lpanel_czm.toml`` (the
cohesive law, eps = 10 mm, an adaptive mesh down to eps/5) and ``cases/lpanel.toml`` with
``--set model.eps=10.0 --set mesh.adapt=true --set mesh.h=2.0`` (AT1 at the same eps, mesh rule
and load steps of its own). AT1's damage step is one box QP; the cohesive law's is
bound-constrained Newton, each iteration one box QP of its convex model plus a line search
(``thinfilm.solvers.box_newton``). Per run: alternate-minimization iterations (each one damage
solve), Newton iterations per damage solve, seconds per damage solve and per u-solve, their
ratio, the nodes at the end, and the peak force. The damage solves' tolerance is the same
(``solver.damage_rtol``, 1e-9 by default), so the two columns cost the same accuracy.

Every process runs with ``MKL_NUM_THREADS=1`` and ``OMP_NUM_THREADS=1``.

Usage (from the repository root)::

    python -m benchmarks.bench_cohesive            # about 4 minutes
    python -m benchmarks.bench_cohesive --collect  # the rows from runs made

Writes ``cohesive.csv`` and ``cohesive.md`` in ``benchmarks/results`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from benchmarks.tables import markdown_table, merge_csv

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
WORK = Path("/tmp/thinfilm_bench_cohesive")
THREADS = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
RUNS = {
    "czm": ("cases/lpanel_czm.toml", []),
    "at1": ("cases/lpanel.toml", ["model.eps=10.0", "mesh.adapt=true", "mesh.h=2.0",
                                  "output.snapshots=[0.2, 0.3, 0.5]"]),
}
FIELDS = ["law", "nodes", "steps", "iterations", "newton_per_solve", "s_per_damage_solve", "s_per_u_solve",
          "damage_over_u", "steps_s", "peak_kN"]


def run(name, work):
    scene, overrides = RUNS[name]
    command = [sys.executable, "-m", "thinfilm", "run", scene, "--out", str(work / name), "--force", "--quiet",
               "--threads", "1"]
    for item in overrides:
        command += ["--set", item]
    subprocess.run(command, cwd=ROOT, env={**os.environ, **THREADS}, check=True)


def measure(name, work):
    from thinfilm.results.reader import Results

    with Results(work / name) as res:
        s = res.steps
        iterations = int(np.sum(s["iterations"]))
        newton = int(np.sum(s["damage_newton_iterations"])) if "damage_newton_iterations" in s else 0
        u_solves = int(np.sum(s["u_solves"]))
        return dict(law=name, nodes=int(s["nodes"][res.n - 1]), steps=res.n, iterations=iterations,
                    newton_per_solve=round(newton / iterations, 2) if newton else 1.0,
                    s_per_damage_solve=round(float(np.sum(s["time_alpha"])) / iterations, 4),
                    s_per_u_solve=round(float(np.sum(s["time_u"])) / max(u_solves, 1), 4),
                    damage_over_u=round(float(np.sum(s["time_alpha"]) / np.sum(s["time_u"])), 3),
                    steps_s=round(float(np.sum(s["time_total"])), 1),
                    peak_kN=round(float(np.max(s["force"])) / 1e3, 3))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=WORK)
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--collect", action="store_true", help="read the runs already in --work")
    args = parser.parse_args()
    args.work.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in RUNS:
        if not args.collect:
            run(name, args.work)
        rows.append(measure(name, args.work))
        print(rows[-1])
    args.out.mkdir(parents=True, exist_ok=True)
    merged = merge_csv(args.out / "cohesive.csv", rows, FIELDS, "law")
    (args.out / "cohesive.md").write_text("\n".join(markdown_table(merged, FIELDS)) + "\n")


if __name__ == "__main__":
    main()
