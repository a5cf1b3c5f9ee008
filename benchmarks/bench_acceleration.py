"""Over-relaxed against plain alternate minimization in the nucleation step of the Fig. 2.7 strip.

The strip of ``cases/fig2_7.toml`` ((-0.5, 0.5) x (-0.1, 0.1), lam = 31.62, G/a = 1,
nu = 0.3, AT1) stays elastic up to t = 6.4 when backtracking is off; at t = 6.5 all nine
cracks form from alpha = 0 in one load step, one pair after the other. That step is where
alternate minimization does its work (every other step of the evolution converges in one to
four iterations), so it is where an acceleration shows. The step is solved with
``acceleration = "none"`` and ``"overrelax"`` (the scene's ``omega``) at eta = 1/120 on
300 x 60 (the scene, eta = 2.5 dx), 450 x 90 and 600 x 120 cells, and the table lists
iterations, u-solves, rejected extrapolations, wall and CPU time, the final energy and the
cracks along y = 0 of each. Each grid's plain run is the baseline of its ratios.

Usage (from the repository root)::

    python -m benchmarks.bench_acceleration            # three grids, about 5 minutes
    python -m benchmarks.bench_acceleration --cells 300

Writes ``benchmarks/results/acceleration.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import time
from pathlib import Path

import numpy as np

from thinfilm.engine import AltMinOptions, Engine, StepRecord
from thinfilm.plate.cracks import centre_line, crack_positions
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.scene import parse_scene

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
T_NUCLEATION = 6.5


def strip_scene(nx):
    """The fig2_7 scene with eta = 1/120 fixed on an ``nx`` x ``nx / 5`` grid."""
    text = (ROOT / "cases" / "fig2_7.toml").read_text()
    text = text.replace("eta_dx = 2.5", "eta = 0.008333333333333333")
    return parse_scene(text.replace("cells = [300, 60]", f"cells = [{nx}, {nx // 5}]"))


def nucleation_step(scene, acceleration):
    """Alternate minimization at t = 6.5 from alpha = 0; returns one table row (dict)."""
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    engine = Engine(model, AltMinOptions(tol=scene.solver.altmin.tol, acceleration=acceleration,
                                         omega=scene.solver.altmin.omega))
    zero = np.zeros(model.n_alpha)
    record = StepRecord(65, T_NUCLEATION)
    tic, tic_cpu = time.perf_counter(), time.process_time()
    state = engine.alternate_minimization(T_NUCLEATION, zero, zero, None, record, 65)
    wall, cpu = time.perf_counter() - tic, time.process_time() - tic_cpu
    history = np.diff(record.energy_history)
    x, line = centre_line(grid, state.alpha)
    cracks = crack_positions(x, line)
    return dict(grid=f"{grid.nx} x {grid.ny}", eta_dx=round(scene.model.eta / grid.hx, 2),
                acceleration=acceleration, iterations=record.iterations, u_solves=record.u_solves,
                rejected=record.extrapolations_rejected, wall=round(wall, 2), cpu=round(cpu, 2),
                energy=f"{state.total:.10f}", monotone=bool(np.all(history <= 1e-12 * record.energy_history[0])),
                cracks=" ".join(f"{c:+.4f}" for c in cracks))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=int, nargs="+", default=[300, 450, 600],
                        help="cells along x (y gets a fifth)")
    args = parser.parse_args(argv)
    rows = []
    started = time.perf_counter()
    nucleation_step(strip_scene(100), "none")  # load the compiled kernels before timing
    for nx in args.cells:
        scene = strip_scene(nx)
        for acceleration in ("none", "overrelax"):
            rows.append(nucleation_step(scene, acceleration))
            print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)
        base, fast = rows[-2], rows[-1]
        for key in ("iterations", "wall", "cpu"):
            fast[f"{key}/base"] = round(fast[key] / base[key], 3)
            base[f"{key}/base"] = 1.0
        fast["energy diff"] = f"{(float(fast['energy']) - float(base['energy'])) / float(base['energy']):+.1e}"
        base["energy diff"] = "0"
    total = time.perf_counter() - started

    RESULTS.mkdir(parents=True, exist_ok=True)
    columns = ["grid", "eta_dx", "acceleration", "iterations", "iterations/base", "u_solves", "rejected",
               "wall", "wall/base", "cpu", "cpu/base", "energy", "energy diff", "monotone", "cracks"]
    with open(RESULTS / "acceleration.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [
        "# Over-relaxed against plain alternate minimization: the Fig. 2.7 strip's nucleation step",
        "",
        f"Command: `python -m benchmarks.bench_acceleration`. {total / 60:.1f} min wall in all.",
        f"Machine: {os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()};"
        f" 1-min load average at the end {load:.2f} (shared machine: wall times vary).",
        "",
        "t = 6.5 from alpha = 0, eta = 1/120, no backtracking; `overrelax` with the scene's omega."
        " `monotone`: the total energy never rose over the half-steps. Ratios are to the plain"
        " run on the same grid, in the same run.",
        "",
        "| " + " | ".join(columns) + " |",
        "|" + "---|" * len(columns),
    ]
    lines += ["| " + " | ".join(str(r.get(c, "")) for c in columns) + " |" for r in rows]
    (RESULTS / "acceleration.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULTS / 'acceleration.md'}")


if __name__ == "__main__":
    main()
