"""The film's own figures: force against displacement, crack positions along ``y = 0`` and the
toughness of an imperfect film.

Drawn from a :class:`thinfilm.plate.results.PlateResults` alone, beside the figures every run
gets (:mod:`thinfilm.plots`):

* ``force_displacement.png`` (indenter and cantilever): the force conjugate to the imposed
  displacement (indentation depth, tip deflection) against it, the crack events along y = 0
  marked (:func:`thinfilm.plots.force_displacement_figure`, as a solid's reaction is drawn);
  with a material, second axes in SI units;
* ``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9);
* ``toughness.png``: the toughness field of an imperfect film (:mod:`thinfilm.plate.imperfection`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thinfilm.plate.results import crack_events
from thinfilm.plots import DPI, force_displacement_figure, image_extent, line_figure, plt, progress_note

__all__ = ["force_figure", "cracks_figure", "toughness_figure"]

#: The words of each load's displacement and force (non-dimensional: lengths in L, energies in
#: D, forces in D/L).
FORCE_WORDS = {
    "indenter": ("indentation depth d = R t (L)", "indenter force F = dE/dd (D/L)"),
    "cantilever": ("tip deflection $w_t(l_x) = 2 l_x^3 t$ (L)", "tip force F = dE/d$w_t(l_x)$ (D/L)"),
}


def _prefix(value):
    """``(factor, prefix)`` of the SI prefix that writes ``value`` between 1 and 1000."""
    for factor, prefix in ((1.0, ""), (1e3, "m"), (1e6, "µ"), (1e9, "n"), (1e12, "p")):
        if abs(value) * factor >= 1.0:
            return factor, prefix
    return 1e12, "p"


def force_figure(res, outdir):
    """``force_displacement.png`` of an indenter or cantilever run; None for the other loads
    and for a file without recorded forces (written before they were recorded)."""
    load = res.parameters.get("load")
    if load not in FORCE_WORDS or "force" not in res.steps or not np.isfinite(res.steps["force"]).any():
        return None
    xlabel, ylabel = FORCE_WORDS[load]
    if res.dim == 1:
        ylabel = ylabel.replace("(D/L)", "(D/L per unit width)")
    events = [t for t, _ in crack_events(res.t, res.cracks())]
    physical = None
    if "force_si" in res.steps and "material" in res.file:
        material = res.file["material"].attrs
        L, D = float(material["L"]), float(material["rigidity"])
        unit = D / L if res.dim == 2 else D / L**2
        d_factor, d_prefix = _prefix(np.nanmax(res.steps["displacement"]) * L)
        f_factor, f_prefix = _prefix(np.nanmax(np.abs(res.steps["force"])) * unit)
        physical = (L * d_factor, f"displacement ({d_prefix}m)", unit * f_factor,
                    f"force ({f_prefix}N{'' if res.dim == 2 else '/m'})")
    what = "indentation" if load == "indenter" else "cantilever"
    return force_displacement_figure(res, outdir, events=events, xlabel=xlabel, ylabel=ylabel,
                                     event_label="cracks along y = 0 change",
                                     title=f"{what}: force against displacement", physical=physical)


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
