"""Results on disk: the self-describing HDF5 file and the JSON summary.

Everything a plot, a summary or a later comparison needs is read back from these files,
never from live objects. ``results.h5`` of an exact 1D run::

    /                         attrs: format, format_version, kind, scene (the TOML text),
                              scene_source, thinfilm_version, numpy_version, numba_version,
                              h5py_version, created (UTC, ISO 8601)
    /parameters               attrs: length, lam, winkler, toughness, t_max, steps, cells
    /steps/t                  (n,)    load at each step, n = steps + 1, t[0] = 0
    /steps/elastic            (n,)    elastic energy
    /steps/surface            (n,)    surface energy (number of cracks * G/a)
    /steps/total              (n,)    total energy
    /steps/crack_count        (n,)    number of cracks
    /steps/cracks             (n, k)  crack positions, sorted, NaN-padded (k = most cracks)
    /events/t                 (e,)    exact load of each nucleation event
    /events/crack_count       (e,)    number of cracks after the event
    /events/cracks            (e, k)  all crack positions after the event, NaN-padded
    /events/new_cracks        (e, k)  the cracks created at the event, NaN-padded
    /events/branch_coefficient (e + 1,) sum_j (l_j + F(l_j)) of the state before the first
                              event and after each event: a state's energy branch is
                              t^2/2 * coefficient + crack_count * G/a
    /grid/steps/..., /grid/events/...   the same for the grid track (cracks on grid nodes);
                              /steps and /events hold the refined track (cracks off the grid)

``summary.json``::

    {"kind": "exact1d", "scene": ..., "parameters": {...},
     "events": [{"t": <load>, "cracks": [<all crack positions after the event, sorted>]}, ...],
     "events_grid": [... the same for the grid track ...]}

Files are written under a temporary name and renamed when complete, so a failed run never
leaves a truncated file that looks finished.
"""

from __future__ import annotations

import json
import os
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numba
import numpy as np

from thinfilm import __version__

FORMAT = "thinfilm-results"
FORMAT_VERSION = 1


def _padded(rows):
    """Ragged rows of floats -> (len(rows), max(1, longest)) array padded with NaN."""
    width = max([1] + [len(r) for r in rows])
    out = np.full((len(rows), width), np.nan)
    for i, row in enumerate(rows):
        out[i, : len(row)] = row
    return out


def _write_track(group, track):
    steps = group.create_group("steps")
    steps["t"] = track.t
    steps["elastic"] = track.elastic
    steps["surface"] = track.surface
    steps["total"] = track.total
    steps["crack_count"] = np.array([len(c) for c in track.cracks], dtype=np.int64)
    steps["cracks"] = _padded(track.cracks)
    events = group.create_group("events")
    events["t"] = np.array([e.t for e in track.events], dtype=float)
    events["crack_count"] = np.array([len(e.cracks) for e in track.events], dtype=np.int64)
    events["cracks"] = _padded([e.cracks for e in track.events])
    events["new_cracks"] = _padded([e.new_cracks for e in track.events])
    events["branch_coefficient"] = track.event_coefficients


def _atomic_path(path):
    return path.with_name(f".{path.name}.partial")


def write_exact1d(outdir, scene, tracks):
    """Write ``results.h5`` and ``summary.json`` of an exact 1D run.

    Parameters
    ----------
    outdir : Path
        Output directory (created if missing).
    scene : thinfilm.scene.Exact1DScene
    tracks : dict
        ``{"refined": Track, "grid": Track}`` from :func:`thinfilm.exact1d.evolution.run_exact1d`.

    Returns
    -------
    results, summary : Path
        The two files written.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    results = outdir / "results.h5"
    partial = _atomic_path(results)
    m = scene.model
    with h5py.File(partial, "w") as f:
        f.attrs.update({
            "format": FORMAT,
            "format_version": FORMAT_VERSION,
            "kind": scene.kind,
            "scene": scene.text,
            "scene_source": scene.source,
            "thinfilm_version": __version__,
            "numpy_version": np.__version__,
            "numba_version": numba.__version__,
            "h5py_version": h5py.__version__,
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        })
        params = f.create_group("parameters")
        params.attrs.update({
            "length": m.length, "lam": m.lam, "winkler": m.winkler, "toughness": m.toughness,
            "t_max": scene.load.t_max, "steps": scene.load.steps, "cells": scene.grid.cells,
        })
        _write_track(f, tracks["refined"])
        _write_track(f.create_group("grid"), tracks["grid"])
    os.replace(partial, results)

    summary = outdir / "summary.json"
    partial = _atomic_path(summary)
    content = {
        "kind": scene.kind,
        "scene": scene.source,
        "parameters": {"length": m.length, "lam": m.lam, "winkler": m.winkler,
                       "toughness": m.toughness, "t_max": scene.load.t_max,
                       "steps": scene.load.steps, "cells": scene.grid.cells},
        "events": [{"t": e.t, "cracks": list(e.cracks)} for e in tracks["refined"].events],
        "events_grid": [{"t": e.t, "cracks": list(e.cracks)} for e in tracks["grid"].events],
    }
    partial.write_text(json.dumps(content, indent=2) + "\n", encoding="utf-8")
    os.replace(partial, summary)
    return results, summary


def read_track(results, track="refined"):
    """Read one track of an exact 1D ``results.h5`` into plain arrays.

    Parameters
    ----------
    results : str or Path
        The HDF5 file.
    track : {"refined", "grid"}

    Returns
    -------
    dict
        ``steps`` and ``events`` sub-dicts of arrays (names as in the file), and
        ``parameters`` (dict of floats and ints).
    """
    with h5py.File(results, "r") as f:
        group = f if track == "refined" else f["grid"]
        out = {
            "steps": {k: v[()] for k, v in group["steps"].items()},
            "events": {k: v[()] for k, v in group["events"].items()},
            "parameters": {k: v.item() if hasattr(v, "item") else v for k, v in f["parameters"].attrs.items()},
        }
    return out


# -- plate runs ---------------------------------------------------------------------------
def finished_steps(f):
    """Number of finished steps ``n`` of an open results file.

    A plate run appends each step to every dataset of ``/steps`` and ``/fields`` in turn and
    flushes, so a run killed mid-way can leave datasets of lengths ``k`` and ``k + 1``.

    Parameters
    ----------
    f : h5py.File

    Returns
    -------
    int
        The shortest length among the per-step datasets (``/steps/*`` and, for plate runs,
        ``/fields/*``): rows ``0 .. n-1`` are complete in every dataset.
    """
    lengths = [ds.shape[0] for ds in f["steps"].values() if isinstance(ds, h5py.Dataset) and ds.ndim >= 1]
    if "fields" in f:
        lengths += [ds.shape[0] for ds in f["fields"].values() if isinstance(ds, h5py.Dataset)]
    return min(lengths) if lengths else 0


#: Per-step scalar records of a plate run, in /steps (names of thinfilm.engine.evolution.StepRecord).
STEP_FIELDS = ("t", "elastic", "surface", "total", "iterations", "u_solves", "u_solves_skipped",
               "backtracks", "trials", "trials_accepted", "time_u", "time_alpha", "time_total",
               "lowest_curvature", "saddles_left")
#: The integer ones among them.
INTEGER_STEP_FIELDS = ("iterations", "u_solves", "u_solves_skipped", "backtracks", "trials", "trials_accepted",
                       "saddles_left")


class ResumeError(RuntimeError):
    """A results file that cannot be continued; the message is one line for the user."""


class PlateResultsWriter:
    """``results.h5`` of a plate run, written and flushed step by step.

    Layout::

        /                  attrs as for exact runs (format, kind = "plate", scene, versions...)
        /parameters        attrs: at, nu, lam, winkler, toughness, eta, k_res, t_max, steps,
                           symmetry ("none" or the mirror group the fields were restricted to)
        /grid              attrs: dim, x0, x1, nx (and y0, y1, ny); datasets x (nx+1,), y (ny+1,)
        /steps/<name>      (n,) one value per finished step: t, elastic, surface, total,
                           iterations, u_solves, u_solves_skipped, backtracks, trials,
                           trials_accepted, time_u, time_alpha, time_total (seconds),
                           lowest_curvature (units of toughness/eta; NaN without the
                           stability check), saddles_left
        /fields/u          (n, n_nodes) displacement of each finished step
        /fields/alpha      (n, n_nodes) damage of each finished step
        /fields/toughness  (n_nodes,) G/a at the nodes, for an imperfect film only
                           (parameters toughness_noise, toughness_noise_length, toughness_noise_seed)

    Nodal fields follow :mod:`thinfilm.plate.grid`'s flattening (``reshape(ny+1, nx+1)`` in 2D).
    A backtrack to step k truncates every dataset to k steps before step k is rewritten, so
    the file always holds the current evolution up to its last finished step.

    Parameters
    ----------
    path : Path
    scene : thinfilm.scene.PlateScene
    grid : thinfilm.plate.grid.Grid
    resume : bool
        Continue an existing file written by the same scene text.
    toughness : ndarray, shape (n_nodes,), optional
        The toughness field of an imperfect film (stored; on resume, checked against the
        stored one, which the random generator of another numpy could change).
    """

    def __init__(self, path, scene, grid, resume=False, toughness=None):
        self.path = Path(path)
        if resume:
            self.file = h5py.File(self.path, "r+")
            stored = self.file.attrs.get("scene", "")
            if stored != scene.text:
                self.file.close()
                raise ResumeError(f"{self.path} was written by a different scene text; it cannot be resumed"
                                  " (run with --force to start over)")
            if toughness is not None and not np.array_equal(self.file["fields"]["toughness"][()], toughness):
                self.file.close()
                raise ResumeError(f"{self.path}: this installation draws another toughness field from the same"
                                  " seed (numpy's generator changed?); it cannot be resumed (run with --force)")
            n = self.trim()  # a step whose write was cut short is not finished
            for name in STEP_FIELDS:
                if name not in self.file["steps"]:   # written before the record existed
                    self._create_step_dataset(self.file["steps"], name, n)
            self.file.flush()
            return
        self.file = h5py.File(self.path, "w")
        f = self.file
        f.attrs.update({
            "format": FORMAT, "format_version": FORMAT_VERSION, "kind": scene.kind, "scene": scene.text,
            "scene_source": scene.source, "thinfilm_version": __version__, "numpy_version": np.__version__,
            "numba_version": numba.__version__, "h5py_version": h5py.__version__,
            "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        })
        m, load = scene.model, scene.load
        f.create_group("parameters").attrs.update({
            "at": m.at, "nu": m.nu, "lam": m.lam, "winkler": m.winkler, "toughness": m.toughness,
            "eta": m.eta, "k_res": m.k_res, "t_max": load.t_max, "steps": load.steps, "load": load.kind,
            "symmetry": scene.domain.symmetry,
            **({"toughness_noise": m.toughness_noise, "toughness_noise_length": m.toughness_noise_length,
                "toughness_noise_seed": m.toughness_noise_seed} if m.toughness_noise > 0 else {}),
            **({"radius": load.radius} if load.radius else {}), **({"field_file": load.file} if load.file else {}),
            **({"snapshots": scene.snapshots} if scene.snapshots else {}),
        })
        if scene.material is not None:
            mat = scene.material
            f.create_group("material").attrs.update({
                "E": mat.E, "nu": mat.nu, "h": mat.h, "Gc": mat.Gc, "bond_stiffness": mat.bond_stiffness,
                "L": mat.L, **mat.groups()})
        g = f.create_group("grid")
        g.attrs.update({"dim": grid.dim, "x0": grid.x0, "x1": grid.x1, "nx": grid.nx})
        g["x"] = np.asarray(grid.x)
        if grid.dim == 2:
            g.attrs.update({"y0": grid.y0, "y1": grid.y1, "ny": grid.ny})
            g["y"] = np.asarray(grid.y)
        steps = f.create_group("steps")
        for name in STEP_FIELDS:
            self._create_step_dataset(steps, name, 0)
        fields = f.create_group("fields")
        n = grid.n_nodes
        for name in ("u", "alpha"):
            fields.create_dataset(name, shape=(0, n), maxshape=(None, n), dtype=np.float64,
                                  chunks=(1, min(n, 1 << 20)))
        if toughness is not None:
            fields["toughness"] = np.asarray(toughness, dtype=np.float64)
        f.flush()

    @staticmethod
    def _create_step_dataset(steps, name, n):
        """``/steps/<name>`` with ``n`` rows (0 for integers, NaN for floats: not recorded)."""
        integer = name in INTEGER_STEP_FIELDS
        ds = steps.create_dataset(name, shape=(n,), maxshape=(None,), dtype=np.int64 if integer else np.float64,
                                  chunks=(256,))
        if n:
            ds[:] = 0 if integer else np.nan

    def write_step(self, record, state):
        """Store step ``record.index`` (truncating any later steps) and flush.

        The fields are written before the step's records, so a step counts as finished
        (``/steps/t`` has it) only once its fields are stored.
        """
        k = record.index
        f = self.file
        for name, values in (("u", state.u), ("alpha", state.alpha)):
            ds = f["fields"][name]
            ds.resize((k + 1, ds.shape[1]))
            ds[k] = values
        for name in STEP_FIELDS:
            ds = f["steps"][name]
            ds.resize((k + 1,))
            ds[k] = getattr(record, name)
        f.flush()

    def trim(self):
        """Cut every dataset to the finished steps (after a write was interrupted); returns their number."""
        f = self.file
        n = finished_steps(f)
        for name in STEP_FIELDS:
            if name in f["steps"]:
                f["steps"][name].resize((n,))
        for name in ("u", "alpha"):
            ds = f["fields"][name]
            ds.resize((n, ds.shape[1]))
        f.flush()
        return n

    def history(self, all_alpha=True):
        """The finished steps, as states to resume the evolution from.

        Parameters
        ----------
        all_alpha : bool
            Read the damage of every finished step (backtracking may return to any of
            them); otherwise only the last one's, the others' left as None.

        Returns
        -------
        list of thinfilm.engine.evolution.State
            One per finished step; the last one carries ``u``.
        """
        from thinfilm.engine.evolution import State

        f = self.file
        n = finished_steps(f)
        t, elastic, surface = (f["steps"][name][:n] for name in ("t", "elastic", "surface"))
        states = []
        for k in range(n):
            last = k == n - 1
            alpha = f["fields/alpha"][k] if (all_alpha or last) else None
            u = f["fields/u"][k] if last else None
            states.append(State(float(t[k]), u, alpha, float(elastic[k]), float(surface[k])))
        return states

    def close(self):
        self.file.close()


def write_plate_summary(path, scene, results, events):
    """``summary.json`` of a plate run: the crack events and per-step energies and iterations.

    ``{"kind": "plate", "scene": ..., "parameters": {...},
       "events": [{"t": <load>, "cracks": [<positions along y = 0, sorted>]}, ...],
       "steps": {"t": [...], "elastic": [...], "surface": [...], "total": [...],
                 "iterations": [...]}}``

    Parameters
    ----------
    path : Path
    scene : thinfilm.scene.PlateScene
    results : thinfilm.results.PlateResults
        The run's open results (finished steps).
    events : list of (float, ndarray)
    """
    content = {
        "kind": scene.kind,
        "scene": scene.source,
        "parameters": results.parameters,
        "events": [{"t": float(t), "cracks": [float(c) for c in cracks]} for t, cracks in events],
        "steps": {name: results.steps[name].tolist() for name in ("t", "elastic", "surface", "total", "iterations")},
    }
    partial = _atomic_path(Path(path))
    partial.write_text(json.dumps(content, indent=1) + "\n", encoding="utf-8")
    os.replace(partial, path)
    return Path(path)
