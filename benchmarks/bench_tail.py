"""Tail extrapolation against plain settling in the first ring step of the indentation scene.

The scene of ``cases/indentation.toml`` on a finer grid (default 640 x 640 cells on
(-0.4, 0.4)^2, eta = 0.005 = 4 dx), tol 1e-3 as in ``indentation_full.toml``: alternate
minimization at t = 0.25, where the first ring forms, from the damage of the main job's run
at the same load (grid sequencing, as the full-resolution case does), with irreversibility
against the main job's damage at t = 0.2. Once the ring is in place the step settles
linearly (the change of alpha shrinks by a few percent per iteration); the table compares
``omega_tail = 1`` (no tail extrapolation: the baseline) with the default 8: iterations, wall
time, the final energy and the largest difference of the final damage.

Usage (run the main job first: ``python -m thinfilm run cases/indentation.toml``)::

    python -m benchmarks.bench_tail               # about 8 minutes on 2 cores
    python -m benchmarks.bench_tail --cells 480

Writes ``benchmarks/results/tail.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from thinfilm.engine import Engine, StepRecord
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.sequencing import CoarseDamage
from thinfilm.scene import parse_scene

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
COARSE = ROOT / "cases" / "indentation" / "results.h5"
T_RING, T_BEFORE = 0.25, 0.2


def ring_scene(cells):
    """``cases/indentation.toml`` on ``cells`` x ``cells`` with tol 1e-3."""
    text = (ROOT / "cases" / "indentation.toml").read_text()
    for line in ("cells = [320, 320]", 'acceleration = "overrelax"'):
        if line not in text:  # the table would be labelled with a grid or tol it did not use
            raise SystemExit(f"cases/indentation.toml has no line {line!r}; update bench_tail.py")
    text = text.replace("cells = [320, 320]", f"cells = [{cells}, {cells}]")
    return parse_scene(text.replace('acceleration = "overrelax"', 'acceleration = "overrelax"\ntol = 1e-3'))


def ring_step(scene, omega_tail):
    """The sequenced ring step with the given ``omega_tail``; returns (row, alpha)."""
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    engine = Engine.from_options(model, scene.solver)
    engine.altmin = dataclasses.replace(engine.altmin, omega_tail=omega_tail)
    coarse = CoarseDamage(COARSE, grid)
    lower = coarse(T_BEFORE)
    start = np.maximum(lower, coarse(T_RING))
    record = StepRecord(5, T_RING)
    tic = time.perf_counter()
    state = engine.alternate_minimization(T_RING, start, lower, None, record, 5)
    wall = time.perf_counter() - tic
    row = dict(grid=f"{grid.nx} x {grid.ny}", eta_dx=round(scene.model.eta / grid.hx, 2), omega_tail=omega_tail,
               iterations=record.iterations, rejected=record.extrapolations_rejected, wall_s=round(wall, 1),
               energy=f"{state.total:.9f}")
    return row, state.alpha


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, default=640)
    args = parser.parse_args(argv)
    if not COARSE.exists():
        sys.exit(f"{COARSE} is missing: run `python -m thinfilm run cases/indentation.toml` first")
    scene = ring_scene(args.cells)
    ring_step(ring_scene(100), 8.0)  # load the compiled kernels before timing
    base, alpha_base = ring_step(scene, 1.0)
    tail, alpha_tail = ring_step(scene, 8.0)
    for row in (base, tail):
        row["iterations/base"] = round(row["iterations"] / base["iterations"], 3)
        row["wall/base"] = round(row["wall_s"] / base["wall_s"], 3)
        row["energy diff"] = f"{(float(row['energy']) - float(base['energy'])) / float(base['energy']):+.1e}"
    tail["max alpha diff"] = f"{np.max(np.abs(alpha_tail - alpha_base)):.1e}"
    base["max alpha diff"] = "0"
    rows = [base, tail]
    RESULTS.mkdir(parents=True, exist_ok=True)
    with open(RESULTS / "tail.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(base))
        writer.writeheader()
        writer.writerows(rows)
    command = "python -m benchmarks.bench_tail" + (f" --cells {args.cells}" if args.cells != 640 else "")
    lines = ["# Tail extrapolation in the first ring step of the indentation scene", "",
             f"Command: `{command}`.",
             f"Machine: {os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()};"
             f" 1-min load average at the end {os.getloadavg()[0]:.2f} (wall times vary on a shared machine).", "",
             f"t = {T_RING} from the main job's damage at the same load (cases/indentation/results.h5),"
             f" irreversible against its damage at t = {T_BEFORE}; tol 1e-3; `overrelax` with omega = 4."
             " Ratios are to omega_tail = 1 (no tail extrapolation) in the same run.", "",
             "| " + " | ".join(base) + " |", "|" + "---|" * len(base)]
    lines += ["| " + " | ".join(str(r[k]) for k in base) + " |" for r in rows]
    (RESULTS / "tail.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
