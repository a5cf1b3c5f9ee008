"""The film's own figures: force against displacement, crack positions along ``y = 0`` and the
toughness of an imperfect film.

Drawn from a :class:`thinfilm.plate.results.PlateResults` alone, beside the figures every run
gets (:mod:`thinfilm.plots`):

* ``force_displacement.png`` (indenter and cantilever): the force conjugate to the imposed
  displacement (indentation depth, tip deflection) against it, the crack events along y = 0
  marked (:func:`thinfilm.plots.force_displacement_figure`, as a solid's reaction is drawn);
  with a material, second axes in SI units (as on ``crack_metrics.png`` and the shared
  ``energy.png``; field figures give the SI value of L in their axis labels);
* ``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9);
* on the snapshot panels of a 2D indentation, the contact circle of each panel's load
  (:func:`contact_circle`);
* ``toughness.png``: the toughness field of an imperfect film (:mod:`thinfilm.plate.imperfection`);
* ``crack_metrics.png`` (2D): crack length (from the energy, and of the skeleton), the counts
  of cracks, fragments and branch points against t, and under the indenter the ring radii
  against the contact radius (:mod:`thinfilm.plate.crack_metrics`);
* ``crack_pattern.png`` (2D): the damage at the last finished step with the skeleton, the
  branch points and the rings drawn on it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from thinfilm.plate.loads import contact_radius
from thinfilm.plate.results import crack_events
from thinfilm.plate.units import file_scales
from thinfilm.plots import (DPI, force_displacement_figure, image_extent, line_figure, plt, progress_note,
                            save_figure, secondary_si_axis, si_prefix)

__all__ = ["force_figure", "cracks_figure", "contact_circle", "crack_metrics_figure", "crack_pattern_figure", "toughness_figure"]

#: The words of each load's displacement and force, non-dimensional as energy.png's energies:
#: lengths in units of L, energies of D (the film's bending stiffness), so forces in D/L
#: (docs/model.md#physical-units).
FORCE_WORDS = {
    "indenter": ("indentation depth d = R t (non-dimensional, units of L)",
                 "indenter force F = dE/dd (non-dimensional, units of D/L)"),
    "cantilever": ("tip deflection $w_t(l_x) = 2 l_x^3 t$ (non-dimensional, units of L)",
                   "tip force F = dE/d$w_t(l_x)$ (non-dimensional, units of D/L)"),
}


def force_figure(res, outdir):
    """``force_displacement.png`` of an indenter or cantilever run; None for the other loads
    and for a file without recorded forces (written before they were recorded)."""
    load = res.parameters.get("load")
    if load not in FORCE_WORDS or "force" not in res.steps or not np.isfinite(res.steps["force"]).any():
        return None
    xlabel, ylabel = FORCE_WORDS[load]
    if res.dim == 1:
        ylabel = ylabel.replace("units of D/L)", "units of D/L per unit width)")
    events = [t for t, _ in crack_events(res.t, res.cracks())]
    physical = None
    scales = file_scales(res.file)
    if "force_si" in res.steps and scales is not None:
        L, unit = scales["length"], scales["force"]
        d_factor, d_prefix = si_prefix(np.nanmax(res.steps["displacement"]) * L)
        f_factor, f_prefix = si_prefix(np.nanmax(np.abs(res.steps["force"])) * unit)
        physical = (L * d_factor, f"displacement ({d_prefix}m)", unit * f_factor,
                    f"force ({f_prefix}{scales['force_unit']})")
    what = "indentation" if load == "indenter" else "cantilever"
    return force_displacement_figure(res, outdir, events=events, xlabel=xlabel, ylabel=ylabel,
                                     event_label="cracks along y = 0 change",
                                     title=f"{what}: force against displacement", physical=physical)


#: The contact circle on the snapshot figures: thin, dashed, seen on damage and deflection.
CONTACT_STYLE = dict(ls="--", lw=0.8, color="tab:green")


def contact_circle(res, ax, t):
    """Under the indenter, draw the contact circle ``r = R sqrt(t (2 - t))`` about the origin
    (:func:`thinfilm.plate.loads.contact_radius`) on a 2D panel of the film at load ``t``;
    returns the line drawn (labelled "contact radius"), none for another load or before
    contact (t = 0)."""
    if res.parameters.get("load") != "indenter" or res.dim != 2:
        return []
    if not 0.0 < t < 2.0:  # the sphere touches the film's plane for 0 < t < 2
        return []
    r = float(contact_radius(float(res.parameters["radius"]), t))
    angle = np.linspace(0.0, 2.0 * np.pi, 361)
    (line,) = ax.plot(r * np.cos(angle), r * np.sin(angle), label="contact radius", **CONTACT_STYLE)
    return [line]


def cracks_figure(res, outdir):
    """``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9)."""
    path = Path(outdir) / "cracks.png"
    fig, ax = line_figure(6.4, 4.2)
    for ti, cracks in zip(res.t, res.cracks()):  # one row per step: a large run is never read whole
        ax.plot(np.full(cracks.shape, ti), cracks, "|", color="tab:red", ms=6)
    # 2 % beyond the load range and the film on each side: a crack at the last step (or at an
    # edge) is drawn whole, not cut in half by the axes
    t_end = max(res.t_max, res.t[-1])
    ax.set_xlim(-0.02 * t_end, 1.02 * t_end)
    pad = 0.02 * (res.x[-1] - res.x[0])
    ax.set_ylim(res.x[0] - pad, res.x[-1] + pad)
    ax.set_xlabel("load t")
    ax.set_ylabel("crack position x (L)" + (" on y = 0" if res.dim == 2 else ""))
    ax.set_title(f"cracks (local maxima of alpha > 0.9){progress_note(res)}", fontsize=10)
    save_figure(fig, path)
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
    save_figure(fig, path)
    plt.close(fig)
    return path


def crack_metrics_figure(res, outdir):
    """``crack_metrics.png`` of a 2D run: lengths and counts against t (and, under the
    indenter, the ring radii against the contact radius), at the measured steps
    (:meth:`thinfilm.plate.results.PlateResults.crack_metrics`)."""
    path = Path(outdir) / "crack_metrics.png"
    metrics = res.crack_metrics()
    t = np.array([m.t for m in metrics])
    indenter = metrics[-1].contact_radius is not None
    rows = 3 if indenter else 2
    fig, axes = plt.subplots(rows, 1, figsize=(6.4, 2.6 * rows + 0.8), sharex=True)
    fig.subplots_adjust(left=0.95 / 6.4, right=1.0 - 0.2 / 6.4, bottom=0.6 / (2.6 * rows + 0.8),
                        top=1.0 - 0.5 / (2.6 * rows + 0.8), hspace=0.12)
    marker = "o" if len(t) <= 40 else "."
    ax = axes[0]
    crack_length = res.crack_length()  # an imperfect film's is computed step by step: once
    ax.plot(res.t, crack_length, color="black", label="surface energy / toughness")
    ax.plot(t, [m.length_skeleton for m in metrics], marker, ms=4, ls="none", color="tab:red",
            label="skeleton of alpha >= 0.9")
    ax.set_ylabel("crack length (L)")
    ax.legend(fontsize=8)
    physical = file_scales(res.file)
    if physical:  # the lengths in SI on a second axis
        fig.subplots_adjust(right=1.0 - 0.95 / 6.4)
        secondary_si_axis(ax, "right", physical["length"], crack_length, "m", "length")
    ax = axes[1]
    counts = [("cracks", [m.cracks for m in metrics]), ("fragments", [m.fragments for m in metrics]),
              ("intact fragments", [m.intact_fragments for m in metrics]),
              ("branch points", [len(m.branch_points) for m in metrics])]
    if indenter:
        counts.append(("radial cracks", [m.radial_total for m in metrics]))
    for label, values in counts:
        ax.plot(t, values, marker + "-", ms=4, lw=1.0, label=label)
    ax.set_ylabel("count")
    ax.set_ylim(bottom=0)
    ax.legend(fontsize=8, ncol=2)
    if indenter:
        ax = axes[2]
        for m in metrics:
            ax.plot(np.full(len(m.rings), m.t), m.rings, marker, ms=4, color="tab:red")
        ax.plot([], [], marker, ms=4, color="tab:red", label="ring radii (alpha averaged over circles >= 0.9)")
        load = np.linspace(0.0, min(max(res.t_max, res.t[-1]), 1.0), 200)
        radius = float(res.parameters["radius"])
        ax.plot(load, contact_radius(radius, load), color="black", lw=1.0, label="contact radius")
        ax.set_ylabel("radius (L)")
        ax.legend(fontsize=8)
        if physical:
            secondary_si_axis(ax, "right", physical["length"], [radius], "m", "radius")
    axes[-1].set_xlim(0.0, max(res.t_max, res.t[-1]))
    axes[-1].set_xlabel("load t")
    axes[0].set_title(f"crack metrics at {len(t)} step(s){progress_note(res)}", fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path


def crack_pattern_figure(res, outdir):
    """``crack_pattern.png`` of a 2D run: the damage at the last finished step, its skeleton
    (the length measured), its branch points with their number of arms and, under the
    indenter, the rings found and the contact circle."""
    from matplotlib.lines import Line2D

    from thinfilm.plate.skeleton import thin

    path = Path(outdir) / "crack_pattern.png"
    last = res.crack_metrics()[-1]
    alpha = res.field("alpha", last.step)
    aspect = (res.y[-1] - res.y[0]) / (res.x[-1] - res.x[0])
    w = min(6.5, 5.5 / aspect)
    h = w * aspect
    # fixed margins (inches): y label; colour bar; a title of three lines; x label
    left, right, top, bottom = 0.95, 1.25, 0.75, 0.55
    fig = plt.figure(figsize=(left + w + right, bottom + h + top))
    W, H = fig.get_size_inches()
    ax = fig.add_axes((left / W, bottom / H, w / W, h / H))
    image = ax.imshow(alpha, origin="lower", extent=image_extent(res.discretization), cmap="Greys", vmin=0.0,
                      vmax=1.0, interpolation="auto")
    rows, cols = np.nonzero(thin(alpha >= 0.9))
    # markers, not pixels: a line one node wide would vanish when a fine grid is drawn smaller
    ax.plot(res.x[cols], res.y[rows], "s", ms=0.8, mew=0, color="tab:red")
    handles = [Line2D([], [], ls="none", marker="s", ms=4, color="tab:red", label="skeleton of alpha >= 0.9")]
    if last.contact_radius is not None:
        circle = np.linspace(0.0, 2 * np.pi, 721)
        for r in last.rings:
            ax.plot(r * np.cos(circle), r * np.sin(circle), "--", lw=0.6, color="tab:orange")
        ax.plot(last.contact_radius * np.cos(circle), last.contact_radius * np.sin(circle), ":", lw=1.2,
                color="tab:green")
        handles += [Line2D([], [], ls="--", lw=0.8, color="tab:orange", label="rings found"),
                    Line2D([], [], ls=":", lw=1.2, color="tab:green", label="contact radius")]
    if last.branch_points:
        bx, by, _ = zip(*last.branch_points)
        ax.plot(bx, by, "o", ms=6, mfc="none", mew=1.0, color="tab:blue")
        handles.append(Line2D([], [], ls="none", marker="o", ms=6, mfc="none", color="tab:blue",
                              label="branch points" + (" (arms)" if len(bx) <= 30 else "")))
        if len(bx) <= 30:  # more labels than that would hide the pattern
            for px, py, arms in last.branch_points:
                ax.annotate(str(arms), (px, py), xytext=(4, 4), textcoords="offset points", fontsize=7,
                            color="tab:blue")
    ax.set_xlim(res.x[0], res.x[-1])
    ax.set_ylim(res.y[0], res.y[-1])
    ax.set_xlabel("x (L)")
    ax.set_ylabel("y (L)")
    ax.legend(handles=handles, fontsize=7, loc="upper right", framealpha=0.8)
    bar = min(h, 4.0)
    cax = fig.add_axes(((left + w + 0.2) / W, (bottom + (h - bar) / 2) / H, 0.15 / W, bar / H))
    fig.colorbar(image, cax=cax, label=r"damage $\alpha$")
    parts = last.describe().split("; ")
    title = f"t = {last.t:.4g} (step {last.step}): {parts[0]}\n{parts[1]}" + "".join(f"\n{p}" for p in parts[2:])
    fig.suptitle(title + progress_note(res), fontsize=8, y=1.0 - 0.08 / H, va="top")
    save_figure(fig, path)
    plt.close(fig)
    return path
