"""Branching under the small indenter in an imperfect film: the Fig. 2.14 evolutions with a
random toughness field, against the perfect film.

The perfect film's evolutions of ``cases/indentation_branching_*.toml`` pass through a
D4-symmetric disk of damage and stay symmetric to round-off, ending as crosses along the
grid axes, although at G/a = 1.5 a three-armed star is the lower state
(:mod:`studies.branching.seeds`). A film whose toughness varies a little from place to place
(``[model] toughness_noise``, :mod:`thinfilm.plate.imperfection`) has no symmetry to stay on. This
study runs each case's whole evolution for the perfect film and for several seeds of an
imperfect one (the perfect film restricted to D4-symmetric fields, which its
unrestricted evolution keeps to round-off), and reads the crack pattern at the case's snapshot loads: the cracks that
cut a circle about the junction of the damage (:func:`thinfilm.plate.cracks.arms`), their number
and the angles between neighbours (three arms about 120 degrees apart make a star, 90-90-180
a T, four about 90 apart a cross).

The circle: about the junction of the broken nodes (alpha >= 0.9) inside 0.8 times the
contact radius (so that a ring at the contact edge is left out), the broken node about
which the most arms cut a circle of radius 2 eta and point the same ways on a circle twice
as large (:func:`junction`); its radius 3 eta, or 0.6 times the distance to the farthest
broken node if that is less (less than 2 eta: a spot, no arms).
The gaps are the angles at which the arms leave the junction, read where the crack bands
are a few eta wide and the junction a blob of damage, so they are good to 10-20 degrees:
look at the figure too.

The scenes are the case files ``cases/indentation_branching_G20.toml``, ``_G15`` and
``_G07`` with what the study changes set over them (:func:`scene`): the grid (``--fine``,
``--finer``: :data:`studies.branching.scenes.FINE`, ``FINER``), the toughness noise and its
seed, ``domain.symmetry = "d4"`` for the perfect film, or ``solver.stability = true``.

Usage (from the repository root; defaults: the three cases as their files give them, eta =
2 dx on (-0.2, 0.2)^2, 160^2 cells, toughness_noise = 0.05, correlation length eta, seeds 1
2 3; 11 minutes; with --fine and seeds 1 2, 50 minutes)::

    python -m studies.branching.imperfect
    python -m studies.branching.imperfect --cases G15 --seeds 1 --fine   # eta = 5 dx, 360^2
    python -m studies.branching.imperfect --cases G15 --seeds 1 --finer  # eta = 10 dx, 720^2
    python -m studies.branching.imperfect --fine --stability  # the perfect film, checked

The imperfect film of ``--finer`` with seed 1 is the scene of
``cases/indentation_branching_*_fine.toml`` (the same scene, built here from the coarse case
file, ``tests/core/test_case_files.py`` checks it; 36-77 minutes per evolution).

With ``--stability`` the study runs, instead of imperfect films, the perfect film unrestricted
with ``[solver] stability = true`` (:mod:`thinfilm.plate.stability`): its evolution leaves the
symmetric states that are saddles along their most unstable mode.

Writes ``studies/branching/results/imperfect_branching.md``, ``.csv``, ``.png`` and
``_alpha.npz`` (the grid's ``x``, ``y`` and each run's last damage, shape ``(ny + 1, nx + 1)``,
keyed ``G15_perfect``, ``G15_seed2``, ...; not kept under version control) after each run
(a stopped study keeps the runs it finished); with
``--fine`` or ``--finer``, ``imperfect_branching_fine.*`` or ``_finer.*``. A study of some of
the cases adds their names and the seeds to the file name
(``imperfect_branching_fine_G15_seeds1.*``), a noise other than 0.05 adds it too
(``_s0.01``), and ``--stability`` adds ``_stability``, so that none overwrites another.
"""

from __future__ import annotations

import argparse
import csv
import platform
import time
from pathlib import Path

import numpy as np

from studies.branching.scenes import FINE, FINER, RESULTS, load_case
from thinfilm.engine import Engine
from thinfilm.plate.cracks import CRACK_THRESHOLD, arms, branch_points, branch_spacing
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.plate.loads import contact_radius

CASES = ("G20", "G15", "G07")


def scene_overrides(noise, seed, grid, checked=False, restricted=True):
    """What the study sets over a case file: the ``grid`` overrides (a dict of dotted keys,
    :data:`FINE` or :data:`FINER`, empty for the case file's own grid) and the noise or
    symmetry keys; ``checked``: the perfect film, unrestricted, with the stability check;
    ``restricted = False``: the perfect film unrestricted, without it."""
    overrides = dict(grid)
    if checked:
        overrides["solver.stability"] = True
    elif noise > 0:
        overrides.update({"model.toughness_noise": noise, "model.toughness_noise_seed": seed})
    elif restricted:
        # Left unrestricted, the perfect film's evolution stays D4-symmetric to round-off
        # (studies/branching/README.md): the restricted run is the same evolution, 5-10x faster.
        overrides["domain.symmetry"] = "d4"
    return overrides


def scene(name, noise, seed, grid, checked=False, restricted=True):
    """The validated scene of case ``name`` with :func:`scene_overrides` set over its file."""
    return load_case(name, scene_overrides(noise, seed, grid, checked, restricted))


def _mismatch(a, b):
    """Sum over the directions ``a`` (degrees) of the angle to the nearest of ``b``."""
    return sum(min(abs((u - v + 180.0) % 360.0 - 180.0) for v in b) for u in a)


def junction(alpha, broken, x, y, reach):
    """The broken node where the cracks meet: the most arms cut the circle of radius
    ``reach`` about it, and they point the same ways on the circle of twice that radius
    (straight arms radiate from their junction; from a node one row off, the directions
    differ on the two circles)."""
    best = None
    for j, i in zip(*np.nonzero(broken)):
        centre = (x[i], y[j])
        near = arms(alpha, x, y, reach, centre=centre, samples=240)
        far = arms(alpha, x, y, 2 * reach, centre=centre, samples=240)
        key = (len(near), len(far) == len(near), -_mismatch(near, far) if len(far) else -np.inf)
        if best is None or key > best[0]:
            best = (key, centre)
    return best[1]


def pattern(alpha, x, y, inner_radius, eta):
    """``(number of arms, sorted gaps between neighbouring arms in degrees)`` about the
    junction of the broken nodes inside ``inner_radius`` (see the module docstring)."""
    X, Y = np.meshgrid(x, y)
    broken = (alpha >= CRACK_THRESHOLD) & (np.hypot(X, Y) < inner_radius)
    if not broken.any():
        return 0, []
    cx, cy = junction(alpha, broken, x, y, 2 * eta)
    reach = np.hypot(X[broken] - cx, Y[broken] - cy).max()
    if reach < 2 * eta:
        return 0, []   # a spot, not yet arms
    radius = min(3 * eta, 0.6 * reach)   # where the arms leave the junction (they may curve further out)
    directions = np.sort(arms(alpha, x, y, radius, centre=(cx, cy)))
    if len(directions) < 2:
        return len(directions), []
    gaps = np.diff(np.r_[directions, directions[0] + 360.0])
    return len(directions), sorted(np.round(gaps).astype(int).tolist())


def run(name, noise, seed, grid_overrides, checked=False):
    case = scene(name, noise, seed, grid_overrides, checked)
    grid = build_grid(case.domain)
    model = make_model(case, grid)
    engine = Engine.from_options(model, case.solver)
    t_values = np.linspace(0.0, case.load.t_max, case.load.steps + 1)
    start = time.perf_counter()
    records, states = engine.run(t_values)
    seconds = time.perf_counter() - start
    x, y = np.asarray(grid.x), np.asarray(grid.y)
    X, Y = np.meshgrid(x, y)
    out = []
    for t_snap in case.snapshots:
        k = int(np.argmin(np.abs(t_values - t_snap)))
        alpha = states[k].alpha.reshape(grid.ny + 1, grid.nx + 1)
        inner_radius = 0.8 * contact_radius(case.load.radius, t_values[k])
        n_arms, gaps = pattern(alpha, x, y, inner_radius, case.model.eta)
        junctions = branch_points(alpha, x, y, 1.5 * case.model.eta, within=np.hypot(X, Y) < inner_radius)
        out.append({"case": name, "toughness": case.model.toughness, "noise": noise,
                    "seed": seed if noise else ("stability" if checked else "-"),
                    "t": round(float(t_values[k]), 6), "arms": n_arms, "gaps": " ".join(map(str, gaps)),
                    "branch_points": len(junctions), "spacing": branch_spacing(junctions) / case.model.eta,
                    "total": states[k].total, "iterations": sum(r.iterations for r in records),
                    "seconds": seconds})
    final = states[-1].alpha.reshape(grid.ny + 1, grid.nx + 1)
    return out, final, (x, y)


def write_results(stem, fig, rows, fields, command):
    """Write ``stem``.png, .csv, .md and _alpha.npz (``fields``: the grid's ``x``, ``y`` and
    each run's last damage) from the runs so far; return the Markdown table."""
    stem.parent.mkdir(parents=True, exist_ok=True)
    path = {ext: stem.parent / (stem.name + ext)   # the stem may hold "_s0.01"
            for ext in (".png", ".csv", ".md", "_alpha.npz")}
    np.savez_compressed(path["_alpha.npz"], **fields)
    fig.tight_layout()
    fig.savefig(path[".png"], dpi=90)
    with open(path[".csv"], "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Branching in an imperfect film (Fig. 2.14 evolutions)",
        "",
        f"`{command}` ({platform.machine()}, Python {platform.python_version()}). "
        "Arms: cracks cutting a circle of radius 3 eta about the junction of the damage; gaps: angles between neighbouring "
        "arms (degrees). Branch points: clusters of broken nodes about which three or more cracks cut a circle of "
        "radius 1.5 eta (`thinfilm.plate.cracks.branch_points`; closer than about 2-3 eta they read as one); spacing: the "
        "largest distance between two of them, in eta. The perfect film (noise 0, seed -) runs restricted to D4-symmetric fields, the imperfect "
        "ones and the perfect film with the stability check (seed: stability) unrestricted; time and iterations are "
        "the whole evolution's (with the stability check's).",
        "",
        "| case | G/a | noise | seed | t | arms | gaps | branch points | spacing / eta | total energy | iterations "
        "| time (s) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        lines.append(f"| {row['case']} | {row['toughness']:g} | {row['noise']:g} | {row['seed']} | {row['t']:g} | "
                     f"{row['arms']} | {row['gaps'] or '-'} | {row['branch_points']} | "
                     f"{row['spacing']:.1f} | {row['total']:.5f} | {row['iterations']} | "
                     f"{row['seconds']:.0f} |")
    text = "\n".join(lines) + "\n"
    path[".md"].write_text(text)
    return text


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    parser.add_argument("--seeds", nargs="+", type=int, default=[1, 2, 3])
    parser.add_argument("--noise", type=float, default=0.05, help="toughness_noise of the imperfect films")
    resolution = parser.add_mutually_exclusive_group()
    resolution.add_argument("--fine", action="store_true", help="eta = 5 dx: 360^2 cells on (-0.12, 0.12)^2")
    resolution.add_argument("--finer", action="store_true", help="eta = 10 dx: 720^2 cells on (-0.12, 0.12)^2")
    parser.add_argument("--stability", action="store_true",
                        help="instead of imperfect films, the perfect film unrestricted with [solver] stability = true")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid_overrides, suffix = (FINER, "_finer") if args.finer else (FINE, "_fine") if args.fine else ({}, "")
    if args.cases != list(CASES):   # a partial study does not overwrite the whole one
        suffix += "_" + "_".join(args.cases)
    if args.stability:
        suffix += "_stability"
        runs = [(0.0, 0, False), (0.0, 0, True)]
    else:
        if args.cases != list(CASES):
            suffix += "_seeds" + "_".join(map(str, args.seeds))
        if args.noise != 0.05:
            suffix += f"_s{args.noise:g}"
        runs = [(0.0, 0, False)] + [(args.noise, s, False) for s in args.seeds]
    resolution_flag = " --fine" if args.fine else " --finer" if args.finer else ""
    command = (f"python -m studies.branching.imperfect --cases {' '.join(args.cases)}"
               + (" --stability" if args.stability else
                  f" --seeds {' '.join(map(str, args.seeds))} --noise {args.noise:g}") + resolution_flag)
    stem = args.out / f"imperfect_branching{suffix}"
    rows, fields = [], {}   # fields: the grid, then each run's last damage
    fig, axes = plt.subplots(len(args.cases), len(runs), figsize=(2.6 * len(runs), 2.6 * len(args.cases)),
                             squeeze=False)
    for axes_row, name in zip(axes, args.cases):
        for ax, (noise, seed, checked) in zip(axes_row, runs):
            case_rows, final, (x, y) = run(name, noise, seed, grid_overrides, checked)
            rows += case_rows
            last = case_rows[-1]
            print(f"{name} noise {noise} seed {seed}{' stability' if checked else ''}: " + "; ".join(
                f"t = {r['t']:g}: {r['arms']} arms, gaps {r['gaps'] or '-'}" for r in case_rows)
                + f" ({last['iterations']} iterations, {last['seconds']:.0f} s)", flush=True)
            ax.imshow(final, origin="lower", extent=[x[0], x[-1], y[0], y[-1]], cmap="magma_r", vmin=0, vmax=1)
            ax.set_xlim(-0.07, 0.07)
            ax.set_ylim(-0.07, 0.07)
            ax.set_xticks([])
            ax.set_yticks([])
            label = ("perfect, stability check" if checked else "perfect") if noise == 0 else f"s = {noise:g}, seed {seed}"
            ax.set_title(f"{name}, {label}\nt = {last['t']:g}: {last['arms']} arms", fontsize=8)
            # The last damage, to read the patterns again without rerunning an evolution.
            fields.update(x=x, y=y)
            fields[f"{name}_{'perfect' if noise == 0 else f'seed{seed}'}{'_stability' if checked else ''}"] = \
                final.astype(np.float32)
            table = write_results(stem, fig, rows, fields, command)   # after each run: an evolution takes up to an hour
    print(table)


if __name__ == "__main__":
    main()
