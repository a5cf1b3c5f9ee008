"""A plate run against the exact 1D evolution with the same parameters (Figs. 2.5-2.7).

The exact solution is that of a film of length ``x1 - x0`` under pure bending; a 2D strip is
compared per unit width (its energies divided by ``y1 - y0``), its cracks read along
``y = 0``.
"""

from __future__ import annotations

import json
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from onedim.evolution import Evolution  # noqa: E402
from thinfilm.plate.results import PlateResults  # noqa: E402
from thinfilm.plots import save_figure  # noqa: E402


def exact_counterpart(x0, x1, lam, toughness, t, cells=2000):
    """The exact evolution of the film ``(x0, x1)`` under pure bending, sampled at the loads ``t``.

    Parameters
    ----------
    x0, x1 : float
        Ends of the film (units of L).
    lam, toughness : float
        ``lambda`` and ``G/a``.
    t : ndarray, shape (n,)
        Loads, increasing.
    cells : int, optional
        Grid of the exact solver (events are refined off it).

    Returns
    -------
    dict
        ``t`` (the loads), ``total`` (exact total energy per unit width),
        ``events`` (list of onedim Event), ``offset`` (the film's centre: exact positions
        are shifted by it).
    """
    t = np.asarray(t, dtype=float)
    evolution = Evolution(x1 - x0, lam, toughness, cells, float(t[-1]))
    total = []
    for ti in t:
        evolution.advance_to(float(ti))
        total.append(evolution.energies(float(ti))[2])
    return {"t": t, "total": np.array(total), "events": evolution.events, "offset": 0.5 * (x0 + x1)}


def compare(results, outdir=None):
    """Draw ``compare.png`` and write ``compare.json`` for a plate ``results.h5``.

    Parameters
    ----------
    results : str or Path
    outdir : str or Path, optional
        Defaults to the results' directory.

    Returns
    -------
    figure, report : Path
        The figure and the JSON report: for each exact event the first step of the run
        with as many cracks, and the relative energy error at every step.
    """
    results = Path(results)
    outdir = Path(outdir) if outdir is not None else results.parent
    with PlateResults(results) as res:
        x, width = res.x, res.width
        exact = exact_counterpart(float(x[0]), float(x[-1]), res.parameters["lam"], res.parameters["toughness"],
                                  res.t)
        total = res.steps["total"] / width
        cracks = res.cracks()
    t = exact["t"]

    fig, (ax_e, ax_c) = plt.subplots(1, 2, figsize=(11.0, 4.2), layout="constrained")
    ax_e.plot(t, exact["total"], "--", color="tab:blue", lw=2, label="exact 1D (global minimizer)")
    ax_e.plot(t, total, "-", color="black", lw=1.5, label="regularized" + (" (per unit width)" if width != 1 else ""))
    ax_e.set_xlabel("load t")
    ax_e.set_ylabel("total energy")
    ax_e.legend()
    t_max = t[-1]
    for event in exact["events"]:
        for c in event.new_cracks:
            ax_c.plot([event.t, t_max], [c + exact["offset"]] * 2, "-", color="tab:blue", lw=3, alpha=0.4)
    for ti, c in zip(t, cracks):
        ax_c.plot(np.full(c.shape, ti), c, "|", color="black", ms=5)
    ax_c.set_xlim(0, t_max)
    ax_c.set_ylim(x[0], x[-1])
    ax_c.set_xlabel("load t")
    ax_c.set_ylabel("crack position x")
    ax_c.set_title("cracks: exact (blue bands), regularized (black)")
    figure = outdir / "compare.png"
    save_figure(fig, figure, dpi=130)
    plt.close(fig)

    counts = np.array([len(c) for c in cracks])
    events = []
    for event in exact["events"]:
        hit = np.flatnonzero(counts >= len(event.cracks))
        k = int(hit[0]) if hit.size else None
        events.append({
            "exact_t": event.t, "exact_cracks": [c + exact["offset"] for c in event.cracks],
            "regularized_t": float(t[k]) if k is not None else None,
            "regularized_cracks": cracks[k].tolist() if k is not None else None,
        })
    nonzero = exact["total"] > 0
    report = {
        "events": events,
        "energy_relative_error": {
            "t": t[nonzero].tolist(),
            "error": ((total[nonzero] - exact["total"][nonzero]) / exact["total"][nonzero]).tolist(),
        },
    }
    path = outdir / "compare.json"
    path.write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    return figure, path
