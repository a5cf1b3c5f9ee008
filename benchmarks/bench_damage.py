"""Benchmark of the damage solver (:func:`thinfilm.solvers.boxqp.solve_box_qp`) on 2D grids.

For each grid of n x n nodes on the unit square (dx = 1/(n-1), eta = 4 dx,
toughness = 1) it times:

- ``cold``: the damage problem of a realistic field, solved from ``a0 = lower``;
- ``warm-increment``: the elastic density raised by 1% (+-0.5%, smooth), re-solved
  from the previous solution with ``lower`` = previous damage (a load step);
- ``warm-perturb``: the elastic density perturbed by +-1% (smooth, both signs), likewise
  (as between alternate-minimization iterations: damage grows in some places and is
  held by irreversibility in others, and the boundary between the two must be found).

The AT1 field: three crack lines (two straight, one inclined) that already exist
(``lower = upper = 1`` on the nodes they cross: alpha = 1 across them), an elastic
density that concentrates near them (1000 times the damage threshold, Gaussian of
width 2 dx) on a sub-critical smooth background. AT2 uses the same field.

Writes ``benchmarks/results/damage.csv`` and ``damage.md``. Every solve is repeated
``--repeat`` times and the fastest is reported (the machine may be shared).

Usage (from the repository root)::

    python -m benchmarks.bench_damage                       # the full table (~3 min)
    python -m benchmarks.bench_damage --at1 250 500 --at2 250 --repeat 1
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse as sp

from thinfilm.solvers.boxqp import kkt_residual, solve_box_qp

C_M = {1: 2.0 / 3.0, 2: 0.5}
RESULTS = Path(__file__).resolve().parent / "results"


def laplacian_2d(n, dx):
    """5-point stiffness Laplacian per unit area, natural boundaries, (n^2, n^2)."""
    main = np.full(n, 2.0)
    main[[0, -1]] = 1.0
    off = -np.ones(n - 1)
    L1 = sp.diags([off, main, off], [-1, 0, 1], format="csr") / dx**2
    eye = sp.identity(n, format="csr")
    return (sp.kron(eye, L1) + sp.kron(L1, eye)).tocsr()


def at_problem(W, L, toughness, eta, at):
    """``(A, b)`` of the AT1/AT2 damage problem at elastic density W (see the tests)."""
    c_m = C_M[at]
    diagonal = W if at == 1 else W + toughness / (2 * c_m * eta)
    A = sp.csr_array(L * (toughness * eta / (2 * c_m)) + sp.diags(diagonal, format="csr"))
    b = W - toughness / (4 * c_m * eta) if at == 1 else W.copy()
    return A, b


def crack_field(n, eta, toughness=1.0):
    """Elastic density W (n*n,) and the crack indicator (alpha = 1 there), x fastest."""
    x = np.linspace(0.0, 1.0, n)
    X, Y = np.meshgrid(x, x)
    dx = x[1] - x[0]
    threshold = toughness / (4 * C_M[1] * eta)  # AT1 damage threshold
    distances = [np.abs(X - 0.3), np.abs(X - 0.7),
                 np.abs(Y - 0.45 - 0.2 * X) / np.hypot(1.0, 0.2)]
    W = 0.5 * threshold * (1.0 + 0.3 * np.sin(2 * np.pi * X) * np.cos(3 * np.pi * Y))
    crack = np.zeros_like(X, dtype=bool)
    for d in distances:
        W += 1000 * threshold * np.exp(-((d / (2 * dx)) ** 2))
        crack |= d <= 0.5 * dx
    return W.ravel(), crack.ravel()


def smooth_field(n, seed):
    """A smooth field of both signs with values in about [-1, 1]."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 1.0, n)
    X, Y = np.meshgrid(x, x)
    f = np.zeros_like(X)
    for _ in range(4):
        kx, ky = rng.uniform(1, 4, 2)
        phase_x, phase_y = rng.random(2)
        f += np.sin(2 * np.pi * (kx * X + phase_x)) * np.sin(2 * np.pi * (ky * Y + phase_y))
    return (f / 4).ravel()


def timed_solve(repeat, *args, **kwargs):
    """Wall-clock and CPU times of the fastest of ``repeat`` solves, and its result.

    On a shared machine the CPU time (this process only) is the steadier number.
    """
    best = (np.inf, np.inf)
    result = None
    for _ in range(repeat):
        tic, tic_cpu = time.perf_counter(), time.process_time()
        res = solve_box_qp(*args, **kwargs)
        times = (time.perf_counter() - tic, time.process_time() - tic_cpu)
        if times[0] < best[0]:
            best, result = times, res
    return best, result


def bench_grid(n, at, repeat):
    dx = 1.0 / (n - 1)
    eta = 4 * dx
    tic = time.perf_counter()
    W, crack = crack_field(n, eta)
    L = laplacian_2d(n, dx)
    A, b = at_problem(W, L, 1.0, eta, at)
    lower = crack.astype(float)
    build = time.perf_counter() - tic

    rows = []

    def record(case, times, res, A_, b_, lower_):
        # Independent check of the answer on a fresh residual.
        kkt = kkt_residual(A_, b_, res.a, lower_, 1.0)
        assert kkt <= 1e-8 and np.all(res.a >= lower_) and np.all(res.a <= 1.0)
        rows.append(dict(
            model=f"AT{at}", n=n, nodes=n * n, case=case, seconds=round(times[0], 3),
            cpu_seconds=round(times[1], 3),
            iterations=res.iterations, cg_iterations=res.linear_iterations,
            free_fraction=round(max(res.n_free_history, default=0) / (n * n), 4),
            n_free=res.n_free, kkt=f"{kkt:.1e}",
            t_linear=round(res.timings["linear_solve"], 3),
            t_other=round(res.timings["total"] - res.timings["linear_solve"], 3),
            build=round(build, 2)))
        print(" ".join(f"{k}={v}" for k, v in rows[-1].items()), flush=True)

    times, cold = timed_solve(repeat, A, b, lower, 1.0)
    record("cold", times, cold, A, b, lower)
    for case, factor in (("warm-increment", 1.01 + 0.005 * smooth_field(n, 1)),
                         ("warm-perturb", 1.0 + 0.01 * smooth_field(n, 2))):
        A2, b2 = at_problem(W * factor, L, 1.0, eta, at)
        times, warm = timed_solve(repeat, A2, b2, cold.a, 1.0, a0=cold.a)
        record(case, times, warm, A2, b2, cold.a)
    return rows


def write_tables(rows, command, load_before):
    RESULTS.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    with open(RESULTS / "damage.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)
    header = ["model", "nodes", "case", "time [s]", "CPU [s]", "iterations", "CG iterations",
              "largest free set", "KKT", "linear solve [s]", "rest [s]"]
    lines = [
        "# Damage solver benchmark",
        "",
        f"`{command}`",
        "",
        f"Machine: {os.cpu_count()} cores, {platform.processor() or platform.machine()}; "
        f"Python {platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}. "
        f"Load average before the run: {load_before} (the machine is shared; CPU time of "
        "this process is the steadier number). Times are the fastest of the repeats of one "
        "`solve_box_qp` call (input checks included, matrix assembly excluded); "
        "'linear solve' and 'rest' split the wall time.",
        "",
        "Problem: n x n grid on the unit square, eta = 4 dx, three existing cracks "
        "(alpha = 1 on them) with the elastic density concentrated near them; "
        "`warm-increment`: density x (1.01 +- 0.005) re-solved from the previous "
        "solution with lower = previous damage; `warm-perturb`: density x (1 +- 0.01). "
        "rtol = 1e-8 (scaled KKT residual, units of damage).",
        "",
        "| " + " | ".join(header) + " |",
        "|" + "---|" * len(header),
    ]
    for r in rows:
        lines.append("| " + " | ".join(str(v) for v in (
            r["model"], f"{r['n']}^2", r["case"], r["seconds"], r["cpu_seconds"], r["iterations"],
            r["cg_iterations"], f"{100 * r['free_fraction']:.1f}%", r["kkt"], r["t_linear"],
            r["t_other"])) + " |")
    (RESULTS / "damage.md").write_text("\n".join(lines) + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--at1", type=int, nargs="*", default=[250, 500, 1000, 1500],
                        help="AT1 grid sizes (nodes per side)")
    parser.add_argument("--at2", type=int, nargs="*", default=[250, 500],
                        help="AT2 grid sizes (nodes per side)")
    parser.add_argument("--repeat", type=int, default=3, help="repeats per solve (min taken)")
    args = parser.parse_args(argv)
    given = sys.argv[1:] if argv is None else argv
    command = "python -m benchmarks.bench_damage " + " ".join(given)
    load_before = " ".join(f"{x:.2f}" for x in os.getloadavg())

    # Compile (or load from cache) the Numba kernels outside the timings.
    bench_grid(40, 1, 1)
    rows = []
    for at, sizes in ((1, args.at1), (2, args.at2)):
        for n in sizes:
            rows += bench_grid(n, at, args.repeat)
    write_tables(rows, command.strip(), load_before)
    print(f"wrote {RESULTS / 'damage.md'} and {RESULTS / 'damage.csv'}")


if __name__ == "__main__":
    main()
