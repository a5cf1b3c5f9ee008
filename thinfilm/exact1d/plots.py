"""Figures of an exact 1D run, like the dissertation's Fig. 2.15, from its results file alone.

* ``energy.png``: total energy against t (solid), and the energy branch
  ``t^2/2 * coefficient + n G/a`` of every crack configuration the evolution visits
  (dashed, over the whole load range), so each event shows as a crossing of branches;
* ``cracks.png``: crack positions against t, each crack from its nucleation load on.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thinfilm.exact1d.results import read_track
from thinfilm.plots import plt, save_figure

__all__ = ["plot_exact1d"]


def _energy_figure(data, path):
    steps, events, p = data["steps"], data["events"], data["parameters"]
    t = steps["t"]
    fig, ax = plt.subplots(figsize=(6.0, 4.2), layout="constrained")
    counts = np.concatenate(([0], events["crack_count"]))
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, len(counts)))
    for coef, n, color in zip(events["branch_coefficient"], counts, colors):
        ax.plot(t, 0.5 * t**2 * coef + n * p["toughness"], "--", lw=1.0, color=color,
                label=f"{n} crack{'s' if n != 1 else ''}")
    ax.plot(t, steps["total"], "-", lw=2.2, color="black", label="evolution (total)")
    for te in events["t"]:
        ax.axvline(te, color="0.6", lw=0.6, zorder=0)
    ax.set_xlim(t[0], t[-1])
    ax.set_ylim(0.0, 1.05 * steps["total"].max())
    ax.set_xlabel("load t")
    ax.set_ylabel("total energy $E^*_t$")
    ax.set_title(f"exact evolution: $l_0$ = {p['length']:g}, $\\lambda$ = {p['lam']:g}, G/a = {p['toughness']:g}")
    ax.legend(fontsize=8, loc="upper left")
    save_figure(fig, path, dpi=130)
    plt.close(fig)


def _cracks_figure(data, path):
    steps, events, p = data["steps"], data["events"], data["parameters"]
    t_max = steps["t"][-1]
    fig, ax = plt.subplots(figsize=(6.0, 4.2), layout="constrained")
    for te, new in zip(events["t"], events["new_cracks"]):
        for x in new[np.isfinite(new)]:
            ax.plot([te, t_max], [x, x], "-", color="tab:red", lw=1.6)
            ax.plot([te], [x], "o", color="tab:red", ms=3.5)
    half = 0.5 * p["length"]
    ax.set_xlim(0.0, t_max)
    ax.set_ylim(-half, half)
    ax.set_xticks(sorted(set(np.round(np.concatenate(([0.0, t_max], events["t"])), 3))))
    ax.tick_params(axis="x", labelrotation=45, labelsize=8)
    ax.set_xlabel("load t (ticks at the event loads)")
    ax.set_ylabel("crack position x")
    ax.set_title("crack positions")
    ax.grid(axis="y", color="0.9")
    save_figure(fig, path, dpi=130)
    plt.close(fig)


def plot_exact1d(results, outdir=None):
    """Draw ``energy.png`` and ``cracks.png`` of an exact 1D results file.

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of an exact 1D run.
    outdir : str or Path, optional
        Where to write; defaults to the file's directory.

    Returns
    -------
    list of Path
        The figures written.
    """
    results = Path(results)
    outdir = Path(outdir) if outdir is not None else results.parent
    data = read_track(results, "refined")
    outdir.mkdir(parents=True, exist_ok=True)
    paths = [outdir / "energy.png", outdir / "cracks.png"]
    _energy_figure(data, paths[0])
    _cracks_figure(data, paths[1])
    return paths
