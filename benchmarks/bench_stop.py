"""The energy stop against the change stop, replayed on logged alternate-minimization histories.

A scene runs once with the change stop (``stop = "change"``), and every alternate-minimization
iteration is logged: the energy after the alpha-solve, the change of alpha, the scaled KKT
residual of the damage at the iteration's u-solve, and, once the step has converged, the
largest difference between the iteration's damage and the step's final one. The energy stop
(:meth:`thinfilm.engine.evolution.Engine._energy_settled`, the engine's own code) is then
replayed on each step's history for several ``energy_tol`` and ``kkt_factor``: where it would
have stopped, the iterations saved, and how far that state is from the change stop's final
one (energy, damage).

The replay takes each step as the change stop ran it; a run with the energy stop would start
the next step from its own, earlier state (the tests run both for real on a coarse
indentation: ``tests/engine/test_stop.py``).

Usage::

    python -m benchmarks.bench_stop cases/fig2_7.toml                 # about 1 minute
    python -m benchmarks.bench_stop cases/indentation.toml            # about 5 minutes
    python -m benchmarks.bench_stop cases/indentation_full_d4.toml    # about 25 minutes, 3.5 GB

(the last two after the main job: ``python -m thinfilm run cases/indentation.toml``). Each
writes its log to ``--work`` (default ``/tmp/thinfilm_bench_stop/<scene>``) and its rows into
``benchmarks/results/stop.csv`` and ``stop.md`` (merged by scene); ``--replay`` reuses a log.
"""

from __future__ import annotations

import argparse
import pickle
from pathlib import Path

import numpy as np

from benchmarks.tables import markdown_table, merge_csv
from thinfilm.engine import evolution
from thinfilm.engine.options import AltMinOptions
from thinfilm.solvers.boxqp import kkt_residual

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
FIELDS = ["scene", "tol", "energy_tol", "kkt_factor", "iterations_change", "iterations_energy", "ratio",
          "steps_stopped", "worst_energy_diff", "worst_alpha_diff", "worst_step"]
GRID = [(1e-5, 10.0), (1e-6, 10.0), (1e-6, 100.0), (1e-7, 10.0)]


def log_run(scene_path, work):
    """Run the scene with the change stop, logging each iteration; returns the log."""
    from thinfilm.run import run
    from thinfilm.scene import load_scene

    log, current = [], []
    solve_alpha, minimize = evolution.Engine._solve_alpha, evolution.Engine.alternate_minimization

    def logged_solve_alpha(self, u, t, alpha, lower, record, step, iteration):
        A, b = self.model.damage_problem(u, t)
        kkt = kkt_residual(A, b, alpha, lower, 1.0)
        new = solve_alpha(self, u, t, alpha, lower, record, step, iteration)
        elastic, surface = self.model.energies(u, new, t)
        current.append((dict(step=step, t=t, it=iteration, kkt=kkt, change=float(np.max(np.abs(new - alpha))),
                             E=elastic + surface), new.astype(np.float32)))
        return new

    def logged_minimization(self, *args, **kwargs):
        state = minimize(self, *args, **kwargs)
        final = state.alpha.astype(np.float32)
        for entry, alpha in current:
            entry["dalpha"] = float(np.max(np.abs(alpha - final)))
            log.append(entry)
        current.clear()
        return state

    evolution.Engine._solve_alpha = logged_solve_alpha
    evolution.Engine.alternate_minimization = logged_minimization
    try:
        scene = load_scene(scene_path, overrides={"solver.stop": "change"})
        run(scene, work)
    finally:
        evolution.Engine._solve_alpha, evolution.Engine.alternate_minimization = solve_alpha, minimize
    with open(work / "log.pkl", "wb") as fh:
        pickle.dump(log, fh)
    return log


def histories(log):
    """The log split into alternate minimizations (the iteration count restarts at 1)."""
    runs, current = [], []
    for entry in log:
        if entry["it"] == 1 and current:
            runs.append(current)
            current = []
        current.append(entry)
    if current:
        runs.append(current)
    return runs


class _Options:
    def __init__(self, altmin):
        self.altmin = altmin


def replay(runs, tol, energy_tol, kkt_factor):
    """Where the energy stop ends each history, and the differences there; one summary row."""
    engine = _Options(AltMinOptions(tol=tol, stop="energy", energy_tol=energy_tol, kkt_factor=kkt_factor))
    total_change = total_energy = stopped = 0
    worst_e = worst_a = 0.0
    worst_step = ""
    for history in runs:
        energies, changes, end = [], [], len(history) - 1
        for k, entry in enumerate(history):
            energies.append(entry["E"])
            changes.append(entry["change"])
            if entry["change"] < tol:
                end = k
                break
            if evolution.Engine._energy_settled(engine, energies, entry["kkt"], changes):
                end = k
                break
        final = history[-1]["E"]
        de = abs(history[end]["E"] - final) / abs(final) if final else 0.0
        da = history[end]["dalpha"]
        total_change += len(history)
        total_energy += end + 1
        stopped += end + 1 < len(history)
        if de > worst_e:
            worst_e, worst_step = de, f"t = {history[0]['t']:g}"
        worst_a = max(worst_a, da)
    return dict(tol=tol, energy_tol=energy_tol, kkt_factor=kkt_factor, iterations_change=total_change,
                iterations_energy=total_energy, ratio=round(total_energy / total_change, 3), steps_stopped=stopped,
                worst_energy_diff=f"{worst_e:.1e}", worst_alpha_diff=f"{worst_a:.2g}", worst_step=worst_step)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scene")
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--replay", type=Path, default=None, help="a log.pkl of an earlier invocation")
    args = parser.parse_args(argv)
    from thinfilm.scene import load_scene

    name = Path(args.scene).stem
    tol = load_scene(args.scene).solver.altmin.tol
    if args.replay:
        with open(args.replay, "rb") as fh:
            log = pickle.load(fh)
    else:
        work = args.work or Path("/tmp/thinfilm_bench_stop") / name
        work.mkdir(parents=True, exist_ok=True)
        log = log_run(args.scene, work)
    runs = histories(log)
    rows = [dict(scene=name, **replay(runs, tol, e, k)) for e, k in GRID]
    rows = merge_csv(RESULTS / "stop.csv", rows, FIELDS, "scene")
    lines = ["# The energy stop replayed on the change stop's histories", "",
             "Commands: `python -m benchmarks.bench_stop cases/<scene>.toml` for each scene below.", "",
             "Each scene ran with the change stop; the energy stop is replayed on every step's history"
             " (iterations: all alternate-minimization iterations of the run; `steps_stopped`: steps it"
             " ends early; the differences are to the change stop's final state of the same step:"
             " energy relative, damage max over the nodes). A real run with the energy stop starts each"
             " step from its own state, so later steps differ a little more.", ""] + markdown_table(rows, FIELDS)
    (RESULTS / "stop.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
