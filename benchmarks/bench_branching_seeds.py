"""Crosses against three-armed stars under the small indenter: the energy of each pattern
at one load, from seeded damage, on the dissertation's Fig. 2.14 scenes.

The evolutions of ``cases/indentation_branching_*.toml`` end as crosses along the grid axes
where the dissertation shows cracks meeting at 120 degrees. Two causes are possible: the
grid (which favours axis-aligned cracks, ``bench_crack_orientation.py``) or the model
(the cross is the lower state). This study separates them. For each scene it seeds four
patterns of straight arms of one length from the centre, each arm the optimal AT1 profile of
the distance to a segment:

- ``cross 0``: four arms along the axes (what the evolutions end with);
- ``cross 45``: the same cross turned by 45 degrees (same continuum energy: the difference
  to ``cross 0`` is the grid's bias for this pattern);
- ``star 0``: three arms at 120 degrees, one along +x;
- ``star 15``: the star turned by 15 degrees (every other star is one of these two up to the
  grid's symmetries, which repeat stars every 30 degrees).

and runs alternate minimization at the load ``t`` from each seed with no irreversibility
bound (``Engine.run`` with the seed as the step's starting guess, the scene's own solver
options), so that arms may grow, shrink or turn. It reports each final state's energies,
iterations and time, and the final damage fields in a figure.

Usage (the defaults are the three Fig. 2.14 cases at the dissertation's eta = 0.0033 = 5 dx,
360 x 360 cells on (-0.12, 0.12)^2, unrestricted, at their last loads; about 18 minutes, most of it in the G/a = 2.0 stars)::

    python benchmarks/bench_branching_seeds.py
    python benchmarks/bench_branching_seeds.py --cells 720 --cases G07     # eta = 10 dx

Writes ``benchmarks/results/branching_seeds.md``, ``.csv`` and ``.png``.
"""

from __future__ import annotations

import argparse
import csv
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # run from a checkout

from thinfilm.evolution import EvolutionError  # noqa: E402
from thinfilm.model import crack_profile  # noqa: E402
from thinfilm.run import build_grid, make_engine, make_model  # noqa: E402
from thinfilm.scene import parse_scene  # noqa: E402

ETA = 0.0033333333333333335  # the dissertation's eta = 5 dx at 1500 nodes on (-0.5, 0.5)
HALF_WIDTH = 0.12
# case: toughness G/a, load t (the figure's), arm length (alpha > 0.5 of the D4 evolutions)
CASES = {"G07": (0.7, 0.075, 0.027), "G15": (1.5, 0.1, 0.025), "G20": (2.0, 0.17, 0.036)}
SEEDS = {"cross 0": (0, 90, 180, 270), "cross 45": (45, 135, 225, 315),
         "star 0": (0, 120, 240), "star 15": (15, 135, 255)}

SCENE = """
[model]
kind = "plate"
at = 1
nu = 0.3
winkler = 6.4e7
toughness = {toughness}
eta = {eta}
k_res = 1e-6

[domain]
x = [-{half}, {half}]
y = [-{half}, {half}]
cells = [{cells}, {cells}]

[load]
kind = "indenter"
radius = 0.1
t_max = {t}
steps = 2  # only t_max is computed here

[solver]
acceleration = "overrelax"
max_iter = {max_iter}
"""


def seed_damage(grid, eta, angles_deg, length):
    """AT1 profile of the distance to straight arms of ``length`` from the origin, shape
    ``(n_nodes,)``."""
    x, y = (c.ravel() for c in grid.coordinates)
    distance = np.full(x.size, np.inf)
    for angle in np.radians(angles_deg):
        ex, ey = np.cos(angle), np.sin(angle)
        s = np.clip(x * ex + y * ey, 0.0, length)  # foot of the perpendicular on the arm
        distance = np.minimum(distance, np.hypot(x - s * ex, y - s * ey))
    return crack_profile(distance, eta, 1)


def run_case(name, cells, max_iter):
    toughness, t, length = CASES[name]
    scene = parse_scene(SCENE.format(toughness=toughness, eta=ETA, half=HALF_WIDTH, cells=cells, t=t,
                                     max_iter=max_iter), source=f"<{name}>")
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)  # one model (and solver analysis) for every seed
    rows, fields = [], {}
    for seed_name, angles in SEEDS.items():
        engine = make_engine(scene, model)
        seed = seed_damage(grid, ETA, angles, length)
        start = time.perf_counter()
        try:
            records, states = engine.run([t], guess=lambda _t: seed)
        except EvolutionError as err:  # a pattern still moving after max_iter: say so, go on
            print(f"{name} {seed_name:9s} {err}", flush=True)
            rows.append({"case": name, "toughness": toughness, "t": t, "cells": cells, "seed": seed_name,
                         "total": np.nan, "elastic": np.nan, "surface": np.nan, "iterations": -max_iter,
                         "seconds": time.perf_counter() - start})
            fields[seed_name] = np.zeros((grid.ny + 1, grid.nx + 1))
            continue
        seconds = time.perf_counter() - start
        state = states[-1]
        fields[seed_name] = state.alpha.reshape(grid.ny + 1, grid.nx + 1)
        rows.append({"case": name, "toughness": toughness, "t": t, "cells": cells, "seed": seed_name,
                     "total": state.total, "elastic": state.elastic, "surface": state.surface,
                     "iterations": records[-1].iterations, "seconds": seconds})
        print(f"{name} {seed_name:9s} total {state.total:.6f} its {records[-1].iterations} {seconds:.0f} s",
              flush=True)
    return rows, fields


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--cells", type=int, default=360, help="cells per side of (-0.12, 0.12)^2")
    parser.add_argument("--max-iter", type=int, default=600,
                        help="alternate-minimization iterations allowed (a pattern still moving is reported)")
    parser.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results")
    args = parser.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    fig, axes = plt.subplots(len(args.cases), len(SEEDS), figsize=(3 * len(SEEDS), 3 * len(args.cases)),
                             squeeze=False)
    for axes_row, name in zip(axes, args.cases):
        case_rows, fields = run_case(name, args.cells, args.max_iter)
        rows += case_rows
        reference = case_rows[0]["total"]
        for ax, row in zip(axes_row, case_rows):
            ax.imshow(fields[row["seed"]], origin="lower", extent=[-HALF_WIDTH, HALF_WIDTH] * 2,
                      cmap="magma_r", vmin=0, vmax=1)
            ax.set_xlim(-0.06, 0.06)
            ax.set_ylim(-0.06, 0.06)
            ax.set_title(f"{name} {row['seed']}: {row['total'] - reference:+.4f}", fontsize=9)
    args.out.mkdir(parents=True, exist_ok=True)
    fig.suptitle(f"final damage from each seed, {args.cells}^2 cells; total energy against cross 0", fontsize=10)
    fig.tight_layout()
    fig.savefig(args.out / "branching_seeds.png", dpi=80)

    with open(args.out / "branching_seeds.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Crosses against three-armed stars under the small indenter (seeded, one load)",
        "",
        f"`python benchmarks/bench_branching_seeds.py --cells {args.cells} --cases {' '.join(args.cases)}` "
        f"({platform.machine()}, Python {platform.python_version()}). eta = {ETA:.4g} = "
        f"{ETA / (2 * HALF_WIDTH / args.cells):.3g} dx, winkler = 6.4e7, R = 0.1, unrestricted. "
        "Energies of the final states; `- cross 0` is the total energy minus that of the axis cross; "
        f"iterations -{args.max_iter}: still moving after {args.max_iter} iterations (not a minimizer).",
        "",
        "| case | G/a | t | seed | total | elastic | surface | - cross 0 | iterations | time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        reference = next(r["total"] for r in rows if r["case"] == row["case"] and r["seed"] == "cross 0")
        lines.append(f"| {row['case']} | {row['toughness']} | {row['t']} | {row['seed']} | {row['total']:.6f} | "
                     f"{row['elastic']:.6f} | {row['surface']:.6f} | {row['total'] - reference:+.6f} | "
                     f"{row['iterations']} | {row['seconds']:.0f} |")
    (args.out / "branching_seeds.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
