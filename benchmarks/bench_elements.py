"""Per-iteration cost of the element-dependent parts of an alternate-minimization iteration,
the element abstraction (:mod:`fem3d.elements`) against the code before it.

The parts an iteration spends in the elasticity operator, apart from the sparse
factorization and solve: the assembly of ``K(alpha)`` (``elasticity.matrix``), the
right-hand side with the expansion to all dofs (``rhs`` + ``expand``), the nodal energy the
damage problem takes (``nodal_energy``) and the elastic energy (``elastic_energy``, twice per
iteration in the engine); the reactions (once per step) are listed apart. The scenes: the 2D
L-panel of ``cases/lpanel.toml`` at the size of ``benchmarks/bench_fem_lpanel.py`` (eps = 5
mm, h = 1.25 mm in the band, 12.5 mm elsewhere: 60,500 P1 dofs) and the 3D panel of
``cases/lpanel_3d.toml`` at h = 10 mm (40,000 P1 dofs), each with P1 and P2 displacements,
at a damaged state (a band of damage across the panel) and a random displacement.

Each case runs in two worker processes, one importing this tree and one an older tree (a
checkout given by ``--old``, first on ``sys.path``), both built once; the repeats alternate
between them (one round of every part in one, then in the other), one thread per library
(``OMP/MKL/OPENBLAS/NUMBA_NUM_THREADS = 1``). Each part is timed in CPU time of its process
(``time.process_time``: on one thread the wall time of a quiet machine, less disturbed by
other jobs). A cell is the minimum over the repeats; the ratio is new over old. For P1, the
new worker also times the generic kernel of :func:`fem3d.kernels.stiffness_values` on P1's
one-point rule, against the P1 fast path.

Usage (from the repository root; make the old tree first)::

    git worktree add /tmp/elements_base a70cdd5            # or: git archive a70cdd5 | tar -x -C ...
    python -m benchmarks.bench_elements --old /tmp/elements_base            # the scenes above, ~2 min
    python -m benchmarks.bench_elements --old /tmp/elements_base --quick --repeats 3 --out /tmp/el

Writes ``benchmarks/results/elements.md`` and ``.csv`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}
#: (name, case file, overrides): the scenes, and their quick sizes.
CASES = (("2D L-panel", "lpanel", {"model.eps": 5.0, "mesh.h": 1.25, "mesh.h_coarse": 12.5, "model.k_res": 1e-6}),
         ("3D L-panel", "lpanel_3d", {"model.eps": 20.0, "mesh.h": 10.0, "mesh.h_coarse": 40.0}))
QUICK = (("2D L-panel", "lpanel", {"model.eps": 10.0, "mesh.h": 5.0, "mesh.h_coarse": 25.0}),
         ("3D L-panel", "lpanel_3d", {"model.eps": 40.0, "mesh.h": 20.0, "mesh.h_coarse": 50.0}))
ELEMENTS = ("P1", "P2")
#: The parts timed: (key, label, times per iteration).
PARTS = (("assembly", "assembly of K(alpha)", 1), ("rhs", "right-hand side + expansion", 1),
         ("nodal_energy", "nodal energy", 1), ("energy", "elastic energy", 2))
EXTRA = (("reactions", "reactions (once per step)"), ("assembly_generic", "P1: generic kernel's assembly"))


# ------------------------------------------------------------------------------------------
# the worker: one tree, one case, rounds on demand
# ------------------------------------------------------------------------------------------


def worker(tree, case, overrides, element):
    """Build the case with the code of ``tree``, then answer each ``round`` line on stdin with
    one timing of every part (JSON, seconds) until ``quit``."""
    sys.path.insert(0, tree)
    import numpy as np

    import thinfilm.solvers.linear as linear
    from fem3d.kind import build_mesh, build_model
    from tests.helpers import load_case

    linear.make_solver = lambda *args, **kwargs: None   # no factorization: not timed here
    scene = load_case(case, dict(overrides, **{"model.element": element}))
    mesh = build_mesh(scene)
    model = build_model(scene, mesh)
    el, loads = model.elasticity, model.loads
    y = mesh.points[:, 1]
    alpha = np.exp(-((y - np.median(y)) / scene.model.eps) ** 2)   # a damage band across the panel
    u = np.random.default_rng(0).standard_normal(el.n_dofs) * 1e-3
    values, force = loads.values_at(0.5), loads.force_at(0.5)
    u_free = u[el.free]
    parts = {"assembly": lambda: el.matrix(alpha),
             "rhs": lambda: el.expand(el.rhs(alpha, values, force) + u_free, values),
             "nodal_energy": lambda: el.nodal_energy(u),
             "energy": lambda: el.elastic_energy(u, alpha),
             "reactions": lambda: el.reactions(alpha, u, force)}
    space = getattr(el, "space", None)
    if element == "P1" and space is not None and hasattr(space, "basis_gradients"):
        from fem3d import kernels

        data = np.empty(el.nnz)
        lam, mu = el.lame(alpha)

        def generic():
            lam_q, mu_q = el.lame(alpha)
            kernels.stiffness_values(space.basis_gradients, space.measure, space.weights, space.cells,
                                     lam_q[:, None], mu_q[:, None], el.thickness, el._free_index, el._indptr,
                                     el._offsets, data)

        parts["assembly_generic"] = generic
    for f in parts.values():   # compile and warm up
        f()
    print(json.dumps({"dofs": int(el.n_dofs), "nodes": mesh.n_nodes, "cells": mesh.n_cells, "nnz": int(el.nnz)}),
          flush=True)
    for line in sys.stdin:
        if line.strip() != "round":
            break
        out = {}
        for key, f in parts.items():
            start = time.process_time()
            f()
            out[key] = time.process_time() - start
        print(json.dumps(out), flush=True)


class Worker:
    def __init__(self, tree, case, overrides, element):
        env = dict(os.environ, **THREADS)
        env.pop("PYTHONPATH", None)
        self.process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker", json.dumps([tree, case, overrides, element])],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=tree)
        self.info = self._read()

    def _read(self):
        line = self.process.stdout.readline()
        if not line:
            raise RuntimeError(f"worker failed (exit {self.process.wait()})")
        return json.loads(line)

    def round(self):
        self.process.stdin.write("round\n")
        self.process.stdin.flush()
        return self._read()

    def close(self):
        self.process.stdin.write("quit\n")
        self.process.stdin.close()
        self.process.wait()


# ------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------


def measure(old_tree, cases, repeats):
    rows = []
    for name, case, overrides in cases:
        for element in ELEMENTS:
            print(f"{name} {element}: building", flush=True)
            old, new = Worker(old_tree, case, overrides, element), Worker(str(ROOT), case, overrides, element)
            times = {"old": [], "new": []}
            for _ in range(repeats):
                times["old"].append(old.round())
                times["new"].append(new.round())
            old.close()
            new.close()
            best = {side: {key: min(r[key] for r in runs) for key in runs[0]} for side, runs in times.items()}
            row = dict(case=name, element=element, dofs=new.info["dofs"], cells=new.info["cells"],
                       nnz=new.info["nnz"], old_nnz=old.info["nnz"])
            for key, _, _ in PARTS:
                row[f"{key}_old"], row[f"{key}_new"] = best["old"][key], best["new"][key]
            row["iteration_old"] = sum(n * best["old"][key] for key, _, n in PARTS)
            row["iteration_new"] = sum(n * best["new"][key] for key, _, n in PARTS)
            row["reactions_old"], row["reactions_new"] = best["old"]["reactions"], best["new"]["reactions"]
            row["assembly_generic"] = best["new"].get("assembly_generic", float("nan"))
            rows.append(row)
            print(f"  iteration new/old {row['iteration_new'] / row['iteration_old']:.3f}", flush=True)
    return rows


def write(rows, out, header):
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "elements.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# Element-dependent parts of an iteration, new against old (`python -m benchmarks.bench_elements`)",
             "", header, "",
             "| case | element | dofs | part | old [ms] | new [ms] | new/old |", "|---|---|---|---|---|---|---|"]
    labels = [(key, label + (" (x2)" if n == 2 else "")) for key, label, n in PARTS]
    labels += [("iteration", "**sum per iteration**"), ("reactions", EXTRA[0][1])]
    for r in rows:
        for key, label in labels:
            o, n = r[f"{key}_old"], r[f"{key}_new"]
            lines.append(f"| {r['case']} | {r['element']} | {r['dofs']:,} | {label} | {1e3 * o:.2f} | {1e3 * n:.2f}"
                         f" | {n / o:.3f} |")
        if r["element"] == "P1":
            g = r["assembly_generic"]
            lines.append(f"| {r['case']} | P1 | {r['dofs']:,} | {EXTRA[1][1]} (against the fast path) | "
                         f"{1e3 * r['assembly_new']:.2f} | {1e3 * g:.2f} | {g / r['assembly_new']:.3f} |")
    (out / "elements.md").write_text("\n".join(lines) + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--old", help="the older tree (a checkout of the code before the element abstraction)")
    parser.add_argument("--old-label", help="how the results name the older tree (default: its git commit)")
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--quick", action="store_true", help="coarse meshes")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(*json.loads(args.worker))
        return
    if not args.old:
        parser.error("--old is required")
    label = args.old_label
    if label is None:
        done = subprocess.run(["git", "-C", args.old, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        label = done.stdout.strip() if done.returncode == 0 else Path(args.old).name
    start = time.time()
    rows = measure(str(Path(args.old).resolve()), QUICK if args.quick else CASES, args.repeats)
    load = os.getloadavg()[0]
    header = (f"{platform.processor() or platform.machine()}, python {platform.python_version()}; one thread per"
              f" library; CPU time, {args.repeats} interleaved repeats, the minimum; load average {load:.2f} at the end"
              f" (other jobs on the machine inflate both sides alike); {'quick sizes; ' if args.quick else ''}"
              f"old code {label}; {(time.time() - start) / 60:.1f} min.")
    write(rows, args.out, header)
    print((args.out / "elements.md").read_text())


if __name__ == "__main__":
    main()
