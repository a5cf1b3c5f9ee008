"""Nooru-Mohamed's load path 4b with the cohesive law: the normal force across band widths
and meshes, and the split.

Usage (from the repository root)::

    python -m studies.nooru_mohamed_czm.analyze --run /tmp/nm_czm   # the runs, then the table
    python -m studies.nooru_mohamed_czm.analyze /tmp/nm_czm         # the table from runs made

Each run is ``thinfilm run cases/nooru_mohamed_4b_czm.toml --threads 1`` with the ``--set``
of :data:`RUNS`, in ``WORK/<name>``. Writes ``results/summary.csv`` and ``results/curves.png``.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from studies.runs import run_case, study_main

RESULTS = Path(__file__).resolve().parent / "results"

#: name -> the run's ``--set`` options (the case file's: eps = 5 mm, h = 1 mm, split "positive")
RUNS = {
    "eps5_h1": [],
    "eps5_h0.5": ["mesh.h=0.5"],
    "eps2.5_h0.5": ["model.eps=2.5", "mesh.h=0.5"],
    "eps5_h1_none": ['model.split="none"'],
}


def run(work, names):
    for name in names:
        run_case("nooru_mohamed_4b_czm", RUNS[name], work / name)


def crack_heights(points, alpha, xs=(40.0, 100.0, 160.0)):
    """Where the damage is largest on each vertical ``x`` (the nodes within 2 mm of it,
    inside the specimen): that height (mm) and the damage there."""
    out = []
    for x in xs:
        near = np.flatnonzero((np.abs(points[:, 0] - x) < 2.0) & (points[:, 1] > 0.0) & (points[:, 1] < 200.0))
        k = near[np.argmax(alpha[near])]
        out.append((round(float(points[k, 1]), 1), round(float(alpha[k]), 2)))
    return out


def summarize(work, names):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from thinfilm.results.reader import Results

    rows = []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for name in names:
        if not (work / name / "results.h5").exists():
            continue
        with Results(work / name) as res:
            F = np.asarray(res.steps["force"])
            k = int(np.argmax(F))
            last = res.n - 1
            mesh = res.discretization_at(last)
            heights = crack_heights(mesh.points, res.field("alpha", last))
            surface = np.asarray(res.steps["surface"])
            rises = np.diff(F)
            rows.append(dict(run=name, nodes=mesh.points.shape[0], steps_s=round(float(res.steps["time_total"].sum()), 1),
                             peak_kN=round(float(F[k]) / 1e3, 2), peak_at_mm=round(float(res.t[k]), 4),
                             F_end_kN=round(float(F[last]) / 1e3, 2),
                             rises_after_peak=int((rises[k:] > 0.02 * F[k]).sum()),
                             crack_length_mm=round(float(surface[last]) / (0.11 * 50.0), 1),
                             **{f"y_at_x{x}": h[0] for x, h in zip((40, 100, 160), heights)},
                             alpha_max_at_x100=heights[1][1]))
            ax.plot(res.t, F / 1e3, ".-", ms=3, label=name)
    ax.set_xlabel("normal displacement of the upper platen (mm)")
    ax.set_ylabel("normal force (kN)")
    ax.legend()
    fig.tight_layout()
    RESULTS.mkdir(exist_ok=True)
    fig.savefig(RESULTS / "curves.png", dpi=120)
    with open(RESULTS / "summary.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    for row in rows:
        print(row)


def main(argv=None):
    study_main(__doc__.splitlines()[0], Path("/tmp/nm_czm"), RUNS, run, summarize,
               duration=None, argv=argv)


if __name__ == "__main__":
    main()
