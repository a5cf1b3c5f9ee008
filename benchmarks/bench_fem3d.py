"""The 3D u-solve against mesh size: AMG setup, CG per alternate-minimization iteration,
hierarchy reuse, memory; and what resolution two cores reach.

For each 3D case file and mesh size (``SIZES``: overrides of the case's ``mesh`` and ``eps``),
one subprocess (one MKL/OpenMP/Numba thread) builds the mesh and the model as ``thinfilm run``
does, then times, each ``--repeats`` times (the median is reported):

1. ``assembly``: :meth:`fem3d.elasticity.Elasticity.matrix` at a damaged state;
2. ``setup``: the smoothed-aggregation hierarchy of the sound matrix (the elasticity settings
   of :data:`fem3d.kind.AMG_OPTIONS`, six rigid modes);
3. ``cold``: CG from zero to the engine's tightest tolerance (1e-6 relative residual) on the
   sound matrix at t = 1 (the first u-solve of a run);
4. ``warm``: the u-solve of an alternate-minimization iteration: the matrix of a damaged state
   (a band of damage, :func:`damage_band`: the profile of a crack across half the solid) with
   the hierarchy of the sound matrix kept (what the solver does until its rate degrades), from
   the sound solution, at rtol 1e-4 (a mid-step iteration's) and 1e-6;
5. ``rebuilt``: the same solves after rebuilding the hierarchy on the damaged matrix;
6. ``amor``: one u-solve with the split (4.11) from the sound solution (number of linear solves
   until the switch settles, and the time).

and the peak resident memory of the process. A power law ``time = c dofs^p`` fitted to the
warm iteration (u-solve plus the damage QP is measured by the evolutions themselves, see
docs/speed.md) gives the size a one-hour budget reaches and the time of the dissertation's 1.45
million tetrahedra.

Usage (from the repository root)::

    python -m benchmarks.bench_fem3d            # ~15 min
    python -m benchmarks.bench_fem3d --quick --out /tmp/fem3d

Writes ``benchmarks/results/fem3d.md`` and ``.csv`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.bench_fem_lpanel import machine_check, versions, wait_for_idle

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
#: (case, label, overrides) of each measured size: eps = 2 h in the refined zone.
SIZES = [
    ("lpanel_3d", "h = 10 mm", {"mesh.h": 10.0, "mesh.h_coarse": 40.0, "model.eps": 20.0}),
    ("lpanel_3d", "h = 7 mm", {"mesh.h": 7.0, "mesh.h_coarse": 40.0, "model.eps": 14.0}),
    ("lpanel_3d", "h = 5 mm", {"mesh.h": 5.0, "mesh.h_coarse": 25.0, "model.eps": 10.0}),
    ("double_torsion", "h = 0.75 mm", {"mesh.h": 0.75, "mesh.h_coarse": 1.0, "model.eps": 2.25}),
    ("double_torsion", "h = 0.6 mm", {"mesh.h": 0.6, "mesh.h_coarse": 1.0, "model.eps": 1.8}),
    ("double_torsion", "h = 0.45 mm", {"mesh.h": 0.45, "mesh.h_coarse": 0.75, "model.eps": 1.35}),
    ("brokenshire", "h = 6.25 mm", {"mesh.h": 6.25}),
    ("brokenshire", "h = 4.5 mm", {"mesh.h": 4.5}),
    ("brokenshire", "h = 3.125 mm", {"mesh.h": 3.125}),
]
QUICK = [("lpanel_3d", "h = 14 mm", {"mesh.h": 14.0, "mesh.h_coarse": 50.0, "model.eps": 28.0})]
#: The dissertation's Brokenshire mesh (section 3.5.4), the size to extrapolate to.
DISSERTATION_TETS = 1.45e6
THREADS = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def damage_band(points, eps):
    """A crack's damage profile ``(1 - |d| / (2 eps))^2`` (the AT1 profile, of half-width
    2 eps) across the middle of the solid's longest extent, over half of its second extent
    and all of its third: shape (n_nodes,)."""
    lo, hi = points.min(axis=0), points.max(axis=0)
    order = np.argsort(hi - lo)[::-1]
    a, b = order[0], order[1]
    d = points[:, a] - 0.5 * (lo[a] + hi[a])
    inside = points[:, b] <= 0.5 * (lo[b] + hi[b])
    return np.where(inside, np.clip(1.0 - np.abs(d) / (2.0 * eps), 0.0, 1.0) ** 2, 0.0)


def _median_time(fn, repeats):
    times, out = [], None
    for _ in range(repeats):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), out


def worker(spec):
    """One case and size in this process: the measurements of the module docstring."""
    from fem3d.kind import AMG_OPTIONS, build_mesh, build_model
    from tests.helpers import load_case
    from thinfilm.solvers.linear import AMGSolver

    case, label, overrides, repeats = spec["case"], spec["label"], spec["overrides"], spec["repeats"]
    scene = load_case(case, {**overrides, "solver.linear": "amg"})
    start = time.perf_counter()
    mesh = build_mesh(scene)
    mesh_s = time.perf_counter() - start
    model = build_model(scene, mesh)
    el = model.elasticity
    n0 = np.zeros(mesh.n_nodes)
    alpha = damage_band(mesh.points, scene.model.eps)
    row = {"case": case, "size": label, "nodes": mesh.n_nodes, "tets": mesh.n_cells, "dofs": int(el.free.size),
           "mesh_s": mesh_s}
    row["assembly_s"], _ = _median_time(lambda: el.matrix(alpha), repeats)

    def built(K):
        s = AMGSolver(K, near_nullspace=el.rigid_modes(), **AMG_OPTIONS)
        s.update(K)
        s._build()
        return s

    K0 = el.matrix(n0).copy()
    row["setup_s"], sound = _median_time(lambda: built(K0), repeats)
    values, force = model.loads.values_at(1.0), model.loads.force_at(1.0)
    f0 = el.rhs(n0, values, force)
    row["cold_s"], (u0, info) = _median_time(lambda: sound.solve(f0, rtol=1e-6), repeats)
    row["cold_iterations"] = info.iterations
    K1 = el.matrix(alpha).copy()
    f1 = el.rhs(alpha, values, force)
    for rtol in (1e-4, 1e-6):
        def warm():
            # the sound hierarchy kept, as the solver keeps it between iterations
            sound.update(K1)
            sound._stale, sound._fresh, sound._baseline = False, False, None
            return sound.solve(f1, x0=u0, rtol=rtol)
        row[f"warm_{rtol:g}_s"], (_, info) = _median_time(warm, repeats)
        row[f"warm_{rtol:g}_iterations"] = info.iterations
        row[f"warm_{rtol:g}_rebuilt"] = bool(info.rebuilt)
    rebuilt = built(K1)
    for rtol in (1e-4, 1e-6):
        row[f"rebuilt_{rtol:g}_s"], (_, info) = _median_time(lambda: rebuilt.solve(f1, x0=u0, rtol=rtol), repeats)
        row[f"rebuilt_{rtol:g}_iterations"] = info.iterations
    row["operator_complexity"] = float(rebuilt.operator_complexity())
    # the split (4.11): one u-solve from the sound solution at the damaged state
    el.split = "amor"
    model.linear_solver = built(K1)
    u_full = el.expand(u0, values)
    model.switches.clear()
    start = time.perf_counter()
    model.solve_u(alpha, 1.0, u_full, 1e-6)
    row["amor_s"] = time.perf_counter() - start
    row["amor_solves"] = len(model.switches)
    row["amor_switched"] = int(sum(model.switches))
    row["peak_gb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6
    return row


def run_case(spec, timeout):
    env = {**os.environ, **THREADS, "PYTHONPATH": str(ROOT)}
    code = ("import json, sys; from benchmarks.bench_fem3d import worker; "
            "print('ROW', json.dumps(worker(json.loads(sys.argv[1]))))")
    proc = subprocess.run([sys.executable, "-c", code, json.dumps(spec)], capture_output=True, text=True,
                          env=env, cwd=ROOT, timeout=timeout)
    for line in proc.stdout.splitlines():
        if line.startswith("ROW "):
            return json.loads(line[4:])
    raise RuntimeError(f"{spec['case']} {spec['label']} failed:\n{proc.stderr[-3000:]}")


def fit_power(dofs, seconds):
    """``(c, p)`` of ``seconds = c dofs^p`` (least squares in logs)."""
    p, logc = np.polyfit(np.log(dofs), np.log(seconds), 1)
    return math.exp(logc), p


def write_outputs(rows, command, total, check, out):
    out.mkdir(parents=True, exist_ok=True)
    keys = list(rows[0])
    with open(out / "fem3d.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    lines = [f"# The 3D u-solve against size (`{command}`)", "",
             f"{versions()}; one thread per library; machine before the run: {check}; total {total / 60:.1f} min.", "",
             "| case | size | tets | dofs | assembly [s] | AMG setup [s] | cold CG 1e-6 [s] (it) |"
             " warm, kept hierarchy, 1e-4 [s] (it) | 1e-6 [s] (it) | rebuilt 1e-4 [s] (it) | 1e-6 [s] (it) |"
             " amor u-solve [s] (solves) | peak [GB] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['size']} | {r['tets']:,} | {r['dofs']:,} | {r['assembly_s']:.3f} |"
                     f" {r['setup_s']:.2f} | {r['cold_s']:.2f} ({r['cold_iterations']}) |"
                     f" {r['warm_0.0001_s']:.2f} ({r['warm_0.0001_iterations']}) |"
                     f" {r['warm_1e-06_s']:.2f} ({r['warm_1e-06_iterations']}) |"
                     f" {r['rebuilt_0.0001_s']:.2f} ({r['rebuilt_0.0001_iterations']}) |"
                     f" {r['rebuilt_1e-06_s']:.2f} ({r['rebuilt_1e-06_iterations']}) |"
                     f" {r['amor_s']:.2f} ({r['amor_solves']}) | {r['peak_gb']:.2f} |")
    # per case: the cost of an iteration grows with the size differently for each geometry
    for case in dict.fromkeys(r["case"] for r in rows):
        case_rows = [r for r in rows if r["case"] == case]
        if len(case_rows) < 2:
            continue
        dofs = np.array([r["dofs"] for r in case_rows], dtype=float)
        per_iteration = np.array([r["assembly_s"] + r["warm_0.0001_s"] for r in case_rows])
        c, p = fit_power(dofs, per_iteration)
        tets_per_dof = float(np.median([r["tets"] / r["dofs"] for r in case_rows]))
        dofs_dissertation = DISSERTATION_TETS / tets_per_dof
        setup_c, setup_p = fit_power(dofs, np.array([r["setup_s"] for r in case_rows]))
        memory_c, memory_p = fit_power(dofs, np.array([r["peak_gb"] for r in case_rows]))
        lines += ["", f"**{case}**: assembly + warm CG (1e-4) per iteration {c:.3g} dofs^{p:.2f} s; AMG setup"
                  f" {setup_c:.3g} dofs^{setup_p:.2f} s; peak memory {memory_c:.3g} dofs^{memory_p:.2f} GB."
                  f" At the dissertation's {DISSERTATION_TETS:.3g} tetrahedra ({dofs_dissertation:,.0f} dofs at"
                  f" {tets_per_dof:.2f} tetrahedra per dof): {c * dofs_dissertation ** p:.1f} s per iteration,"
                  f" setup {setup_c * dofs_dissertation ** setup_p:.0f} s, memory"
                  f" {memory_c * dofs_dissertation ** memory_p:.1f} GB."]
        for iterations in (1000, 3000):
            budget = 3600.0 / iterations
            reach = (budget / c) ** (1.0 / p)
            lines.append(f"An evolution of {iterations} iterations in one hour: {budget:.1f} s per iteration,"
                         f" about {reach:,.0f} dofs ({reach * tets_per_dof:,.0f} tetrahedra).")
    (out / "fem3d.md").write_text("\n".join(lines) + "\n")
    return out / "fem3d.md"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--no-wait", action="store_true")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    check = machine_check()[1] if args.no_wait else wait_for_idle()[-1]
    started = time.perf_counter()
    rows = []
    for case, label, overrides in (QUICK if args.quick else SIZES):
        spec = {"case": case, "label": label, "overrides": overrides, "repeats": 1 if args.quick else args.repeats}
        rows.append(run_case(spec, timeout=3600))
        print(json.dumps(rows[-1]), flush=True)
    command = "python -m benchmarks.bench_fem3d" + (" --quick" if args.quick else "")
    path = write_outputs(rows, command, time.perf_counter() - started, check, args.out)
    print(path.read_text())


if __name__ == "__main__":
    main()
