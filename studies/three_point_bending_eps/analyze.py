"""Configuration II of the three-point bending beam (Tables 3.3-3.4) at the case file's
eps = 0.05 in and at the dissertation's eps = 0.02 in, without backtracking, with Alg. 3.1 and
with Alg. 3.2: where the crack goes (which holes it enters) and which run ends lowest in energy.

Usage (from the repository root)::

    python -m studies.three_point_bending_eps.analyze --run /tmp/tpb_eps   # the runs, then the table
    python -m studies.three_point_bending_eps.analyze /tmp/tpb_eps         # the table from runs made

Each run is ``thinfilm run cases/three_point_bending_II.toml --threads 1`` with the ``--set``
of :data:`RUNS`, in ``WORK/<name>``. Writes ``results/paths.csv`` and ``results/paths.png``.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from studies.runs import run_case, study_main

RESULTS = Path(__file__).resolve().parent / "results"

#: The holes of the beam (in): centre and radius (fem3d/specimens/three_point_bending.py).
HOLES = {"B": (-4.0, 2.75), "M": (-4.0, 4.75), "T": (-4.0, 6.75)}
RADIUS = 0.25
#: Damage from which a node counts as broken.
BROKEN = 0.9

_FINE = ["model.eps=0.02", "mesh.h=0.01", "mesh.adapt=true"]
_STANDARD = ['solver.backtrack="standard"']
_DEEP = ['solver.backtrack="deep"']
#: name -> the run's ``--set`` options. eps = 0.05 in: the case file's banded mesh (h = 0.025
#: in), Alg. 3.2 checked every 5 steps as in docs/cases.md; eps = 0.02 in: the adaptive mesh
#: down to h = 0.01 in (the dissertation's), Alg. 3.2 checked at every step.
RUNS = {
    "eps0.05_none": [],
    "eps0.05_alg3.1": _STANDARD,
    "eps0.05_alg3.2": _DEEP + ["solver.backtrack_interval=5"],
    "eps0.02_none": _FINE,
    "eps0.02_alg3.1": _FINE + _STANDARD,
    "eps0.02_alg3.2": _FINE + _DEEP + ["solver.backtrack_interval=1"],
}


def run(work, names):
    for name in names:
        run_case("three_point_bending_II", RUNS[name], work / name)


def hole_gaps(points, alpha):
    """Distance (in) from each hole's edge to the nearest broken node; about 0 where the crack
    runs into the hole (its broken nodes sit on the hole's boundary)."""
    broken = points[alpha >= BROKEN]
    return {name: float(np.hypot(broken[:, 0] - cx, broken[:, 1] - cy).min() - RADIUS)
            for name, (cx, cy) in HOLES.items()}


def x_at(points, alpha, y, half=0.05):
    """Mean x (in) of the broken nodes within ``half`` of height ``y``; NaN if none."""
    near = (alpha >= BROKEN) & (np.abs(points[:, 1] - y) < half)
    return float(points[near, 0].mean()) if near.any() else float("nan")


def first_event(run):
    """The load (in) of the run's first crack event (``summary.json``); NaN if none."""
    events = json.loads((Path(run) / "summary.json").read_text())["events"]
    return events[0]["t"] if events else float("nan")


def summarize(work, names):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.tri import Triangulation

    from thinfilm.results.reader import Results

    rows = []
    shown = [n for n in names if (work / n / "results.h5").exists()]
    fig, axes = plt.subplots(1, max(len(shown), 1), figsize=(2.0 * max(len(shown), 1), 3.6), sharey=True,
                             squeeze=False)
    for ax, name in zip(axes[0], shown):
        with Results(work / name) as res:
            F = np.asarray(res.steps["force"])
            peak = int(np.argmax(F))
            last = res.n - 1
            mesh = res.discretization_at(last)
            alpha = res.field("alpha", last)
            gaps = hole_gaps(mesh.points, alpha)
            energy = float(res.steps["elastic"][last] + res.steps["surface"][last])
            rows.append(dict(run=name, nodes=mesh.points.shape[0], peak_lbf=round(float(F[peak]), 1),
                             crack_at_in=first_event(work / name),
                             **{f"gap_{h}_in": round(g, 3) for h, g in gaps.items()},
                             x_at_T_in=round(x_at(mesh.points, alpha, HOLES["T"][1]), 2),
                             x_at_top_in=round(x_at(mesh.points, alpha, 7.9, half=0.1), 2),
                             surface=round(float(res.steps["surface"][last]), 4),
                             energy_end=round(energy, 4)))
            tri = Triangulation(mesh.points[:, 0], mesh.points[:, 1], mesh.cells)
            ax.tricontourf(tri, alpha, levels=np.linspace(0, 1, 11), cmap="magma_r")
        for cx, cy in HOLES.values():
            ax.add_patch(plt.Circle((cx, cy), RADIUS, fc="white", ec="0.3", lw=0.6))
        ax.set_xlim(-7.0, -2.0)
        ax.set_ylim(0.0, 8.0)
        ax.set_aspect("equal")
        ax.set_title(name.replace("_", "\n"), fontsize=8)
        ax.set_xlabel("x (in)")
    axes[0][0].set_ylabel("y (in)")
    fig.suptitle("configuration II: damage at t = 0.1 in", fontsize=9)
    fig.tight_layout()
    RESULTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(RESULTS / "paths.png", dpi=110)
    with open(RESULTS / "paths.csv", "w", newline="") as f:
        if rows:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    for r in rows:
        print(r)
    return rows


def main(argv=None):
    study_main(__doc__.splitlines()[0], Path("/tmp/tpb_eps"), RUNS, run, summarize,
               duration="about 1 hour on one thread", argv=argv)


if __name__ == "__main__":
    main()
