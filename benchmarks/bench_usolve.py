"""Cost of one u-solve ``K(alpha) u = f`` for each solver kind, on realistic damaged plates.

For each grid of m x m nodes and each case, a fresh subprocess (so that ``ru_maxrss`` is the
peak of that case alone, C allocations included) builds the plate + Winkler test matrix of
:func:`tests.solvers.plate_system.plate_test_matrix` (nu = 0.3, winkler = 4e6 i.e. lam = 31.6,
k_res = 1e-6) with the crack field of :func:`tests.solvers.plate_system.crack_bands` (a through crack,
a T-junction, a ring and a partial crack, alpha = 1 across them), loads it by pure bending
``w = -x^2/2`` and measures

- ``first``: the first solve, setup included (PARDISO: analysis + factorization + solve; AMG:
  hierarchy + CG from zero);
- ``resolve``: after the partial crack grows by 5 cells, ``update(K) + solve`` with reuse
  (PARDISO/SuperLU: numeric refactorization with the kept analysis/order; AMG: kept hierarchy,
  warm start from the previous u), rtol = 1e-8;
- ``resolve_loose`` (AMG and single-precision PARDISO, whose work depends on the tolerance):
  the crack grows 5 more cells, warm start, rtol = 1e-6;
- ``peak_gb``: the subprocess's peak resident memory; ``base_gb`` what the test matrices alone
  held before any solver ran.

Cases: ``plain`` (``scipy.sparse.linalg.spsolve`` on the grown crack, the baseline every ratio
refers to, measured in the same invocation), ``pardiso``, ``pardiso-single`` (the factorization
in single precision, each solve refined by CG to rtol) and ``superlu`` (``kind="direct"``
backends), ``amg`` (``kind="amg"``, told the plate's near-nullspace,
:func:`thinfilm.plate.operators.near_nullspace`). Cases whose estimated cost is past ~5
minutes or ~12 GB are skipped and listed as such.

Usage (from the repository root)::

    python -m benchmarks.bench_usolve                      # 250 500 1000 1500, ~25 min
    python -m benchmarks.bench_usolve --sizes 250 500 1000 # one invocation per ~15 min
    python -m benchmarks.bench_usolve --sizes 1500         # rows are merged into the CSV

Writes ``benchmarks/results/usolve.csv`` (rows merged by (m, case)), ``usolve.md`` and
``usolve.png`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
CASES = ("plain", "pardiso", "pardiso-single", "superlu", "amg")
FIELDS = ["m", "unknowns", "nnz", "case", "status", "first_setup_s", "first_solve_s",
          "first_s", "first_iterations", "resolve_s", "resolve_s_max", "resolve_setup_s",
          "resolve_rebuilt", "resolve_iterations",
          "resolve_residual", "resolve_loose_s", "resolve_loose_iterations", "peak_gb",
          "base_gb", "ratio_first", "ratio_resolve", "note", "command"]

# Skip rules from measurements on the 2-core machine (see the module docstring of the results):
# spsolve (COLAMD) took 14 s and 2.6 GB at 500^2 and grows like N^1.5 in time, faster in
# memory; SuperLU with MMD took 5.7 s / 1.4 GB at 500^2.
SKIP = {
    ("plain", 1500): "skipped: spsolve (COLAMD) estimated > 5 min and > 20 GB at 1500^2",
    ("superlu", 1500): "skipped: SuperLU estimated > 12 GB at 1500^2",
}


def _rss_gb(field="VmRSS"):
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1e6
    return float("nan")


def worker(m, case):
    """Run one case in this process and print one JSON line."""
    import numpy as np
    import scipy.sparse.linalg as spla

    from tests.solvers.plate_system import crack_bands, grid_coords, plate_test_matrix
    from thinfilm.plate.operators import near_nullspace
    from thinfilm.solvers.linear import LinearSolverError, make_solver

    winkler = 4e6
    t = time.perf_counter()
    K1 = plate_test_matrix(crack_bands(m), winkler=winkler, k_res=1e-6, nu=0.3)
    K2 = plate_test_matrix(crack_bands(m, grow=5), winkler=winkler, k_res=1e-6, nu=0.3)
    coords = grid_coords(m)
    f = winkler * (-coords[:, 0] ** 2 / 2) / (m - 1) ** 2  # winkler * h^2 * w
    build = time.perf_counter() - t
    row = dict(m=m, unknowns=m * m, nnz=K1.nnz, case=case, status="ok",
               base_gb=round(_rss_gb(), 3), note=f"matrix build {build:.1f} s")

    def relres(K, u):
        return float(np.linalg.norm(f - K @ u) / np.linalg.norm(f))

    try:
        if case == "plain":
            t = time.perf_counter()
            u = spla.spsolve(K2.tocsc(), f)
            dt = time.perf_counter() - t
            row.update(first_s=dt, resolve_s=dt, resolve_setup_s=dt, resolve_iterations=0,
                       resolve_residual=relres(K2, u))
        else:
            kind = "amg" if case == "amg" else "direct"
            opts = ({} if kind == "amg" else {"backend": "pardiso", "precision": "single"} if case == "pardiso-single"
                    else {"backend": case, "precision": "double"})
            t = time.perf_counter()  # construction included: PARDISO analyses there
            solver = make_solver(kind, K1, near_nullspace=near_nullspace(coords), **opts)
            solver.update(K1)
            u1, i1 = solver.solve(f)
            first = time.perf_counter() - t
            row.update(first_s=first, first_setup_s=first - i1.time_solve,
                       first_solve_s=i1.time_solve, first_iterations=i1.iterations)
            # Two re-solves after two small growths (K1 -> K2 -> K2b): the VM's timings vary by
            # up to 2x from run to run, so report the faster and keep the slower.
            K2b = plate_test_matrix(crack_bands(m, grow=6), winkler=winkler, k_res=1e-6)
            samples, u_prev = [], u1
            for K in (K2, K2b):
                t = time.perf_counter()
                solver.update(K)
                u2, i2 = solver.solve(f, x0=u_prev)
                samples.append((time.perf_counter() - t, i2, relres(K, u2)))
                u_prev = u2
            best = min(samples, key=lambda s: s[0])
            row.update(resolve_s=best[0], resolve_s_max=max(s[0] for s in samples),
                       resolve_setup_s=best[1].time_setup, resolve_rebuilt=best[1].rebuilt,
                       resolve_iterations=best[1].iterations, resolve_residual=best[2])
            if case in ("amg", "pardiso-single"):  # solvers whose work depends on rtol
                K3 = plate_test_matrix(crack_bands(m, grow=11), winkler=winkler, k_res=1e-6)
                t = time.perf_counter()
                solver.update(K3)
                _, i3 = solver.solve(f, x0=u_prev, rtol=1e-6)
                row.update(resolve_loose_s=time.perf_counter() - t,
                           resolve_loose_iterations=i3.iterations)
            if kind == "amg":
                row["note"] += f"; operator complexity {solver.operator_complexity():.2f}"
    except LinearSolverError as exc:
        row.update(status="failed", note=str(exc))
    row["peak_gb"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6, 3)
    print("RESULT " + json.dumps(row), flush=True)


def run_case(m, case, timeout):
    if (case, m) in SKIP:
        return dict(m=m, unknowns=m * m, case=case, status="skipped", note=SKIP[(case, m)])
    if case.startswith("pardiso"):
        from thinfilm.solvers.linear import pardiso_available

        if not pardiso_available():
            return dict(m=m, unknowns=m * m, case=case, status="skipped",
                        note="pypardiso not installed")
    cmd = [sys.executable, "-m", "benchmarks.bench_usolve", "--worker", str(m), case]
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    t = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return dict(m=m, unknowns=m * m, case=case, status="timeout",
                    note=f"killed after {timeout:.0f} s")
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            row = json.loads(line[7:])
            print(f"  m={m:5d} {case:8s} {time.perf_counter() - t:7.1f} s wall", flush=True)
            return row
    return dict(m=m, unknowns=m * m, case=case, status="crashed",
                note=(out.stderr.strip().splitlines() or ["?"])[-1][:200])


def load_rows(path):
    if not path.exists():
        return []
    with open(path) as fh:
        return list(csv.DictReader(fh))


def fmt(x, spec):
    if x in (None, ""):
        return ""
    try:
        return format(float(x), spec)
    except ValueError:
        return str(x)


def write_outputs(rows, command, out=RESULTS):
    out.mkdir(parents=True, exist_ok=True)
    rows = sorted(rows, key=lambda r: (int(r["m"]), CASES.index(r["case"])))
    with open(out / "usolve.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)

    lines = [
        "# Cost of one u-solve (plate + Winkler, 13-point stencil, cracked)",
        "",
        "Commands (rows are merged from these invocations; ratios only within one): "
        + ", ".join(f"`{c}`" for c in sorted({r.get("command") or command for r in rows})),
        "Machine: 2 cores, 24 GB; numpy/scipy with OpenBLAS, MKL from the `mkl` wheel.",
        "Problem: nu = 0.3, winkler = 4e6 (lam = 31.6), k_res = 1e-6, crack bands with",
        "alpha = 1; re-solves after the partial crack grows 5 cells, then 1 more; rtol = 1e-8",
        "unless noted (the loose re-solve of AMG and single-precision PARDISO: 5 cells more).",
        "`pardiso-single`: the factorization in single precision, each solve refined by CG",
        "preconditioned by it to rtol (`its` = refinement steps).",
        "`first` = construction + setup + first solve; `re-solve` = update + solve with reuse (direct:",
        "numeric refactorization with the kept analysis; amg: kept hierarchy, warm start);",
        "ratios divide by `plain` (`scipy.sparse.linalg.spsolve`, COLAMD) at the same size.",
        "Targets: a u-solve at 1000^2 in 3 s, at 1500^2 in 8 s, peak memory < 12 GB at 1500^2.",
        "",
        "| nodes | case | first [s] (setup + solve) | re-solve [s] min / max of 2 | its "
        "| re-solve rtol 1e-6 [s] (its) "
        "| peak RSS [GB] (matrices) | first / plain | re-solve / plain | note |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r.get("status") != "ok":
            lines.append(f"| {r['m']}^2 | {r['case']} | {r['status']} | | | | | | | "
                         f"{r.get('note', '')} |")
            continue
        first = fmt(r.get("first_s"), ".2f")
        if r.get("first_setup_s"):
            first += f" ({fmt(r['first_setup_s'], '.2f')} + {fmt(r['first_solve_s'], '.2f')})"
        loose = ""
        if r.get("resolve_loose_s"):
            loose = f"{fmt(r['resolve_loose_s'], '.2f')} ({r['resolve_loose_iterations']})"
        its = r.get("resolve_iterations", "")
        resolve = fmt(r.get("resolve_s"), ".2f")
        if r.get("resolve_s_max"):
            resolve += f" / {fmt(r['resolve_s_max'], '.2f')}"
        if r["case"] == "amg" and r.get("first_iterations"):
            its = f"{its} (first {r['first_iterations']})"
        lines.append(
            f"| {r['m']}^2 | {r['case']} | {first} | {resolve} | {its} | "
            f"{loose} | {fmt(r.get('peak_gb'), '.2f')} ({fmt(r.get('base_gb'), '.2f')}) | "
            f"{fmt(r.get('ratio_first'), '.2f')} | {fmt(r.get('ratio_resolve'), '.2f')} | "
            f"{r.get('note', '')} |")
    by_case = {(int(r["m"]), r["case"]): r for r in rows if r.get("status") == "ok"}
    ratios = []
    for m in sorted({int(r["m"]) for r in rows}):
        single, double = by_case.get((m, "pardiso-single")), by_case.get((m, "pardiso"))
        if single and double and single.get("command") == double.get("command"):
            ratios.append(f"{m}^2: re-solve {float(single['resolve_s']) / float(double['resolve_s']):.2f},"
                          f" at rtol 1e-6 {float(single['resolve_loose_s']) / float(double['resolve_s']):.2f},"
                          f" peak memory {float(single['peak_gb']) / float(double['peak_gb']):.2f}")
    if ratios:
        lines += ["", "Single-precision PARDISO against double in the same invocation (ratios of times): "
                  + "; ".join(ratios) + "."]
    (out / "usolve.md").write_text("\n".join(lines) + "\n")
    plot(rows, out)


def plot(rows, out=RESULTS):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    styles = {"plain": "k", "pardiso": "C0", "pardiso-single": "C1", "superlu": "C2", "amg": "C3"}
    for case in CASES:
        rs = [r for r in rows if r["case"] == case and r.get("status") == "ok"]
        if not rs:
            continue
        n = [int(r["unknowns"]) for r in rs]
        if case != "plain":
            ax1.loglog(n, [float(r["first_s"]) for r in rs], "--o", color=styles[case],
                       mfc="none", label=f"{case}: first (setup + solve)")
        ax1.loglog(n, [float(r["resolve_s"]) for r in rs], "-o", color=styles[case],
                   label=f"{case}: re-solve" if case != "plain" else "plain spsolve")
        ax2.loglog(n, [float(r["peak_gb"]) for r in rs], "-o", color=styles[case], label=case)
    ax1.plot([1000**2, 1500**2], [3, 8], "k*", ms=12, label="targets")
    ax1.set_xlabel("unknowns")
    ax1.set_ylabel("seconds")
    ax1.set_title("one u-solve (2 cores)")
    ax1.legend(fontsize=7)
    ax1.grid(True, which="both", alpha=0.3)
    ax2.axhline(12, color="k", ls=":", label="12 GB budget")
    ax2.set_xlabel("unknowns")
    ax2.set_ylabel("peak RSS [GB]")
    ax2.set_title("peak memory (subprocess per case)")
    ax2.legend(fontsize=7)
    ax2.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(out / "usolve.png", dpi=120)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[250, 500, 1000, 1500],
                    help="nodes per side of the square grids")
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--timeout", type=float, default=600.0, help="seconds per case")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result files")
    ap.add_argument("--worker", nargs=2, metavar=("M", "CASE"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(int(args.worker[0]), args.worker[1])
        return
    command = "python -m benchmarks.bench_usolve " + " ".join(sys.argv[1:])
    old = {(int(r["m"]), r["case"]): r for r in load_rows(args.out / "usolve.csv")}
    for m in args.sizes:
        new = {}
        for case in args.cases:
            new[case] = run_case(m, case, args.timeout)
        base = new.get("plain")
        for case, r in new.items():
            if base and base.get("status") == "ok" and r.get("status") == "ok":
                r["ratio_first"] = float(r["first_s"]) / float(base["resolve_s"])
                r["ratio_resolve"] = float(r["resolve_s"]) / float(base["resolve_s"])
            r["command"] = command
            old[(m, case)] = r
        write_outputs(list(old.values()), command, args.out)  # after each size: partial results survive
    print((args.out / "usolve.md").read_text())


if __name__ == "__main__":
    main()
