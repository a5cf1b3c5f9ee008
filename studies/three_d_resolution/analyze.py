"""The 3D specimens at the finest resolution two cores reach in an hour: the 3D L-panel
(Fig. 3.5) and the Brokenshire torsion prism (Figs. 3.17-3.18), each at the case file's eps
and at finer ones.

Usage (from the repository root)::

    python -m studies.three_d_resolution.analyze --run /tmp/three_d   # the runs, then the tables
    python -m studies.three_d_resolution.analyze /tmp/three_d         # the tables from runs made

Each run is ``/usr/bin/time -v python -m thinfilm run cases/<case>.toml --threads 1`` with the
``--set`` of :data:`RUNS`, in ``WORK/<name>`` (its log, with the wall time and peak memory,
in ``WORK/<name>.log``). Writes ``results/lpanel_3d.csv``, ``results/brokenshire.csv`` and
``results/brokenshire_traces.png`` and
``results/brokenshire_finest_crack.png``.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from benchmarks.bench_adaptive import time_report
from studies.runs import run_case, study_main

RESULTS = Path(__file__).resolve().parent / "results"

#: name -> (case, the run's ``--set`` options). eps/h = 2 but for the finest prism (1.5).
RUNS = {
    "lpanel_3d_eps10_h5": ("lpanel_3d", []),
    "lpanel_3d_eps7.5_h3.75": ("lpanel_3d", ["model.eps=7.5", "mesh.h=3.75"]),
    "lpanel_3d_eps6.25_h3.125": ("lpanel_3d", ["model.eps=6.25", "mesh.h=3.125"]),
    "brokenshire_eps12.5_h3.125": ("brokenshire", []),
    "brokenshire_eps5_h2.5": ("brokenshire", ["model.eps=5.0", "mesh.h=2.5"]),
    "brokenshire_eps2.5_h1.667": ("brokenshire", ["model.eps=2.5", "mesh.h=1.6667"]),
}

#: The L-panel's re-entrant edge in (x, y), mm, and the slices through its depth.
CORNER = (250.0, 250.0)
DEPTHS = (0.0, 20.0, 40.0, 60.0, 80.0, 100.0)
#: The prism's horizontal sections (mm above its bottom face; the notch's floor is at 50).
LEVELS = (45.0, 40.0, 30.0, 20.0, 10.0, 5.0)
#: The prism's thirds of its width: y < -25, |y| < 25, y > 25 mm.
THIRDS = {"whole": (-np.inf, np.inf), "y<-25": (-np.inf, -25.0), "middle": (-25.0, 25.0), "y>25": (25.0, np.inf)}


def run(work, names):
    work.mkdir(parents=True, exist_ok=True)
    for name in names:
        case, sets = RUNS[name]
        run_case(case, sets, work / name, log=work / f"{name}.log")


def wall_and_memory(log):
    """Wall time (min) and peak memory (GB) from the run's ``/usr/bin/time -v`` report."""
    seconds, peak_gb = time_report(log)
    return round(seconds / 60.0, 1), round(peak_gb, 2)


def jump(res, run):
    """The step the crack appeared at: the run's first crack event (``summary.json``)."""
    first = json.loads((Path(run) / "summary.json").read_text())["events"][0]["t"]
    return int(np.flatnonzero(np.asarray(res.t) == first)[0])


def lpanel_row(name, res, work):
    from fem3d.cracks import crack_through_depth

    k, last = jump(res, work / name), res.n - 1
    p = res.parameters
    F = np.asarray(res.steps["force"])
    row = dict(run=name, eps=p["eps"], h=p["h"], nodes=res.discretization_at(last).points.shape[0],
               stiffness_kN_per_mm=round(float(F[1] / res.t[1]) / 1e3, 2), crack_at_mm=round(float(res.t[k]), 4),
               force_before_kN=round(float(F[k - 1]) / 1e3, 2),
               area_mm2=f"{res.steps['surface'][k - 1] / p['Gc']:.0f} -> {res.steps['surface'][k] / p['Gc']:.0f}")
    for label, step in (("jump", k), ("end", last)):
        mesh = res.discretization_at(step)
        slabs = crack_through_depth(mesh.points, res.field("alpha", step), CORNER, DEPTHS, 2.0 * float(p["h"]))
        # the crack runs left of the corner: its angle above the horizontal is 180 - the chord's
        angles = [180.0 - s[3] for s in slabs]
        row[f"{label}_angle_deg"] = f"{min(angles):.1f}-{max(angles):.1f}"
        row[f"{label}_tip_mm"] = f"{min(s[2] for s in slabs):.0f}-{max(s[2] for s in slabs):.0f}"
        row[f"{label}_start_mm"] = round(max(s[1] for s in slabs), 1)
    row["energy_end"] = round(float(res.steps["elastic"][last] + res.steps["surface"][last]), 1)
    row["wall_min"], row["memory_GB"] = wall_and_memory(work / f"{name}.log")
    row["iterations"] = int(np.sum(res.steps["iterations"]))
    return row


def brokenshire_row(name, res, work, ax=None):
    from fem3d.cracks import trace_angles, twist

    k, last = jump(res, work / name), res.n - 1
    p = res.parameters
    F = np.asarray(res.steps["force"])
    peak = int(np.argmax(F))
    mesh = res.discretization_at(last)
    points, alpha = mesh.points, res.field("alpha", last)
    row = dict(run=name, eps=p["eps"], h=p["h"], nodes=points.shape[0], crack_at_mm=round(float(res.t[k]), 3),
               peak_kN=round(float(F[peak]) / 1e3, 2), peak_at_mm=round(float(res.t[peak]), 3),
               area_mm2=f"{res.steps['surface'][k - 1] / p['Gc']:.0f} -> {res.steps['surface'][k] / p['Gc']:.0f}")
    width = max(2.0 * float(p["h"]), 2.5)
    for third, (lo, hi) in THIRDS.items():
        inside = (points[:, 1] > lo) & (points[:, 1] < hi)
        traces = trace_angles(points, np.where(inside, alpha, 0.0), LEVELS, width)
        unwrapped, turn = twist([t[1] for t in traces])
        row[f"{third}_deg"] = " ".join(f"{a:.0f}" for a in unwrapped)
        row[f"{third}_turn_deg"] = round(turn, 1)
        if ax is not None and third == "whole":
            ax.plot(unwrapped, LEVELS[: len(unwrapped)], ".-", label=f"eps = {p['eps']:g} mm, h = {p['h']:g} mm")
    row["wall_min"], row["memory_GB"] = wall_and_memory(work / f"{name}.log")
    row["iterations"] = int(np.sum(res.steps["iterations"]))
    return row


def write(path, rows):
    with open(path, "w", newline="") as f:
        if rows:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    for r in rows:
        print(r)


def summarize(work, names):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from thinfilm.results.reader import Results

    RESULTS.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(5.0, 4.0))
    panels, prisms = [], []
    for name in names:
        if not (work / name / "summary.json").exists():
            continue
        with Results(work / name) as res:
            if RUNS[name][0] == "lpanel_3d":
                panels.append(lpanel_row(name, res, work))
            else:
                prisms.append(brokenshire_row(name, res, work, ax))
    write(RESULTS / "lpanel_3d.csv", panels)
    write(RESULTS / "brokenshire.csv", prisms)
    ax.set_xlabel("trace's angle to the axis, whole width (deg)")
    ax.set_ylabel("section z (mm)")
    ax.set_title("Brokenshire: the crack's trace on horizontal sections at t = 1 mm", fontsize=9)
    if prisms:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(RESULTS / "brokenshire_traces.png", dpi=110)
    if prisms:
        finest = min(prisms, key=lambda r: r["eps"])["run"]
        sections(work / finest, RESULTS / "brokenshire_finest_crack.png")


def sections(run, path):
    """The finest prism's crack from above and on three sections (:func:`fem3d.plots.crack_sections_figure`),
    stored at three quarters of its size in 128 colours to keep the file small."""
    from PIL import Image

    from fem3d.plots import crack_sections_figure
    from thinfilm.results.reader import Results

    with Results(run) as res:
        crack_sections_figure(res, path, [45, 25, 5], xlim=(120, 280), ylim=(-60, 60))
    image = Image.open(path).convert("RGB")
    image = image.resize((image.width * 3 // 4, image.height * 3 // 4), Image.LANCZOS).quantize(colors=128)
    image.save(path, optimize=True)


def main(argv=None):
    study_main(__doc__.splitlines()[0], Path("/tmp/three_d"), RUNS, run, summarize,
               duration="about 2 hours on one thread", argv=argv)


if __name__ == "__main__":
    main()
