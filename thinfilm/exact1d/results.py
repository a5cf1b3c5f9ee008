"""Results of an exact 1D run: ``results.h5`` and ``summary.json``.

``results.h5``::

    /                         attrs as for every results file (thinfilm.results.writer):
                              format, format_version, kind = "exact1d", scene, versions, created
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

import os
from pathlib import Path

import h5py
import numpy as np

from thinfilm.results.writer import root_attributes, write_json

__all__ = ["write_exact1d", "read_track"]


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
    scene : thinfilm.exact1d.scene.Exact1DScene
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
        f.attrs.update(root_attributes(scene))
        params = f.create_group("parameters")
        params.attrs.update({
            "length": m.length, "lam": m.lam, "winkler": m.winkler, "toughness": m.toughness,
            "t_max": scene.load.t_max, "steps": scene.load.steps, "cells": scene.grid.cells,
        })
        _write_track(f, tracks["refined"])
        _write_track(f.create_group("grid"), tracks["grid"])
    os.replace(partial, results)

    content = {
        "kind": scene.kind,
        "scene": scene.source,
        "parameters": {"length": m.length, "lam": m.lam, "winkler": m.winkler,
                       "toughness": m.toughness, "t_max": scene.load.t_max,
                       "steps": scene.load.steps, "cells": scene.grid.cells},
        "events": [{"t": e.t, "cracks": list(e.cracks)} for e in tracks["refined"].events],
        "events_grid": [{"t": e.t, "cracks": list(e.cracks)} for e in tracks["grid"].events],
    }
    return results, write_json(outdir / "summary.json", content, indent=2)


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
