"""Figures drawn from a results file alone (never from live objects).

For an exact 1D run, like the dissertation's Fig. 2.15:

* ``energy.png``: total energy against t (solid), and the energy branch
  ``t^2/2 * coefficient + n G/a`` of every crack configuration the evolution visits
  (dashed, over the whole load range), so each event shows as a crossing of branches;
* ``cracks.png``: crack positions against t, each crack from its nucleation load on.

For a plate run (:func:`plot_plate`), from the finished steps of ``results.h5`` (a run that
stopped early is drawn as far as it got; :mod:`thinfilm.results`):

* ``energy.png``: elastic, surface and total energy against t;
* ``cracks.png``: crack positions along y = 0 against t (local maxima of alpha > 0.9);
* ``alpha.png``: the damage at the last finished step;
* ``alpha_snapshots.png``, ``u_snapshots.png``: the damage and the deflection at a few loads
  (nearest finished steps), one shared colour scale per figure: [0, 1] for alpha,
  symmetric about 0 for u. 2D fields as images with the domain's aspect ratio, 1D fields as
  curves;
* ``iterations.png``: alternate-minimization iterations and u-solves of each step;
* ``alpha.gif`` (on request): the damage over the load, at most ~100 frames.

Lengths are in units of L, energies and the load t non-dimensional (MODEL.md).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only; no display needed
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402
import numpy as np  # noqa: E402

from thinfilm.io import read_track  # noqa: E402
from thinfilm.results import PlateResults, ResultsError, open_results  # noqa: E402


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
    fig.savefig(path, dpi=130)
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
    fig.savefig(path, dpi=130)
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
    paths = [outdir / "energy.png", outdir / "cracks.png"]
    _energy_figure(data, paths[0])
    _cracks_figure(data, paths[1])
    return paths


# -- plate runs ---------------------------------------------------------------------------
#: Damage from sound (light) to broken (dark), as alpha.png has always been drawn.
ALPHA_CMAP = "magma_r"
#: Deflection: diverging about u = 0, so that its sign reads at a glance.
U_CMAP = "RdBu_r"
DPI = 130
#: Default number of snapshots, evenly spread over the finished steps.
SNAPSHOTS = 5
#: Most frames of alpha.gif; longer runs are subsampled evenly (first and last step kept).
MAX_FRAMES = 100
_LABEL = {"alpha": r"damage $\alpha$", "u": "deflection u (L)"}


def snapshot_steps(t, loads=None, count=SNAPSHOTS):
    """Finished steps to draw: the nearest to each requested load, or ``count`` spread evenly.

    Parameters
    ----------
    t : array_like, shape (n,)
        Loads of the finished steps, increasing.
    loads : sequence of float, optional
        Requested loads. Each selects the finished step of nearest t, so a load beyond the
        last finished step (a run that stopped early) selects the last one.
    count : int, optional
        Without ``loads``: this many steps evenly spread from the first to the last finished
        one (all of them if fewer have finished).

    Returns
    -------
    ndarray of int
        Step indices, sorted, without repeats (two loads nearest to one step draw it once).
    """
    t = np.asarray(t, dtype=float)
    if len(t) == 0:
        return np.empty(0, dtype=int)
    if loads is None or len(loads) == 0:
        steps = np.rint(np.linspace(0, len(t) - 1, min(count, len(t)))).astype(int)
    else:
        steps = np.array([int(np.argmin(np.abs(t - float(load)))) for load in loads], dtype=int)
    return np.unique(steps)


def _progress(res):
    """Title suffix of a run that has not finished all its steps."""
    return "" if res.n >= res.n_planned else f" [{res.n} of {res.n_planned} steps finished]"


def _model_title(res):
    p = res.parameters
    return (f"AT{p.get('at', '?')}, $\\lambda$ = {p.get('lam', float('nan')):g}, "
            f"G/a = {p.get('toughness', float('nan')):g}, $\\eta$ = {p.get('eta', float('nan')):.3g}")


def _extent(res):
    """Image extent with each pixel centred on its node (half pixels beyond the edges)."""
    x, y = res.x, res.y
    hx, hy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    return (x[0] - hx / 2, x[-1] + hx / 2, y[0] - hy / 2, y[-1] + hy / 2)


def _colour_range(field, values):
    """Shared colour (or y) range of a figure: [0, 1] for damage, symmetric about 0 for u."""
    if field == "alpha":
        return 0.0, 1.0, ALPHA_CMAP
    m = float(np.max(np.abs(values))) if np.size(values) else 0.0
    m = m if m > 0.0 and np.isfinite(m) else 1.0  # an undeformed film still needs a scale
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
_GAP_W, _GAP_H = 0.2, 0.4


def _draw_images(res, steps, field, values, path, title):
    """Images of ``values`` (shape (k, ny+1, nx+1)) at ``steps``, one colour scale and bar.

    The panels are placed explicitly, each exactly of the domain's aspect ratio, instead of
    by constrained layout: the same figure, at a fraction of the drawing time (a layout
    engine draws every panel's text several times).
    """
    vmin, vmax, cmap = _colour_range(field, values)
    aspect = (res.y[-1] - res.y[0]) / (res.x[-1] - res.x[0])
    nrows, ncols, w, h = _panel_layout(len(steps), aspect)
    h_box = max(h, 0.3)  # a very thin strip still gets room for its y ticks (image centred)
    W = _MARGIN_L + ncols * w + (ncols - 1) * _GAP_W + _MARGIN_R
    H = _MARGIN_T + nrows * h_box + (nrows - 1) * _GAP_H + _MARGIN_B
    fig = plt.figure(figsize=(W, H))
    extent = _extent(res)
    image = None
    for i, k in enumerate(steps):
        row, col = divmod(i, ncols)
        left = _MARGIN_L + col * (w + _GAP_W)
        bottom = _MARGIN_B + (nrows - 1 - row) * (h_box + _GAP_H)
        ax = fig.add_axes((left / W, bottom / H, w / W, h_box / H))
        # "auto": nearest pixels when the grid is coarser than the screen, antialiased when
        # finer, so that a crack band a few nodes wide never falls between the pixels.
        image = ax.imshow(values[i], origin="lower", extent=extent, vmin=vmin, vmax=vmax, cmap=cmap,
                          interpolation="auto")
        ax.set_xlim(res.x[0], res.x[-1])
        ax.set_ylim(res.y[0], res.y[-1])
        ax.yaxis.set_major_locator(MaxNLocator(nbins=4 if h_box > 1.0 else 2))
        ax.set_title(f"t = {res.t[k]:.4g} (step {k})", fontsize=9, pad=3)
        bottom_of_column = i + ncols >= len(steps)
        ax.tick_params(labelbottom=bottom_of_column, labelleft=col == 0, labelsize=8)
        if bottom_of_column:
            ax.set_xlabel("x (L)")
        if col == 0:
            ax.set_ylabel("y (L)")
    # One colour bar beside the panels, at most 4 in tall, centred on them.
    top, bottom = H - _MARGIN_T, _MARGIN_B
    bar = min(top - bottom, 4.0)
    cax = fig.add_axes(((W - _MARGIN_R + 0.2) / W, (bottom + (top - bottom - bar) / 2) / H, 0.15 / W, bar / H))
    fig.colorbar(image, cax=cax, label=_LABEL[field])
    fig.suptitle(title, fontsize=10, y=1.0 - 0.12 / H, va="top")
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _line_figure(width, height):
    """A figure of one axes with fixed margins (inches) for tick labels, axis labels and title.

    Fixed margins rather than a layout engine: at these sizes the figure looks the same and
    draws in two thirds of the time (constrained layout draws all the text twice).
    """
    fig = plt.figure(figsize=(width, height))
    fig.subplots_adjust(left=0.95 / width, right=1.0 - 0.2 / width, bottom=0.6 / height, top=1.0 - 0.4 / height)
    return fig, fig.add_subplot()


def _draw_curves(res, steps, field, values, path, title):
    """Curves of ``values`` (shape (k, nx+1)) against x, coloured by load, on one axes."""
    vmin, vmax, _ = _colour_range(field, values)
    fig, ax = _line_figure(6.8, 4.2)
    colors = plt.cm.viridis(np.linspace(0.0, 0.9, len(steps)))
    for k, v, color in zip(steps, values, colors):
        ax.plot(res.x, v, color=color, lw=1.4, label=f"t = {res.t[k]:.4g} (step {k})")
    pad = 0.02 * (vmax - vmin)
    ax.set_xlim(res.x[0], res.x[-1])
    ax.set_ylim(vmin - pad, vmax + pad)
    if field == "u":
        ax.axhline(0.0, color="0.7", lw=0.6, zorder=0)
    ax.set_xlabel("x (L)")
    ax.set_ylabel(_LABEL[field])
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _snapshots(res, outdir, field, loads=None, count=SNAPSHOTS, path=None, title=None):
    """Draw ``field`` at the steps of :func:`snapshot_steps` into ``path`` (default
    ``outdir/<field>_snapshots.png``); ``res`` is an open :class:`PlateResults`."""
    if res.n == 0:
        raise ResultsError(f"{res.path}: no finished step to plot")
    steps = snapshot_steps(res.t, loads, count)
    values = np.array([res.field(field, k) for k in steps])
    path = Path(path) if path is not None else Path(outdir) / f"{field}_snapshots.png"
    if title is None:
        what = "damage" if field == "alpha" else "deflection"
        title = f"{what} at {len(steps)} load{'s' if len(steps) != 1 else ''}: {_model_title(res)}{_progress(res)}"
    (_draw_curves if res.dim == 1 else _draw_images)(res, steps, field, values, path, title)
    return path


def _energies(res, outdir):
    path = Path(outdir) / "energy.png"
    steps = res.steps
    t = res.t
    marker = "." if res.n <= 40 else None  # few steps: show where they are
    fig, ax = _line_figure(6.4, 4.2)
    ax.plot(t, steps["elastic"], color="tab:blue", marker=marker, label="elastic")
    ax.plot(t, steps["surface"], color="tab:red", marker=marker, label="surface")
    ax.plot(t, steps["total"], color="black", lw=2, marker=marker, label="total")
    ax.set_xlim(0.0, max(res.t_max, t[-1] if res.n else 0.0))  # the full load range: an early stop shows
    ax.set_xlabel("load t")
    ax.set_ylabel("energy (non-dimensional)")
    ax.set_title(f"energies: {_model_title(res)}{_progress(res)}", fontsize=10)
    ax.legend()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _iterations(res, outdir):
    path = Path(outdir) / "iterations.png"
    steps = res.steps
    t = res.t
    fig, ax = _line_figure(6.4, 4.2)
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
                 f" {int(steps['u_solves'].sum())} u-solves{_progress(res)}", fontsize=10)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _cracks(res, outdir):
    path = Path(outdir) / "cracks.png"
    fig, ax = _line_figure(6.4, 4.2)
    for ti, cracks in zip(res.t, res.cracks()):  # one row per step: a large run is never read whole
        ax.plot(np.full(cracks.shape, ti), cracks, "|", color="tab:red", ms=6)
    ax.set_xlim(0.0, max(res.t_max, res.t[-1]))
    ax.set_ylim(res.x[0], res.x[-1])
    ax.set_xlabel("load t")
    ax.set_ylabel("crack position x (L)" + (" on y = 0" if res.dim == 2 else ""))
    ax.set_title(f"cracks (local maxima of alpha > 0.9){_progress(res)}", fontsize=10)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _toughness(res, outdir):
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
        fig, ax = _line_figure(6.8, 3.2)
        ax.plot(res.x, values, lw=1.0)
        ax.set_xlim(res.x[0], res.x[-1])
        ax.set_xlabel("x (L)")
        ax.set_ylabel("G/a")
    else:
        aspect = (res.y[-1] - res.y[0]) / (res.x[-1] - res.x[0])
        width = min(6.0, 4.5 / aspect)
        fig, ax = _line_figure(width + 1.6, width * aspect + 1.2)
        image = ax.imshow(values.reshape(len(res.y), len(res.x)), origin="lower", extent=_extent(res),
                          cmap="cividis", interpolation="auto")
        ax.set_xlabel("x (L)")
        ax.set_ylabel("y (L)")
        fig.colorbar(image, ax=ax, label="G/a", shrink=0.9)
    ax.set_title(title, fontsize=9)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)
    return path


def _animate(res, outdir, max_frames=MAX_FRAMES, fps=10):
    from matplotlib.animation import PillowWriter

    path = Path(outdir) / "alpha.gif"
    frames = snapshot_steps(res.t, count=max_frames)
    if res.dim == 1:
        fig, ax = plt.subplots(figsize=(6.4, 3.4), layout="constrained")
        (artist,) = ax.plot(res.x, res.field("alpha", frames[0]), color="tab:red", lw=1.5)
        ax.set_xlim(res.x[0], res.x[-1])
        ax.set_ylim(-0.02, 1.02)
        ax.set_ylabel(_LABEL["alpha"])

        def show(k):
            artist.set_ydata(res.field("alpha", k))
    else:
        _, _, w, h = _panel_layout(1, (res.y[-1] - res.y[0]) / (res.x[-1] - res.x[0]))
        fig, ax = plt.subplots(figsize=(w + 1.5, h + 1.2), layout="constrained")
        artist = ax.imshow(res.field("alpha", frames[0]), origin="lower", extent=_extent(res), vmin=0.0,
                           vmax=1.0, cmap=ALPHA_CMAP, interpolation="auto")
        ax.set_xlim(res.x[0], res.x[-1])
        ax.set_ylim(res.y[0], res.y[-1])
        ax.set_ylabel("y (L)")
        fig.colorbar(artist, ax=ax, label=_LABEL["alpha"])

        def show(k):
            artist.set_data(res.field("alpha", k))
    ax.set_xlabel("x (L)")
    # Fixed-width numbers, and the layout frozen after the first frame, so that the axes do
    # not jitter from frame to frame as the title changes.
    last = res.n_planned - 1
    tw, kw = len(f"{max(res.t_max, res.t[-1]):.4f}"), len(str(last))
    title = ax.set_title(f"damage at t = {res.t[frames[0]]:{tw}.4f} (step {frames[0]:{kw}d} of {last})",
                         fontsize=10, family="monospace")
    writer = PillowWriter(fps=fps)
    with writer.saving(fig, str(path), dpi=90):
        for i, k in enumerate(frames):
            show(k)
            title.set_text(f"damage at t = {res.t[k]:{tw}.4f} (step {k:{kw}d} of {last})")
            writer.grab_frame()
            if i == 0:
                # None (not "none", which keeps a placeholder engine): savefig then draws
                # each frame once instead of twice.
                fig.set_layout_engine(None)
    plt.close(fig)
    return path


def plot_snapshots(results, outdir=None, loads=None, field="alpha", count=SNAPSHOTS):
    """Draw ``<field>_snapshots.png``: a field at a few loads with one shared colour scale.

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of a plate run (or its run directory).
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
    if field not in _LABEL:
        raise ValueError(f"field = {field!r}: must be one of {', '.join(_LABEL)}")
    with PlateResults(results) as res:
        return _snapshots(res, outdir if outdir is not None else res.path.parent, field, loads, count)


def plot_energies(results, outdir=None):
    """Draw ``energy.png``: elastic, surface and total energy of a plate run against t.

    Returns
    -------
    Path
    """
    with PlateResults(results) as res:
        return _energies(res, outdir if outdir is not None else res.path.parent)


def plot_iterations(results, outdir=None):
    """Draw ``iterations.png``: alternate-minimization iterations and u-solves of each step.

    Returns
    -------
    Path
    """
    with PlateResults(results) as res:
        return _iterations(res, outdir if outdir is not None else res.path.parent)


def animate_alpha(results, outdir=None, max_frames=MAX_FRAMES, fps=10):
    """Write ``alpha.gif``: the damage over the load, one frame per step.

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of a plate run.
    outdir : str or Path, optional
    max_frames : int, optional
        Longer runs are subsampled to this many steps, evenly, the first and last kept.
    fps : float, optional

    Returns
    -------
    Path
    """
    with PlateResults(results) as res:
        if res.n == 0:
            raise ResultsError(f"{res.path}: no finished step to animate")
        return _animate(res, outdir if outdir is not None else res.path.parent, max_frames, fps)


def plot_plate(results, outdir=None, loads=None, animate=False, xdmf=True):
    """Draw every figure of a plate results file (and its XDMF index).

    Parameters
    ----------
    results : str or Path
        ``results.h5`` of a plate run (or its run directory); a run that stopped early is
        drawn up to its last finished step.
    outdir : str or Path, optional
        Where to write; defaults to the file's directory.
    loads : sequence of float, optional
        Loads of the snapshot figures (default: the scene's ``[output] snapshots``, stored
        in ``/parameters``, else 5 spread over the finished steps).
    animate : bool, optional
        Also write ``alpha.gif``.
    xdmf : bool, optional
        Also write ``results.xdmf`` (:func:`thinfilm.xdmf.write_xdmf`), so that the run path,
        which calls this function, leaves the index beside the fields.

    Returns
    -------
    list of Path
        ``energy.png``, ``cracks.png``, ``alpha.png``, ``alpha_snapshots.png``,
        ``u_snapshots.png``, ``iterations.png``, ``toughness.png`` for an imperfect film, then
        ``alpha.gif`` and ``results.xdmf`` if asked for.
    """
    with PlateResults(results) as res:
        if res.n == 0:
            raise ResultsError(f"{res.path}: no finished step to plot")
        outdir = Path(outdir) if outdir is not None else res.path.parent
        outdir.mkdir(parents=True, exist_ok=True)
        if loads is None and "snapshots" in res.parameters:
            loads = res.parameters["snapshots"]
        last = res.n - 1
        paths = [
            _energies(res, outdir),
            _cracks(res, outdir),
            _snapshots(res, outdir, "alpha", loads=[res.t[last]], path=outdir / "alpha.png",
                       title=f"damage at the last finished step: {_model_title(res)}{_progress(res)}"),
            _snapshots(res, outdir, "alpha", loads),
            _snapshots(res, outdir, "u", loads),
            _iterations(res, outdir),
        ]
        toughness = _toughness(res, outdir)
        if toughness is not None:
            paths.append(toughness)
        if animate:
            paths.append(_animate(res, outdir))
    if xdmf:
        from thinfilm.xdmf import write_xdmf

        paths.append(write_xdmf(results, outdir))
    return paths


def plot_results(results, outdir=None, loads=None, animate=False):
    """Draw the figures of any thinfilm results file, by its kind.

    Exact 1D runs get :func:`plot_exact1d` (``loads`` and ``animate`` do not apply); plate
    runs :func:`plot_plate`.

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
    if kind == "exact1d":
        outdir.mkdir(parents=True, exist_ok=True)
        return kind, plot_exact1d(path, outdir)
    return kind, plot_plate(path, outdir, loads=loads, animate=animate)
