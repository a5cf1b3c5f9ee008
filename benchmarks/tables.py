"""The results files of the benchmarks that merge their rows across invocations.

A benchmark run for one grid or one scene replaces that grid's or scene's rows in its CSV and
keeps the others, then writes the whole as a markdown table (``bench_precision``,
``bench_stop``).
"""

from __future__ import annotations

import csv
from pathlib import Path


def merge_csv(path: Path, rows, fields, key, sort=None):
    """Write ``rows`` into the CSV ``path`` in place of the stored rows with the same ``key``.

    Parameters
    ----------
    path : Path
    rows : list of dict
        The new rows (values of ``fields``; other keys are not written).
    fields : list of str
        The CSV's columns.
    key : str
        The column whose values the new rows replace.
    sort : callable, optional
        Sort key of the merged rows (default: the stored rows first, in their order).

    Returns
    -------
    list of dict
        The merged rows, as written.
    """
    new = {str(r[key]) for r in rows}
    kept = []
    if path.exists():
        with open(path) as fh:
            kept = [r for r in csv.DictReader(fh) if r[key] not in new]
    merged = kept + list(rows)
    if sort is not None:
        merged.sort(key=sort)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(merged)
    return merged


def markdown_table(rows, fields):
    """The lines of a markdown table of ``rows`` in the columns ``fields``."""
    return (["| " + " | ".join(fields) + " |", "|" + "---|" * len(fields)]
            + ["| " + " | ".join(str(r[k]) for k in fields) + " |" for r in rows])
