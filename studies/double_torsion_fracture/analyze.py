"""Double torsion with damage: crack fronts, compressive damage, force, compliance and the energy
release rate of each run of the two scans ``cases/scans/double_torsion_contact.toml`` ((4.11)
and (4.12)) and ``cases/scans/double_torsion_buffer.toml`` ((4.11) with four buffer layers).

For each run (its ``results.h5`` alone):

* the crack front at each snapshot: the ``alpha = 0.9`` contour on the crack plane, drawn from
  the nodes within ``h / 2`` of y = 0 in the (x, z) plane (the dissertation's Figs. 4.3, 4.5, 4.8);
* the compressive damage: the volume of the cells of the top half (z > T/2) whose mean damage is
  at least 0.9 and whose strain trace is negative at the last step, in mm^3 (spurious cracks
  where the material is compressed; Fig. 4.3 against 4.5 and 4.8);
* the force at the last step and the compliance ``t / F`` against the crack length
  ``a + a0 = S / (Gc T) + a0`` (Figs. 4.4, 4.6, 4.9), with the classical (4.1) and Fuller's line;
* the energy release rate G / Gc from (4.17) (``fem3d.release``) against ``a + a0`` (Fig. 4.12's
  check: 1 within 5 % during stable growth, for a between 0.2 L and 0.7 L; and over every step
  of growth past the first 2 mm).

Usage (from the repository root, after the two scans)::

    python -m studies.double_torsion_fracture.analyze cases/scans/double_torsion_contact cases/scans/double_torsion_buffer

Writes ``studies/double_torsion_fracture/results/runs.csv`` and the figures ``fronts.png``,
``compliance.png`` and ``release_rate.png`` there.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fem3d import kernels, split as splits, torsion_theory  # noqa: E402
from fem3d.specimens.double_torsion import TABLE_4_1  # noqa: E402
from fem3d.release import energy_release_rate  # noqa: E402
from thinfilm.results.reader import Results  # noqa: E402

HERE = Path(__file__).resolve().parent
T, A0, L = TABLE_4_1["T"], TABLE_4_1["a0"], TABLE_4_1["L"]


def label(record):
    """A run's name from its scan record's overrides."""
    o = record.get("overrides", {})
    name = {"amor": "(4.11)", "positive": "(4.12)"}.get(o.get("model.split", "amor"), "?")
    if "model.buffers.buffer" in o:
        name += f" + buffer {o['geometry.buffer']:g} mm, E/E_b = {TABLE_4_1['E'] / o['model.buffers.buffer']:.0e}"
    return name


def runs(scan_dirs):
    """``(label, run directory)`` of every finished run of the scans."""
    out = []
    for scan in scan_dirs:
        for run in sorted((Path(scan) / "runs").iterdir()):
            record = json.loads((run / "run.json").read_text())
            if (run / "summary.json").exists():
                out.append((label(record), run))
    return out


def compressive_damage(res, k):
    """Volume (mm^3) of the top-half cells with mean damage >= 0.9 and negative strain trace."""
    mesh = res.discretization
    points, cells = np.asarray(mesh.points), np.asarray(mesh.cells)
    u = res.nodal("u", k)[: points.shape[0] * 3]
    alpha = res.nodal("alpha", k)
    grads, measure = kernels.cell_geometry(points, cells)
    strain = kernels.p1_strain(grads, cells, u)
    z = points[cells, 2].mean(axis=1)
    broken = alpha[cells].mean(axis=1) >= 0.9
    compressed = ~splits.tension(strain, 3)
    return float(measure[broken & compressed & (z > 0.5 * T)].sum())


def front(res, k, h):
    """The nodes within h/2 of the crack plane: (x, z, alpha)."""
    points = np.asarray(res.discretization.points)
    near = np.abs(points[:, 1]) <= 0.5 * h
    return points[near, 0], points[near, 2], res.nodal("alpha", k)[near]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scans", nargs="+", type=Path)
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    found = runs(args.scans)
    rows = []
    fig_f, axes_f = plt.subplots(len(found), 1, figsize=(9, 1.6 * len(found) + 0.6), sharex=True, squeeze=False)
    fig_c, ax_c = plt.subplots(figsize=(6.5, 4.5))
    fig_g, ax_g = plt.subplots(figsize=(6.5, 4.5))
    for i, (name, run) in enumerate(found):
        with Results(run / "results.h5") as res:
            p = res.parameters
            h, Gc = float(p["h"]), float(p["Gc"])
            t = np.asarray(res.t)
            force = np.asarray(res.steps["force"])
            surface = np.asarray(res.steps["surface"])
            a = surface / (Gc * T) + A0
            G, a_G = energy_release_rate(t, res.steps["elastic"], surface, Gc, T, a0=A0, da_min=h)
            last = res.n - 1
            growing = (a_G >= A0 + 0.2 * L) & (a_G <= A0 + 0.7 * L) & np.isfinite(G)
            grown = (a_G >= A0 + 2.0) & np.isfinite(G)
            rows.append({"run": name, "steps": res.n, "t_last": float(t[last]), "force_last": float(force[last]),
                         "peak_force": float(force.max()), "a_last": float(a[last]),
                         "G_over_Gc_median_0.2L_0.7L": float(np.median(G[growing] / Gc)) if growing.any() else np.nan,
                         "G_steps_in_window": int(growing.sum()),
                         # every step of growth past the first 2 mm (the front formed)
                         "G_over_Gc_growth_median": float(np.median(G[grown] / Gc)) if grown.any() else np.nan,
                         "G_over_Gc_growth_max_deviation": float(np.max(np.abs(G[grown] / Gc - 1)))
                         if grown.any() else np.nan, "G_steps_growth": int(grown.sum()),
                         "compressive_damage_mm3": compressive_damage(res, last), "iterations":
                         int(np.sum(res.steps["iterations"]))})
            ax = axes_f[i, 0]
            snapshots = [k for k in range(res.n) if np.isclose(t[k] / t[last] * 4, round(t[k] / t[last] * 4))
                         and t[k] > 0]
            for k in snapshots:
                x, z, al = front(res, k, h)
                if al.max() >= 0.9:
                    ax.tricontour(x, z, al, levels=[0.9], colors=[plt.cm.viridis(t[k] / t[last])], linewidths=1.2)
            ax.set_ylabel("z [mm]")
            ax.set_title(f"{name}: fronts (alpha = 0.9 on y = 0) at t = "
                         + ", ".join(f"{t[k]:.3g}" for k in snapshots) + " mm", fontsize=8)
            ax.set_ylim(0, T)
            sound = surface == 0.0
            ax_c.plot(a[1:], (t / np.where(force > 0, force, np.nan))[1:], ".-", ms=3, label=name)
            ax_g.plot(a_G, G / Gc, ".-", ms=3, label=name)
    axes_f[-1, 0].set_xlabel("x [mm]")
    fig_f.tight_layout()
    fig_f.savefig(args.out / "fronts.png", dpi=130)
    aa = np.linspace(A0, L, 50)
    for reading, style in ((None, "k-"), ("T/W", "k--"), ("2T/W", "k:")):
        slope = torsion_theory.compliance_slope(TABLE_4_1["E"], TABLE_4_1["nu"], TABLE_4_1["W"], T, TABLE_4_1["Wm"],
                                                fuller=reading)
        ax_c.plot(aa, slope * aa, style, lw=0.8, label="(4.1)" if reading is None else f"Fuller, tau = {reading}")
    ax_c.set_xlabel("a + a0 [mm]")
    ax_c.set_ylabel("compliance t / F [mm/N]")
    ax_c.legend(fontsize=7)
    fig_c.tight_layout()
    fig_c.savefig(args.out / "compliance.png", dpi=130)
    ax_g.axhline(1.0, color="k", lw=0.8)
    ax_g.axvspan(A0 + 0.2 * L, A0 + 0.7 * L, color="0.9")
    ax_g.set_ylim(0, 2)
    ax_g.set_xlabel("a + a0 [mm]")
    ax_g.set_ylabel("G / Gc, (4.17)")
    ax_g.legend(fontsize=7)
    fig_g.tight_layout()
    fig_g.savefig(args.out / "release_rate.png", dpi=130)
    with open(args.out / "runs.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()
