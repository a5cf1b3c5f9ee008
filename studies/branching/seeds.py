"""Crosses, three-armed stars, double branches and rings under the small indenter: the
energy of each pattern at one load, from seeded damage, on the dissertation's Fig. 2.14 scenes.

The evolutions of ``cases/indentation_branching_*.toml`` end as crosses along the grid axes
where the dissertation shows cracks meeting at 120 degrees. Two causes are possible: the
grid (which favours axis-aligned cracks, :mod:`studies.branching.orientation`) or the model
(the cross is the lower state). This study separates them. For each scene it seeds four
patterns of straight arms of one length from the centre, each arm the optimal AT1 profile of
the distance to a segment:

- ``cross 0``: four arms along the axes (what the evolutions end with);
- ``cross 45``: the same cross turned by 45 degrees (same continuum energy: the difference
  to ``cross 0`` is the grid's bias for this pattern);
- ``star 0``: three arms at 120 degrees, one along +x;
- ``star 15``: the star turned by 15 degrees (every other star is one of these two up to the
  grid's symmetries, which repeat stars every 30 degrees).

and, on request (``--seeds``), patterns with two branch points or a ring crack:

- ``double Y c``: a segment of length ``2 c eta`` along x through the centre, each of whose
  ends branches into two arms at 120 degrees (c = 1.5, 3, 6): Fig. 2.14's "two close branch
  points" and "distant branch points";
- ``ring``, ``cross 0 + ring``, ``star 0 + ring``: a ring crack of 0.9 times the contact
  radius at the load, alone or around a cross or a star;

and runs alternate minimization at the load ``t`` from each seed with no irreversibility
bound (``Engine.run`` with the seed as the step's starting guess, the scene's own solver
options), so that arms may grow, shrink or turn. It reports each final state's energies,
branch points (number and spacing), iterations and time, and the final damage fields in a
figure.

The scenes are the case files ``cases/indentation_branching_G07.toml``, ``_G15`` and ``_G20``
(toughness, indenter, load ``t`` = their ``t_max``, solver) with the grid of
:func:`studies.branching.scenes.grid_overrides` and ``max_iter`` set over them.

Usage (from the repository root; the defaults are the three Fig. 2.14 cases at the
dissertation's eta = 0.0033 = 5 dx, 360 x 360 cells on (-0.12, 0.12)^2, unrestricted, at their
last loads; about 18 minutes, most of it in the G/a = 2.0 stars)::

    python -m studies.branching.seeds
    python -m studies.branching.seeds --cells 720 --cases G07     # eta = 10 dx
    python -m studies.branching.seeds --seeds 'star 0' 'double Y 1.5' 'double Y 3' \
        'double Y 6' --stem branching_seeds_double_y                  # 35 minutes
    python -m studies.branching.seeds --cases G07 --seeds ring 'cross 0 + ring' \
        'star 0 + ring' --stem branching_seeds_ring_G07              # 5 minutes

Writes ``studies/branching/results/branching_seeds.md``, ``.csv`` and ``.png`` (``--stem``
names them), and with ``--save-alpha`` the final damage fields in ``_alpha.npz`` (not kept
under version control). :mod:`studies.branching.extrapolation` takes the ``.csv`` files of
several grids (``--cells``) and extrapolates each seed's energy against the cross to ``h = 0``.
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path

import numpy as np

from studies.branching.scenes import ETA, HALF_WIDTH, RESULTS, grid_overrides, load_case
from thinfilm.engine import Engine, EvolutionError
from thinfilm.plate.cracks import branch_points, branch_spacing
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.loads import contact_radius
from thinfilm.plate.model import crack_profile

# case: arm length of the seeds (alpha > 0.5 of the D4 evolutions); the toughness G/a and the
# load t (the figure's) are the case file's toughness and t_max
CASES = {"G07": 0.027, "G15": 0.025, "G20": 0.036}
# Seeds made of arms from the centre: the arms' directions in degrees.
SEEDS = {"cross 0": (0, 90, 180, 270), "cross 45": (45, 135, 225, 315),
         "star 0": (0, 120, 240), "star 15": (15, 135, 255)}
# Seeds of two branch points: a segment along x from (-c, 0) to (c, 0) whose ends each branch
# into two arms at 120 degrees to it and to each other (an "H" with bent legs), by c / eta.
DOUBLE_Y = {"double Y 1.5": 1.5, "double Y 3": 3.0, "double Y 6": 6.0}
# Seeds with a ring crack of 0.9 times the contact radius at the load: the pattern inside it.
RINGED = {"ring": (), "cross 0 + ring": SEEDS["cross 0"], "star 0 + ring": SEEDS["star 0"]}



def case_scene(name, cells, max_iter):
    """The scene of case ``name`` (its case file) on ``cells`` x ``cells`` cells of
    (-0.12, 0.12)^2 at eta = 0.0033, allowing ``max_iter`` iterations; only its ``t_max`` is
    computed here."""
    return load_case(name, {**grid_overrides(cells), "load.steps": 2, "solver.max_iter": max_iter})


def segments(seed_name, eta, length):
    """The straight segments of a seeded pattern, as ``((x0, y0), (x1, y1))`` pairs.

    A star or cross (:data:`SEEDS`, and the pattern inside a ring of :data:`RINGED`, whose
    ring :func:`seed_damage` adds) has arms of ``length`` from the origin; a double Y
    (:data:`DOUBLE_Y`) has its central segment of length ``2 c`` along x and four arms of
    ``length`` from its ends, at 60 degrees to the x axis.
    """
    arms = {**SEEDS, **RINGED}
    if seed_name in arms:
        directions = np.radians(arms[seed_name])
        return [((0.0, 0.0), (length * np.cos(a), length * np.sin(a))) for a in directions]
    c = DOUBLE_Y[seed_name] * eta
    pieces = [((-c, 0.0), (c, 0.0))]
    for end, directions in ((c, (60.0, -60.0)), (-c, (120.0, 240.0))):
        for a in np.radians(directions):
            pieces.append(((end, 0.0), (end + length * np.cos(a), length * np.sin(a))))
    return pieces


def seed_damage(grid, eta, pieces, ring_radius=None):
    """AT1 profile of the distance to the segments ``pieces`` (from :func:`segments`) and to
    the circle of ``ring_radius`` about the origin if one is given, shape ``(n_nodes,)``."""
    x, y = (c.ravel() for c in grid.coordinates)
    distance = np.full(x.size, np.inf)
    if ring_radius is not None:
        distance = np.abs(np.hypot(x, y) - ring_radius)
    for (x0, y0), (x1, y1) in pieces:
        ex, ey = x1 - x0, y1 - y0
        # foot of the perpendicular on the segment, as a fraction of its length
        s = np.clip(((x - x0) * ex + (y - y0) * ey) / (ex * ex + ey * ey), 0.0, 1.0)
        distance = np.minimum(distance, np.hypot(x - x0 - s * ex, y - y0 - s * ey))
    return crack_profile(distance, eta, 1)


def junctions(alpha, grid):
    """Branch points of a final damage field (:func:`thinfilm.plate.cracks.branch_points`, circles of
    1.5 eta, as :mod:`studies.branching.imperfect` reads them): their number and largest distance
    apart in units of eta (0 for fewer than two)."""
    points = branch_points(alpha, grid.x, grid.y, 1.5 * ETA)
    return len(points), branch_spacing(points) / ETA


def run_case(name, cells, max_iter, seed_names):
    scene = case_scene(name, cells, max_iter)
    toughness, t, length = scene.model.toughness, scene.load.t_max, CASES[name]
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)  # one model (and solver analysis) for every seed
    rows, fields = [], {}
    for seed_name in seed_names:
        engine = Engine.from_options(model, scene.solver)
        ring_radius = 0.9 * contact_radius(scene.load.radius, t) if seed_name in RINGED else None
        seed = seed_damage(grid, ETA, segments(seed_name, ETA, length), ring_radius)
        start = time.perf_counter()
        try:
            records, states = engine.run([t], guess=lambda _t: seed)
        except EvolutionError as err:  # a pattern still moving after max_iter: say so, go on
            print(f"{name} {seed_name:9s} {err}", flush=True)
            rows.append({"case": name, "toughness": toughness, "t": t, "cells": cells, "seed": seed_name,
                         "total": np.nan, "elastic": np.nan, "surface": np.nan, "iterations": -max_iter,
                         "seconds": time.perf_counter() - start, "branch_points": -1, "spacing": np.nan})
            fields[seed_name] = np.zeros((grid.ny + 1, grid.nx + 1))
            continue
        seconds = time.perf_counter() - start
        state = states[-1]
        fields[seed_name] = state.alpha.reshape(grid.ny + 1, grid.nx + 1)
        count, spacing = junctions(fields[seed_name], grid)
        rows.append({"case": name, "toughness": toughness, "t": t, "cells": cells, "seed": seed_name,
                     "total": state.total, "elastic": state.elastic, "surface": state.surface,
                     "iterations": records[-1].iterations, "seconds": seconds,
                     "branch_points": count, "spacing": spacing})
        print(f"{name} {seed_name:9s} total {state.total:.6f} its {records[-1].iterations} {seconds:.0f} s",
              flush=True)
    return rows, fields


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--cells", type=int, default=360, help="cells per side of (-0.12, 0.12)^2")
    parser.add_argument("--max-iter", type=int, default=600,
                        help="alternate-minimization iterations allowed (a pattern still moving is reported)")
    parser.add_argument("--seeds", nargs="+", default=list(SEEDS), choices=list(SEEDS) + list(DOUBLE_Y) + list(RINGED),
                        help="patterns to seed (cross 0, the reference, is always run first)")
    parser.add_argument("--stem", default="branching_seeds", help="name of the result files")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--save-alpha", action="store_true",
                        help="also write every final damage field to <stem>_alpha.npz (key 'CASE SEED')")
    args = parser.parse_args(argv)
    seed_names = ["cross 0"] + [name for name in args.seeds if name != "cross 0"]

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows, all_fields = [], {}
    fig, axes = plt.subplots(len(args.cases), len(seed_names), figsize=(3 * len(seed_names), 3 * len(args.cases)),
                             squeeze=False)
    for axes_row, name in zip(axes, args.cases):
        case_rows, fields = run_case(name, args.cells, args.max_iter, seed_names)
        rows += case_rows
        all_fields.update({f"{name} {seed}": field for seed, field in fields.items()})
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
    fig.savefig(args.out / f"{args.stem}.png", dpi=80)

    if args.save_alpha:  # nodal damage, shape (cells + 1, cells + 1), y first
        np.savez_compressed(args.out / f"{args.stem}_alpha.npz", **all_fields)
    with open(args.out / f"{args.stem}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    # the options that differ from the defaults, so that the file names the command that made it
    options = ""
    if seed_names != list(SEEDS):
        options += " --seeds " + " ".join(f"'{name}'" for name in seed_names)
    if args.stem != parser.get_default("stem"):
        options += f" --stem {args.stem}"
    if args.max_iter != parser.get_default("max_iter"):
        options += f" --max-iter {args.max_iter}"
    if args.save_alpha:
        options += " --save-alpha"
    lines = [
        "# Seeded crack patterns under the small indenter (one load, no irreversibility)",
        "",
        f"`python -m studies.branching.seeds --cells {args.cells} --cases {' '.join(args.cases)}"
        f"{options}` "
        f"({platform.machine()}, Python {platform.python_version()}). eta = {ETA:.4g} = "
        f"{ETA / (2 * HALF_WIDTH / args.cells):.3g} dx, winkler = 6.4e7, R = 0.1, unrestricted. "
        "Energies of the final states; `- cross 0` is the total energy minus that of the axis cross; "
        f"iterations -{args.max_iter}: still moving after {args.max_iter} iterations (not a minimizer). "
        "Branch points: clusters of broken nodes about which three or more cracks cut a circle of radius "
        "1.5 eta (`thinfilm.plate.cracks.branch_points`; closer than about 2-3 eta they read as one); spacing: "
        "the largest distance between two of them, in eta.",
        "",
        "| case | G/a | t | seed | total | elastic | surface | - cross 0 | branch points | spacing / eta "
        "| iterations | time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        reference = next(r["total"] for r in rows if r["case"] == row["case"] and r["seed"] == "cross 0")
        # an unsettled seed has no final state to read branch points from
        junction_cells = (f"{row['branch_points']} | {row['spacing']:.2f}" if row["branch_points"] >= 0
                          else "- | -")
        lines.append(f"| {row['case']} | {row['toughness']} | {row['t']} | {row['seed']} | {row['total']:.6f} | "
                     f"{row['elastic']:.6f} | {row['surface']:.6f} | {row['total'] - reference:+.6f} | "
                     f"{junction_cells} | "
                     f"{row['iterations']} | {row['seconds']:.0f} |")
    (args.out / f"{args.stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
