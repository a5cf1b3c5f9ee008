"""The film's own figures: crack positions along ``y = 0`` and the toughness of an imperfect film.

Drawn from a :class:`thinfilm.plate.results.PlateResults` alone, beside the figures every run
gets (:mod:`thinfilm.plots`):

* ``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9);
* ``toughness.png``: the toughness field of an imperfect film (:mod:`thinfilm.plate.imperfection`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thinfilm.plots import DPI, image_extent, line_figure, plt, progress_note

__all__ = ["cracks_figure", "toughness_figure"]


def cracks_figure(res, outdir):
    """``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9)."""
    path = Path(outdir) / "cracks.png"
    fig, ax = line_figure(6.4, 4.2)
    for ti, cracks in zip(res.t, res.cracks()):  # one row per step: a large run is never read whole
        ax.plot(np.full(cracks.shape, ti), cracks, "|", color="tab:red", ms=6)
    ax.set_xlim(0.0, max(res.t_max, res.t[-1]))
    ax.set_ylim(res.x[0], res.x[-1])
    ax.set_xlabel("load t")
    ax.set_ylabel("crack position x (L)" + (" on y = 0" if res.dim == 2 else ""))
    ax.set_title(f"cracks (local maxima of alpha > 0.9){progress_note(res)}", fontsize=10)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def toughness_figure(res, outdir):
    """The toughness field of an imperfect film, ``toughness.png``; None for a uniform film."""
    stored = res.file["fields"].get("toughness")
    if stored is None:
        return None
    values = stored[()]
    path = Path(outdir) / "toughness.png"
    p = res.parameters
    title = (f"toughness G/a = {p['toughness']:g} exp({p['toughness_noise']:g} $\\xi$)\n"
             f"correlation length {p['toughness_noise_length']:.3g}, seed {p['toughness_noise_seed']}")
    if res.dim == 1:
        fig, ax = line_figure(6.8, 3.2)
        ax.plot(res.x, values, lw=1.0)
        ax.set_xlim(res.x[0], res.x[-1])
        ax.set_xlabel("x (L)")
        ax.set_ylabel("G/a")
    else:
        aspect = (res.y[-1] - res.y[0]) / (res.x[-1] - res.x[0])
        width = min(6.0, 4.5 / aspect)
        fig, ax = line_figure(width + 1.6, width * aspect + 1.2)
        image = ax.imshow(values.reshape(len(res.y), len(res.x)), origin="lower",
                          extent=image_extent(res.discretization), cmap="cividis", interpolation="auto")
        ax.set_xlabel("x (L)")
        ax.set_ylabel("y (L)")
        fig.colorbar(image, ax=ax, label="G/a", shrink=0.9)
    ax.set_title(title, fontsize=9)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path
