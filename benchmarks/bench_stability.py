"""Speed against error of the stability check's eigensolver: LOBPCG preconditioned by the
damage part of the Hessian (:func:`thinfilm.plate.stability.lowest_modes`) against ARPACK's
Lanczos iteration on the same operator.

The states are those of the small indenter's perfect film (G/a = 1.5, eta = 5 dx, 360 x 360
cells, the D4-restricted evolution of :mod:`studies.branching.saddles`) at t = 0.06 and 0.065,
where the disk of damage is a saddle. For each, the four lowest curvatures of the reduced
energy are computed by

- a reference: LOBPCG to residual 1e-6 (at most 400 iterations);
- LOBPCG to 1e-4 (the check's setting);
- ``scipy.sparse.linalg.eigsh`` (Lanczos, ``which="SA"``) to relative tolerances 1e-4 and 1e-2,

and the table lists Hessian products (one u-solve each), seconds and the largest error of
the four eigenvalues against the reference, in units of G/(a eta).

The scene is ``cases/indentation_branching_G15.toml`` on the grid of
:data:`studies.branching.scenes.FINE`, as :func:`studies.branching.imperfect.scene` builds it.

Usage (from the repository root)::

    python -m benchmarks.bench_stability      # about 5 minutes

Writes ``benchmarks/results/stability.md`` and ``.csv`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path

import numpy as np
import scipy.sparse.linalg as spla

from studies.branching.imperfect import scene as branching_scene
from studies.branching.scenes import FINE
from thinfilm.engine import Engine
from thinfilm.plate import stability
from thinfilm.plate.kind import build_grid, make_model

RESULTS = Path(__file__).resolve().parent / "results"

CASE, LOADS, K = "G15", (0.06, 0.065), 4


def lanczos(plate, damage, alpha, w, lower, tol):
    """The ``K`` lowest eigenvalues by ARPACK on the operator of :func:`stability.lowest_modes`;
    returns ``(eigenvalues, products)``."""
    problem = stability.reduced_problem(plate, damage, alpha, w, lower)
    m = len(problem.free)
    values = spla.eigsh(problem.operator, k=K, which="SA", tol=tol, v0=np.ones(m), maxiter=100 * m,
                        return_eigenvectors=False)
    return np.sort(values), problem.solves


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    scene = branching_scene(CASE, 0.0, 0, FINE)
    grid = build_grid(scene.domain)
    t_values = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    _, states = Engine.from_options(make_model(scene, grid), scene.solver).run(t_values)
    free_scene = branching_scene(CASE, 0.0, 0, FINE, restricted=False)
    model = make_model(free_scene, grid)
    unit = model.damage.toughness / model.eta
    rows = []
    for t in LOADS:
        k = int(np.argmin(np.abs(t_values - t)))
        alpha, lower, w = states[k].alpha, states[k - 1].alpha, model.load(t_values[k])
        runs = {}
        for label, call in [
            ("LOBPCG, tol 1e-6 (reference)", lambda: stability.lowest_modes(model.plate, model.damage, alpha, w, lower,
                                                                            k=K, tol=1e-6, maxiter=400)),
            ("LOBPCG, tol 1e-4 (the check)", lambda: stability.lowest_modes(model.plate, model.damage, alpha, w, lower,
                                                                            k=K, tol=1e-4)),
            ("Lanczos, tol 1e-4", lambda: lanczos(model.plate, model.damage, alpha, w, lower, 1e-4)),
            ("Lanczos, tol 1e-2", lambda: lanczos(model.plate, model.damage, alpha, w, lower, 1e-2)),
        ]:
            start = time.perf_counter()
            result = call()
            seconds = time.perf_counter() - start
            values, products = ((result.eigenvalues, result.products) if isinstance(result, stability.Modes)
                                else result)
            runs[label] = (values / unit, products, seconds)
        reference = runs["LOBPCG, tol 1e-6 (reference)"][0]
        for label, (values, products, seconds) in runs.items():
            rows.append({"t": float(t_values[k]), "solver": label, "products": products, "seconds": seconds,
                         "eigenvalues": " ".join(f"{v:+.4f}" for v in values),
                         "error": float(np.max(np.abs(values - reference)))})
            print(f"t = {t_values[k]:g} {label}: {rows[-1]['eigenvalues']} ({products} products, {seconds:.1f} s,"
                  f" error {rows[-1]['error']:.1e})", flush=True)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "stability.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# The stability check's eigensolver: speed against error",
        "",
        f"`python -m benchmarks.bench_stability` ({platform.machine()}, Python {platform.python_version()}). "
        f"Small indenter, G/a = 1.5, eta = 5 dx, 360^2 cells, the symmetric states at t = {LOADS[0]} and {LOADS[1]}; "
        f"the {K} lowest curvatures of the reduced energy (units of G/(a eta)); error: the largest difference from "
        "the reference's.",
        "",
        "| t | solver | eigenvalues | products (u-solves) | time (s) | error |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(f"| {r['t']:g} | {r['solver']} | {r['eigenvalues']} | {r['products']} | {r['seconds']:.1f} | "
                     f"{r['error']:.1e} |")
    (out / "stability.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
