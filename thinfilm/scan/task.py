"""One run of a scan, as a Dask worker executes it: :func:`run_task`.

The task is a plain function of plain arguments (paths, the overrides), so any Dask worker with
thinfilm installed and the scan directory on its file system can run it. It runs the scene
exactly as ``thinfilm run`` does (:func:`thinfilm.run.run`) into the run's own directory, and
ends by writing the scan's record of the run, ``run.json`` (status, error line, wall time,
worker), which is what marks the run finished.

It is safe to execute more than once. Dask executes it again when the worker running it dies
(the scheduler's ``allowed-failures``); the run then continues from its last finished step,
since ``results.h5`` is committed step by step (a kill at any instant leaves it as it was after
its last finished step: :mod:`thinfilm.results.journal`) and a resumed run gives the same
results as an uninterrupted one (:mod:`thinfilm.run`). A run whose ``run.json`` says ``done`` is not run again.
"""

from __future__ import annotations

import json
import logging
import os
import socket
import time
from pathlib import Path

from thinfilm.results.writer import write_json

__all__ = ["run_task", "read_record", "RECORD"]

#: The scan's record of a run, in the run's directory.
RECORD = "run.json"


def read_record(outdir):
    """The ``run.json`` of a run directory, or None if the run has not finished."""
    path = Path(outdir) / RECORD
    if not path.exists():
        return None
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _worker_name():
    """The Dask worker's address, or ``host:pid`` outside a worker."""
    try:
        from distributed import get_worker

        return str(get_worker().address)
    except (ImportError, ValueError):
        return f"{socket.gethostname()}:{os.getpid()}"


def _one_line(err):
    """An exception as the table's error column shows it: one line, its class named."""
    return f"{err.__class__.__name__}: {' '.join(str(err).split())}"


class _Warnings(logging.Handler):
    """Collects the run's warnings for its record (a worker has no terminal to print them on)."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.lines = []

    def emit(self, log_record):
        self.lines.append(log_record.getMessage())


def run_task(base, overrides, outdir, name):
    """Run one scene of a scan in ``outdir`` and write its ``run.json``.

    Parameters
    ----------
    base : str
        The base scene file (absolute path).
    overrides : dict
        The run's dotted-key overrides.
    outdir : str
        The run's directory.
    name : str
        The run's name (its hash), stored in the record.

    Returns
    -------
    dict
        The record: ``name``, ``status`` (``"done"`` or ``"failed"``), ``error`` (one line, or
        ""), ``wall_s``, ``worker``, ``resumed_after_step`` (the last finished step it continued
        from, or None), ``overrides``, ``warnings`` (the run's warning lines).
    """
    from thinfilm import kinds
    from thinfilm.results.reader import ResultsError, finished_steps, open_results
    from thinfilm.results.writer import ResumeError
    from thinfilm.run import run
    from thinfilm.scene import load_scene

    outdir = Path(outdir)
    record = read_record(outdir)
    if record is not None and record.get("status") == "done":
        return record
    start = time.perf_counter()
    record = {"name": name, "status": "done", "error": "", "wall_s": None, "worker": _worker_name(),
              "resumed_after_step": None, "overrides": overrides, "warnings": []}
    (outdir / RECORD).unlink(missing_ok=True)
    logger, warnings = logging.getLogger("thinfilm"), _Warnings()
    propagate, level = logger.propagate, logger.level
    logger.addHandler(warnings)
    logger.propagate = False
    logger.setLevel(logging.WARNING)
    try:
        scene = load_scene(base, overrides=overrides)
        resume = False
        if kinds.get(scene.kind).resumable and (outdir / "results.h5").exists():
            try:
                with open_results(outdir) as f:
                    resume = finished_steps(f) > 0
                    record["resumed_after_step"] = finished_steps(f) - 1 if resume else None
            except (ResultsError, OSError) as err:  # damaged otherwise (cut short by a copy): start over
                warnings.lines.append(f"could not resume ({' '.join(str(err).split())}); started over")
        try:
            run(scene, outdir, resume=resume, threads=1)
        except (ResumeError, OSError) as err:
            if not resume:
                raise
            # written by another scene, numpy or input files, or damaged otherwise: start over
            warnings.lines.append(f"could not resume ({' '.join(str(err).split())}); started over")
            record["resumed_after_step"] = None
            run(scene, outdir, resume=False, threads=1)
    except Exception as err:  # the run's failure is the table's, not the scan's
        record["status"], record["error"] = "failed", _one_line(err)
    finally:
        logger.removeHandler(warnings)
        logger.propagate = propagate
        logger.setLevel(level)
    record["warnings"] = warnings.lines
    record["wall_s"] = time.perf_counter() - start
    outdir.mkdir(parents=True, exist_ok=True)
    write_json(outdir / RECORD, record)
    return record
