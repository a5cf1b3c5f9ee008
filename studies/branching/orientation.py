"""How much the structured grid favours cracks along its axes: the energy released by a
straight crack band against its angle, and how that bias falls as the grid is refined.

The continuum energy is isotropic, so the energy change a straight crack brings per unit
length does not depend on its direction. On the grid it does: a crack lying on a row of
nodes has ``alpha = 1`` at those nodes along its whole length, and only the grid's axes (and
diagonals) offer such rows. This study measures the effect on the operators of
:mod:`thinfilm.plate.operators` themselves.

Set-up. The square (-0.12, 0.12)^2 with free edges, ``winkler = 6.4e7`` (``1/lam = 0.016``),
``nu = 0.3``, ``G/a = 1``, AT1 with ``eta = 0.0075`` (``eta lam = 0.47``), and a uniaxial
bending load ``w = -t s^2 / 2`` with ``s = x cos(theta) + y sin(theta)``, ``t = 10``. The damage
is the optimal 1D profile :func:`thinfilm.plate.model.crack_profile` of the distance ``|s - s0|``
to the line ``s = s0`` (a crack band perpendicular to the bending direction, at angle
``theta`` from the y axis); ``s0 = 0`` puts it through the centre node, ``s0 = h/2`` between
two node rows. For each band the u-problem is solved with and without damage, and
``release`` is the change of the energy (elastic + surface, :func:`thinfilm.plate.energy.nodal_energy`)
inside the disk ``|x| < 0.06``
divided by the chord 0.12: the energy change per unit crack length (negative: the crack
pays). The disk keeps the free edges 3.8 decay lengths away (doubling the square changes
``release`` by less than 2e-3 of itself).

For each ``eta / h`` in (5, 10, 20) the table lists ``release`` at each angle and the spread
(largest minus smallest over the mean), and the fitted order of the spread in ``h``. A second
table splits ``release`` into its parts: the bending energy at the nodes (``g_n omega_n Q_n / 2``),
the twist at the cell centres (each node taking ``g_n`` times a quarter of its four cells', as
:func:`thinfilm.plate.energy.nodal_energy` shares it), the foundation and the surface energy, to show
which term of the discrete energy the bias comes from.

The set-up is built from the operators directly (no scene file: no case of ``cases/`` has
this load or damage).

Usage (from the repository root)::

    python -m studies.branching.orientation              # eta/h = 5 10 20, about 3 minutes
    python -m studies.branching.orientation --ratios 5 10

Writes ``studies/branching/results/crack_orientation.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path

import numpy as np

from thinfilm.plate.energy import bending_density, nodal_energy
from thinfilm.plate.grid import Grid
from thinfilm.plate.model import crack_profile
from thinfilm.plate.operators import GridDamage, PlateOperator
from thinfilm.solvers.linear import make_solver

RESULTS = Path(__file__).resolve().parent / "results"

HALF_WIDTH = 0.12
WINKLER, NU, TOUGHNESS, K_RES = 6.4e7, 0.3, 1.0, 1e-6
ETA = 0.0075
LOAD_T = 10.0
DISK_RADIUS = 0.06
# (label, angle in degrees, offset of the line in units of h)
PARTS = ("bending", "twist", "foundation", "surface")
BANDS = [("0 (on a node row)", 0.0, 0.0), ("0 (between rows)", 0.0, 0.5), ("10", 10.0, 0.0),
         ("22.5", 22.5, 0.0), ("30", 30.0, 0.0), ("45 (on a diagonal)", 45.0, 0.0)]


def energy_parts(plate, damage, u, alpha, w):
    """The energy at each node split into ``(bending, twist, foundation, surface)``, each of
    shape ``(n_nodes,)``, summing to :func:`nodal_energy`.

    The twist share of node ``n`` is ``g_n / 2`` times a quarter of ``hx hy 2 (1 - nu) d_c^2``
    summed over its cells (interior formula: the disk of the study is far from the edges);
    the bending share is the rest of ``g_n e_n / 2``.
    """
    grid = plate.grid
    ny, nx = grid.ny + 1, grid.nx + 1
    g = plate.degradation(alpha)
    U = u.reshape(ny, nx)
    d = (U[:-1, :-1] - U[:-1, 1:] - U[1:, :-1] + U[1:, 1:]) / (grid.hx * grid.hy)
    cell = grid.hx * grid.hy * 2 * (1 - plate.nu) * d**2
    quarter = np.zeros((ny, nx))
    for dj, di in ((0, 0), (0, 1), (1, 0), (1, 1)):
        quarter[dj:dj + ny - 1, di:di + nx - 1] += cell / 4
    twist = 0.5 * g * quarter.ravel()
    total = nodal_energy(plate, damage, u, alpha, w)
    foundation = 0.5 * plate.winkler * grid.weights * (u - w) ** 2
    bending = 0.5 * g * bending_density(plate, u) - twist
    surface = total - bending - twist - foundation
    return bending, twist, foundation, surface


def release_per_length(ratio):
    """``release`` of every band of :data:`BANDS` on the grid with ``h = ETA / ratio``."""
    n = int(round(2 * HALF_WIDTH / (ETA / ratio)))
    grid = Grid.rectangle(-HALF_WIDTH, HALF_WIDTH, n, -HALF_WIDTH, HALF_WIDTH, n)
    x, y = (c.ravel() for c in grid.coordinates)
    plate = PlateOperator(grid, NU, WINKLER, K_RES)
    damage = GridDamage(grid, ETA, TOUGHNESS, 1)
    disk = x**2 + y**2 < DISK_RADIUS**2
    zero = np.zeros(grid.n_nodes)
    # K(0) is the same for every band: factored once (on a copy, since the plate operator
    # rewrites its one matrix in place for the damaged solves).
    undamaged = make_solver("direct", plate.matrix(zero))
    undamaged.update(plate.matrix(zero).copy())
    damaged = make_solver("direct", plate.matrix(zero))
    out = []
    for label, degrees, offset in BANDS:
        theta = np.radians(degrees)
        s = x * np.cos(theta) + y * np.sin(theta)
        w = -LOAD_T * s**2 / 2
        f = plate.rhs(w)
        start = time.perf_counter()
        u0, _ = undamaged.solve(f)
        alpha = crack_profile(np.abs(s - offset * grid.hx), ETA, 1)
        u1, _ = damaged(plate.matrix(alpha), f)
        change = (nodal_energy(plate, damage, u1, alpha, w) - nodal_energy(plate, damage, u0, zero, w))[disk].sum()
        parts = [float((after - before)[disk].sum()) / (2 * DISK_RADIUS) for after, before in
                 zip(energy_parts(plate, damage, u1, alpha, w), energy_parts(plate, damage, u0, zero, w))]
        out.append((label, float(change) / (2 * DISK_RADIUS), time.perf_counter() - start, parts))
    return n, out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--ratios", type=int, nargs="+", default=[5, 10, 20], help="eta / h")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows, spreads = [], []
    for ratio in args.ratios:
        n, results = release_per_length(ratio)
        values = np.array([r[1] for r in results])
        spread = (values.max() - values.min()) / abs(values.mean())
        spreads.append(spread)
        for label, value, seconds, parts in results:
            rows.append({"eta_over_h": ratio, "cells": n, "band": label, "release": value,
                         **dict(zip(PARTS, parts)), "seconds": seconds})
        print(f"eta/h = {ratio}: {n}^2 cells, spread {spread:.4f}", flush=True)

    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "crack_orientation.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Energy change per unit length of a straight crack band against its direction",
        "",
        f"`python -m studies.branching.orientation --ratios {' '.join(map(str, args.ratios))}` "
        f"({platform.machine()}, Python {platform.python_version()}). Square (-0.12, 0.12)^2, "
        f"winkler = {WINKLER:g}, eta = {ETA} (eta lam = {ETA * (WINKLER / 4) ** 0.25:.2f}), G/a = {TOUGHNESS:g}, "
        f"uniaxial bending t = {LOAD_T:g} across the band; energy change (elastic + surface) inside "
        f"|x| < {DISK_RADIUS} per unit length. The continuum value does not depend on the angle.",
        "",
        "| band angle (deg) | " + " | ".join(f"eta = {r} h" for r in args.ratios) + " |",
        "|---|" + "---|" * len(args.ratios),
    ]
    for label, _, _ in BANDS:
        vals = [r["release"] for r in rows if r["band"] == label]
        lines.append(f"| {label} | " + " | ".join(f"{v:.4f}" for v in vals) + " |")
    lines.append("| **spread** (max - min) / mean | " + " | ".join(f"**{s:.3f}**" for s in spreads) + " |")
    if len(spreads) > 1:
        h = ETA / np.array(args.ratios, dtype=float)
        order = np.polyfit(np.log(h), np.log(spreads), 1)[0]
        lines += ["", f"Fitted order of the spread in h: {order:.2f}."]
    lines += ["", "Parts of the energy change per unit length (bending at the nodes, twist at the cell "
              "centres, foundation, surface) and their sum; last line, the largest minus the smallest over the "
              "bands:", "", "| eta / h | band | " + " | ".join(PARTS) + " | bending + twist | total |",
              "|---|---|" + "---|" * (len(PARTS) + 2)]
    for ratio in args.ratios:
        sub = [r for r in rows if r["eta_over_h"] == ratio]
        table = np.array([[r[p] for p in PARTS] + [r["bending"] + r["twist"], r["release"]] for r in sub])
        for r, values in zip(sub, table):
            lines.append(f"| {ratio} | {r['band']} | " + " | ".join(f"{v:+.4f}" for v in values) + " |")
        lines.append(f"| {ratio} | **max - min** | " + " | ".join(f"**{v:.4f}**" for v in np.ptp(table, axis=0))
                     + " |")
    (args.out / "crack_orientation.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
