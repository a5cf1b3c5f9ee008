"""The correction-factor scan (the dissertation's section 4.6, Figs. 4.12 and 4.13): the
energy release rate and the correction factor psi(a) of the eight non-dimensional
double-torsion plates of ``cases/scans/double_torsion_correction.toml``.

For each run (its ``results.h5`` alone: the scene stored there, with its overrides, gives the
geometry), at every step where the crack grew by at least one mesh size:

* ``a = S / (Gc T) + a0`` (a0 = 0.1 L) and ``G`` from (4.17) (:mod:`fem3d.release`);
* the crack front read off the damage: the largest x where ``alpha >= 0.9`` on the crack
  plane (the nodes within h/2 of y = 0), on the bottom face (``a_bottom``) and at mid-thickness
  (``a_mid``). ``S / (Gc T)`` counts every damaged volume, the band's width included, so it is
  compared with the fronts: their ratio says how far the surface energy over-counts the crack;
* the classical (4.2) at the run's force, ``G_42 = 3 P^2 Wm^2 (1 + nu) / (W T^4 E)``;
* ``psi_sim = G_42 / G``: in Fuller's convention ``G = G_42 / psi``, below 1 for a specimen
  more compliant than two torsion bars; and ``psi_1 = G_42 / Gc`` (taking G = Gc, the
  dissertation's reading of its propagation; the two differ by G/Gc).

The collapse of Fig. 4.13: for each L/W, the largest relative spread (max - min over mean)
of psi_sim among W/T = 9..12 on a common grid of ``0.2 <= a/L <= 0.6``.

Usage (from the repository root)::

    python -m studies.double_torsion_correction.analyze cases/scans/double_torsion_correction

Writes ``studies/double_torsion_correction/results/psi.csv``, ``collapse.md`` and
``correction.png``.
"""

from __future__ import annotations

import argparse
import csv
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from fem3d import torsion_theory  # noqa: E402
from fem3d.release import energy_release_rate  # noqa: E402
from thinfilm.results.reader import Results  # noqa: E402
from thinfilm.resume import scene_keys  # noqa: E402

HERE = Path(__file__).resolve().parent
L, A0, NU, E, GC = 1.0, 0.1, 0.22, 1.0, 1.0


def curves(scan):
    """One dict per finished run of the scan (:func:`curve`)."""
    return [curve(run) for run in sorted((Path(scan) / "runs").iterdir())
            if (run / "summary.json").exists() and (run / "results.h5").exists()]


def geometry(res):
    """The plate's width W, thickness T and support offset Wm, from the scene stored in the
    results file with its ``--set`` overrides (a scan's run or a run of its own)."""
    keys = scene_keys(res.attrs["scene"], res.attrs.get("scene_overrides"))
    return float(keys["geometry.width"]), float(keys["geometry.thickness"]), float(keys["geometry.support"])


def curve(run):
    """A run's geometry and the arrays a, G, P, psi_sim, psi_1 at its steps of growth. On a
    refined mesh G is differenced across a refinement from the previous step's energies on the
    step's own mesh (docs/adaptivity.md#the-energy-release-rate) and the fronts are read on
    each step's mesh."""
    with Results(Path(run) / "results.h5") as res:
        W, T, Wm = geometry(res)
        h = float(res.parameters["h"])
        t = np.asarray(res.t)
        nan = np.full(t.size, np.nan)
        G, a = energy_release_rate(t, res.steps["elastic"], res.steps["surface"], GC, T, a0=A0, da_min=h,
                                   meshes=res.steps.get("mesh"),
                                   previous=(res.steps.get("elastic_previous", nan),
                                             res.steps.get("surface_previous", nan)))
        P = np.asarray(res.steps["force"])
        a_bottom, a_mid = fronts(res, T, h)
    G42 = torsion_theory.release_rate(P, E, NU, W, T, Wm)
    # growth: G defined, the crack past its notch, the bottom front not yet at the far end
    # (the plate then hangs on its uncracked top layer alone)
    grew = np.isfinite(G) & (a > A0 + 0.02 * L) & (a_bottom < 0.95 * L)
    return {"L/W": round(L / W), "W/T": round(W / T), "W": W, "T": T, "a": a[grew], "G": G[grew],
            "P": P[grew], "a_bottom": a_bottom[grew], "a_mid": a_mid[grew], "psi_sim": G42[grew] / G[grew],
            "psi_1": G42[grew] / GC, "fuller_2T/W": torsion_theory.psi(W, T, "2T/W"),
            "fuller_T/W": torsion_theory.psi(W, T, "T/W")}


def fronts(res, T, h):
    """The front's x on the bottom face and at mid-thickness at every step, shape (n,) each:
    the largest x of a crack-plane node (``|y| < h/2``) with ``alpha >= 0.9``, a0 when none
    (on each step's own mesh)."""
    out = np.full((2, res.n), A0)
    for k in range(res.n):
        points = res.discretization_at(k).points
        plane = np.abs(points[:, 1]) < 0.5 * h
        bottom = plane & (points[:, 2] < 0.25 * h)
        mid = plane & (np.abs(points[:, 2] - 0.5 * T) < 0.5 * h)
        cracked = res.nodal("alpha", k) >= 0.9
        for row, where in enumerate((bottom, mid)):
            hit = where & cracked
            if hit.any():
                out[row, k] = max(A0, float(points[hit, 0].max()))
    return out


def collapse(group):
    """Largest relative spread of psi_sim among the runs of one L/W over 0.2 <= a/L <= 0.6."""
    grid = np.linspace(0.2, 0.6, 41) * L
    if len(group) < 2:
        return np.nan, 0.0
    rows = []
    for c in group:
        order = np.argsort(c["a"])
        a, psi = c["a"][order], c["psi_sim"][order]
        inside = (grid >= a.min()) & (grid <= a.max())
        rows.append(np.where(inside, np.interp(grid, a, psi), np.nan))
    values = np.array(rows)
    covered = np.all(np.isfinite(values), axis=0)
    if not covered.any():
        return np.nan, 0.0
    v = values[:, covered]
    return float(np.max((v.max(axis=0) - v.min(axis=0)) / v.mean(axis=0))), float(covered.mean())


def step_table(name, c):
    """A markdown table of run ``name``'s steps of growth (``c``, its :func:`curve`): a, the
    fronts, the surface energy's over-count of the area the bottom front swept, G / Gc and
    psi_sim."""
    lines = [f"{name}: L/W = {c['L/W']}, W/T = {c['W/T']}", "",
             "| a / L | bottom front / L | mid front / L | (a - a0) / (bottom front - a0) | G / Gc | psi_sim |",
             "|---|---|---|---|---|---|"]
    for k in range(c["a"].size):
        swept = c["a_bottom"][k] - A0
        over = (c["a"][k] - A0) / swept if swept > 0 else np.nan
        lines.append(f"| {c['a'][k] / L:.3f} | {c['a_bottom'][k] / L:.3f} | {c['a_mid'][k] / L:.3f} | {over:.2f} |"
                     f" {c['G'][k] / GC:.3f} | {c['psi_sim'][k]:.2f} |")
    return "\n".join(lines) + "\n"


def runs_figure(found, scan_csv, path):
    """G/Gc and psi_sim against a/L of single runs, beside the scan's run of the same L/W and
    W/T (``scan_csv``, the scan's ``psi.csv``, if it has one)."""
    scan = {}
    if scan_csv.exists():
        with open(scan_csv) as f:
            for row in csv.DictReader(f):
                scan.setdefault((int(row["L/W"]), int(row["W/T"])), []).append((float(row["a"]), float(row["G"]),
                                                                                float(row["psi_sim"])))
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for c in found:
        label = f"L/W = {c['L/W']}, W/T = {c['W/T']}"
        rows = np.array(sorted(scan.get((c["L/W"], c["W/T"]), [])))
        if rows.size:
            axes[0].plot(rows[:, 0] / L, rows[:, 1] / GC, "s--", ms=3, label=f"{label}, the scan (h = T/4)")
            axes[1].plot(rows[:, 0] / L, rows[:, 2], "s--", ms=3, label=f"{label}, the scan (h = T/4)")
        order = np.argsort(c["a"])
        axes[0].plot(c["a"][order] / L, c["G"][order] / GC, "o-", ms=3, label=f"{label}, this run")
        axes[1].plot(c["a"][order] / L, c["psi_sim"][order], "o-", ms=3, label=f"{label}, this run")
    axes[0].axhline(1.0, color="k", lw=0.8)
    axes[0].set_ylim(0, 1.4)
    axes[0].set_title("G / Gc from (4.17)", fontsize=9)
    axes[1].set_title("psi_sim = G_(4.2)(P) / G", fontsize=9)
    for ax in axes:
        ax.set_xlabel("a / L, a = S / (Gc T) + a0")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scan", type=Path, nargs="?")
    parser.add_argument("--runs", type=Path, nargs="+", default=[],
                        help="single runs (finished or not) to tabulate step by step instead, into runs.md")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.runs:
        found = [curve(run) for run in args.runs]
        text = "\n".join(step_table(run.name, c) for run, c in zip(args.runs, found))
        (args.out / "runs.md").write_text(text)
        runs_figure(found, args.out / "psi.csv", args.out / "runs.png")
        print(text)
        return
    found = sorted(curves(args.scan), key=lambda c: (c["L/W"], c["W/T"]))
    fig, axes = plt.subplots(3, 2, figsize=(11, 10.5))
    lines = ["| L/W | runs | largest spread of psi_sim over W/T = 9..12, 0.2 <= a/L <= 0.6 | part of the window"
             " covered by all runs |", "|---|---|---|---|"]
    with open(args.out / "psi.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["L/W", "W/T", "a", "a_bottom", "a_mid", "G", "P", "psi_sim", "psi_1"])
        for c in found:
            for k in range(c["a"].size):
                w.writerow([c["L/W"], c["W/T"], f"{c['a'][k]:.6g}", f"{c['a_bottom'][k]:.6g}",
                            f"{c['a_mid'][k]:.6g}", f"{c['G'][k]:.6g}", f"{c['P'][k]:.6g}",
                            f"{c['psi_sim'][k]:.6g}", f"{c['psi_1'][k]:.6g}"])
    for col, ratio in enumerate((2, 3)):
        group = [c for c in found if c["L/W"] == ratio]
        spread, covered = collapse(group)
        lines.append(f"| {ratio} | {len(group)} | {spread:.3f} | {covered:.2f} |")
        for c in group:
            order = np.argsort(c["a"])
            label = f"W/T = {c['W/T']}"
            axes[0, col].plot(c["a"][order] / L, c["G"][order] / GC, ".-", ms=3, label=label)
            line, = axes[1, col].plot(c["a"][order] / L, c["psi_sim"][order], ".-", ms=3, label=label)
            axes[1, col].axhline(c["fuller_2T/W"], color=line.get_color(), lw=0.6, ls=":")
            axes[2, col].plot(c["a_mid"][order] / L, c["psi_sim"][order], ".-", ms=3, color=line.get_color(),
                              label=label)
            axes[2, col].plot(c["a_bottom"][order] / L, c["psi_sim"][order], ":", color=line.get_color(), lw=0.8)
        axes[0, col].axhline(1.0, color="k", lw=0.8)
        axes[0, col].set_ylim(0, 1.4)
        axes[0, col].set_title(f"L/W = {ratio}: G / Gc from (4.17) (Fig. 4.12)", fontsize=9)
        axes[1, col].set_title(f"L/W = {ratio}: psi_sim = G_(4.2)(P) / G (Fig. 4.13)\n"
                               "(dotted: Fuller's psi, tau = 2T/W)", fontsize=9)
        axes[1, col].axvspan(0.2, 0.6, color="0.92")
        axes[1, col].set_xlabel("a / L, a = S / (Gc T) + a0")
        axes[2, col].set_title(f"L/W = {ratio}: psi_sim against the front on y = 0\n"
                               "(solid: mid-thickness, dotted: bottom face)", fontsize=9)
        axes[2, col].set_xlabel("front position x / L (alpha >= 0.9 on y = 0)")
        axes[0, col].set_xlabel("a / L, a = S / (Gc T) + a0")
        for ax in axes[:, col]:
            ax.legend(fontsize=7)
    lines += ["", "| L/W | W/T | steps of growth | psi_sim at a = 0.4 L | (a - a0) / (bottom front - a0) at its"
              " last growth step | G / Gc: median, largest deviation |", "|---|---|---|---|---|---|"]
    for c in found:
        order = np.argsort(c["a"])
        psi_04 = np.interp(0.4 * L, c["a"][order], c["psi_sim"][order], left=np.nan, right=np.nan)
        over = (c["a"][-1] - A0) / max(c["a_bottom"][-1] - A0, 1e-12) if c["a"].size else np.nan
        deviation = np.max(np.abs(c["G"] / GC - 1.0)) if c["G"].size else np.nan
        lines.append(f"| {c['L/W']} | {c['W/T']} | {c['a'].size} | {psi_04:.3f} | {over:.2f} |"
                     f" {np.median(c['G']) / GC:.4f}, {deviation:.3f} |")
    fig.tight_layout()
    fig.savefig(args.out / "correction.png", dpi=130)
    (args.out / "collapse.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
