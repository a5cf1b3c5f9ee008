"""The L-panel with the cohesive law at three band widths, against Winkler's measured curve.

Usage (from the repository root)::

    python -m studies.lpanel_czm_length.analyze --run /tmp/lpanel_czm   # the three runs, then the table
    python -m studies.lpanel_czm_length.analyze /tmp/lpanel_czm         # the table from runs made

Each run is ``thinfilm run cases/lpanel_czm.toml --set model.eps=E --set mesh.h_min=E/5
--threads 1`` in ``WORK/epsE``. Writes ``results/summary.csv`` and ``results/curves.png``.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import numpy as np

from studies.runs import run_case

ROOT = Path(__file__).resolve().parents[2]
RESULTS = Path(__file__).resolve().parent / "results"
EPS = (5.0, 10.0, 20.0)
CORNER = (250.0, 250.0)      # the re-entrant corner (mm)


def run(work):
    for eps in EPS:
        run_case("lpanel_czm", [f"model.eps={eps}", f"mesh.h_min={eps / 5}"], work / f"eps{eps:g}")


def measured():
    data = np.loadtxt(ROOT / "cases" / "winkler_lpanel_series_a.csv", delimiter=",", comments="#", skiprows=4)
    return data[:, 0], data[:, 1]


def summarize(work):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from fem3d.cracks import initial_direction
    from thinfilm.results.reader import Results

    d_m, F_m = measured()
    rows = []
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ax.plot(d_m, F_m / 1e3, "k-", lw=2, label="measured (Winkler, series A)")
    for eps in EPS:
        with Results(work / f"eps{eps:g}") as res:
            F = np.asarray(res.steps["force"])
            k = int(np.argmax(F))
            last = res.n - 1
            angle = 180.0 - initial_direction(res.discretization_at(last).points, res.field("alpha", last), CORNER,
                                              3.0 * eps)
            rows.append(dict(eps=eps, nodes=int(res.steps["nodes"][last]), steps_s=round(float(res.steps["time_total"].sum()), 1),
                             peak_kN=round(F[k] / 1e3, 3), peak_at=float(res.t[k]),
                             **{f"F_{x:g}_kN": round(float(np.interp(x, res.t, F)) / 1e3, 3) for x in (0.3, 0.5, 1.0)},
                             angle_deg=round((angle + 180.0) % 360.0 - 180.0, 1)))
            ax.plot(res.t, F / 1e3, label=f"PF-CZM, eps = {eps:g} mm")
    ax.set_xlabel("load-point displacement (mm)")
    ax.set_ylabel("force (kN)")
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
    i = int(np.argmax(F_m))
    print(f"measured: peak {F_m[i] / 1e3:.3f} kN at {d_m[i]:.3f} mm;",
          ", ".join(f"F({x:g}) = {np.interp(x, d_m, F_m) / 1e3:.3f} kN" for x in (0.3, 0.5, 1.0)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("work", nargs="?", type=Path, default=Path("/tmp/lpanel_czm"))
    parser.add_argument("--run", action="store_true", help="make the three runs first")
    args = parser.parse_args()
    if args.run:
        run(args.work)
    summarize(args.work)


if __name__ == "__main__":
    main()
