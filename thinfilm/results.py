"""Reading a ``results.h5`` back for inspection: validation, finished steps, ``thinfilm info``.

:mod:`thinfilm.io` writes the files; this module reads them for the commands that work from
a file alone (``thinfilm plot``, ``thinfilm info``, the XDMF index of
:mod:`thinfilm.xdmf`) and for the run's own summary. Everything here copes with files of
runs that stopped early: only the **finished steps** (:func:`thinfilm.io.finished_steps`)
are read; rows beyond them are an unfinished write and are ignored.

A path that is not a thinfilm results file raises :class:`ResultsError`, whose message is
one line for the user (the command line prints it and exits with status 2).
"""

from __future__ import annotations

import math
from pathlib import Path

import h5py
import numpy as np

from thinfilm.plate.cracks import crack_positions
from thinfilm.io import FORMAT, FORMAT_VERSION, finished_steps

#: Kinds of results files that the inspection commands know.
KINDS = ("exact1d", "plate")


class ResultsError(ValueError):
    """A path that is not a readable thinfilm results file; the message is one line."""


def _scalar(value):
    """An HDF5 attribute value as a plain Python object (numpy scalars -> int/float/str,
    arrays -> lists), ready for JSON and for printing."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value.item() if isinstance(value, np.generic) else value


def attrs_dict(node):
    """The attributes of an HDF5 group or dataset as a dict of plain Python values."""
    return {key: _scalar(value) for key, value in node.attrs.items()}


def resolve_results(path):
    """The ``results.h5`` that ``path`` names: the file itself, or ``DIR/results.h5``.

    Raises
    ------
    ResultsError
        If nothing readable is there.
    """
    path = Path(path)
    if path.is_dir():
        candidate = path / "results.h5"
        if not candidate.is_file():
            raise ResultsError(f"{path}: a directory without results.h5 (give the results file or its run directory)")
        return candidate
    if not path.exists():
        raise ResultsError(f"{path}: no such file")
    if not path.is_file():
        raise ResultsError(f"{path}: not a regular file")
    return path


def open_results(path):
    """Open a thinfilm ``results.h5`` for reading, after checking that it is one.

    A file still open for writing by a running job is locked by HDF5; it is then opened
    without the lock, which gives the steps flushed so far (each step is flushed whole).

    Parameters
    ----------
    path : str or Path
        The file, or the run directory holding ``results.h5``.

    Returns
    -------
    h5py.File
        Open read-only; the caller closes it.

    Raises
    ------
    ResultsError
        Missing file, not HDF5, not written by thinfilm, a newer format, or an unknown kind.
    """
    path = resolve_results(path)
    if not h5py.is_hdf5(path):
        raise ResultsError(f"{path}: not an HDF5 file (expected the results.h5 of a thinfilm run)")
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        if "lock" not in str(err).lower():
            raise ResultsError(f"{path}: cannot be opened: {err}") from None
        try:  # held by a running job: read what it has flushed
            f = h5py.File(path, "r", locking=False)
        except OSError as err2:
            raise ResultsError(f"{path}: cannot be opened: {err2}") from None
    try:
        fmt = _scalar(f.attrs.get("format", None))
        if fmt != FORMAT:
            found = "no 'format' attribute" if fmt is None else f"format = {fmt!r}"
            raise ResultsError(f"{path}: not a thinfilm results file ({found}, expected {FORMAT!r})")
        version = _scalar(f.attrs.get("format_version", 0))
        if not isinstance(version, int) or version > FORMAT_VERSION:
            raise ResultsError(f"{path}: format_version = {version!r} is newer than this thinfilm reads"
                               f" ({FORMAT_VERSION}); upgrade thinfilm")
        kind = _scalar(f.attrs.get("kind", None))
        if kind not in KINDS:
            raise ResultsError(f"{path}: kind = {kind!r} is not one of {', '.join(KINDS)}")
        required = ("steps/t", "parameters") + (("grid/x", "fields/u", "fields/alpha") if kind == "plate" else ())
        for name in required:
            if name not in f:
                raise ResultsError(f"{path}: incomplete {kind} results: /{name} is missing")
    except BaseException:
        f.close()
        raise
    return f


class PlateResults:
    """A plate ``results.h5`` opened for reading, cut to its finished steps.

    Reads the grid, the parameters and the per-step records at once; nodal fields are read
    one step at a time (:meth:`field`), so a large run is never loaded whole.

    Parameters
    ----------
    path : str or Path
        The file or its run directory.

    Attributes
    ----------
    path : Path
    n : int
        Finished steps (see :func:`finished_steps`).
    n_planned : int
        Steps of the complete run, ``parameters.steps + 1`` (step 0 is t = 0).
    dim : int
        1 or 2.
    x : ndarray, shape (nx+1,)
    y : ndarray, shape (ny+1,) or None
        Node coordinates (units of L); ``y`` is None in 1D.
    shape : tuple of int
        ``(nx+1,)`` or ``(ny+1, nx+1)``: a flat field reshaped to the grid (x fastest).
    steps : dict of ndarray, each shape (n,)
        ``/steps/*`` cut to the finished steps.
    parameters, grid_attrs, attrs : dict
        Attributes of ``/parameters``, ``/grid`` and the root.
    """

    def __init__(self, path):
        self.file = open_results(path)
        self.path = Path(self.file.filename)
        f = self.file
        try:
            if _scalar(f.attrs["kind"]) != "plate":
                raise ResultsError(f"{self.path}: kind = {_scalar(f.attrs['kind'])!r}, not a plate run")
            self.attrs = attrs_dict(f)
            self.parameters = attrs_dict(f["parameters"])
            self.grid_attrs = attrs_dict(f["grid"])
            self.dim = int(self.grid_attrs.get("dim", 2 if "y" in f["grid"] else 1))
            self.x = f["grid/x"][()]
            self.y = f["grid/y"][()] if self.dim == 2 else None
            self.n = finished_steps(f)
            self.steps = {name: ds[: self.n] for name, ds in f["steps"].items()}
            n_nodes = f["fields/alpha"].shape[1]
            if n_nodes != int(np.prod(self.shape)):
                raise ResultsError(f"{self.path}: /fields/alpha has {n_nodes} nodes per step, the grid"
                                   f" {self.shape} has {int(np.prod(self.shape))}")
        except KeyError as err:
            f.close()
            raise ResultsError(f"{self.path}: incomplete plate results: {err}") from None
        except BaseException:
            f.close()
            raise

    @property
    def shape(self):
        return (len(self.x),) if self.dim == 1 else (len(self.y), len(self.x))

    @property
    def n_planned(self):
        return int(self.parameters.get("steps", self.n - 1)) + 1

    @property
    def t(self):
        """Loads of the finished steps, shape (n,)."""
        return self.steps["t"]

    @property
    def t_max(self):
        """Final load of the complete run (the last finished one if not recorded)."""
        return float(self.parameters.get("t_max", self.t[-1] if self.n else 0.0))

    def field(self, name, k):
        """Nodal field ``name`` (``"alpha"`` or ``"u"``) of finished step ``k``, shape :attr:`shape`."""
        if not 0 <= k < self.n:
            raise IndexError(f"step {k} is not among the {self.n} finished steps")
        return self.file[f"fields/{name}"][k].reshape(self.shape)

    def centre_rows(self, name):
        """Field ``name`` along ``y = 0`` (the row nearest to it in 2D) at every finished step.

        Returns
        -------
        ndarray, shape (n, nx+1)
            Read by hyperslab, so only one row per step leaves the disk.
        """
        ds = self.file[f"fields/{name}"]
        if self.dim == 1:
            return ds[: self.n]
        j = int(np.argmin(np.abs(self.y)))
        width = len(self.x)
        return ds[: self.n, j * width:(j + 1) * width]

    def cracks(self):
        """Crack positions along ``y = 0`` at every finished step.

        Returns
        -------
        list of ndarray
            Sorted positions (units of L) of the local maxima of alpha above 0.9
            (:func:`thinfilm.plate.cracks.crack_positions`), one array per step.
        """
        return [crack_positions(self.x, row) for row in self.centre_rows("alpha")]

    @property
    def width(self):
        """Width ``y1 - y0`` of a 2D strip (units of L); 1 in 1D, so energies per unit width divide by it."""
        return float(self.y[-1] - self.y[0]) if self.dim == 2 else 1.0

    def close(self):
        self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# -- thinfilm info ------------------------------------------------------------------------
def _fmt(value):
    """A parameter value for one line: floats with 6 significant digits (also in lists), the
    rest as is."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return "[" + ", ".join(_fmt(v) for v in value) + "]"
    return str(value)


def _seconds(s):
    """Wall time for people: ``0.42 s``, ``3 min 12 s``, ``2 h 05 min``."""
    if not math.isfinite(s):
        return "n/a"
    if s < 60:
        return f"{s:.3g} s"
    if s < 3600:
        return f"{int(s // 60)} min {s % 60:02.0f} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


def describe(path):
    """The report of ``thinfilm info``: scene, versions, progress, last energies, timings.

    Parameters
    ----------
    path : str or Path
        A ``results.h5`` (plate or exact 1D run) or its run directory.

    Returns
    -------
    str
        Several lines, no trailing newline. Energies are printed with 12 significant digits.

    Raises
    ------
    ResultsError
    """
    with open_results(path) as f:
        path = Path(f.filename)
        attrs = attrs_dict(f)
        kind = attrs["kind"]
        params = attrs_dict(f["parameters"])
        n = finished_steps(f)
        planned = int(params.get("steps", n - 1)) + 1
        steps = {name: ds[:n] for name, ds in f["steps"].items() if isinstance(ds, h5py.Dataset)}
        lines = [f"results: {path} (kind = {kind}, format {attrs.get('format_version')})",
                 f"created: {attrs.get('created', 'unknown')}"]
        # thinfilm first, then its dependencies in the order io.py writes them.
        order = {"thinfilm_version": 0, "numpy_version": 1, "numba_version": 2, "h5py_version": 3}
        keys = sorted((key for key in attrs if key.endswith("_version") and key != "format_version"),
                      key=lambda key: (order.get(key, len(order)), key))
        versions = [f"{key[: -len('_version')]} {attrs[key]}" for key in keys]
        lines.append("versions: " + (", ".join(versions) if versions else "not recorded"))
        lines.append(f"scene: {attrs.get('scene_source', 'unknown')}")
        lines += ["    " + line if line else "" for line in str(attrs.get("scene", "")).strip("\n").splitlines()]
        lines.append("parameters: " + ", ".join(f"{k} = {_fmt(v)}" for k, v in params.items()))
        if "material" in f:
            lines.append("material: " + ", ".join(f"{k} = {_fmt(v)}" for k, v in attrs_dict(f["material"]).items()))
        if kind == "plate":
            g = attrs_dict(f["grid"])
            cells = f"{g.get('nx')}" if int(g.get("dim", 1)) == 1 else f"{g.get('nx')} x {g.get('ny')}"
            lines.append(f"grid: {int(g.get('dim', 1))}D, {cells} cells, {f['fields/alpha'].shape[1]} nodes")

        t = steps["t"]
        t_max = params.get("t_max")
        state = "complete" if n >= planned else "stopped early or still running"
        span = f"t = {t[0]:.6g} .. {t[-1]:.6g}" if n else "none"
        lines.append(f"steps finished: {n} of {planned} ({span}; t_max = {_fmt(t_max)}): {state}")
        if n:
            lines.append(f"last finished step: {n - 1}, t = {t[-1]:.12g}")
            lines.append(f"  elastic = {steps['elastic'][-1]:.12g}")
            lines.append(f"  surface = {steps['surface'][-1]:.12g}")
            lines.append(f"  total   = {steps['total'][-1]:.12g}")

        if kind == "plate" and "time_total" in steps:
            def total(name):
                return steps[name].sum() if name in steps else 0

            lines.append(f"timings (summed over the {n} finished steps):")
            lines.append(f"  wall time     {_seconds(float(total('time_total')))}")
            lines.append(f"  u-solves      {_seconds(float(total('time_u')))}"
                         f" ({int(total('u_solves'))} solves, {int(total('u_solves_skipped'))} skipped)")
            lines.append(f"  alpha-solves  {_seconds(float(total('time_alpha')))}")
            lines.append(f"  iterations    {int(total('iterations'))} alternate-minimization iterations"
                         f" (most in one step: {int(steps['iterations'].max()) if n else 0})")
            lines.append(f"  backtracks    {int(total('backtracks'))}; trials (search, stability)"
                         f" {int(total('trials'))} ({int(total('trials_accepted'))} kept)")
            if "lowest_curvature" in steps and n and np.isfinite(steps["lowest_curvature"]).any():
                curvature = steps["lowest_curvature"]
                checked = np.isfinite(curvature)
                unstable = np.flatnonzero(checked & (curvature < 0))
                lines.append(f"stability: {int(total('saddles_left'))} saddle(s) left; lowest curvature at the kept"
                             f" states {np.nanmin(curvature):.3g} toughness/eta"
                             + (f"; still negative at t = {', '.join(f'{t[k]:.4g}' for k in unstable)}"
                                if len(unstable) else ""))
        elif kind == "exact1d":
            events = f["events/t"][()] if "events/t" in f else np.empty(0)
            counts = f["events/crack_count"][()] if "events/crack_count" in f else np.zeros(len(events), int)
            lines.append("events: " + ("; ".join(f"t = {te:.8g}: {c} crack(s)" for te, c in zip(events, counts))
                                       if len(events) else "none"))
            lines.append("timings: not recorded for exact 1D runs")
    return "\n".join(lines)
