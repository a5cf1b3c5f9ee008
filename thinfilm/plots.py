"""Figures of a run driven by the engine, drawn from its results file alone (never from live objects).

From the finished steps of ``results.h5`` (a run that stopped early is drawn as far as it
got; :mod:`thinfilm.results.reader`), for every kind (:func:`plot_run`):

* ``energy.png``: elastic, surface and total energy against t;
* ``alpha.png``: the damage at the last finished step;
* ``alpha_snapshots.png``, ``u_snapshots.png``: the damage and the displacement at a few
  loads (nearest finished steps), one shared colour scale per figure: [0, 1] for alpha,
  symmetric about 0 for u. Fields on a 2D grid as images with the domain's aspect ratio, on a
  2D mesh as coloured triangles, 1D fields as curves (a vector field, or a 3D mesh, is left
  to the kind's own figures); the panels share their axes, and the kind may draw on each
  (:meth:`thinfilm.run.EvolutionKind.overlay`: the film's contact circle under the indenter);
* ``iterations.png``: alternate-minimization iterations and u-solves of each step;
* ``alpha.gif`` (on request): the damage over the load, at most ~100 frames;

then the kind's own figures (:meth:`thinfilm.run.EvolutionKind.figures`: the film's force
against displacement, crack positions and toughness field) and ``results.xdmf`` (:mod:`thinfilm.xdmf`). Titles, field
labels and the length unit come from the kind (:class:`thinfilm.run.EvolutionKind`).

Kinds that record a force against a prescribed displacement draw it with
:func:`force_displacement_figure` (``force_displacement.png``), the same for every kind.
"""

from __future__ import annotations

import contextlib
import os

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no display needed
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
import numpy as np  # noqa: E402

from thinfilm import kinds  # noqa: E402
from thinfilm.discretization import StructuredGrid  # noqa: E402
from thinfilm.results.reader import Results, ResultsError, open_results  # noqa: E402


#: Damage from sound (light) to broken (dark), as alpha.png has always been drawn.
ALPHA_CMAP = "magma_r"
#: Deflection: diverging about u = 0, so that its sign reads at a glance.
U_CMAP = "RdBu_r"
#: A field whose values of one sign reach less than this fraction of its extreme of the other
#: counts as one-signed (:func:`colour_range`).
ONE_SIGNED = 0.02
#: The two halves of :data:`U_CMAP`, for a field that is never positive or never negative:
#: blue to white and white to red, so one colour means one sign in every figure.
U_HALF_CMAPS = (matplotlib.colors.LinearSegmentedColormap.from_list(
                    "u_negative", matplotlib.colormaps[U_CMAP](np.linspace(0.0, 0.5, 128))),
                matplotlib.colors.LinearSegmentedColormap.from_list(
                    "u_positive", matplotlib.colormaps[U_CMAP](np.linspace(0.5, 1.0, 128))))
DPI = 130
#: Default number of snapshots, evenly spread over the finished steps.
SNAPSHOTS = 5
#: Most frames of alpha.gif; longer runs are subsampled evenly (first and last step kept).
MAX_FRAMES = 100


def partial_path(path):
    """The temporary name a file is written under before it is renamed into place: hidden, in
    the same folder (a rename within one file system is atomic), with the same suffix (which
    tells matplotlib and Pillow the format)."""
    path = Path(path)
    return path.with_name(f".{path.stem}.partial{path.suffix}")


def unclip_markers(fig):
    """Let the markers of every line whose points all lie within its axes' limits be drawn
    whole: a marker on a limit (the first step at t = 0, a curve's peak at the top) is
    otherwise cut in half by the frame. Lines that run past the limits stay clipped."""
    for ax in fig.axes:
        (x0, x1), (y0, y1) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
        for line in ax.get_lines():
            if line.get_marker() in (None, "None", "none", "", " "):
                continue
            try:
                x = np.asarray(line.get_xdata(), dtype=float)
                y = np.asarray(line.get_ydata(), dtype=float)
            except (TypeError, ValueError):  # not numbers (dates, categories): left as drawn
                continue
            x, y = x[np.isfinite(x) & np.isfinite(y)], y[np.isfinite(x) & np.isfinite(y)]
            if x.size and x.min() >= x0 and x.max() <= x1 and y.min() >= y0 and y.max() <= y1:
                line.set_clip_on(False)


def save_figure(fig, path, dpi=None):
    """Write ``fig`` to ``path`` under :func:`partial_path`, then rename it: a run killed while
    it draws leaves the previous figure or the new one, never a truncated file.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    path : str or Path
        The figure's file; its suffix gives the format.
    dpi : float, optional
        Default :data:`DPI`.

    Returns
    -------
    Path
    """
    path = Path(path)
    partial = partial_path(path)
    unclip_markers(fig)
    fig.savefig(partial, dpi=DPI if dpi is None else dpi)
    os.replace(partial, path)
    return path


def snapshot_steps(t, loads=None, count=SNAPSHOTS, first=0):
    """Finished steps to draw: the nearest to each requested load, or ``count`` spread evenly.

    Parameters
    ----------
    t : array_like, shape (n,)
        Loads of the finished steps, increasing.
    loads : sequence of float, optional
        Requested loads. Each selects the finished step of nearest t, so a load beyond the
        last finished step (a run that stopped early) selects the last one.
    count : int, optional
        Without ``loads``: this many steps evenly spread from step ``first`` to the last
        finished one (all of them if fewer have finished).
    first : int, optional
        Without ``loads``: the first step that may be drawn (clipped to the finished ones).

    Returns
    -------
    ndarray of int
        Step indices, sorted, without repeats (two loads nearest to one step draw it once).
    """
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return np.empty(0, dtype=int)
    if loads is None or len(loads) == 0:
        first = min(max(int(first), 0), len(t) - 1)
        steps = np.rint(np.linspace(first, len(t) - 1, min(count, len(t) - first))).astype(int)
    else:
        steps = np.array([int(np.argmin(np.abs(t - float(load)))) for load in loads], dtype=int)
    return np.unique(steps)


def progress_note(res):
    """Title suffix of a run that has not finished all its steps."""
    return "" if res.n >= res.n_planned else f" [{res.n} of {res.n_planned} steps finished]"


def _model_title(res):
    return kinds.get(res.kind).title(res.parameters)


def _label(res, field):
    """The axis or colour-bar label of ``field`` (the kind's words and units)."""
    return kinds.get(res.kind).figure_labels(res.parameters)[field]


def axis_label(res, name):
    """``"x (L)"``: a coordinate axis in the kind's length unit (``"x"`` if it has none: the
    scene's own units), with the unit's SI value if the run has one (``"x (L = 1.88 µm)"``)."""
    unit = kinds.get(res.kind).figure_length_unit(res.parameters)
    physical = kinds.get(res.kind).physical(res)
    if unit and physical:
        factor, prefix = si_prefix(physical["length"])
        return f"{name} ({unit} = {physical['length'] * factor:.3g} {prefix}{physical['length_unit']})"
    return f"{name} ({unit})" if unit else name


def si_prefix(value):
    """``(factor, prefix)`` of the SI prefix that writes ``value`` between 1 and 1000
    (``value * factor``), from the unit itself down to pico."""
    for factor, prefix in ((1.0, ""), (1e3, "m"), (1e6, "µ"), (1e9, "n"), (1e12, "p")):
        if abs(value) * factor >= 1.0:
            return factor, prefix
    return 1e12, "p"


def secondary_si_axis(ax, which, scale, values, unit, what):
    """A second axis (``which``: ``"right"`` or ``"top"``) reading the data of ``ax`` in SI:
    ``scale`` SI units per data unit, the prefix chosen for the largest of ``values``; labelled
    ``"<what> (<prefix><unit>)"``."""
    finite = np.abs(np.asarray(values, dtype=float))
    finite = finite[np.isfinite(finite)]
    factor, prefix = si_prefix(float(finite.max()) * scale if finite.size and finite.max() > 0 else scale)
    k = scale * factor
    if which == "right":
        axis = ax.secondary_yaxis("right", functions=(lambda v: v * k, lambda v: v / k))
        axis.set_ylabel(f"{what} ({prefix}{unit})")
    else:
        axis = ax.secondary_xaxis("top", functions=(lambda v: v * k, lambda v: v / k))
        axis.set_xlabel(f"{what} ({prefix}{unit})")
    return axis


def image_extent(grid):
    """Image extent of a 2D :class:`StructuredGrid` with each pixel centred on its node (half
    pixels beyond the edges)."""
    x, y = grid.x, grid.y
    hx, hy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    return (x[0] - hx / 2, x[-1] + hx / 2, y[0] - hy / 2, y[-1] + hy / 2)


def _aspect(d):
    """Height over width of a 2D domain (grid or mesh)."""
    if isinstance(d, StructuredGrid):
        return (d.y[-1] - d.y[0]) / (d.x[-1] - d.x[0])
    span = np.ptp(d.points, axis=0)
    return span[1] / span[0]


def _abscissa(d):
    """Node coordinates of a 1D discretization and the order that sorts them."""
    x = d.x if isinstance(d, StructuredGrid) else d.points[:, 0]
    order = np.argsort(x, kind="stable")
    return x[order], order


def colour_range(field, values):
    """Shared colour (or y) range of a figure and its colour map: [0, 1] for damage; for u,
    symmetric about 0 with a diverging map where it takes both signs, and from 0 to its
    extreme with the matching half of that map where it keeps one sign, up to
    :data:`ONE_SIGNED` of it (a film pressed down by an indenter: half a symmetric scale
    would stay unused)."""
    if field == "alpha":
        return 0.0, 1.0, ALPHA_CMAP
    values = np.asarray(values, dtype=float)
    finite = values[np.isfinite(values)] if values.size else values
    lo = float(finite.min()) if finite.size else 0.0
    hi = float(finite.max()) if finite.size else 0.0
    if lo == hi == 0.0:
        return -1.0, 1.0, U_CMAP  # an undeformed film still needs a scale
    # one-signed up to a ripple: an indented film rises by 0.2-0.6 % of its depth beyond the
    # contact, invisible on either scale; it is drawn at 0 (white) on the half scale
    if lo >= -ONE_SIGNED * hi:
        return 0.0, hi, U_HALF_CMAPS[1]
    if hi <= -ONE_SIGNED * lo:
        return lo, 0.0, U_HALF_CMAPS[0]
    m = max(-lo, hi)
    return -m, m, U_CMAP


def _panel_layout(count, aspect):
    """Rows, columns and panel size (inches) for ``count`` images of height/width ``aspect``.

    Long strips (the usual film) read best stacked at full width, sharing x; squarer
    domains side by side. A panel is kept at most 4 in tall.
    """
    ncols = 1 if aspect <= 0.3 else (2 if count == 4 else min(count, 3))
    nrows = -(-count // ncols)
    width = 6.8 if ncols == 1 else 9.6 / ncols
    width = min(width, 4.0 / aspect)
    return nrows, ncols, width, width * aspect


#: Margins of the image figures (inches): y label and ticks; colour bar; suptitle and the
#: first row's panel titles; x label and ticks. Gaps between panels: (hidden) tick labels
#: across, a panel title down.
_MARGIN_L, _MARGIN_R, _MARGIN_T, _MARGIN_B = 0.95, 1.25, 0.7, 0.55
_GAP_W, _GAP_H = 0.3, 0.4


def boundary_edges(triangles):
    """The edges of a triangle mesh that lie in one triangle only: its boundary, slits
    included.

    Parameters
    ----------
    triangles : ndarray, shape (m, 3), int

    Returns
    -------
    ndarray, shape (k, 2), int64
        Node pairs, each edge once, sorted.
    """
    triangles = np.asarray(triangles, dtype=np.int64)
    edges = np.sort(triangles[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    return unique[counts == 1]


def _draw_field(ax, d, values, vmin, vmax, cmap):
    """One 2D field on the axes: an image on a grid, coloured triangles on a mesh."""
    if isinstance(d, StructuredGrid):
        # "auto": nearest pixels when the grid is coarser than the screen, antialiased when
        # finer, so that a crack band a few nodes wide never falls between the pixels.
        image = ax.imshow(values, origin="lower", extent=image_extent(d), vmin=vmin, vmax=vmax, cmap=cmap,
                          interpolation="auto")
        ax.set_xlim(d.x[0], d.x[-1])
        ax.set_ylim(d.y[0], d.y[-1])
        return image
    image = ax.tripcolor(d.points[:, 0], d.points[:, 1], d.cells, values, shading="gouraud", vmin=vmin,
                         vmax=vmax, cmap=cmap)
    # the boundary drawn as a thin line: a notch of zero width (a slit, its two faces on
    # nodes of their own) shows in no colour, only as boundary
    edges = boundary_edges(d.cells)
    ax.add_collection(LineCollection(d.points[edges], colors="0.35", linewidths=0.4))
    low, high = d.points.min(axis=0), d.points.max(axis=0)
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(low[1], high[1])
    ax.set_aspect("equal")
    return image


def image_figure(res, steps, field, values, title):
    """The figure of images of ``values`` (shape (k, ny+1, nx+1); on a mesh, one field per step,
    each on its step's mesh, :meth:`thinfilm.results.reader.Results.discretization_at`) at
    ``steps``, one colour scale and bar, and the kind's overlays
    (:meth:`thinfilm.run.EvolutionKind.overlay`).

    The panels are placed explicitly, each exactly of the domain's aspect ratio, instead of
    by constrained layout: the same figure, at a fraction of the drawing time (a layout
    engine draws every panel's text several times). They read as shared axes: the same ticks
    on every panel, labelled only along the left column and under the bottom panel of each
    column, and few enough of them that neighbouring labels never meet.
    """
    vmin, vmax, cmap = colour_range(field, _flat(values))
    d = res.discretization
    kind = kinds.get(res.kind)
    aspect = _aspect(d)
    nrows, ncols, w, h = _panel_layout(len(steps), aspect)
    h_box = max(h, 0.3)  # a very thin strip still gets room for its y ticks (image centred)
    W = _MARGIN_L + ncols * w + (ncols - 1) * _GAP_W + _MARGIN_R
    H = _MARGIN_T + nrows * h_box + (nrows - 1) * _GAP_H + _MARGIN_B
    fig = plt.figure(figsize=(W, H))
    image, handles, first = None, [], None
    for i, k in enumerate(steps):
        row, col = divmod(i, ncols)
        left = _MARGIN_L + col * (w + _GAP_W)
        bottom = _MARGIN_B + (nrows - 1 - row) * (h_box + _GAP_H)
        ax = fig.add_axes((left / W, bottom / H, w / W, h_box / H), sharex=first, sharey=first)
        first = first or ax
        image = _draw_field(ax, res.discretization_at(k), values[i], vmin, vmax, cmap)
        handles += [h for h in kind.overlay(res, ax, float(res.t[k])) if h.get_label() not in
                    [g.get_label() for g in handles]]
        ax.set_title(f"t = {res.t[k]:.4g} (step {k})", fontsize=9, pad=3)
        bottom_of_column = i + ncols >= len(steps)
        ax.tick_params(labelbottom=bottom_of_column, labelleft=col == 0, labelsize=8)
        if bottom_of_column:
            ax.set_xlabel(axis_label(res, "x"))
        if col == 0:
            ax.set_ylabel(axis_label(res, "y"))
    # Shared axes share their locators: at most one tick per ~0.75 in across (a label such as
    # "-0.025" is ~0.4 in wide at this size), and the last one dropped where a neighbour's
    # first label would stand beside it.
    first.yaxis.set_major_locator(MaxNLocator(nbins=4 if h_box > 1.0 else 2))
    first.xaxis.set_major_locator(MaxNLocator(nbins=max(2, int(w / 0.75)), steps=[1, 2, 2.5, 5, 10],
                                              prune="upper" if ncols > 1 else None))
    if handles:
        fig.axes[0].legend(handles=handles, fontsize=7, loc="upper right", framealpha=0.8)
    # One colour bar beside the panels, at most 4 in tall, centred on them.
    top, bottom = H - _MARGIN_T, _MARGIN_B
    bar = min(top - bottom, 4.0)
    cax = fig.add_axes(((W - _MARGIN_R + 0.2) / W, (bottom + (top - bottom - bar) / 2) / H, 0.15 / W, bar / H))
    fig.colorbar(image, cax=cax, label=_label(res, field))
    fig.suptitle(title, fontsize=10, y=1.0 - 0.12 / H, va="top")
    return fig


def _flat(values):
    """Every value of a list of fields (of one mesh or of several) in one flat array."""
    return np.concatenate([np.ravel(v) for v in values]) if len(values) else np.zeros(0)


def _draw_images(res, steps, field, values, path, title):
    """Write :func:`image_figure` to ``path``."""
    fig = image_figure(res, steps, field, values, title)
    save_figure(fig, path)
    plt.close(fig)


def line_figure(width, height):
    """A figure of one axes with fixed margins (inches) for tick labels, axis labels and title.

    Fixed margins rather than a layout engine: at these sizes the figure looks the same and
    draws in two thirds of the time (constrained layout draws all the text twice).
    """
    fig = plt.figure(figsize=(width, height))
    fig.subplots_adjust(left=0.95 / width, right=1.0 - 0.2 / width, bottom=0.6 / height, top=1.0 - 0.4 / height)
    return fig, fig.add_subplot()


def read_reference(path):
    """A measured curve: a CSV of two columns (displacement, force), ``#`` comment lines
    and one header line allowed. Returns ``(displacement, force)`` arrays."""
    rows = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        try:
            rows.append([float(v) for v in line.split(",")[:2]])
        except ValueError:
            continue  # the header
    data = np.array(rows)
    return data[:, 0], data[:, 1]


def force_displacement_figure(res, outdir, events=(), reference=None, xlabel="prescribed displacement",
                              ylabel="reaction force", event_label="crack length jumps",
                              title="force against displacement", physical=None):
    """``force_displacement.png``: the recorded force of each finished step against its
    prescribed displacement (``/steps/force``, ``/steps/displacement``), crack events marked.

    Parameters
    ----------
    res : Results
        An open results file with ``force`` and ``displacement`` in its steps (steps whose
        force was not recorded, NaN, are left out).
    outdir : str or Path
    events : sequence of float
        Loads t of the crack events; each is marked at the finished step nearest to it.
    reference : str or Path, optional
        A measured curve (:func:`read_reference`), drawn beside the computed one.
    xlabel, ylabel, event_label, title : str
        The kind's words.
    physical : tuple, optional
        ``(length factor, length label, force factor, force label)``: a second pair of axes
        (top, right) reading the same curve in physical units.

    Returns
    -------
    Path
    """
    path = Path(outdir) / "force_displacement.png"
    width, height = 6.4, 4.4
    fig, ax = line_figure(width, height)
    if physical is not None:
        # room for the second axes' ticks and labels, right and top
        fig.subplots_adjust(right=1.0 - 0.95 / width, top=1.0 - 0.95 / height)
    d, force = np.asarray(res.steps["displacement"]), np.asarray(res.steps["force"])
    ax.plot(d, force, "o-", ms=2.5, lw=1.4, color="black", label="computed")
    for t_event in events:
        k = int(np.argmin(np.abs(res.t - t_event)))
        ax.plot(d[k], force[k], "v", ms=8, mfc="none", color="tab:red")
    if len(events):
        ax.plot([], [], "v", ms=8, mfc="none", color="tab:red", label=event_label)
    if reference is not None:
        ref_d, ref_f = read_reference(reference)
        ax.plot(ref_d, ref_f, "-", lw=1.2, color="tab:blue", label=f"measured ({Path(reference).name})")
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(force))))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if physical is not None:
        length, length_label, unit, force_label = physical
        top = ax.secondary_xaxis("top", functions=(lambda v: v * length, lambda v: v / length))
        top.set_xlabel(length_label)
        right = ax.secondary_yaxis("right", functions=(lambda v: v * unit, lambda v: v / unit))
        right.set_ylabel(force_label)
    # above the second x axis' ticks and label, if there is one
    ax.set_title(f"{title}{progress_note(res)}", fontsize=10, pad=6 if physical is None else 40)
    ax.legend(fontsize=8)
    save_figure(fig, path)
    plt.close(fig)
    return path


def _draw_curves(res, steps, field, values, path, title):
    """Curves of ``values`` (one per step, each on its step's nodes) against x, coloured by
    load, on one axes."""
    vmin, vmax, _ = colour_range(field, _flat(values))
    fig, ax = line_figure(6.8, 4.2)
    colors = plt.cm.viridis(np.linspace(0.0, 0.9, len(steps)))
    x, _ = _abscissa(res.discretization)
    for k, v, color in zip(steps, values, colors):
        xk, order = _abscissa(res.discretization_at(k))
        ax.plot(xk, v[order], color=color, lw=1.4, label=f"t = {res.t[k]:.4g} (step {k})")
    pad = 0.02 * (vmax - vmin)
    ax.set_xlim(x[0], x[-1])
    ax.set_ylim(vmin - pad, vmax + pad)
    if field == "u":
        ax.axhline(0.0, color="0.7", lw=0.6, zorder=0)
    ax.set_xlabel(axis_label(res, "x"))
    ax.set_ylabel(_label(res, field))
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="best")
    save_figure(fig, path)
    plt.close(fig)


def _first_snapshot(res, field):
    """The first step worth a panel when no loads are asked for: for alpha the first whose
    surface energy is at least a hundredth of the last step's, otherwise the first loaded
    one (step 1); a panel of the sound, unloaded start shows nothing."""
    if field == "alpha" and "surface" in res.steps:
        surface = np.asarray(res.steps["surface"], dtype=float)
        # a crack worth seeing: a hundredth of the last step's surface energy (the first
        # faint damage of a nucleation would show as an empty panel)
        damaged = np.flatnonzero(surface >= 0.01 * surface[-1]) if surface.size and surface[-1] > 0 else []
        if len(damaged):
            return int(damaged[0])
    return 1


def _snapshots(res, outdir, field, loads=None, count=SNAPSHOTS, path=None, title=None):
    """Draw ``field`` at the steps of :func:`snapshot_steps` into ``path`` (default
    ``outdir/<field>_snapshots.png``); ``res`` is an open :class:`Results`. Returns the path,
    or None for a field this module does not draw (a vector field, a 3D mesh)."""
    if res.n == 0:
        raise ResultsError(f"{res.path}: no finished step to plot")
    d = res.discretization
    if res.components(field) > 1 or d.dim > 2:
        return None
    steps = snapshot_steps(res.t, loads, count, first=_first_snapshot(res, field))
    values = [res.field(field, k) for k in steps]  # each on its step's mesh (a refined mesh)
    if not res.adaptive:
        values = np.array(values)
    path = Path(path) if path is not None else Path(outdir) / f"{field}_snapshots.png"
    if title is None:
        what = _label(res, field).split(" ")[0]
        title = f"{what} at {len(steps)} load{'s' if len(steps) != 1 else ''}: {_model_title(res)}{progress_note(res)}"
    (_draw_curves if d.dim == 1 else _draw_images)(res, steps, field, values, path, title)
    return path


def _energies(res, outdir):
    path = Path(outdir) / "energy.png"
    steps = res.steps
    t = res.t
    marker = "." if res.n <= 40 else None  # few steps: show where they are
    physical = kinds.get(res.kind).physical(res)
    fig, ax = line_figure(6.4, 4.2)
    if physical:
        fig.subplots_adjust(right=1.0 - 0.95 / 6.4)  # room for the SI axis
        secondary_si_axis(ax, "right", physical["energy"], steps["total"], physical["energy_unit"], "energy")
    ax.plot(t, steps["elastic"], color="tab:blue", marker=marker, label="elastic")
    ax.plot(t, steps["surface"], color="tab:red", marker=marker, label="surface")
    ax.plot(t, steps["total"], color="black", lw=2, marker=marker, label="total")
    ax.set_xlim(0.0, max(res.t_max, t[-1] if res.n else 0.0))  # the full load range: an early stop shows
    ax.set_xlabel("load t")
    ax.set_ylabel(_label(res, "energy"))
    ax.set_title(f"energies: {_model_title(res)}{progress_note(res)}", fontsize=10)
    ax.legend()
    save_figure(fig, path)
    plt.close(fig)
    return path


def _iterations(res, outdir):
    path = Path(outdir) / "iterations.png"
    steps = res.steps
    t = res.t
    fig, ax = line_figure(6.4, 4.2)
    ax.plot(t, steps["iterations"], "o-", ms=3, color="black", label="alternate-minimization iterations")
    ax.plot(t, steps["u_solves"], "s--", ms=3, color="tab:blue", label="u-solves")
    if "backtracks" in steps and np.any(steps["backtracks"] > 0):
        back = steps["backtracks"] > 0
        ax.plot(t[back], steps["iterations"][back], "v", ms=7, mfc="none", color="tab:red",
                label="step restarted by backtracking")
    ax.set_xlim(0.0, max(res.t_max, t[-1] if res.n else 0.0))
    ax.set_ylim(bottom=0)
    ax.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("load t")
    ax.set_ylabel("count per load step")
    ax.set_title(f"solver work per step: {int(steps['iterations'].sum())} iterations,"
                 f" {int(steps['u_solves'].sum())} u-solves{progress_note(res)}", fontsize=10)
    ax.legend(fontsize=8)
    save_figure(fig, path)
    plt.close(fig)
    return path


def _animate(res, outdir, max_frames=MAX_FRAMES, fps=10):
    from matplotlib.animation import PillowWriter

    path = Path(outdir) / "alpha.gif"
    frames = snapshot_steps(res.t, count=max_frames)
    d = res.discretization
    if d.dim == 1:
        x, order = _abscissa(d)
        fig, ax = plt.subplots(figsize=(6.4, 3.4), layout="constrained")
        (artist,) = ax.plot(x, res.field("alpha", frames[0])[order], color="tab:red", lw=1.5)
        ax.set_xlim(x[0], x[-1])
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel(_label(res, "alpha"))

        def show(k):
            if res.adaptive:  # the step's own nodes
                xk, order_k = _abscissa(res.discretization_at(k))
                artist.set_data(xk, res.field("alpha", k)[order_k])
            else:
                artist.set_ydata(res.field("alpha", k)[order])
    elif d.dim == 2:
        _, _, w, h = _panel_layout(1, _aspect(d))
        fig, ax = plt.subplots(figsize=(w + 1.5, h + 1.2), layout="constrained")
        drawn = {"version": res.mesh_version(frames[0]),
                 "artist": _draw_field(ax, res.discretization_at(frames[0]), res.field("alpha", frames[0]), 0.0, 1.0,
                                       ALPHA_CMAP)}
        drawn["artists"] = list(ax.collections)
        ax.set_ylabel(axis_label(res, "y"))
        fig.colorbar(drawn["artist"], ax=ax, label=_label(res, "alpha"))

        def show(k):
            if isinstance(d, StructuredGrid):
                drawn["artist"].set_data(res.field("alpha", k))
            elif res.mesh_version(k) != drawn["version"]:
                # a refined mesh: the frame drawn anew on the step's triangles, on the same scale
                for artist in drawn["artists"]:
                    artist.remove()
                drawn["artist"] = _draw_field(ax, res.discretization_at(k), res.field("alpha", k), 0.0, 1.0,
                                              ALPHA_CMAP)
                drawn["artists"] = [a for a in ax.collections]
                drawn["version"] = res.mesh_version(k)
            else:
                drawn["artist"].set_array(res.field("alpha", k))
    else:
        raise ResultsError(f"{res.path}: alpha.gif is drawn for 1D and 2D runs only")
    ax.set_xlabel(axis_label(res, "x"))
    # Fixed-width numbers, and the layout frozen after the first frame, so that the axes do
    # not jitter from frame to frame as the title changes.
    last = res.n_planned - 1
    tw, kw = len(f"{max(res.t_max, res.t[-1]):.4f}"), len(str(last))
    title = ax.set_title(f"damage at t = {res.t[frames[0]]:{tw}.4f} (step {frames[0]:{kw}d} of {last})",
                         fontsize=10, family="monospace")
    writer = PillowWriter(fps=fps)
    partial = partial_path(path)
    with writer.saving(fig, str(partial), dpi=90):
        for i, k in enumerate(frames):
            show(k)
            title.set_text(f"damage at t = {res.t[k]:{tw}.4f} (step {k:{kw}d} of {last})")
            writer.grab_frame()
            if i == 0:
                # None (not "none", which keeps a placeholder engine): savefig then draws
                # each frame once instead of twice.
                fig.set_layout_engine(None)
    plt.close(fig)
    os.replace(partial, path)
    return path


def plot_snapshots(results, outdir=None, loads=None, field="alpha", count=SNAPSHOTS):
    """Draw ``<field>_snapshots.png``: a field at a few loads with one shared colour scale.

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of a run (or its run directory).
    outdir : str or Path, optional
        Where to write; defaults to the file's directory.
    loads : sequence of float, optional
        Loads to show; each is drawn at the nearest finished step (:func:`snapshot_steps`).
        Default: ``count`` loads evenly spread over the finished steps.
    field : {"alpha", "u"}
        Damage (colour scale [0, 1]) or deflection (symmetric about 0, the largest ``|u|``
        shown).
    count : int, optional

    Returns
    -------
    Path
    """
    if field not in ("alpha", "u"):
        raise ValueError(f"field = {field!r}: must be one of alpha, u")
    with Results(results) as res:
        return _snapshots(res, outdir if outdir is not None else res.path.parent, field, loads, count)


def plot_energies(results, outdir=None):
    """Draw ``energy.png``: elastic, surface and total energy of a run against t.

    Returns
    -------
    Path
    """
    with Results(results) as res:
        return _energies(res, outdir if outdir is not None else res.path.parent)


def plot_iterations(results, outdir=None):
    """Draw ``iterations.png``: alternate-minimization iterations and u-solves of each step.

    Returns
    -------
    Path
    """
    with Results(results) as res:
        return _iterations(res, outdir if outdir is not None else res.path.parent)


def animate_alpha(results, outdir=None, max_frames=MAX_FRAMES, fps=10):
    """Write ``alpha.gif``: the damage over the load, one frame per step.

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of a run.
    outdir : str or Path, optional
    max_frames : int, optional
        Longer runs are subsampled to this many steps, evenly, the first and last kept.
    fps : float, optional

    Returns
    -------
    Path
    """
    with Results(results) as res:
        if res.n == 0:
            raise ResultsError(f"{res.path}: no finished step to animate")
        return _animate(res, outdir if outdir is not None else res.path.parent, max_frames, fps)


def plot_run(results, outdir=None, loads=None, animate=False, xdmf=True, opener=Results):
    """Draw every figure of a run driven by the engine (and its XDMF index).

    Parameters
    ----------
    results : str or Path or Results
        ``results.h5`` of the run (or its run directory), or the run's reader already open (the
        run path's, whose cached readings, such as a film's crack metrics, are then not
        computed again); a run that stopped early is drawn up to its last finished step.
    outdir : str or Path, optional
        Where to write; defaults to the file's directory.
    loads : sequence of float, optional
        Loads of the snapshot figures, in ``[0, t_max]`` (default: the scene's ``[output]
        snapshots``, stored in ``/parameters``, else 5 spread over the finished steps). A load
        beyond the last finished step of a run that stopped early draws that step.
    animate : bool, optional
        Also write ``alpha.gif``.
    xdmf : bool, optional
        Also write ``results.xdmf`` (:func:`thinfilm.xdmf.write_xdmf`), so that the run path,
        which calls this function, leaves the index beside the fields.
    opener : type, optional
        The reader the kind's figures expect (a subclass of :class:`Results`).

    Returns
    -------
    list of Path
        ``energy.png``, then the kind's own figures (the film's ``force_displacement.png`` and
        ``cracks.png``), ``alpha.png``,
        ``alpha_snapshots.png``, ``u_snapshots.png`` (those drawn: see the module docstring),
        ``iterations.png``, the kind's figures drawn once (the film's ``toughness.png``), then
        ``alpha.gif`` and ``results.xdmf`` if asked for.
    """
    with (contextlib.nullcontext(results) if isinstance(results, Results) else opener(results)) as res:
        if res.n == 0:
            raise ResultsError(f"{res.path}: no finished step to plot")
        kind = kinds.get(res.kind)
        outside = [v for v in loads or () if not 0.0 <= v <= res.t_max]
        if outside:
            raise ResultsError(f"{res.path}: snapshot loads (--t) {' '.join(f'{v:g}' for v in outside)}: must be in"
                               f" [0, {res.t_max:g}], the run's loads (t_max = {res.t_max:g})")
        outdir = Path(outdir) if outdir is not None else res.path.parent
        outdir.mkdir(parents=True, exist_ok=True)
        if loads is None and "snapshots" in res.parameters:
            loads = res.parameters["snapshots"]
        last = res.n - 1
        paths = [_energies(res, outdir), *kind.figures(res, outdir),
                 _snapshots(res, outdir, "alpha", loads=[res.t[last]], path=outdir / "alpha.png",
                            title=f"damage at the last finished step: {_model_title(res)}{progress_note(res)}"),
                 _snapshots(res, outdir, "alpha", loads),
                 _snapshots(res, outdir, "u", loads),
                 _iterations(res, outdir),
                 *kind.constant_figures(res, outdir)]
        paths = [p for p in paths if p is not None]
        if animate:
            paths.append(_animate(res, outdir))
        path = res.path
    if xdmf:
        from thinfilm.xdmf import write_xdmf

        paths.append(write_xdmf(path, outdir))
    return paths


def plot_results(results, outdir=None, loads=None, animate=False):
    """Draw the figures of any thinfilm results file, by its kind.

    Returns
    -------
    kind : str
    paths : list of Path
    """
    with open_results(results) as f:
        path = Path(f.filename)
        kind = f.attrs["kind"]
        kind = kind.decode() if isinstance(kind, bytes) else str(kind)
    outdir = Path(outdir) if outdir is not None else path.parent
    return kind, kinds.get(kind).plot(path, outdir, loads=loads, animate=animate)  # which makes outdir
