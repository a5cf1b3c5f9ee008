"""Single- against double-precision factorization inside the evolution, on the full-resolution scene.

``cases/indentation_full.toml`` (the dissertation's 1500 x 1500 nodes on (-0.5, 0.5)^2, eta
= 0.005, tol 1e-3; ``--nodes`` another grid of the same domain and eta) at one load step,
started as the full-resolution run starts it: from the main job's damage at the same load
(grid sequencing, ``coarse = "indentation/results.h5"``), irreversible against the main
job's damage at the step before. The step runs once with the direct solver's factorization
in double precision (the baseline) and once in single precision (each u-solve refined by
CG to the tolerance alternate minimization asks, ``rtol = 1e-2 x`` the last change of alpha,
clipped to [1e-8, 1e-5]); the table gives the iterations, the time per u-solve and per step,
the CG refinement steps, and the differences of the final energy and damage.

Usage (run the main job first: ``python -m thinfilm run cases/indentation.toml``)::

    python -m benchmarks.bench_precision --nodes 1000      # about 10 minutes on 2 cores
    python -m benchmarks.bench_precision --threads 1       # on a machine shared with other jobs

Writes ``benchmarks/results/precision.md`` and ``.csv`` (rows merged by grid).
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.tables import markdown_table, merge_csv
from thinfilm.engine import Engine, StepRecord
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.sequencing import CoarseDamage
from thinfilm.scene import parse_scene
from thinfilm.threads import limit_threads

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
COARSE = ROOT / "cases" / "indentation" / "results.h5"
FIELDS = ["nodes", "t", "precision", "threads", "iterations", "u_solves", "refinement_steps", "time_per_u_solve_s",
          "step_s", "u_solve/base", "step/base", "energy_diff", "max_alpha_diff", "command"]


def full_scene(nodes, precision):
    """``cases/indentation_full.toml`` on ``nodes`` x ``nodes`` nodes with the given precision."""
    text = (ROOT / "cases" / "indentation_full.toml").read_text()
    for line in ("cells = [1499, 1499]", "[solver]"):
        if line not in text:  # the table would be labelled with a grid it did not use
            raise SystemExit(f"cases/indentation_full.toml has no line {line!r}; update bench_precision.py")
    text = text.replace("cells = [1499, 1499]", f"cells = [{nodes - 1}, {nodes - 1}]")
    text = text.replace("[solver]", f'[solver]\nprecision = "{precision}"\nstop = "change"')
    return parse_scene(text, source="cases/indentation_full.toml")


class _CountingSolves:
    """Wraps the model's linear solver to count the CG refinement steps of its solves."""

    def __init__(self, solver):
        self.solver, self.steps = solver, 0

    def update(self, K):
        self.solver.update(K)

    def solve(self, f, x0=None, rtol=None):
        u, info = self.solver.solve(f, x0=x0, rtol=rtol)
        self.steps += info.iterations
        return u, info


def one_step(nodes, precision, t, t_before):
    """The sequenced step at load ``t``; returns (row, alpha)."""
    scene = full_scene(nodes, precision)
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    model.linear_solver = counting = _CountingSolves(model.linear_solver)
    engine = Engine.from_options(model, scene.solver)
    coarse = CoarseDamage(COARSE, grid)
    lower = coarse(t_before)
    start = np.maximum(lower, coarse(t))
    record = StepRecord(1, t)
    tic = time.perf_counter()
    state = engine.alternate_minimization(t, start, lower, None, record, 1)
    wall = time.perf_counter() - tic
    row = dict(nodes=f"{nodes}^2", t=t, precision=counting.solver.precision, iterations=record.iterations,
               u_solves=record.u_solves, refinement_steps=counting.steps,
               time_per_u_solve_s=round(record.time_u / max(record.u_solves, 1), 2), step_s=round(wall, 1),
               energy=state.total)
    return row, state.alpha


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, default=1500)
    parser.add_argument("--t", type=float, default=0.35, help="the load step (default 0.35)")
    parser.add_argument("--threads", type=int, default=None, help="MKL/OpenMP/Numba threads (default: all cores)")
    args = parser.parse_args(argv)
    if not COARSE.exists():
        sys.exit(f"{COARSE} is missing: run `python -m thinfilm run cases/indentation.toml` first")
    threads = args.threads or os.cpu_count()
    limit_threads(threads)
    t_before = round(args.t - 0.05, 10)
    one_step(101, "double", args.t, t_before)  # load the compiled kernels before timing
    base, alpha_base = one_step(args.nodes, "double", args.t, t_before)
    single, alpha_single = one_step(args.nodes, "single", args.t, t_before)
    command = "python -m benchmarks.bench_precision" + "".join(
        f" --{k} {v}" for k, v in (("nodes", args.nodes), ("t", args.t), ("threads", args.threads))
        if v is not None and not (k == "nodes" and v == 1500) and not (k == "t" and v == 0.35))
    for row, alpha in ((base, alpha_base), (single, alpha_single)):
        row["threads"] = threads
        row["u_solve/base"] = round(row["time_per_u_solve_s"] / base["time_per_u_solve_s"], 3)
        row["step/base"] = round(row["step_s"] / base["step_s"], 3)
        row["energy_diff"] = f"{(row['energy'] - base['energy']) / abs(base['energy']):+.1e}"
        row["max_alpha_diff"] = f"{np.max(np.abs(alpha - alpha_base)):.1e}"
        row["command"] = command
    rows = merge_csv(RESULTS / "precision.csv", [base, single], FIELDS, "nodes",
                     sort=lambda r: (int(str(r["nodes"]).split("^")[0]), r["precision"] != "double"))
    shown = FIELDS[:-1]
    lines = ["# Single- against double-precision factorization inside the evolution", "",
             "Commands: " + ", ".join(sorted({f"`{r['command']}`" for r in rows})) + ".",
             f"Machine: {os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()};"
             f" 1-min load average at the end {os.getloadavg()[0]:.2f}.", "",
             "One load step of `cases/indentation_full.toml` on the grid shown, from the main job's damage at"
             " the same load, irreversible against its damage at t - 0.05; tol 1e-3, the change stop."
             " Ratios are to double precision on the same grid, in the same invocation. `refinement_steps`:"
             " CG steps of all the step's u-solves.", ""] + markdown_table(rows, shown)
    (RESULTS / "precision.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
