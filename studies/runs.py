"""Running a case file for a study: ``thinfilm run`` in its own process on one thread.

One thread for MKL, OpenMP and Numba, so that two runs made side by side on 2 cores each keep
a core; the output directory is overwritten (``--force``), so a study's ``--run`` starts its
runs from nothing.
"""

from __future__ import annotations

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
