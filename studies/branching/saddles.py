"""Which way the perfect film's symmetric states are unstable: the lowest curvatures of the
reduced energy at the small indenter's D4-symmetric states (Fig. 2.14 evolutions) and the
angular harmonics of their modes.

Each case's perfect-film evolution is run restricted to D4-symmetric fields (the path its
unrestricted evolution follows to round-off), at the dissertation's eta = 5 dx (360 x 360
cells on (-0.12, 0.12)^2). At the first ``--steps`` load steps where damage moves, the
lowest ``--modes`` curvatures of the reduced energy on the unrestricted grid are computed
(:func:`thinfilm.plate.stability.lowest_modes`) and each mode is named by its angular harmonic
about the centre: the ``m`` of the largest ``|sum_n v_n e^{i m theta_n}| / sum_n |v_n|``,
``m = 0..6``. ``m = 2`` is a mode that elongates the damage one way (a straight crack),
``m = 3`` one that grows it three ways (a three-armed star), ``m = 4`` a cross.
Curvatures are in units of ``G/(a eta)``; negative ones make the state a saddle.

The scenes are the case files ``cases/indentation_branching_G20.toml``, ``_G15`` and
``_G07`` on the grid :data:`studies.branching.scenes.FINE`, as
:func:`studies.branching.imperfect.scene` builds them for the perfect film.

Usage (from the repository root)::

    python -m studies.branching.saddles              # G20 G15 G07, 3 steps each
    python -m studies.branching.saddles --cases G15 --steps 2

Writes ``studies/branching/results/symmetric_saddles.md`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path

import numpy as np

from studies.branching.imperfect import CASES, scene
from studies.branching.scenes import FINE, RESULTS
from thinfilm.engine import Engine
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.stability import lowest_modes

HARMONICS = 7


def harmonic(mode, theta):
    """``(m, content)``: the angular harmonic with the largest share of ``mode`` and the shares
    of ``m = 0 .. HARMONICS - 1``."""
    norm = np.abs(mode).sum()
    content = np.array([abs(np.sum(mode * np.exp(1j * m * theta))) / norm for m in range(HARMONICS)])
    return int(np.argmax(content)), content


def study(name, n_steps, n_modes):
    symmetric = scene(name, 0.0, 0, FINE)
    grid = build_grid(symmetric.domain)
    engine = Engine.from_options(make_model(symmetric, grid), symmetric.solver)
    t_values = np.linspace(0.0, symmetric.load.t_max, symmetric.load.steps + 1)
    _, states = engine.run(t_values)
    # The unrestricted operators of the same film, for the curvatures.
    free = scene(name, 0.0, 0, FINE, restricted=False)
    model = make_model(free, grid)
    x, y = grid.coordinates
    theta = np.arctan2(y, x)
    rows, checked = [], 0
    for k in range(1, len(states)):
        if checked == n_steps:
            break
        lower, alpha = states[k - 1].alpha, states[k].alpha
        if not np.any(alpha > lower + 1e-6):
            continue
        checked += 1
        start = time.perf_counter()
        modes = lowest_modes(model.plate, model.damage, alpha, model.load(t_values[k]), lower, k=n_modes)
        seconds = time.perf_counter() - start
        scale = model.damage.toughness / model.eta
        for rank, (value, mode) in enumerate(zip(modes.eigenvalues, modes.modes)):
            m, content = harmonic(mode, theta)
            rows.append({"case": name, "toughness": free.model.toughness, "t": round(float(t_values[k]), 6),
                         "max_alpha": float(alpha.max()), "free_nodes": len(modes.free), "rank": rank,
                         "curvature": value / scale, "harmonic": m, "share": float(content[m]),
                         "products": modes.products, "seconds": seconds})
        print(f"{name} t = {t_values[k]:g}: " + ", ".join(
            f"{r['curvature']:+.3f} (m = {r['harmonic']})" for r in rows[-len(modes.eigenvalues):])
            + f" [{seconds:.0f} s]", flush=True)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--steps", type=int, default=3, help="load steps with moving damage to check per case")
    parser.add_argument("--modes", type=int, default=6)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    rows = []
    for name in args.cases:
        rows += study(name, args.steps, args.modes)
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "symmetric_saddles.csv", "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Curvatures of the reduced energy at the small indenter's symmetric states",
        "",
        f"`python -m studies.branching.saddles --cases {' '.join(args.cases)} --steps {args.steps} "
        f"--modes {args.modes}` ({platform.machine()}, Python {platform.python_version()}). Perfect film, eta = 5 dx, "
        "360^2 cells; states of the D4-restricted evolution, curvatures on the unrestricted grid in units of "
        "G/(a eta), ascending; (m) the mode's angular harmonic about the centre (2: one straight crack, "
        "3: a three-armed star, 4: a cross).",
        "",
        "| case | t | max alpha | free nodes | lowest curvatures (m) | time (s) |",
        "|---|---|---|---|---|---|",
    ]
    keys = sorted({(r["case"], r["t"]) for r in rows}, key=lambda k: (args.cases.index(k[0]), k[1]))
    for case, t in keys:
        sub = [r for r in rows if r["case"] == case and r["t"] == t]
        lines.append(f"| {case} | {t:g} | {sub[0]['max_alpha']:.3f} | {sub[0]['free_nodes']} | "
                     + ", ".join(f"{r['curvature']:+.3f} ({r['harmonic']})" for r in sub)
                     + f" | {sub[0]['seconds']:.0f} |")
    (args.out / "symmetric_saddles.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
