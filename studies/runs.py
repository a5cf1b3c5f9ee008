"""Running a case file for a study: ``thinfilm run`` in its own process on one thread, and
the command line of a study made of named runs.

One thread for MKL, OpenMP and Numba, so that two runs made side by side on 2 cores each keep
a core; the output directory is overwritten (``--force``), so a study's ``--run`` starts its
runs from nothing.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}


def run_case(case, sets, out, log=None):
    """``python -m thinfilm run cases/<case>.toml --threads 1 --force --set ... --out out``
    from the repository root, raising if it fails.

    Parameters
    ----------
    case : str
        The case file's name in ``cases/``, without ``.toml``.
    sets : sequence of str
        ``KEY=VALUE`` overrides, each passed as ``--set``.
    out : Path
        The run's output directory.
    log : Path, optional
        Run under ``/usr/bin/time -v`` with its output and the report (wall time, peak
        memory: :func:`benchmarks.bench_adaptive.time_report`) in this file; else the output
        goes to the terminal.
    """
    command = [sys.executable, "-m", "thinfilm", "run", f"cases/{case}.toml", "--threads", "1", "--force",
               *[x for s in sets for x in ("--set", s)], "--out", str(out)]
    env = {**os.environ, **ONE_THREAD}
    if log is None:
        subprocess.run(command, cwd=ROOT, env=env, check=True)
        return
    with open(log, "w") as stream:
        subprocess.run(["/usr/bin/time", "-v", *command], cwd=ROOT, env=env, stdout=stream,
                       stderr=subprocess.STDOUT, check=True)


def study_main(description, work, runs, run, summarize, duration=None, argv=None):
    """The command line of a study made of named runs: ``[WORK] [--run] [--only NAME...]``.

    With ``--run`` it first calls ``run(work, names)``, then always ``summarize(work, names)``,
    so that the same command tabulates runs made earlier.

    Parameters
    ----------
    description : str
        The study's one-line description, for ``--help``.
    work : Path
        The default folder of the runs.
    runs : iterable of str
        The study's run names, the choices of ``--only`` (default: all).
    run, summarize : callable
        ``f(work: Path, names: list[str])``.
    duration : str, optional
        How long ``--run`` takes, for its help (e.g. "about 1 hour on one thread").
    argv : list of str, optional
        The arguments (default: the command line's).
    """
    names = list(runs)
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("work", type=Path, nargs="?", default=Path(work))
    parser.add_argument("--run", action="store_true",
                        help="make the runs first" + (f" ({duration})" if duration else ""))
    parser.add_argument("--only", nargs="*", default=names, choices=names, help="these runs only")
    args = parser.parse_args(argv)
    if args.run:
        run(args.work, args.only)
    summarize(args.work, args.only)
