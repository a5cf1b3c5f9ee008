"""A scan's table and figure, rebuilt from its directory alone.

The scan directory::

    DIR/scan.json          the plan: scan file, base scene, mode, keys, metrics, and every
                           run's name, values and overrides (written before anything runs)
    DIR/runs/<name>/       one run, as ``thinfilm run`` writes it (results.h5, summary.json,
                           figures), and the scan's record of it, run.json
    DIR/scan.csv           one row per run: run, the varied keys, the metrics, status, error,
                           wall_s, worker
    DIR/scan.png           each metric against the first varied key, one line per value of
                           the others

:func:`collect` reads ``scan.json`` and every run's files and writes the last two; the scan
calls it after each finished run, and ``thinfilm scan --collect DIR`` calls it alone.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np

from thinfilm.scan.metrics import METRICS, compute
from thinfilm.scan.task import read_record

__all__ = ["PLAN", "TABLE", "FIGURE", "write_plan", "read_plan", "collect", "read_table", "run_dir",
           "TableError"]

PLAN, TABLE, FIGURE = "scan.json", "scan.csv", "scan.png"
#: Columns after the parameters and the metrics.
TRAILER = ("status", "error", "wall_s", "worker")


class TableError(ValueError):
    """A directory that is not a scan's; the message is one line for the user."""


def run_dir(outdir, name):
    """The directory of run ``name`` in scan directory ``outdir``."""
    return Path(outdir) / "runs" / name


def write_plan(plan, outdir):
    """Write ``scan.json``: everything :func:`collect` needs besides the runs' files."""
    from thinfilm.results.writer import write_json

    content = {"scan": plan.source, "base": str(plan.base), "kind": plan.kind, "mode": plan.mode,
               "keys": list(plan.keys), "seed": plan.seed, "metrics": list(plan.metrics), "text": plan.text,
               "runs": [{"name": r.name, "values": r.values, "overrides": r.overrides} for r in plan.runs]}
    return write_json(Path(outdir) / PLAN, content, indent=1)


def read_plan(outdir):
    """``scan.json`` of a scan directory.

    Raises
    ------
    TableError
        If ``outdir`` has no readable ``scan.json``.
    """
    path = Path(outdir) / PLAN
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise TableError(f"{outdir}: not a scan directory (no {PLAN}; give the --out directory of a scan)") from None
    except (OSError, ValueError) as err:
        raise TableError(f"{path}: cannot be read ({err.__class__.__name__})") from None


def _columns(plan):
    metrics = [m for m in plan["metrics"] if m != "wall_s"]
    return ["run", *plan["keys"], *metrics, *TRAILER], metrics


def _cell(value):
    """A value as the table writes it: floats in their shortest exact form, None as ""."""
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    if isinstance(value, (list, dict)):
        return json.dumps(value)
    return str(value)


def rows(outdir, plan=None):
    """The table's rows, in the scan's order: ``[{column: value}]``."""
    plan = plan or read_plan(outdir)
    columns, metrics = _columns(plan)
    out = []
    for spec in plan["runs"]:
        rundir = run_dir(outdir, spec["name"])
        record = read_record(rundir)
        if record is None:
            status = "unfinished" if (rundir / "results.h5").exists() else "pending"
            record = {"status": status, "error": "", "wall_s": None, "worker": ""}
        values = compute(rundir, metrics) if record["status"] == "done" else dict.fromkeys(metrics, math.nan)
        row = {"run": spec["name"], **{k: spec["values"].get(k) for k in plan["keys"]}, **values,
               **{k: record.get(k) for k in TRAILER}}
        out.append({c: row.get(c) for c in columns})
    return out


def collect(outdir, figure=True):
    """Rebuild ``scan.csv`` (and ``scan.png``) from the scan directory alone.

    Parameters
    ----------
    outdir : str or Path
        The scan directory (with ``scan.json``).
    figure : bool
        Also draw ``scan.png``.

    Returns
    -------
    table : Path
    figure : Path or None
    counts : dict
        Runs per status (``done``, ``failed``, ``unfinished``, ``pending``).
    """
    outdir = Path(outdir)
    plan = read_plan(outdir)
    table_rows = rows(outdir, plan)
    columns, metrics = _columns(plan)
    path = outdir / TABLE
    partial = path.with_name(f".{path.name}.partial")  # renamed when whole, as results files are
    with open(partial, "w", newline="", encoding="utf-8") as f:
        writer = csv.writer(f)
        writer.writerow(columns)
        for row in table_rows:
            writer.writerow([_cell(row[c]) for c in columns])
    partial.replace(path)
    counts = {}
    for row in table_rows:
        counts[row["status"]] = counts.get(row["status"], 0) + 1
    picture = draw(outdir, plan, table_rows) if figure else None
    return path, picture, counts


def read_table(path):
    """``scan.csv`` read back as a list of ``{column: str}`` rows."""
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _number(value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    return float(value)


def draw(outdir, plan, table_rows):
    """``scan.png``: one panel per metric against the first varied key (numbers only), one line
    per combination of the other varied keys; repeats (the seed key) are drawn as points with
    their mean as the line. A ``zip`` scan without a seed, whose keys vary together, is one
    series: each metric against the run's place in the scan file (its values are in
    ``scan.csv``), since no single key orders it and its other keys are not a second
    dimension."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    keys = list(plan["keys"])
    seed = plan.get("seed")
    x_key = keys[0]
    others = [k for k in keys[1:] if k != seed]
    metrics = list(plan["metrics"])
    done = [r for r in table_rows if r["status"] == "done"]
    if plan.get("mode") == "zip" and seed is None and len(keys) > 1:
        return _draw_zip(outdir, plan, table_rows, done, metrics, plt)
    xs = [_number(r[x_key]) for r in done]
    numeric = all(x is not None for x in xs) and len(done) > 0
    fig, axes = plt.subplots(len(metrics), 1, figsize=(6.4, 0.4 + 2.4 * len(metrics)), squeeze=False)
    groups = sorted({tuple(_cell(r[k]) for k in others) for r in done})
    categories = sorted({_cell(r[x_key]) for r in done}) if not numeric else None
    for ax, metric in zip(axes[:, 0], metrics):
        for group in groups:
            members = [r for r in done if tuple(_cell(r[k]) for k in others) == group]
            label = ", ".join(f"{k.split('.')[-1]} = {v}" for k, v in zip(others, group)) or None
            x = np.array([_number(r[x_key]) if numeric else categories.index(_cell(r[x_key])) for r in members])
            y = np.array([float(r[metric]) for r in members])
            order = np.argsort(x, kind="stable")
            x, y = x[order], y[order]
            unique = np.unique(x)
            mean = np.array([np.nanmean(y[x == u]) if np.isfinite(y[x == u]).any() else np.nan for u in unique])
            line, = ax.plot(unique, mean, marker="o", label=label)
            if seed is not None:
                ax.plot(x, y, ".", color=line.get_color(), alpha=0.5)
        positive = numeric and xs and min(xs) > 0 and max(xs) / min(xs) > 5
        if positive:
            ax.set_xscale("log")
            # ticks at the scanned values: a log axis's own minor labels overlap
            ax.set_xticks(sorted(set(xs)), [f"{x:g}" for x in sorted(set(xs))])
            ax.xaxis.set_minor_formatter(NullFormatter())
        if not numeric:
            ax.set_xticks(range(len(categories)), categories)
        ax.set_ylabel(metric.replace("_", " "))
        ax.grid(alpha=0.3)
        if groups and len(groups) > 1:
            ax.legend(fontsize="small")
    axes[-1, 0].set_xlabel(x_key)
    return _save(fig, axes, outdir, plan, done, table_rows, plt)


def _draw_zip(outdir, plan, table_rows, done, metrics, plt):
    """``scan.png`` of a zip scan: each metric against the run's place in the scan file."""
    order = {r["run"]: k for k, r in enumerate(table_rows)}
    fig, axes = plt.subplots(len(metrics), 1, figsize=(6.4, 0.4 + 2.4 * len(metrics)), squeeze=False)
    x = np.array([order[r["run"]] + 1 for r in done])
    for ax, metric in zip(axes[:, 0], metrics):
        ax.plot(x, [float(r[metric]) for r in done], "o-", lw=0.8)
        ax.set_xticks(range(1, len(table_rows) + 1))
        ax.set_ylabel(metric.replace("_", " "))
        ax.grid(alpha=0.3)
    keys = ", ".join(k.split(".")[-1] for k in plan["keys"])
    axes[-1, 0].set_xlabel(f"run, in the scan file's order (together: {keys}; values in {TABLE})", wrap=True)
    return _save(fig, axes, outdir, plan, done, table_rows, plt)


def _save(fig, axes, outdir, plan, done, table_rows, plt):
    """Title ``scan.png`` (with the runs done so far) and write it."""
    axes[0, 0].set_title(f"scan of {Path(plan['base']).name}" + (f" ({len(done)} of {len(table_rows)} runs done)"
                                                                  if len(done) < len(table_rows) else ""))
    fig.tight_layout()
    from thinfilm.plots import save_figure

    path = Path(outdir) / FIGURE
    save_figure(fig, path, dpi=110)
    plt.close(fig)
    return path
