"""Adaptive meshes against today's banded ones: whole evolutions, case by case.

Each case is run twice with ``python -m thinfilm run CASE --threads 1``: with
``--set mesh.adapt=false`` (the mesh refined in advance in a band where the crack was
expected) and with ``--set mesh.adapt=true`` (a uniform first mesh of the case's
``h_coarse``, refined during the run down to its ``h``: docs/adaptivity.md). The two rows of
a case run side by side, one thread each, so that both see the same machine. Per row: wall time and peak memory of the
process, the time in its steps (``/steps/time_total``: the speed-up is the banded row's over
the adaptive row's), its nodes (the banded mesh's; the adaptive run's first and last), the
iterations of the step where the crack first jumps, the critical displacement (that step's
load) and the force at the step before, the final energy, and the distance between the two
runs' cracks (the symmetric Hausdorff distance between their nodes with alpha >= 0.9) at the
last step both reached.

Every process runs with ``MKL_NUM_THREADS=1`` and ``OMP_NUM_THREADS=1``.

Usage (from the repository root)::

    python -m benchmarks.bench_adaptive --cases lpanel              # about 25 minutes
    python -m benchmarks.bench_adaptive --cases lpanel_fine         # banded: 3-4 hours
    python -m benchmarks.bench_adaptive --quick --out /tmp/adaptive # the coarse L-panel, 1 minute
    python -m benchmarks.bench_adaptive --cases lpanel_fine --collect   # rows from runs made
    python -m benchmarks.bench_adaptive --cases lpanel --sequential     # one row after the other

``--collect`` reads the run folders already in ``--work`` (default
``/tmp/thinfilm_bench_adaptive``; wall time and peak memory then from their ``.log`` if it
holds ``/usr/bin/time -v``'s report, else unknown), so a banded run started by hand
(``thinfilm run CASE --out WORK/CASE-banded``) or stopped before its end is compared over the
steps it made. Writes ``adaptive.csv`` (rows merged by key) and ``adaptive.md`` in
``benchmarks/results`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from benchmarks.tables import markdown_table, merge_csv

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
WORK = Path("/tmp/thinfilm_bench_adaptive")
THREADS = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}

#: case -> (scene, overrides of both rows, quick overrides)
CASES = {
    "lpanel": ("cases/lpanel.toml", [], []),
    "lpanel_fine": ("cases/lpanel_fine.toml", [], []),
    "lpanel_coarse": ("cases/lpanel.toml", ["model.eps=12.5", "mesh.h=2.5", "mesh.h_coarse=25.0"], []),
    "lpanel_3d": ("cases/lpanel_3d.toml", [], []),
    "brokenshire": ("cases/brokenshire.toml", [], []),
    # the double-torsion fracture run of docs/cases.md#double-torsion-with-damage: (4.11) with
    # a T/3 buffer of E/1e3, at the resolution of its measured table
    "double_torsion": ("cases/double_torsion.toml", ["mesh.h=0.6", "mesh.h_coarse=1.0", "model.eps=1.8",
                                                     "load.t_max=0.06", "load.steps=20", "geometry.buffer=1.0",
                                                     "model.buffers.buffer=72.0",
                                                     "output.snapshots=[0.015, 0.03, 0.045, 0.06]"], []),
}
QUICK = ("lpanel_coarse",)
FIELDS = ["id", "case", "mesh", "wall_s", "steps_s", "speedup", "peak_gb", "steps", "nodes_first", "nodes_last",
          "node_ratio", "iterations", "jump_iterations", "u_c", "F_c", "final_energy", "energy_vs_banded",
          "crack_distance", "crack_distance_at", "h_min"]


def _start(case, mesh, work):
    scene, overrides, _ = CASES[case]
    folder = work / f"{case}-{mesh}"
    command = ["/usr/bin/time", "-v", sys.executable, "-m", "thinfilm", "run", scene, "--out", str(folder),
               "--force", "--threads", "1"]
    for item in overrides + [f"mesh.adapt={'true' if mesh == 'adaptive' else 'false'}"]:
        command += ["--set", item]
    log = open(work / f"{case}-{mesh}.log", "w")
    process = subprocess.Popen(command, cwd=ROOT, env={**os.environ, **THREADS}, stdout=log, stderr=subprocess.STDOUT)
    return process, folder, time.perf_counter()


def time_report(log):
    """``(wall s, peak GB)`` from ``/usr/bin/time -v``'s report in a run's log, or NaNs."""
    text = log.read_text(errors="replace") if log.exists() else ""
    wall = re.search(r"Elapsed \(wall clock\) time.*: (?:(\d+):)?(\d+):([\d.]+)", text)
    peak = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    seconds = (float(wall.group(1) or 0) * 3600 + float(wall.group(2)) * 60 + float(wall.group(3))) if wall else np.nan
    return seconds, (int(peak.group(1)) * 1024 / 1e9 if peak else np.nan)


def _first_jump(res):
    """The step where the crack length first grows by a band's width at once, or None."""
    from fem3d.kind import crack_events, crack_lengths

    length, jump = crack_lengths(res)
    events = crack_events(res.t, length, jump)
    return None if not events else int(np.searchsorted(res.t, events[0]["t"]))


def crack_distance(res_a, k_a, res_b, k_b):
    """:func:`fem3d.cracks.crack_distance` of step ``k_a`` of one run and ``k_b`` of another."""
    from fem3d.cracks import crack_distance as distance

    return distance(res_a.discretization_at(k_a).points, res_a.field("alpha", k_a),
                    res_b.discretization_at(k_b).points, res_b.field("alpha", k_b))


def measure(case, work, timing):
    """The two rows of ``case`` from its run folders (``timing``: mesh -> (wall, peak))."""
    from thinfilm.results.reader import Results

    rows = {}
    with Results(work / f"{case}-banded") as banded, Results(work / f"{case}-adaptive") as adaptive:
        n = min(banded.n, adaptive.n)
        steps_s = {}
        for mesh, res in (("banded", banded), ("adaptive", adaptive)):
            steps_s[mesh] = float(res.steps["time_total"][:n].sum())
        for mesh, res in (("banded", banded), ("adaptive", adaptive)):
            jump = _first_jump(res)
            nodes = (res.steps["nodes"][:n] if "nodes" in res.steps
                     else np.full(n, res.discretization.n_nodes))
            wall, peak = timing.get(mesh, (np.nan, np.nan))
            rows[mesh] = dict(
                id=f"{case}/{mesh}", case=case, mesh=mesh, wall_s=round(wall, 1), steps_s=round(steps_s[mesh], 1),
                speedup=round(steps_s["banded"] / steps_s[mesh], 2), peak_gb=round(peak, 2), steps=n,
                nodes_first=int(nodes[0]), nodes_last=int(nodes[n - 1]),
                node_ratio=round(float(banded.discretization.n_nodes) / float(nodes[n - 1]), 2),
                iterations=int(res.steps["iterations"][:n].sum()),
                jump_iterations=int(res.steps["iterations"][jump]) if jump is not None and jump < n else "",
                u_c=float(res.t[jump]) if jump is not None and jump < n else "",
                F_c=round(float(res.steps["force"][jump - 1]), 1) if jump is not None and jump < n else "",
                final_energy=float(res.steps["total"][n - 1]),
                energy_vs_banded=round(float(res.steps["total"][n - 1] / banded.steps["total"][n - 1] - 1.0), 5),
                crack_distance=round(crack_distance(res, n - 1, banded, n - 1), 3),
                crack_distance_at=float(res.t[n - 1]), h_min=float(res.parameters["h"]))
    return list(rows.values())


def run_cases(cases, out, work, collect, sequential=False):
    work.mkdir(parents=True, exist_ok=True)
    for case in cases:
        timing = {}
        if collect:
            for mesh in ("banded", "adaptive"):
                timing[mesh] = time_report(work / f"{case}-{mesh}.log")
        else:
            meshes = ("banded", "adaptive")
            started = [] if sequential else [_start(case, mesh, work) for mesh in meshes]
            for k, mesh in enumerate(meshes):
                process, folder, _ = _start(case, mesh, work) if sequential else started[k]
                if process.wait() != 0:
                    raise RuntimeError(f"{folder.name} failed; see {folder}.log")
                timing[mesh] = time_report(work / f"{case}-{mesh}.log")
        rows = measure(case, work, timing)
        merge_csv(out / "adaptive.csv", rows, FIELDS, "id")
        write_markdown(out)
        for row in rows:
            print(row, flush=True)


def write_markdown(out):
    import csv

    with open(out / "adaptive.csv") as f:
        rows = list(csv.DictReader(f))
    columns = ["case", "mesh", "steps", "wall_s", "steps_s", "speedup", "peak_gb", "nodes_first", "nodes_last",
               "node_ratio", "jump_iterations", "u_c", "F_c", "energy_vs_banded", "crack_distance", "crack_distance_at",
               "h_min"]
    text = ("# Adaptive meshes against banded ones\n\n`python -m benchmarks.bench_adaptive` (one thread per run; the"
            " two rows of a case side by side, or one after the other with `--sequential`; speed-up: the banded"
            " row's step time over the row's; energy and crack distance at the last step both reached,"
            " `crack_distance_at`; docs/adaptivity.md#measured)\n\n"
            + "\n".join(markdown_table(rows, columns)) + "\n")
    (out / "adaptive.md").write_text(text)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="+", choices=sorted(CASES), default=None)
    parser.add_argument("--quick", action="store_true", help="the coarse L-panel only")
    parser.add_argument("--collect", action="store_true", help="measure the run folders already in --work")
    parser.add_argument("--sequential", action="store_true",
                        help="the two rows one after the other (a core is busy with another run)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--work", type=Path, default=WORK)
    args = parser.parse_args(argv)
    cases = args.cases or (list(QUICK) if args.quick else ["lpanel"])
    args.out.mkdir(parents=True, exist_ok=True)
    run_cases(cases, args.out, args.work, args.collect, args.sequential)


if __name__ == "__main__":
    main()
