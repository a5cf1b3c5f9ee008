"""The u-solve restricted to D4-symmetric fields against the unrestricted one, at the
full-resolution indentation scene's geometry.

For each grid of m x m nodes on (-0.5, 0.5)^2 (the scene of ``cases/indentation_full.toml``,
without grid sequencing) and each ``[domain] symmetry`` in ("none", "d4"), a fresh
subprocess (so that ``ru_maxrss`` is that case's peak alone) builds the plate model
(``setup_s``: the model, the first matrix and the solver's analysis of its pattern), takes
the damage of the main job's run at t = 0.7 (three rings linked by radial cracks,
interpolated to the grid and averaged over the D4 orbits so that both cases solve the same
problem) and times ``solve_u`` three times (``u_solve_s``: the median; each one assembles
K(alpha), restricts it for "d4", refactorizes and solves, as every alternate-minimization
iteration does). ``ratio`` is the unrestricted time over the restricted one, measured in the
same invocation; ``error`` the largest difference of the two u over max |u|, and
``energy_error`` the relative difference of the total energies.

Usage (run the main job first: ``python -m thinfilm run cases/indentation.toml``)::

    python -m benchmarks.bench_symmetry                     # 400 800 1500, about 6 minutes
    python -m benchmarks.bench_symmetry --sizes 400 800

Writes ``benchmarks/results/symmetry.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import multiprocessing
import os
import platform
import resource
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
COARSE = ROOT / "cases" / "indentation" / "results.h5"
T_LOAD = 0.7
FIELDS = ["nodes", "symmetry", "unknowns", "setup_s", "u_solve_s", "ratio", "error", "energy_error", "peak_gb"]


def scene_text(nodes, symmetry):
    """``cases/indentation_full.toml`` on ``nodes`` x ``nodes`` nodes, no sequencing."""
    text = (ROOT / "cases" / "indentation_full.toml").read_text()
    for line in ("cells = [1499, 1499]", 'coarse = "indentation/results.h5"'):
        if line not in text:  # the table would describe a scene it did not run
            raise SystemExit(f"cases/indentation_full.toml has no line {line!r}; update bench_symmetry.py")
    text = text.replace('coarse = "indentation/results.h5"', "")
    return text.replace("cells = [1499, 1499]", f'cells = [{nodes - 1}, {nodes - 1}]\nsymmetry = "{symmetry}"')


def case(nodes, symmetry, out):
    """One subprocess: set up, solve three times, save u; returns the row (without ratios)."""
    from thinfilm.plate.kind import build_grid, make_model
    from thinfilm.scene import parse_scene
    from thinfilm.plate.sequencing import CoarseDamage
    from thinfilm.plate.symmetry import GridSymmetry

    scene = parse_scene(scene_text(nodes, symmetry))
    grid = build_grid(scene.domain)
    tic = time.perf_counter()
    model = make_model(scene, grid)
    model.linear_solver.update(model.reduced_matrix(np.zeros(grid.n_nodes)))
    setup = time.perf_counter() - tic
    alpha = GridSymmetry(grid, "d4").average(CoarseDamage(COARSE, grid)(T_LOAD))
    times = []
    for _ in range(3):
        tic = time.perf_counter()
        u = model.solve_u(alpha, T_LOAD, None, 1e-10)
        times.append(time.perf_counter() - tic)
    np.save(out, u)
    energy = sum(model.energies(u, alpha, T_LOAD))
    unknowns = grid.n_nodes if model.symmetry is None else model.symmetry.n_orbits
    return dict(nodes=f"{nodes}^2", symmetry=symmetry, unknowns=unknowns, setup_s=round(setup, 2),
                u_solve_s=round(float(np.median(times)), 3), energy=energy,
                peak_gb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 / 1e9, 2))  # KiB


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[400, 800, 1500], help="nodes per side")
    args = parser.parse_args(argv)
    if not COARSE.exists():
        sys.exit(f"{COARSE} is missing: run `python -m thinfilm run cases/indentation.toml` first")
    context = multiprocessing.get_context("spawn")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for nodes in args.sizes:
            pair = {}
            for symmetry in ("none", "d4"):
                out = os.path.join(tmp, f"u_{nodes}_{symmetry}.npy")
                with context.Pool(1) as pool:
                    pair[symmetry] = pool.apply(case, (nodes, symmetry, out))
                pair[symmetry]["u"] = np.load(out)
                print(pair[symmetry]["nodes"], symmetry, pair[symmetry]["u_solve_s"], "s", flush=True)
            full, reduced = pair["none"], pair["d4"]
            scale = float(np.max(np.abs(full["u"])))
            error = float(np.max(np.abs(reduced["u"] - full["u"]))) / scale
            energy_error = abs(reduced["energy"] - full["energy"]) / abs(full["energy"])
            for row in (full, reduced):
                row["ratio"] = round(full["u_solve_s"] / row["u_solve_s"], 2)
                row["error"] = f"{error:.1e}" if row is reduced else "-"
                row["energy_error"] = f"{energy_error:.1e}" if row is reduced else "-"
                rows.append({k: row[k] for k in FIELDS})
    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "symmetry.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# u-solve restricted to D4-symmetric fields (indentation, t = 0.7 damage)",
        "",
        f"`python -m benchmarks.bench_symmetry --sizes {' '.join(map(str, args.sizes))}`;"
        f" {platform.machine()}, {os.cpu_count()} cores. ratio: unrestricted u-solve time / this one;"
        " error: max |u_d4 - u| / max |u|.",
        "",
        "| " + " | ".join(FIELDS) + " |",
        "|" + "---|" * len(FIELDS),
    ]
    lines += ["| " + " | ".join(str(row[k]) for k in FIELDS) + " |" for row in rows]
    (RESULTS / "symmetry.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
