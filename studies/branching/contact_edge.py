"""Where and when the intact film under the small indenter reaches AT1's elastic limit: at
the centre of the contact, and at its edge, where a ring crack would start.

An AT1 film stays undamaged at a node as long as its undamaged bending energy density ``e``
(:meth:`thinfilm.plate.model.PlateModel.elastic_density`; the bending energy is ``1/2 g(alpha) e``)
is below the elastic limit ``e_c = (G/a) / (4 c_1 eta) = 3 (G/a) / (8 eta)``: below it the
derivative of the energy in ``alpha`` at ``alpha = 0``, ``-e + e_c``, is positive. Damage
therefore nucleates where ``e`` first reaches ``e_c``, and a smaller ``eta`` delays it.

Under the indenter the intact film's ``e`` along a radius has its largest value at the
centre of the contact and a second maximum near the contact edge ``r_c``. For each
Fig. 2.14 case this study solves the intact film at loads ``t = 0.005, 0.01, ...`` (360 x 360
cells on (-0.12, 0.12)^2; the density of the intact film does not depend on ``eta``), reads
``e`` along ``y = 0``, and reports the first load at which the centre and the edge maximum
reach ``e_c`` for the dissertation's ``eta = 0.0033`` (the ``_fine`` case files) and for the
coarse case files' ``eta = 0.005``, and both densities at the figure's load.

The toughnesses and figure loads are those of ``cases/indentation_branching_G07.toml``,
``_G15`` and ``_G20``. The intact film scanned to ``--t-end`` has no case file of its own: it is
``indentation_branching_G20.toml`` with the grid, ``G/a = 1``, ``eta = 0.005`` and
``t_max = --t-end`` set over it (G/a and eta do not enter the intact film's density).

Usage (from the repository root)::

    python -m studies.branching.contact_edge          # under a minute

Writes ``studies/branching/results/contact_edge_limit.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import platform
from pathlib import Path

import numpy as np
from scipy.signal import argrelextrema

from studies.branching.scenes import ETA, RESULTS, grid_overrides, load_case
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.loads import contact_radius
from thinfilm.damage import c_m

CASES = ("G07", "G15", "G20")  # the Fig. 2.14 cases, in the seeds study's order
ETAS = (ETA, 0.005)  # the _fine case files' 0.0033, the coarse case files' 0.005
T_STEP = 0.005


def radial_densities(model, grid, t):
    """The intact film's bending energy density along ``y = 0``, ``x >= 0`` at load ``t``:
    its value at the centre and its largest local maximum beyond its first local minimum
    (the edge maximum) with that maximum's radius. Returns ``(e_centre, e_edge, r_edge)``."""
    u = model.solve_u(np.zeros(grid.n_nodes), t, None, 1e-10)
    e = model.elastic_density(u, np.zeros(grid.n_nodes), t).reshape(grid.ny + 1, grid.nx + 1)
    x = np.asarray(grid.x)
    row = e[grid.ny // 2, x >= -1e-12]  # y = 0 (an even number of cells puts a row on it)
    r = x[x >= -1e-12]
    minima = argrelextrema(row, np.less)[0]
    beyond = np.arange(minima[0], row.size) if minima.size else np.arange(1, row.size)
    k = beyond[np.argmax(row[beyond])]
    return float(row[0]), float(row[k]), float(r[k])


def first_crossing(t_values, values, limit):
    """The first load of ``t_values`` at which ``values`` reaches ``limit`` (nan if none)."""
    reached = np.nonzero(np.asarray(values) >= limit)[0]
    return float(t_values[reached[0]]) if reached.size else float("nan")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cells", type=int, default=360, help="cells per side of (-0.12, 0.12)^2")
    parser.add_argument("--t-end", type=float, default=0.25, help="last load scanned")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)

    # Each case's toughness G/a and figure's load t (its case file's t_max).
    figures = {}
    for name in CASES:
        case = load_case(name)
        figures[name] = (case.model.toughness, case.load.t_max)
    # The scan's loads, with the figures' loads among them so that none is solved twice.
    t_figures = [t for _toughness, t in figures.values()]
    t_values = np.unique(np.round(np.r_[np.arange(T_STEP, args.t_end + 1e-12, T_STEP), t_figures], 6))
    # The intact film does not depend on G/a or eta: one scan serves every case.
    scene = load_case("G20", {**grid_overrides(args.cells, eta=ETAS[1]), "model.toughness": 1.0,
                              "load.t_max": args.t_end, "load.steps": 2, "solver.max_iter": 1,
                              "output.snapshots": [args.t_end]})
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    profile = np.array([radial_densities(model, grid, t) for t in t_values])
    print(", ".join(f"t = {t:.3f}: centre {c:.0f}, edge {e:.0f} at {r:.4f}"
                    for t, (c, e, r) in zip(t_values[::5], profile[::5])), flush=True)
    rows = []
    radius = scene.load.radius
    for name, (toughness, t_figure) in figures.items():
        at_figure = profile[np.searchsorted(t_values, round(t_figure, 6))]
        for eta in ETAS:
            limit = toughness / (4.0 * c_m(1) * eta)
            rows.append({"case": name, "toughness": toughness, "eta": eta, "limit": limit,
                         "t_centre": first_crossing(t_values, profile[:, 0], limit),
                         "t_edge": first_crossing(t_values, profile[:, 1], limit),
                         "t_figure": t_figure, "e_centre": at_figure[0], "e_edge": at_figure[1],
                         "r_edge": at_figure[2], "r_contact": float(contact_radius(radius, t_figure))})

    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "contact_edge_limit.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# The intact film's AT1 elastic limit under the small indenter",
        "",
        f"`python -m studies.branching.contact_edge --cells {args.cells} --t-end {args.t_end}` "
        f"({platform.machine()}, Python {platform.python_version()}). winkler = 6.4e7, R = {radius}, "
        f"{args.cells}^2 cells on (-0.12, 0.12)^2, loads every {T_STEP}. e: the intact film's undamaged "
        "bending energy density along y = 0, at the centre and at its maximum near the contact edge; "
        "limit: 3 (G/a) / (8 eta); t centre, t edge: the first load at which each reaches the limit "
        "(nan: not by the last load scanned).",
        "",
        "| case | G/a | eta | limit | t centre | t edge | figure's t | e centre there | e edge there | "
        "its radius / contact radius |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(f"| {row['case']} | {row['toughness']} | {row['eta']:.4f} | {row['limit']:.1f} | "
                     f"{row['t_centre']:.3f} | {row['t_edge']:.3f} | {row['t_figure']} | {row['e_centre']:.1f} | "
                     f"{row['e_edge']:.1f} | {row['r_edge'] / row['r_contact']:.3f} |")
    (args.out / "contact_edge_limit.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
