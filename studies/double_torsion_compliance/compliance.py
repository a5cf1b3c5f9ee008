"""The elastic double-torsion compliance C(a + a0) from the scan over the explicit crack length,
against the two-torsion-bar model (4.1) and Fuller's correction (both readings).

It runs no solver: it reads finished ``thinfilm scan`` runs of
``cases/scans/double_torsion_compliance.toml`` (their ``scan.csv`` and ``scan.json``), fits a
straight line over the mid-length cracks (a + a0 in 0.25 L ... 0.75 L) and writes

- ``results/<stem>.csv``: for each scan (element, mesh sizes) and crack, a, a + a0 (mm), the
  computed compliance and the classical lines (mm/N);
- ``results/<stem>.md``: each scan's fitted slope against (4.1) and Fuller, its local slopes;
- ``results/<stem>.png``: C against a + a0, one series per scan, with the classical and
  Fuller lines.

Usage (from the repository root)::

    thinfilm scan cases/scans/double_torsion_compliance.toml --out studies/double_torsion_compliance/scan
    python -m studies.double_torsion_compliance.compliance studies/double_torsion_compliance/scan

P2, the same scan with every run's element (and here the mesh) overridden, drawn with the P1
scan::

    thinfilm scan cases/scans/double_torsion_compliance.toml --set 'model.element="P2"' \\
        --set mesh.h=1.5 --set mesh.h_coarse=1.5 --out studies/double_torsion_compliance/scan_p2_h1.5
    python -m studies.double_torsion_compliance.compliance studies/double_torsion_compliance/scan \\
        studies/double_torsion_compliance/scan_p2_h1.5
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

import numpy as np

from fem3d.specimens.double_torsion import TABLE_4_1
from studies.double_torsion_compliance.theory_lines import RESULTS, SCAN, WINDOW, classical_slopes, fit
from thinfilm.scan.table import read_table
from thinfilm.scene import load_scene


def read_scan(directory):
    """``(a, C, scene)``: the crack lengths (mm), the compliances (mm/N) of the runs that are
    done, sorted by a, and the first run's scene (its mesh and geometry)."""
    directory = Path(directory)
    plan = json.loads((directory / "scan.json").read_text(encoding="utf-8"))
    rows = [r for r in read_table(directory / "scan.csv") if r["status"] == "done"]
    if not rows:
        raise SystemExit(f"{directory}: no finished run")
    a = np.array([float(r["geometry.crack"]) for r in rows])
    C = np.array([float(r["compliance"]) for r in rows])
    order = np.argsort(a)
    first = next(run for run in plan["runs"] if run["name"] == rows[0]["run"])
    scene = load_scene(plan["base"], overrides=first["overrides"])
    return a[order], C[order], scene


def geometry_of(scene):
    """The scene's specimen: Table 4.1 with its ``[geometry]`` keys, and the load offset."""
    options = dict(scene.geometry.options)
    values = {"L": options.get("length", TABLE_4_1["L"]), "W": options.get("width", TABLE_4_1["W"]),
              "T": options.get("thickness", TABLE_4_1["T"]), "Wm": options.get("support", TABLE_4_1["Wm"]),
              "a0": options.get("notch", TABLE_4_1["a0"])}
    values["load_offset"] = options.get("load_offset", 0.5 * options.get("notch_width", 0.5))
    return values


def report(scans, stem):
    """Write the table, the page and the figure of ``scans``, a list of ``(a, C, scene)``."""
    g = geometry_of(scans[0][2])
    m = scans[0][2].model
    lines = classical_slopes(m.E, m.nu, g["W"], g["T"], g["Wm"])
    arm = classical_slopes(m.E, m.nu, g["W"], g["T"], g["Wm"], g["load_offset"])
    RESULTS.mkdir(parents=True, exist_ok=True)
    labels = [f"{getattr(scene.model, 'element', 'P1')}, h = {scene.mesh.h:g} mm" for _, _, scene in scans]

    with open(RESULTS / f"{stem}.csv", "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["element", "h_mm", "h_coarse_mm", "a_mm", "a_plus_a0_mm", "C_fem_mm_per_N"]
                   + [f"C_{k.replace(' ', '_').replace('/', '')}_mm_per_N" for k in lines])
        for a, C, scene in scans:
            for ai, ci in zip(a, C):
                ti = ai + g["a0"]
                w.writerow([getattr(scene.model, "element", "P1"), f"{scene.mesh.h:g}", f"{scene.mesh.h_coarse:g}",
                            f"{ai:g}", f"{ti:g}", f"{ci:.6e}"] + [f"{s * ti:.6e}" for s in lines.values()])

    window = f"{WINDOW[0] * g['L']:g}-{WINDOW[1] * g['L']:g} mm"
    text = [f"# Double-torsion compliance against the crack length ({stem})", "",
            f"Explicit straight cracks a beyond the notch a0 = {g['a0']:g} mm; slopes fitted over a + a0 = {window}.",
            "References (1/N): " + ", ".join(f"{k} {v:.4e}" for k, v in lines.items())
            + f"; with the moment arm Wm - load offset = {g['Wm'] - g['load_offset']:g} mm: "
            + ", ".join(f"{k} {v:.4e}" for k, v in arm.items()) + ".", "",
            "| run | points | dC/da (1/N) | intercept (mm/N) | " + " | ".join(f"/ {k}" for k in lines)
            + f" | / {list(arm)[-1]}, arm {g['Wm'] - g['load_offset']:g} mm |",
            "|---|---|---|---|" + "---|" * (len(lines) + 1)]
    fits = []
    for (a, C, scene), label in zip(scans, labels):
        slope, offset, mask = fit(a + g["a0"], C, g["L"])
        fits.append((slope, offset, mask))
        text.append(f"| {label} (arms {scene.mesh.h_coarse:g} mm) | {int(mask.sum())} | {slope:.4e} | {offset:.4e} | "
                    + " | ".join(f"{slope / v:.3f}" for v in lines.values())
                    + f" | {slope / list(arm.values())[-1]:.3f} |")
    for (a, C, _), label in zip(scans, labels):
        t = a + g["a0"]
        text += ["", f"Local slopes, {label}:", "", "| a + a0 (mm) | C (mm/N) | dC/da to the next (1/N) |",
                 "|---|---|---|"]
        local = list(np.diff(C) / np.diff(a)) + [None]
        text += [f"| {ti:g} | {ci:.4e} | {'' if s is None else f'{s:.4e}'} |" for ti, ci, s in zip(t, C, local)]
    (RESULTS / f"{stem}.md").write_text("\n".join(text) + "\n", encoding="utf-8")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    x = np.linspace(0.0, g["L"], 2)
    for (key, s), style in zip(lines.items(), ("-", "--", ":")):
        ax.plot(x, 1e3 * s * x, "k" + style, lw=1.2, label=f"{key}: {s:.3e} 1/N")
    for k, ((a, C, _), label, (slope, offset, mask)) in enumerate(zip(scans, labels, fits)):
        t = a + g["a0"]
        ax.plot(t, 1e3 * C, "os^v"[k % 4], color=f"C{k}", label=f"{label}: {slope:.3e} 1/N (fit over {window})")
        ax.plot(t[mask], 1e3 * (slope * t[mask] + offset), "-", color=f"C{k}", lw=0.8)
    ax.axvspan(WINDOW[0] * g["L"], WINDOW[1] * g["L"], color="0.93", zorder=0)
    ax.set_xlabel("a + a0 (mm)")
    ax.set_ylabel("compliance (1e-3 mm/N)")
    ax.set_xlim(0.0, g["L"])
    ax.set_ylim(bottom=0.0)
    ax.set_title("Double torsion, Table 4.1, elastic, explicit straight crack")
    ax.legend(fontsize=7.5, loc="upper left")
    fig.tight_layout()
    fig.savefig(RESULTS / f"{stem}.png", dpi=130)
    plt.close(fig)
    print("\n".join(text))
    print(f"wrote {RESULTS / (stem + '.csv')}, {RESULTS / (stem + '.md')}, {RESULTS / (stem + '.png')}")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("scans", nargs="*", default=[str(SCAN)],
                        help="scan directories, each a series of the figure (default: %(default)s)")
    parser.add_argument("--stem", default="compliance", help="name of the result files (default: %(default)s)")
    args = parser.parse_args(argv)
    report([read_scan(d) for d in args.scans], args.stem)


if __name__ == "__main__":
    main()
