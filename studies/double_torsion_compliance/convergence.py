"""The slope dC/da of the elastic double-torsion specimen over mid-length cracks against the
mesh size: how far P1 tetrahedra are from the converged elastic solution.

For each mesh size h (uniform: ``mesh.h = mesh.h_coarse = h``) the case file
``cases/double_torsion_elastic.toml`` is solved once for each of two cracks, a = 16 and 48 mm
(a + a0 = 23 and 55 mm, the ends of the mid-length window), with one u-solve each (no results
file); the slope is the difference quotient. The fitted order p of ``s(h) = s0 - c h^p``
through the three finest sizes and the extrapolated s0 say where the sequence is heading.

Usage (from the repository root; the h = 0.5 mm pair takes 3 min and 2 GB, each h = 0.375 mm
solve 5 min and 3.7 GB on the loaded 2-core machine)::

    python -m studies.double_torsion_compliance.convergence --h 1.5 1.0 0.75 0.5
    python -m studies.double_torsion_compliance.convergence --h 0.375 --cracks 16
    python -m studies.double_torsion_compliance.convergence --h 0.375 --cracks 48
    python -m studies.double_torsion_compliance.convergence --h 1.5 1.0 --set 'model.element="P2"' \\
        --stem convergence_p2

Writes ``results/<stem>.csv`` (one row per solve; a call keeps the rows of earlier calls with the
same stem and replaces those it solves again) and ``results/<stem>.md`` (the slopes of the sizes
with both cracks; default stem ``convergence``).
"""

from __future__ import annotations

import argparse
import csv
import time
import tomllib
from pathlib import Path

import numpy as np
from scipy.optimize import brentq

from fem3d import torsion_theory as theory
from fem3d.specimens.double_torsion import TABLE_4_1
from studies.double_torsion_compliance.theory_lines import RESULTS, classical_slopes
from thinfilm.scene import load_scene

CRACKS = (16.0, 48.0)   # mm beyond the notch
CASE = Path(__file__).resolve().parents[2] / "cases" / "double_torsion_elastic.toml"


def compliance(h, a, overrides):
    """Load-point compliance (mm/N) of the case file at uniform size h with a crack a, and the
    mesh's node count."""
    from fem3d.kind import build_mesh, build_model

    scene = load_scene(CASE, overrides={"mesh.h": h, "mesh.h_coarse": h, "geometry.crack": a, **overrides})
    mesh = build_mesh(scene)
    model = build_model(scene, mesh)
    alpha = np.zeros(model.n_alpha)
    t = scene.load.t_max
    u = model.solve_u(alpha, t, None, 1e-10)
    return t / model.forces(u, alpha, t)["load_points"], mesh.n_nodes


def fitted_order(h, s):
    """``(p, s0)`` of ``s = s0 - c h^p`` through three points (h decreasing); None if no
    order in (0.05, 8) fits."""
    r = (s[1] - s[0]) / (s[2] - s[1])
    if not r > 0.0:
        return None

    def g(p):
        return (h[0] ** p - h[1] ** p) / (h[1] ** p - h[2] ** p) - r

    try:
        p = brentq(g, 0.05, 8.0)
    except ValueError:
        return None
    c = (s[2] - s[1]) / (h[1] ** p - h[2] ** p)
    return p, s[2] + c * h[2] ** p


def read_rows(path):
    """The solves already in ``path``: ``{(h, a): row}``."""
    if not path.exists():
        return {}
    with open(path, newline="", encoding="utf-8") as f:
        return {(float(r["h_mm"]), float(r["a_mm"])): r for r in csv.DictReader(f)}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--h", type=float, nargs="+", default=[1.5, 1.0, 0.75, 0.5], help="mesh sizes (mm)")
    parser.add_argument("--cracks", type=float, nargs="+", default=list(CRACKS), choices=CRACKS,
                        help="which of the two cracks to solve (mm; default both)")
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="overrides",
                        help="a scene key for every solve, e.g. 'model.element=\"P2\"'")
    parser.add_argument("--stem", default="convergence")
    args = parser.parse_args(argv)
    overrides = {}
    for item in args.overrides:
        key, _, value = item.partition("=")
        overrides[key.strip()] = tomllib.loads(f"v = {value}")["v"]
    RESULTS.mkdir(parents=True, exist_ok=True)
    path = RESULTS / f"{args.stem}.csv"
    rows = read_rows(path)   # the solves of earlier calls with this stem are kept
    for h in sorted(args.h, reverse=True):
        for a in args.cracks:
            start = time.perf_counter()
            C, nodes = compliance(h, a, overrides)
            rows[(h, a)] = {"h_mm": f"{h:g}", "a_mm": f"{a:g}", "nodes": nodes, "C_mm_per_N": f"{C:.6e}",
                            "seconds": f"{time.perf_counter() - start:.0f}"}
            print(rows[(h, a)], flush=True)
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=["h_mm", "a_mm", "nodes", "C_mm_per_N", "seconds"])
        w.writeheader()
        for key in sorted(rows, key=lambda k: (-k[0], k[1])):
            w.writerow(rows[key])

    E, nu, W, T, Wm = (TABLE_4_1[k] for k in ("E", "nu", "W", "T", "Wm"))
    load_offset = 0.25   # the case file's: notch_width / 2
    saint_venant = theory.compliance_slope(E, nu, W, T, Wm, load_offset, fuller="2T/W")
    lines = classical_slopes(E, nu, W, T, Wm)
    hs = sorted({h for h, a in rows if all((h, c) in rows for c in CRACKS)}, reverse=True)
    slopes = [(float(rows[(h, CRACKS[1])]["C_mm_per_N"]) - float(rows[(h, CRACKS[0])]["C_mm_per_N"]))
              / (CRACKS[1] - CRACKS[0]) for h in hs]
    text = [f"# Double-torsion compliance slope against the mesh size ({args.stem})", "",
            f"Cracks a = {CRACKS[0]:g} and {CRACKS[1]:g} mm (a + a0 = {CRACKS[0] + 7:g}, {CRACKS[1] + 7:g} mm),"
            " uniform mesh size h (h = mesh.h = mesh.h_coarse, the tetrahedra's median edge), the case file's"
            " option A boundary conditions" + (f", overrides {overrides}" if overrides else "") + ".", "",
            "Reference slopes (1/N): " + ", ".join(f"{k} {v:.4e}" for k, v in lines.items())
            + f"; two torsion bars with Saint-Venant's constant (Fuller 2T/W) and the moment arm Wm - 0.25 mm:"
            f" {saint_venant:.4e} (SV).", "",
            "| h (mm) | T / h | nodes | dC/da (1/N) | / (4.1) | / Fuller T/W | / Fuller 2T/W | / SV"
            " | s (both solves) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for h, s in zip(hs, slopes):
        r0, r1 = rows[(h, CRACKS[0])], rows[(h, CRACKS[1])]
        text.append(f"| {h:g} | {T / h:.1f} | {r1['nodes']} | {s:.4e} | {s / lines['(4.1)']:.3f} |"
                    f" {s / lines['Fuller T/W']:.3f} | {s / lines['Fuller 2T/W']:.3f} | {s / saint_venant:.3f} |"
                    f" {int(r0['seconds']) + int(r1['seconds'])} |")
    if len(hs) >= 3:
        h3, s3 = hs[-3:], slopes[-3:]
        first = s3[2] + (s3[2] - s3[1]) * h3[2] / (h3[1] - h3[2])
        text += ["", f"First-order extrapolation from the two finest: {first:.4e} 1/N ({first / saint_venant:.3f} SV)."]
        for hh, ss, label in ((hs[-3:], slopes[-3:], "three finest"), (hs[-4:-1], slopes[-4:-1], "next three")):
            fitted = fitted_order(hh, ss) if len(hh) == 3 else None
            if fitted:
                p, s0 = fitted
                text.append(f"Fit s = s0 - c h^p through the {label} ({', '.join(f'{x:g}' for x in hh)} mm):"
                            f" p = {p:.2f}, s0 = {s0:.4e} 1/N ({s0 / saint_venant:.3f} SV).")
    (RESULTS / f"{args.stem}.md").write_text("\n".join(text) + "\n", encoding="utf-8")
    print("\n".join(text))


if __name__ == "__main__":
    main()
