"""Seeded crack patterns of Fig. 2.14 extrapolated to the continuum (h -> 0 at fixed eta).

:mod:`studies.branching.seeds` ranks crosses, stars and double branches by their energies at one
load, on one grid. Those energies carry the grid's bias for the axes, an error of first order in
``h / eta`` (:mod:`studies.branching.orientation`) that is as large as the differences between the
patterns. This study takes the results of several grids for the same seeds and extrapolates the
difference ``D(h) = E(seed) - E(cross 0)`` to ``h = 0``:

- with three grids, it fits ``D(h) = D0 + C h^p`` through the three points (``p`` from the
  ratio of the two successive changes, then ``C`` and ``D0``): the fitted order ``p`` says
  whether the grids are in the asymptotic range at all;
- with four or more, it fits the three finest and, as a check, the three coarsest;
- with two or more grids, it also gives the first-order estimate from the two finest,
  ``D0 = D(h2) - h2 (D(h1) - D(h2)) / (h1 - h2)``.

It runs no solver: it reads the ``.csv`` files that :mod:`studies.branching.seeds` wrote (one per
grid, or several grids in one), keeps the seeds that settled (a seed still moving after its
iteration limit has no energy) and that at least two grids have, and writes a table. It does not know
whether a seed ended as the same pattern on every grid: check the seeds' ``.png`` figures.

Usage (from the repository root)::

    python -m studies.branching.extrapolation \\
        studies/branching/results/branching_seeds_240.csv \\
        studies/branching/results/branching_seeds_double_y.csv \\
        studies/branching/results/branching_seeds_480.csv \\
        studies/branching/results/branching_seeds_480_double_y.csv \\
        studies/branching/results/branching_seeds_G07_720.csv \\
        studies/branching/results/branching_seeds_G15_720.csv \\
        studies/branching/results/branching_seeds_G15_720_y15.csv \\
        studies/branching/results/branching_seeds_G20_720.csv \\
        studies/branching/results/branching_seeds_G20_720_y15.csv

Writes ``studies/branching/results/branching_extrapolation.md`` and ``.csv`` (``--stem`` names
them).
"""

from __future__ import annotations

import argparse
import csv
import math
from collections import defaultdict
from pathlib import Path

from scipy.optimize import brentq

from studies.branching.scenes import ETA, HALF_WIDTH, RESULTS

REFERENCE = "cross 0"
# Seeds that end as the same pattern on every grid of the study (its figures): a double Y of
# c = 6 eta does not (at G/a = 0.7 its arcs grow with the resolution and close into a loop at
# eta = 3.3 dx), so its energies on different grids are not one quantity's.
SAME_PATTERN = ("star 0", "double Y 1.5", "double Y 3")


def fitted_order(h, d):
    """The order ``p`` of ``d = d0 + c h^p`` through three points, ``h`` decreasing.

    Solves ``(d1 - d2) / (d2 - d3) = (h1^p - h2^p) / (h2^p - h3^p)`` for ``p`` in (0.05, 6).
    Returns NaN when the changes differ in sign (not monotone: no power law fits) or no ``p``
    in that range does.
    """
    (h1, h2, h3), (d1, d2, d3) = h, d
    if (d1 - d2) * (d2 - d3) <= 0.0:
        return math.nan
    ratio = (d1 - d2) / (d2 - d3)

    def mismatch(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio

    try:
        return brentq(mismatch, 0.05, 6.0)
    except ValueError:  # no sign change: the ratio is outside what p in (0.05, 6) gives
        return math.nan


def power_limit(h, d):
    """The order ``p`` and limit ``d0`` of ``d = d0 + c h^p`` through three points, ``h``
    decreasing (NaN, NaN when :func:`fitted_order` finds no order)."""
    p = fitted_order(h, d)
    if math.isnan(p):
        return math.nan, math.nan
    c = (d[1] - d[2]) / (h[1] ** p - h[2] ** p)
    return p, d[2] - c * h[2] ** p


def extrapolate(h, d):
    """Continuum estimates of ``d(h)`` from grids ``h`` (decreasing, at least two).

    Returns
    -------
    fine : tuple of float
        ``(p, d0)`` through the three finest grids (NaN with two grids, see :func:`power_limit`).
    coarse : tuple of float
        ``(p, d0)`` through the three coarsest grids when there are four or more: a second
        estimate from other data, which shows how far the grids are from the asymptotic range
        (NaN with fewer grids).
    d0_first : float
        The first-order limit from the two finest grids.
    """
    h1, h2 = h[-2:]
    d1, d2 = d[-2:]
    d0_first = d2 - h2 * (d1 - d2) / (h1 - h2)
    fine = power_limit(h[-3:], d[-3:]) if len(h) >= 3 else (math.nan, math.nan)
    coarse = power_limit(h[:3], d[:3]) if len(h) >= 4 else (math.nan, math.nan)
    return fine, coarse, d0_first


def read_totals(paths):
    """Total energies by ``(case, seed)`` and cells, from :mod:`studies.branching.seeds` result files;
    seeds that did not settle (NaN total) are left out.

    Two files may hold the same seed on the same grid (the cross is in every file); the runs are
    deterministic, so their totals must agree: a ``ValueError`` names any pair that differs by
    more than 1e-6.
    """
    totals = defaultdict(dict)
    for path in paths:
        with open(path, newline="") as fh:
            for row in csv.DictReader(fh):
                total = float(row["total"])
                if math.isnan(total):
                    continue
                key, cells = (row["case"], row["seed"]), int(row["cells"])
                earlier = totals[key].get(cells)
                if earlier is not None and abs(earlier - total) > 1e-6:
                    raise ValueError(f"{path}: {key[0]} {key[1]!r} on {cells} cells has total {total:.6f}, "
                                     f"another file {earlier:.6f}")
                totals[key][cells] = total
    return totals


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("results", nargs="+", type=Path, help="studies.branching.seeds .csv files")
    parser.add_argument("--seeds", nargs="+", default=list(SAME_PATTERN),
                        help="seeds to extrapolate (check that each ends as one pattern on every grid)")
    parser.add_argument("--stem", default="branching_extrapolation", help="name of the result files")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)

    totals = read_totals(args.results)
    rows = []
    for (case, seed), by_cells in sorted(totals.items()):
        reference = totals.get((case, REFERENCE), {})
        cells = sorted(set(by_cells) & set(reference))  # coarse to fine
        if seed not in args.seeds or len(cells) < 2:
            continue
        h = [2 * HALF_WIDTH / n / ETA for n in cells]  # h / eta
        d = [by_cells[n] - reference[n] for n in cells]
        (p, d0_fit), (p_coarse, d0_coarse), d0_first = extrapolate(h, d)
        rows.append({"case": case, "seed": seed, "cells": " ".join(map(str, cells)),
                     "h_over_eta": " ".join(f"{x:.3g}" for x in h), "difference": " ".join(f"{x:+.6f}" for x in d),
                     "order": p, "limit_fitted": d0_fit, "order_coarse": p_coarse, "limit_fitted_coarse": d0_coarse,
                     "limit_first_order": d0_first,
                     "cross_total": " ".join(f"{reference[n]:.6f}" for n in cells)})

    if not rows:
        parser.exit(2, f"{parser.prog}: no seed of {', '.join(args.seeds)} has settled on two or more grids "
                       "in these files (each grid needs the cross as well)\n")
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / f"{args.stem}.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    inputs = " ".join(map(str, args.results))
    if list(args.seeds) != list(SAME_PATTERN):
        inputs += " --seeds " + " ".join(f"'{name}'" for name in args.seeds)
    lines = [
        "# Seeded Fig. 2.14 patterns: energy against the axis cross, extrapolated to h = 0",
        "",
        f"`python -m studies.branching.extrapolation {inputs}`. eta = {ETA:.4g}; "
        "`E - E(cross 0)` on each grid (coarse to fine); the order `p` and limit of "
        "`D0 + C h^p` through the three finest grids and, with four or more, through the "
        "three coarsest (blank: too few grids, or the changes are not monotone); the "
        "first-order limit from the two finest grids; and the cross's own total energy on each grid.",
        "",
        "| case | seed | h / eta | E - E(cross 0) | p, finest three | limit, finest three | "
        "p, coarsest three | limit, coarsest three | limit, first order | cross 0 total |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]

    def number(value, spec):
        return "" if math.isnan(value) else format(value, spec)

    for row in rows:
        lines.append(f"| {row['case']} | {row['seed']} | {row['h_over_eta']} | {row['difference']} | "
                     f"{number(row['order'], '.2f')} | {number(row['limit_fitted'], '+.4f')} | "
                     f"{number(row['order_coarse'], '.2f')} | {number(row['limit_fitted_coarse'], '+.4f')} | "
                     f"{row['limit_first_order']:+.4f} | {row['cross_total']} |")
    (args.out / f"{args.stem}.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
