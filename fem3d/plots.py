"""The finite-element runs' own figures, drawn from their results file alone.

Beside what every run gets (:mod:`thinfilm.plots`: energies, iterations, and in 2D the damage
on the triangles at chosen loads):

* ``force_displacement.png``: the reaction on the loaded boundary against its prescribed
  displacement, crack events marked, and a measured curve if the scene names one
  (``[output] reference``), drawn by :func:`thinfilm.plots.force_displacement_figure`;
* ``crack_length.png``: the crack length (2D) or area (3D), surface energy over ``Gc``,
  against the load;
* 3D: ``crack_surface.png``, the nodes with ``alpha >= 0.9`` at the last finished step seen
  from three sides, and ``alpha_slices.png``, the damage on planes across the thickness
  (exact sections of the P1 field: each cut tetrahedron contributes the polygon where the
  plane meets it, coloured by the interpolated damage).

Each figure of a step draws it on the mesh it was computed on
(:meth:`thinfilm.results.reader.Results.discretization_at`: a mesh refined during the run).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.collections import PolyCollection

from thinfilm.plots import ALPHA_CMAP, DPI, line_figure, plt, progress_note, read_reference, save_figure
from thinfilm.plots import force_displacement_figure as _force_displacement_figure

__all__ = ["force_displacement_figure", "crack_length_figure", "crack_surface_figure", "slice_polygons",
           "alpha_slices_figure", "read_reference", "crack_sections_figure"]

#: Damage at which a node counts as broken in the figures.
BROKEN = 0.9


def units(res):
    """``(length, force)``: the run's unit names from its scene's ``[units]``, or ``("", "")``."""
    p = res.parameters
    return str(p.get("length_unit", "")), str(p.get("force_unit", ""))


def with_unit(label, unit):
    """``"label (unit)"``, or the label alone without a unit."""
    return f"{label} ({unit})" if unit else label


def force_displacement_figure(res, outdir, reference=None, events=()):
    """``force_displacement.png`` (:func:`thinfilm.plots.force_displacement_figure`, shared with
    the film); ``res`` an open results file with ``force`` and ``displacement``."""
    length, force = units(res)
    return _force_displacement_figure(res, outdir, events=events, reference=reference,
                                      xlabel=with_unit("prescribed displacement", length),
                                      ylabel=with_unit("reaction force", force))


def crack_length_figure(res, outdir, length, dim):
    """``crack_length.png``: ``length`` (surface energy / Gc, per step) against t."""
    path = Path(outdir) / "crack_length.png"
    fig, ax = line_figure(6.4, 4.2)
    ax.plot(res.t, length, "o-", ms=2.5, color="tab:red")
    ax.set_xlim(0.0, max(res.t_max, res.t[-1]))
    ax.set_ylim(bottom=0.0)
    length, _ = units(res)
    ax.set_xlabel("load t")
    ax.set_ylabel(with_unit("crack length S/(Gc T)", length) if dim == 2
                  else with_unit("crack area S/Gc", f"{length}^2" if length else ""))
    ax.set_title(f"crack {'length' if dim == 2 else 'area'} from the surface energy{progress_note(res)}",
                 fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path


def release_rate_figure(res, outdir, G, a):
    """``release_rate.png``: G / Gc against the crack length a, where the front moved (None if
    it never did)."""
    moved = np.isfinite(G)
    if not moved.any():
        return None
    path = Path(outdir) / "release_rate.png"
    fig, ax = line_figure(6.4, 4.2)
    ax.axhline(1.0, color="0.6", lw=0.8, ls="--")
    x, y = a[moved], G[moved] / res.parameters["Gc"]
    # no line across a jump of the crack (more than 4 eps at once): its G is that of the jump
    gap = np.flatnonzero(np.diff(x) > 4.0 * res.parameters["eps"]) + 1
    x, y = np.insert(x, gap, np.nan), np.insert(y, gap, np.nan)
    ax.plot(x, y, "o-", ms=3, color="tab:blue")
    ax.set_xlabel(with_unit("crack length a = S/(Gc T)", units(res)[0]))
    ax.set_ylabel("energy release rate G / Gc")
    ax.set_ylim(0.0, max(1.5, float(np.nanmin([np.nanmax(G[moved]) / res.parameters["Gc"], 3.0])) * 1.05))
    ax.set_title(f"G = (2 (B/t) dt - dB) / dA over growths of at least h{progress_note(res)}", fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path


def crack_surface_figure(res, outdir):
    """``crack_surface.png``: the broken nodes of the last finished step, three views."""
    path = Path(outdir) / "crack_surface.png"
    points = res.discretization_at(res.n - 1).points
    alpha = res.field("alpha", res.n - 1)
    broken = alpha >= BROKEN
    low, high = points.min(axis=0), points.max(axis=0)
    fig, axes = plt.subplots(1, 3, figsize=(12.0, 4.2), layout="constrained")
    for ax, (i, j), view in zip(axes, ((0, 1), (0, 2), (1, 2)), ("top (x, y)", "front (x, z)", "side (y, z)")):
        other = 3 - i - j
        outline = ax.scatter(points[::max(1, len(points) // 4000), i], points[::max(1, len(points) // 4000), j],
                             s=0.3, color="0.85")
        outline.set_rasterized(True)
        image = ax.scatter(points[broken, i], points[broken, j], c=points[broken, other], s=2, cmap="viridis",
                           vmin=low[other], vmax=high[other])
        ax.set_xlim(low[i], high[i])
        ax.set_ylim(low[j], high[j])
        ax.set_aspect("equal")
        ax.set_title(f"{view}, colour: {'xyz'[other]}", fontsize=9)
        ax.set_xlabel(with_unit("xyz"[i], units(res)[0]))
        ax.set_ylabel(with_unit("xyz"[j], units(res)[0]))
    fig.colorbar(image, ax=axes, shrink=0.8, label="depth along the view")
    fig.suptitle(f"crack surface (alpha >= {BROKEN}) at t = {res.t[res.n - 1]:.4g}: {int(broken.sum())} nodes"
                 f"{progress_note(res)}", fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path


#: The six edges of a tetrahedron, as pairs of its local vertices.
_EDGES = np.array([(0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3)])


def slice_polygons(points, cells, values, axis, level):
    """The exact section of a P1 field on tetrahedra by the plane ``x_axis = level``.

    Parameters
    ----------
    points : ndarray, shape (n, 3)
    cells : ndarray of int, shape (m, 4)
    values : ndarray, shape (n,)
        Nodal values.
    axis : {0, 1, 2}
    level : float

    Returns
    -------
    polygons : list of ndarray, each shape (3 or 4, 2)
        In the plane's two other coordinates (in increasing axis order).
    means : ndarray, shape (len(polygons),)
        The field's mean over each polygon's vertices.
    """
    coordinate = points[:, axis]
    in_plane = [a for a in range(3) if a != axis]
    # A plane through nodes (a mid-plane of an extruded or symmetric mesh) would cut tetrahedra
    # through a vertex, which the edge crossings below miss: move it off the nodes by a
    # millionth of the extent, far below anything a figure shows.
    extent = float(np.ptp(coordinate)) or 1.0
    while np.any(np.abs(coordinate - level) <= 1e-9 * extent):
        level += 1e-6 * extent
    c = coordinate[cells]
    cut = np.flatnonzero((c.min(axis=1) < level) & (c.max(axis=1) > level))
    polygons, means = [], []
    for e in cut:
        a, b = cells[e][_EDGES[:, 0]], cells[e][_EDGES[:, 1]]
        ca, cb = coordinate[a], coordinate[b]
        crossing = (ca - level) * (cb - level) < 0
        s = (level - ca[crossing]) / (cb[crossing] - ca[crossing])
        xy = points[a[crossing]][:, in_plane] * (1 - s)[:, None] + points[b[crossing]][:, in_plane] * s[:, None]
        v = values[a[crossing]] * (1 - s) + values[b[crossing]] * s
        centre = xy.mean(axis=0)
        order = np.argsort(np.arctan2(xy[:, 1] - centre[1], xy[:, 0] - centre[0]))
        polygons.append(xy[order])
        means.append(v.mean())
    return polygons, np.array(means)


def alpha_slices_figure(res, outdir, count=3):
    """``alpha_slices.png``: the damage of the last finished step on ``count`` planes z = const."""
    path = Path(outdir) / "alpha_slices.png"
    d = res.discretization_at(res.n - 1)
    alpha = res.field("alpha", res.n - 1)
    z0, z1 = d.points[:, 2].min(), d.points[:, 2].max()
    levels = z0 + (z1 - z0) * (np.arange(count) + 0.5) / count
    low, high = d.points.min(axis=0), d.points.max(axis=0)
    fig, axes = plt.subplots(1, count, figsize=(4.2 * count, 4.2), layout="constrained", squeeze=False)
    for ax, level in zip(axes[0], levels):
        polygons, means = slice_polygons(d.points, d.cells, alpha, 2, level)
        collection = PolyCollection(polygons, array=means, cmap=ALPHA_CMAP, edgecolors="face", linewidths=0.1)
        collection.set_clim(0.0, 1.0)
        ax.add_collection(collection)
        ax.set_xlim(low[0], high[0])
        ax.set_ylim(low[1], high[1])
        ax.set_aspect("equal")
        ax.set_title(f"z = {level:.4g}", fontsize=9)
        ax.set_xlabel(with_unit("x", units(res)[0]))
        ax.set_ylabel(with_unit("y", units(res)[0]))
    fig.colorbar(collection, ax=axes[0].tolist(), shrink=0.8, label=r"damage $\alpha$")
    fig.suptitle(f"damage on sections at t = {res.t[res.n - 1]:.4g}{progress_note(res)}", fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path


def crack_sections_figure(res, path, levels, xlim=None, ylim=None, step=None, width=None):
    """The crack of a 3D run seen from above and on horizontal sections, with its trace.

    The first panel: the broken nodes (alpha >= 0.9) seen from above, coloured by z; then the
    damage on each plane ``z = level`` (exact sections, :func:`slice_polygons`) with the line
    fitted to the broken nodes of the slab ``|z - level| <= width / 2`` and its angle
    (:func:`fem3d.cracks.trace_angles`): a twisted crack's trace turns from one section to the
    next (Brokenshire's torsion test, ``docs/cases.md#brokenshire-torsion``).

    Parameters
    ----------
    res : Results
        An open results file of a 3D run.
    path : str or Path
        The PNG to write.
    levels : sequence of float
        The sections' z.
    xlim, ylim : (float, float), optional
        The window drawn (default: the mesh's extent).
    step : int, optional
        The step drawn (default: the last finished one).
    width : float, optional
        The slabs' width for the fitted trace (default: the run's ``h``).

    Returns
    -------
    Path
    """
    from fem3d.cracks import trace_angles

    path = Path(path)
    k = res.n - 1 if step is None else int(step)
    d = res.discretization_at(k)
    alpha = res.field("alpha", k)
    low, high = d.points.min(axis=0), d.points.max(axis=0)
    xlim = (low[0], high[0]) if xlim is None else xlim
    ylim = (low[1], high[1]) if ylim is None else ylim
    width = float(res.parameters["h"]) if width is None else width
    broken = alpha >= BROKEN
    count = len(levels) + 1
    fig, axes = plt.subplots(1, count, figsize=(3.4 * count, 3.9), layout="constrained", squeeze=False)
    ax = axes[0][0]
    order = np.argsort(d.points[broken, 2])
    image = ax.scatter(d.points[broken, 0][order], d.points[broken, 1][order], c=d.points[broken, 2][order], s=2,
                       cmap="viridis")
    ax.set_title(f"alpha >= {BROKEN} from above", fontsize=9)
    fig.colorbar(image, ax=ax, shrink=0.7, location="bottom", label=with_unit("z", units(res)[0]))
    for ax, (level, angle, _, _) in zip(axes[0][1:], trace_angles(d.points, alpha, levels, width)):
        polygons, means = slice_polygons(d.points, d.cells, alpha, 2, level)
        keep = [i for i, q in enumerate(polygons) if xlim[0] <= q[0, 0] <= xlim[1] and ylim[0] <= q[0, 1] <= ylim[1]]
        collection = PolyCollection([polygons[i] for i in keep], array=means[keep], cmap=ALPHA_CMAP,
                                    edgecolors="face", linewidths=0.1)
        collection.set_clim(0.0, 1.0)
        ax.add_collection(collection)
        title = f"z = {level:.4g}"
        slab = broken & (np.abs(d.points[:, 2] - level) <= width / 2)
        if np.isfinite(angle):
            centre = d.points[slab, :2].mean(axis=0)
            direction = np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle))])
            ends = centre + np.outer([-1.0, 1.0], direction) * max(np.ptp(xlim), np.ptp(ylim))
            ax.plot(ends[:, 0], ends[:, 1], "--", color="tab:cyan", lw=1.0)
            title += f": trace {angle:.0f} deg"
        ax.set_title(title, fontsize=9)
    for ax in axes[0]:
        ax.set_xlim(*xlim)
        ax.set_ylim(*ylim)
        ax.set_aspect("equal")
        ax.set_xlabel(with_unit("x", units(res)[0]))
        ax.set_ylabel(with_unit("y", units(res)[0]))
    fig.colorbar(collection, ax=axes[0][1:].tolist(), shrink=0.7, location="bottom", label=r"damage $\alpha$")
    fig.suptitle(f"crack at t = {res.t[k]:.4g}: from above and on sections z = const{progress_note(res)}",
                 fontsize=10)
    save_figure(fig, path)
    plt.close(fig)
    return path

