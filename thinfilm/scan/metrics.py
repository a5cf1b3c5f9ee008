"""The numbers a scan collects from each run, computed from the run's files alone.

A metric reads a finished run's directory (``summary.json``, ``results.h5`` and the scan's
record ``run.json``), never a live object, so ``thinfilm scan --collect DIR`` rebuilds a
table without running anything. :data:`METRICS` lists them; a scan file names them in
``[collect] metrics``, and :func:`thinfilm.scan.plan.check_metrics` refuses a name that is
unknown or that the base scene's kind does not record.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Callable

import numpy as np

__all__ = ["Metric", "METRICS", "RunFiles", "compute", "metrics_reference"]

NAN = float("nan")


class RunFiles:
    """A run directory's files, read on demand.

    Parameters
    ----------
    outdir : Path
        The run's directory.
    """

    def __init__(self, outdir):
        self.outdir = Path(outdir)

    @cached_property
    def summary(self) -> dict:
        return json.loads((self.outdir / "summary.json").read_text(encoding="utf-8"))

    @cached_property
    def record(self) -> dict:
        path = self.outdir / "run.json"
        return json.loads(path.read_text(encoding="utf-8")) if path.exists() else {}

    @cached_property
    def steps(self) -> dict:
        """``/steps`` of ``results.h5`` cut to the finished steps, ``{name: ndarray (n,)}``."""
        from thinfilm.results.reader import finished_steps, open_results

        with open_results(self.outdir) as f:
            n = finished_steps(f)
            return {name: ds[:n] for name, ds in f["steps"].items() if ds.ndim == 1}

    @property
    def events(self) -> list:
        return self.summary.get("events", [])

    def last_cracks(self):
        """Crack positions at the last step (the film's along y = 0, the exact film's): the
        last event's list, since events are where the set of cracks changes."""
        return self.events[-1]["cracks"] if self.events else []


@dataclass(frozen=True)
class Metric:
    """One column of a scan's table.

    Attributes
    ----------
    name : str
    meaning : str
        One line for the documentation and ``thinfilm scan --help``.
    kinds : tuple of str or None
        The model kinds whose runs record it (None: every kind).
    compute : callable
        ``compute(files: RunFiles) -> float`` (NaN where it does not exist, e.g. no event).
    """

    name: str
    meaning: str
    kinds: tuple | None
    compute: Callable


def _last(name):
    return lambda run: float(run.steps[name][-1])


def _first_event_t(run):
    return float(run.events[0]["t"]) if run.events else NAN


def _spacing(run):
    cracks = np.sort(np.asarray(run.last_cracks(), dtype=float))
    # the median: a crack at a clamped end or the last, still partial gap does not pull it
    return float(np.median(np.diff(cracks))) if len(cracks) > 1 else NAN


def _peak(name):
    def compute(run):
        values = np.asarray(run.summary["steps"][name], dtype=float)
        return float(np.nanmax(np.abs(values))) if len(values) else NAN
    return compute


def _t_at_peak_force(run):
    force = np.abs(np.asarray(run.summary["steps"]["force"], dtype=float))
    return float(np.asarray(run.summary["steps"]["t"])[int(np.nanargmax(force))]) if len(force) else NAN


def _fem_last(name):
    return lambda run: float(run.summary["steps"][name][-1])


def _compliance(run):
    steps = run.summary["steps"]
    force = float(steps["force"][-1])
    return float(steps["displacement"][-1]) / force if force != 0.0 else NAN


def _steps_s(run):
    return float(np.sum(run.steps["time_total"]))


METRICS = {m.name: m for m in (
    Metric("first_event_t", "load t of the first event (the first crack nucleation)", None, _first_event_t),
    Metric("first_event_cracks", "number of cracks right after the first event", ("plate", "exact1d"),
           lambda run: float(len(run.events[0]["cracks"])) if run.events else NAN),
    Metric("events", "number of events (loads where the cracks change)", None, lambda run: float(len(run.events))),
    Metric("cracks_at_t_max", "number of cracks at the last step (the film's along y = 0)", ("plate", "exact1d"),
           lambda run: float(len(run.last_cracks()))),
    Metric("crack_spacing_at_t_max", "median distance between neighbouring cracks at the last step (NaN"
           " below two cracks)", ("plate", "exact1d"), _spacing),
    Metric("elastic_at_t_max", "elastic energy at the last step", None, _last("elastic")),
    Metric("surface_at_t_max", "surface energy at the last step", None, _last("surface")),
    Metric("total_at_t_max", "total energy at the last step", None, _last("total")),
    Metric("t_max", "load of the last finished step", None, _last("t")),
    Metric("iterations", "alternate-minimization iterations, summed over the steps", ("plate", "fem"),
           lambda run: float(np.sum(run.steps["iterations"]))),
    Metric("peak_force", "largest reaction force on the loaded boundary", ("fem",), _peak("force")),
    Metric("t_at_peak_force", "load t at the largest reaction force", ("fem",), _t_at_peak_force),
    Metric("crack_length_at_t_max", "crack length at the last step", ("fem",), _fem_last("crack_length")),
    Metric("compliance", "prescribed displacement over the reaction force at the last step (an elastic run's"
           " load-point compliance)", ("fem",), _compliance),
    Metric("steps_s", "seconds spent in the load steps, summed (the same whether the run was resumed or not)",
           ("plate", "fem"), _steps_s),
    Metric("wall_s", "wall time of the run's last attempt, set-up and figures included (seconds)", None,
           lambda run: float(run.record.get("wall_s", NAN))),
)}


def compute(outdir, names):
    """The metrics ``names`` of the finished run in ``outdir``, ``{name: float}``.

    A metric that cannot be read from the files (a missing file or entry) is NaN: the table
    still gets its row.
    """
    run = RunFiles(outdir)
    out = {}
    for name in names:
        try:
            value = METRICS[name].compute(run)
        except (OSError, KeyError, IndexError, ValueError):
            value = NAN
        out[name] = value if math.isfinite(value) or math.isnan(value) else NAN
    return out


def metrics_reference():
    """The metrics as a Markdown table (``docs/scans.md`` holds it between
    ``<!-- metrics -->`` markers; a test checks they agree)."""
    rows = ["| metric | kinds | meaning |", "|---|---|---|"]
    rows += [f"| `{m.name}` | {', '.join(m.kinds) if m.kinds else 'all'} | {m.meaning} |" for m in METRICS.values()]
    return "\n".join(rows)
