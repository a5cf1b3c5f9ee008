"""Newton on both fields against alternate minimization: a nucleation step and whole evolutions.

Two parts, each row against today's default (``[solver] nonlinear = "altmin"``) in the same run:

1. ``nucleation``: the L-panel's nucleation step at the settings an independent NGSolve
   implementation was timed on (``cases/lpanel.toml`` with eps = 5 mm, h = 1.25 mm in the band,
   12.5 mm elsewhere, k_res = 1e-6: 30k nodes; :data:`benchmarks.bench_fem_lpanel.SCENE_2D`).
   The evolution runs (over-relaxed) to the step before the crack appears; that step is then
   solved from the same converged state by a fresh engine per row: plain alternate
   minimization (the baseline of the ratios), over-relaxed, each handing over to Newton,
   Newton with inertia correction instead of the hand-back (at the default hand-over, and
   from the first iterations through the crack front's transit), and a reference, plain
   alternate minimization to ``tol = 1e-5`` (the converged answer the energies and cracks are
   compared with). Per row: alternate-minimization iterations, Newton steps, linear solves,
   factorizations (all, and the large ones: u-matrix and coupled system), wall time, the
   energy against the reference's, the crack nodes (``alpha >= 0.9``) that differ from the
   reference's, the final scaled KKT residual, and the step's phases in u-solves (onset,
   front, tail: :func:`benchmarks.bench_fem_lpanel.phases`).
2. ``runs``: whole evolutions, ``python -m thinfilm run CASE --threads 1`` with
   ``--set solver.nonlinear=...``, the two rows of a case side by side on the two cores (one
   thread each, so that both see the same machine). Per row: wall time and peak memory of the
   process, the time in its steps (``/steps/time_total``: the speed-up is its ratio), the
   totals of its ``summary.json`` (iterations, Newton steps, linear solves, factorizations),
   the largest final KKT residual of a step, the final energy, the largest relative
   difference of a step's energy from the altmin row's, and the crack nodes of the last step
   that differ from the altmin row's.

Every process runs with ``MKL_NUM_THREADS=1`` and ``OMP_NUM_THREADS=1``.

Usage (from the repository root)::

    python -m benchmarks.bench_newton --part nucleation          # about 8 minutes
    python -m benchmarks.bench_newton --part runs                # 2-3 hours (double torsion: 1+ h)
    python -m benchmarks.bench_newton --part runs --cases indentation
    python -m benchmarks.bench_newton --quick --out /tmp/newton  # tiny sizes, about 2 minutes
    python -m benchmarks.bench_newton --part runs --collect --cases fig2_7   # rows from runs made

Each case's rows are merged into the table as soon as its pair is done.

Writes ``newton_nucleation.csv``, ``newton_runs.csv`` (rows merged by key) and ``newton.md``
in ``benchmarks/results`` (``--out`` another folder); the runs of part 2 in ``--work``
(default ``/tmp/thinfilm_bench_newton``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from benchmarks.tables import markdown_table, merge_csv

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
#: Where part 2's run folders go (kept out of the repository: results files of up to GBs).
WORK = Path("/tmp/thinfilm_bench_newton")
THREADS = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}

#: Nucleation rows: (name, alternate-minimization overrides, Newton overrides).
NUCLEATION_ROWS = (
    ("altmin", {"acceleration": "none"}, {"method": "altmin"}),
    ("altmin, overrelax", {"acceleration": "overrelax"}, {"method": "altmin"}),
    ("newton", {"acceleration": "none"}, {"method": "newton"}),
    ("newton, overrelax", {"acceleration": "overrelax"}, {"method": "newton"}),
    ("newton, indefinite = shift", {"acceleration": "none"}, {"method": "newton", "indefinite": "shift"}),
    # Newton through the transit: handed over at once, negative curvature shifted away
    ("newton from the start, indefinite = shift", {"acceleration": "none"},
     {"method": "newton", "indefinite": "shift", "switch": 1.0, "max_steps": 400, "attempts": 1}),
    ("reference: altmin, tol 1e-5", {"acceleration": "none", "tol": 1e-5}, {"method": "altmin"}),
)
NUCLEATION_FIELDS = ["id", "scene", "row", "iterations", "newton_steps", "newton_attempts", "newton_failures",
                     "linear_solves", "factorizations", "large_factorizations", "wall_s", "speedup", "energy",
                     "energy_vs_reference", "crack_nodes", "crack_nodes_off", "kkt_final", "onset", "front",
                     "tail"]

#: Whole-evolution cases: name -> (scene, overrides, quick overrides). The 3D L-panel runs at
#: h = 10 mm (eps = 20 mm, 4.6k nodes): there Newton's coupled factorization already costs
#: several times the u-solves', and the case file's own mesh would keep it for hours.
CASES = {
    "fig2_7": ("cases/fig2_7.toml", [], ["domain.cells=[240,100]"]),
    "indentation": ("cases/indentation.toml", [], ["domain.cells=[80,80]"]),
    "double_torsion_buffer": ("cases/double_torsion.toml", ["geometry.buffer=0.75", "model.buffers.buffer=72.0"],
                              ["mesh.h=0.8", "mesh.h_coarse=1.5", "model.eps=2.4", "load.steps=16"]),
    "lpanel_3d": ("cases/lpanel_3d.toml", ["mesh.h=10", "mesh.h_coarse=40", "model.eps=20"], ["load.steps=10"]),
    "lpanel": ("cases/lpanel.toml", [], ["mesh.h=2.5", "model.eps=5.0"]),
}
RUN_FIELDS = ["id", "case", "nonlinear", "wall_s", "steps_s", "speedup", "peak_gb", "steps", "iterations",
              "newton_steps",
              "linear_solves", "factorizations", "max_kkt_final", "energy", "max_energy_diff",
              "crack_nodes", "crack_nodes_off"]


# ------------------------------------------------------------------------------------------
# part 1: the nucleation step
# ------------------------------------------------------------------------------------------


class _Logged:
    """The model for the engine, logging the crack length ``S / toughness`` at each u-solve;
    every other attribute (the derivatives hook included) is the model's."""

    def __init__(self, model):
        self._model = model
        self.lengths = []

    def __getattr__(self, name):
        return getattr(self._model, name)

    def solve_u(self, alpha, t, u0, rtol):
        self.lengths.append(self._model.damage.surface_energy(alpha) / self._model.toughness)
        return self._model.solve_u(alpha, t, u0, rtol)


def nucleation(quick):
    """The rows of part 1 (in this process)."""
    import dataclasses
    import math

    import numpy as np

    from benchmarks.bench_fem_lpanel import CASE_2D, QUICK_2D, SCENE_2D, crack_jump, phases
    from fem3d.kind import build_mesh, build_model
    from thinfilm.engine import Engine, StepRecord
    from thinfilm.engine.options import NewtonOptions
    from thinfilm.run import load_steps
    from thinfilm.scene import load_scene
    from thinfilm.solvers.work import WORK

    overrides = dict(QUICK_2D if quick else SCENE_2D)
    scene = load_scene(CASE_2D, overrides=overrides)
    mesh = build_mesh(scene)
    model = build_model(scene, mesh)
    jump = crack_jump(scene, mesh)
    states = []

    class Stop(Exception):
        pass

    def on_step(record, state):
        states.append(state)
        if len(states) > 1 and (state.surface - states[-2].surface) / model.toughness > jump:
            raise Stop

    engine = Engine(model, dataclasses.replace(scene.solver.altmin, acceleration="overrelax"))
    try:
        engine.run(load_steps(scene.load), on_step=on_step)
    except Stop:
        pass
    previous, t, step = states[-2], states[-1].t, len(states) - 1
    print(f"  nucleation at step {step}, t = {t:g} ({mesh.n_nodes} nodes)", file=sys.stderr, flush=True)
    rows, finals = [], {}
    for name, altmin, newton in NUCLEATION_ROWS:
        logged = _Logged(model)
        engine = Engine(logged, dataclasses.replace(scene.solver.altmin, **altmin),
                        newton=NewtonOptions(**newton))
        record = StepRecord(step, t)
        before = WORK.snapshot()
        tic = time.perf_counter()
        state = engine.alternate_minimization(t, previous.alpha, previous.alpha, previous.u * (t / previous.t),
                                              record, step)
        wall = time.perf_counter() - tic
        after = WORK.snapshot()
        kkt = engine.final_kkt(state, previous.alpha)
        onset, front, tail, _ = phases(logged.lengths, previous.surface / model.toughness,
                                       state.surface / model.toughness, scene.model.eps)
        newton_factorizations = engine.newton_solver.factorizations if engine.newton_solver else 0
        finals[name] = state
        label = f"lpanel eps={scene.model.eps:g} h={scene.mesh.h:g}"
        rows.append(dict(id=f"{label} / {name}", scene=label, row=name,
                         iterations=record.iterations, newton_steps=record.newton_steps,
                         newton_attempts=record.newton_attempts, newton_failures=record.newton_failures,
                         linear_solves=after[1] - before[1], factorizations=after[0] - before[0],
                         large_factorizations=record.u_solves + newton_factorizations, wall_s=round(wall, 2),
                         energy=state.total, kkt_final=float(f"{kkt:.3g}"), onset=onset, front=front, tail=tail))
        print(f"  {name}: {record.iterations} iterations, {record.newton_steps} Newton steps, {wall:.1f} s",
              file=sys.stderr, flush=True)
    reference = finals[NUCLEATION_ROWS[-1][0]]
    crack = reference.alpha >= 0.9
    base = rows[0]["wall_s"]
    for row in rows:
        state = finals[row["row"]]
        row["speedup"] = round(base / row["wall_s"], 2) if row["wall_s"] > 0 else math.nan
        row["energy_vs_reference"] = float(f"{(state.total - reference.total) / abs(reference.total):.2e}")
        row["crack_nodes"] = int(np.sum(state.alpha >= 0.9))
        row["crack_nodes_off"] = int(np.sum((state.alpha >= 0.9) != crack))
        row["energy"] = round(row["energy"], 6)
    return rows


# ------------------------------------------------------------------------------------------
# part 2: whole evolutions
# ------------------------------------------------------------------------------------------


def _start(case, nonlinear, quick, work):
    scene, overrides, quick_overrides = CASES[case]
    folder = work / f"{case}-{nonlinear}"
    command = [sys.executable, "-m", "thinfilm", "run", scene, "--out", str(folder), "--force", "--threads", "1",
               "--set", f'solver.nonlinear="{nonlinear}"']
    for item in overrides + (quick_overrides if quick else []):
        command += ["--set", item]
    env = {**os.environ, **THREADS}
    log = open(work / f"{case}-{nonlinear}.log", "w")
    process = subprocess.Popen(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
    return process, folder, time.perf_counter()


def _wait(started):
    """Wait for the processes of ``started`` (``(process, folder, start time)`` each) in the
    order they end; ``[(wall s, peak GB)]`` in the order of ``started``."""
    by_pid = {process.pid: k for k, (process, _, _) in enumerate(started)}
    out = [None] * len(started)
    while by_pid:
        pid, status, usage = os.wait4(-1, 0)
        if pid not in by_pid:
            continue
        k = by_pid.pop(pid)
        process, folder, start = started[k]
        process.returncode = os.waitstatus_to_exitcode(status)
        if process.returncode != 0:
            raise RuntimeError(f"{folder.name} failed (exit {process.returncode}); see {folder}.log")
        out[k] = (time.perf_counter() - start, usage.ru_maxrss * 1024 / 1e9)
    return out


def _step_time(folder):
    """Seconds in the evolution's steps (``/steps/time_total``), meshing and figures left out."""
    import h5py

    with h5py.File(folder / "results.h5", "r") as f:
        return float(f["steps/time_total"][()].sum())


def _final_alpha(folder):
    import h5py

    with h5py.File(folder / "results.h5", "r") as f:
        return f["fields/alpha"][-1]


def runs(cases, quick, out, work, collect=False):
    """Part 2: run each case's pair and merge its rows into ``newton_runs.csv`` as soon as it
    is done (the runs themselves in ``work``); with ``collect``, only read the rows back from
    the run folders already in ``work`` (their wall time and peak memory unknown)."""
    import math

    import numpy as np

    work.mkdir(parents=True, exist_ok=True)
    for case in cases:
        rows = []
        if collect:
            started = [(None, work / f"{case}-{nonlinear}", None) for nonlinear in ("altmin", "newton")]
            measured = [(math.nan, math.nan)] * 2
        else:
            started = [_start(case, nonlinear, quick, work) for nonlinear in ("altmin", "newton")]
            measured = _wait(started)
        pair = []
        for (process, folder, _), (wall, peak), nonlinear in zip(started, measured, ("altmin", "newton")):
            steps = json.loads((folder / "summary.json").read_text())["steps"]
            pair.append((folder, steps))
            kkt = [k for k in steps["kkt_final"] if k == k]
            label = case + (" (quick)" if quick else "")
            rows.append(dict(id=f"{label} / {nonlinear}", case=label, nonlinear=nonlinear, wall_s=round(wall, 1),
                             steps_s=round(_step_time(folder), 1),
                             peak_gb=round(peak, 2), steps=len(steps["t"]), iterations=sum(steps["iterations"]),
                             newton_steps=sum(steps["newton_steps"]), linear_solves=sum(steps["linear_solves"]),
                             factorizations=sum(steps["factorizations"]),
                             max_kkt_final=float(f"{max(kkt):.3g}") if kkt else float("nan"),
                             energy=round(steps["total"][-1], 8)))
        (base_folder, base_steps), (folder, steps) = pair
        base_alpha, alpha = _final_alpha(base_folder) >= 0.9, _final_alpha(folder) >= 0.9
        e0, e1 = np.asarray(base_steps["total"]), np.asarray(steps["total"])
        scale = np.maximum(np.abs(e0), 1e-300)
        diff = float(np.max(np.abs(e1 - e0) / scale)) if e0.shape == e1.shape else float("nan")
        for row, a in zip(rows[-2:], (base_alpha, alpha)):
            row["speedup"] = round(rows[-2]["steps_s"] / row["steps_s"], 2)
            row["crack_nodes"] = int(a.sum())
            row["crack_nodes_off"] = int(np.sum(a != base_alpha))
        rows[-2]["max_energy_diff"], rows[-1]["max_energy_diff"] = 0.0, float(f"{diff:.2e}")
        print(f"  {case}: altmin {rows[-2]['steps_s']} s, newton {rows[-1]['steps_s']} s of steps", file=sys.stderr,
              flush=True)
        merge_csv(out / "newton_runs.csv", rows, RUN_FIELDS, key="id")
        write_markdown(out)


# ------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------


def write_markdown(out):
    import csv

    lines = ["# Newton on both fields against alternate minimization", "",
             "Written by `python -m benchmarks.bench_newton` (one thread per process; docs/speed.md#newton).", ""]
    for title, name, fields in (("The L-panel's nucleation step (NGSolve settings)", "newton_nucleation.csv",
                                 NUCLEATION_FIELDS),
                                ("Whole evolutions, the two rows of a case side by side", "newton_runs.csv",
                                 RUN_FIELDS)):
        path = out / name
        if path.exists():
            with open(path, newline="") as fh:
                rows = list(csv.DictReader(fh))
            lines += [f"## {title}", ""] + markdown_table(rows, fields[1:]) + [""]
    (out / "newton.md").write_text("\n".join(lines) + "\n", encoding="utf-8")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=("nucleation", "runs", "all"), default="all")
    parser.add_argument("--cases", nargs="+", choices=tuple(CASES), default=tuple(CASES))
    parser.add_argument("--quick", action="store_true", help="tiny sizes (checks the script)")
    parser.add_argument("--collect", action="store_true",
                        help="part 2: read the rows back from the run folders of --out without running")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--work", type=Path, default=WORK,
                        help="part 2: where the runs' folders go (results files of hundreds of MB)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    if args.worker:  # part 1, in a process whose threads are set before numpy loads
        print("RESULT " + json.dumps(nucleation(args.quick)), flush=True)
        return
    if args.part in ("nucleation", "all"):
        command = [sys.executable, "-m", "benchmarks.bench_newton", "--worker"] + (["--quick"] if args.quick else [])
        done = subprocess.run(command, cwd=ROOT, env={**os.environ, **THREADS}, stdout=subprocess.PIPE, text=True,
                              check=True)
        rows = json.loads(next(line for line in done.stdout.splitlines() if line.startswith("RESULT "))[7:])
        merge_csv(args.out / "newton_nucleation.csv", rows, NUCLEATION_FIELDS, key="id")
    if args.part in ("runs", "all"):
        runs(args.cases, args.quick, args.out, args.work, collect=args.collect)
    write_markdown(args.out)


if __name__ == "__main__":
    main()
