"""Cost of an alternate-minimization iteration and of the nucleation step on the FEM L-panel.

An independent NGSolve implementation of the same model was timed on Winkler's L-panel
(``cases/lpanel.toml`` in 2D: AT1, plane stress, 100 mm thick) with eps = 5 mm, a 1.25 mm band
``0 <= x <= 265``, ``240 <= y <= 360`` mm and 12.5 mm elsewhere (25k vertices), plain alternate
minimization to ``max |change of alpha| < 1e-3``: per iteration, a u-step (assembly + Cholesky +
solve) of 0.45-1.06 s and an alpha-step of 0.10-0.37 s; 340 iterations for the nucleation
step. This benchmark measures ``fem3d`` on that scene (the case file with the overrides
``{"model.eps": 5.0, "mesh.h": 1.25, "mesh.h_coarse": 12.5, "model.k_res": 1e-6}``), and the
3D panel (``cases/lpanel_3d.toml``) at two sizes:

1. the cost per alternate-minimization iteration, split into the assembly of ``K(alpha)``
   (:meth:`fem3d.elasticity.Elasticity.matrix`), the linear solver's update (PARDISO: the
   numeric refactorization with the kept analysis; AMG: new finest matrix, kept hierarchy,
   rebuilt only if the solver asks) and solve (AMG: CG warm-started from the u the engine gave,
   at the rtol it asked), the right-hand side (with the expansion to all dofs), the nodal
   energy + damage problem (:meth:`fem3d.model.FemModel.damage_problem`) and the damage QP
   (:func:`thinfilm.solvers.boxqp.solve_box_qp` as the engine calls it: warm-started from the
   alpha of the u-solve, lower bound the previous step's alpha). The evolution is run once (2D:
   plain alternate minimization over the case file's loads; 3D: the scene's over-relaxation
   over ``--steps3d`` equal steps, to keep it short) to the end of the nucleation step (the
   first step whose crack length ``S / (Gc T)`` grows by more than ``4 eps``, times the panel's
   depth in 3D); iterates of that step (from the sound state to the cracked one) are kept, and
   each part is timed ``--repeats`` (3D: ``--repeats3d``) times on each of ``--samples`` of
   them, in the order of an iteration. A
   cell is the median over the sampled iterates of the median over the repeats, with the
   range over the iterates; the whole ``model.solve_u`` is timed too, to check the sum.
   The engine also evaluates the energies twice per iteration; that row is listed apart;
2. the nucleation step (2D): alternate minimization at that load from the previous step's
   converged state (:meth:`thinfilm.engine.Engine.alternate_minimization`, a fresh engine per
   row) with ``acceleration = "none"`` (the baseline of every ratio) and ``"overrelax"`` (the
   scene's omega), and, if neither takes at most 50 iterations, other settings of the engine's
   declared options (:data:`EXTRA_SETTINGS`): iterations, u-solves, rejected extrapolations,
   wall and CPU time, the final energy (relative difference to the plain row) and the crack
   after (length ``S / (Gc T)``; tip and angle of the chord from the re-entrant corner to the
   farthest node with alpha >= 0.9, :func:`fem3d.cracks.crack_tip`);
3. the peak resident memory (``ru_maxrss``) of each case, one subprocess per case: after the
   evolution (the run) and at the end (with the timings and the nucleation rows);
4. the 3D panel (h = 10 and 8 mm in its band, 40 mm elsewhere, eps = 2 h) with the direct
   solver and with ``linear = "amg"``, each in its own subprocess (its own evolution, so its
   own peak memory).

Every subprocess runs with ``MKL_NUM_THREADS=1`` and ``OMP_NUM_THREADS=1`` (PARDISO, OpenBLAS
and the Numba kernels on one thread each). Before the cases, the script waits until the machine
is idle (1-min load average below 0.5, or no other python process above 20% of a core over
5 s; polled every minute, up to 40 minutes; ``--no-wait`` skips it) and it records the check.

Usage (from the repository root)::

    python -m benchmarks.bench_fem_lpanel                   # the scenes above, ~30 min
    python -m benchmarks.bench_fem_lpanel --quick --out /tmp/fem_lpanel   # tiny sizes, ~2 min

Writes ``benchmarks/results/fem_lpanel.md`` and ``.csv`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results"
CASE_2D = ROOT / "cases" / "lpanel.toml"
CASE_3D = ROOT / "cases" / "lpanel_3d.toml"
#: The scene the NGSolve implementation was timed on (k_res made explicit).
SCENE_2D = {"model.eps": 5.0, "mesh.h": 1.25, "mesh.h_coarse": 12.5, "model.k_res": 1e-6}
#: 3D sizes (h, h_coarse, eps): eps / h = 2 as in the case file.
#: (h = 7 mm, 92k dofs, was measured at 6.5 s per direct u-solve with the machine busy: its
#: evolution alone would take over 10 minutes.)
SIZES_3D = ((10.0, 40.0, 20.0), (8.0, 40.0, 16.0))
QUICK_2D = {"model.eps": 10.0, "mesh.h": 5.0, "mesh.h_coarse": 25.0, "model.k_res": 1e-6}
QUICK_3D = ((20.0, 50.0, 40.0),)
#: The NGSolve figures per iteration (s), from its run on SCENE_2D (another machine).
NGSOLVE = {"u_step": (0.45, 1.06), "alpha_step": (0.10, 0.37), "nucleation_iterations": 340}
TARGET_SPEEDUP = 5.0
TARGET_ITERATIONS = 50
THREADS = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
#: Settings of the nucleation step beyond "none" and "overrelax" (the scene's omega), tried when
#: neither of those reaches TARGET_ITERATIONS: the engine's other declared options.
EXTRA_SETTINGS = (
    {"acceleration": "overrelax", "omega": 8.0},
    {"acceleration": "overrelax", "omega_front": 4.0},
    {"acceleration": "overrelax", "omega": 8.0, "omega_front": 4.0},
    {"acceleration": "overrelax", "omega": 8.0, "omega_front": 8.0},
    {"acceleration": "overrelax", "omega": 8.0, "omega_front": 8.0, "omega_growth": 4.0},
    {"acceleration": "overrelax", "omega": 16.0, "omega_front": 16.0, "omega_growth": 4.0},
    {"acceleration": "overrelax", "omega_tail": 16.0},
    {"acceleration": "overrelax", "omega_tail": 32.0},
    {"acceleration": "overrelax", "omega": 8.0, "omega_front": 4.0, "omega_tail": 16.0},
    {"acceleration": "overrelax", "omega_tail": 1.0},
    {"acceleration": "none", "tol": 3e-3},
    {"acceleration": "overrelax", "tol": 3e-3},
)
#: The parts of an iteration, in its order: (key, label).
PARTS = (
    ("assembly", "assembly of K(alpha) (`elasticity.matrix`)"),
    ("update", "solver update (direct: numeric refactorization; amg: new matrix, rebuilds)"),
    ("solve", "solve (direct: triangular solves + residual check; amg: CG)"),
    ("rhs", "right-hand side + expansion"),
    ("u_step", "**u-step** (sum of the four)"),
    ("solve_u", "u-step measured whole (`model.solve_u`)"),
    ("problem", "nodal energy + damage problem (`damage_problem`)"),
    ("qp", "damage QP (`solve_box_qp`, warm start)"),
    ("alpha_step", "**alpha-step** (sum of the two)"),
    ("energies", "energies, 2 per iteration (engine)"),
    ("iteration", "**iteration** (u-step + alpha-step + energies)"),
)
COUNTS = (("qp_steps", "QP active-set steps"), ("cg_iterations", "CG iterations (amg)"))


# ------------------------------------------------------------------------------------------
# the machine
# ------------------------------------------------------------------------------------------


def _python_ticks():
    """CPU ticks (user + system) of every python process but this one and its children."""
    out = {}
    me = os.getpid()
    for name in os.listdir("/proc"):
        if not name.isdigit() or int(name) == me:
            continue
        try:
            with open(f"/proc/{name}/stat") as fh:
                text = fh.read()
            comm = text[text.index("(") + 1:text.rindex(")")]
            fields = text[text.rindex(")") + 2:].split()
            if "python" in comm and int(fields[1]) != me:  # fields[1]: the parent
                out[int(name)] = int(fields[11]) + int(fields[12])
        except (OSError, ValueError, IndexError):
            continue
    return out


def busy_pythons(seconds=5.0, threshold=20.0):
    """Other python processes above ``threshold`` % of a core over ``seconds``: {pid: %}."""
    tick = os.sysconf("SC_CLK_TCK")
    before = _python_ticks()
    time.sleep(seconds)
    after = _python_ticks()
    share = {pid: 100.0 * (after[pid] - before[pid]) / (tick * seconds) for pid in after if pid in before}
    return {pid: round(p) for pid, p in share.items() if p > threshold}


def machine_check():
    """``(idle, text)``: the 1-min load average and the busy python processes."""
    load = os.getloadavg()[0]
    busy = busy_pythons()
    idle = load < 0.5 or not busy
    text = f"load average {load:.2f}, other python processes above 20% CPU: " + (
        ", ".join(f"pid {pid} {p}%" for pid, p in busy.items()) or "none")
    return idle, text


def wait_for_idle(minutes=40.0, poll=60.0):
    """Wait until :func:`machine_check` says idle, polling every ``poll`` s; the checks' log."""
    started = time.perf_counter()
    log = []
    while True:
        idle, text = machine_check()
        waited = (time.perf_counter() - started) / 60
        log.append(f"{time.strftime('%H:%M:%S')} {text}")
        print(f"machine check: {text}", flush=True)
        if idle:
            return True, log, waited
        if waited >= minutes:
            return False, log, waited
        time.sleep(poll)


def versions():
    import numba
    import numpy
    import pyamg
    import scipy

    return {"numpy": numpy.__version__, "scipy": scipy.__version__, "pyamg": pyamg.__version__,
            "numba": numba.__version__}


# ------------------------------------------------------------------------------------------
# the worker: one case in one process
# ------------------------------------------------------------------------------------------


class _Stop(Exception):
    """Raised from the engine's on_step once the nucleation step is done."""


class Recorder:
    """The model for the engine, keeping a thinned sample of one step's iterates.

    Each damage problem the engine sets up is an iterate: ``(alpha, u0, rtol)`` of the
    u-solve before it (the alpha the QP is warm-started from) and the ``u`` it got. At most
    ``2 keep`` iterates are kept (every ``stride``-th, the stride doubling as the step goes
    on), plus the last, so memory stays bounded whatever the step's length.
    """

    def __init__(self, model, keep):
        self.model, self.keep = model, keep
        self.n_alpha, self.proportional, self.toughness = model.n_alpha, model.proportional, model.toughness
        self.last_solve = None
        self.new_step()

    def new_step(self):
        self.samples, self.count, self.stride, self.last = [], 0, 1, None

    def solve_u(self, alpha, t, u0, rtol):
        u = self.model.solve_u(alpha, t, u0, rtol)
        self.last_solve = (alpha, u0, rtol)
        return u

    def damage_problem(self, u, t):
        alpha, u0, rtol = self.last_solve
        self.last = dict(index=self.count, alpha=alpha, u0=u0, rtol=rtol, u=u, t=t)
        if self.count % self.stride == 0:
            self.samples.append({k: (v.copy() if hasattr(v, "copy") else v) for k, v in self.last.items()})
            if len(self.samples) > 2 * self.keep:
                self.stride *= 2
                self.samples = [s for s in self.samples if s["index"] % self.stride == 0]
        self.count += 1
        return self.model.damage_problem(u, t)

    def energies(self, u, alpha, t):
        return self.model.energies(u, alpha, t)

    def pick(self, n):
        """``n`` iterates of the step, evenly spread from the first to the last."""
        import numpy as np

        pool = list(self.samples)
        if self.last is not None and (not pool or pool[-1]["index"] != self.last["index"]):
            pool.append(self.last)
        k = np.unique(np.linspace(0, len(pool) - 1, min(n, len(pool))).round().astype(int))
        return [pool[i] for i in k]


def _rss_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6  # KB on Linux


def crack_jump(scene, mesh):
    """The growth of ``S / toughness`` in one step that counts as nucleation (``fem3d.kind``)."""
    import numpy as np

    jump = 4.0 * scene.model.eps
    if mesh.dim == 3:
        jump *= float(np.ptp(mesh.points[:, 2]))
    return jump


def evolve_to_nucleation(scene, model, mesh, keep, acceleration):
    """Evolution over the scene's loads with ``acceleration`` to the end of the nucleation step.

    Returns ``(states, records, samples, wall, jumped)``: the states and records up to that
    step, up to ``2 keep + 1`` of its iterates, and whether it passed the threshold. If no step
    does, the whole evolution is run and the step of largest growth stands in (``jumped``
    False; only for tiny test meshes, where the crack grows gradually).
    """
    from thinfilm.engine import Engine
    from thinfilm.run import load_steps

    recorder = Recorder(model, keep)
    engine = Engine(recorder, dataclasses.replace(scene.solver.altmin, acceleration=acceleration))
    jump = crack_jump(scene, mesh)
    states, records = [], []
    best = {"growth": -math.inf}

    def on_step(record, state):
        states.append(state)
        records.append(record)
        length = state.surface / model.toughness
        print(f"    step {record.index:3d} t = {state.t:.5g}: {record.iterations:4d} iterations,"
              f" crack {length:.4g}, {record.time_total:.2f} s", file=sys.stderr, flush=True)
        if len(states) > 1:
            growth = length - states[-2].surface / model.toughness
            if growth > jump:
                raise _Stop
            if growth > best["growth"]:
                best.update(growth=growth, k=len(states), samples=recorder.pick(keep))
        recorder.new_step()

    tic = time.perf_counter()
    try:
        engine.run(load_steps(scene.load), on_step=on_step)
    except _Stop:
        return states, records, recorder.pick(keep), time.perf_counter() - tic, True
    wall = time.perf_counter() - tic
    print(f"  no step grew the crack by more than {jump:g}: the step of largest growth"
          f" ({best['growth']:.4g}) stands in", file=sys.stderr, flush=True)
    k = best["k"]
    return states[:k], records[:k], best["samples"], wall, False


class Tracker:
    """The model for the engine, logging each u-solve's damage: the largest change from the
    last u-solve's and the crack length ``S / toughness`` (one sparse product each, well
    under 1% of an iteration)."""

    def __init__(self, model):
        self.model = model
        self.n_alpha, self.proportional, self.toughness = model.n_alpha, model.proportional, model.toughness
        self.changes, self.lengths, self._prev = [], [], None

    def solve_u(self, alpha, t, u0, rtol):
        import numpy as np

        if self._prev is not None:
            self.changes.append(float(np.max(np.abs(alpha - self._prev))))
        self._prev = alpha
        self.lengths.append(self.model.damage.surface_energy(alpha) / self.toughness)
        return self.model.solve_u(alpha, t, u0, rtol)

    def damage_problem(self, u, t):
        return self.model.damage_problem(u, t)

    def energies(self, u, alpha, t):
        return self.model.energies(u, alpha, t)


def phases(lengths, before, after, eps):
    """u-solves of a nucleation step in three phases, from the crack length at each: ``onset``
    until the crack is ``4 eps`` longer than before the step, ``front`` until it is within 5% of
    the growth of its final length, ``tail`` the rest; and the front's mean speed (length per
    u-solve over the front phase)."""
    import numpy as np

    lengths = np.asarray(lengths)
    n = lengths.size
    above = np.flatnonzero(lengths > before + 4.0 * eps)
    onset = int(above[0]) if above.size else n
    near = np.flatnonzero(lengths >= after - 0.05 * (after - before))
    end = int(near[0]) if near.size else n
    end = max(end, onset)
    front = end - onset
    speed = (lengths[end - 1] - lengths[onset]) / max(front - 1, 1) if front > 1 else math.nan
    return onset, front, n - end, float(speed)


def time_parts(model, samples, lower, repeats, damage_rtol):
    """Per-sample medians (over ``repeats``) of each part of an iteration, in seconds, and counts."""
    import numpy as np

    from thinfilm.solvers.boxqp import solve_box_qp

    el, solver, loads = model.elasticity, model.linear_solver, model.loads
    out = []
    for s in samples:
        alpha, u, t, rtol = s["alpha"], s["u"], s["t"], s["rtol"]
        x0 = None if s["u0"] is None else np.asarray(s["u0"])[el.free]
        times = {k: [] for k, _ in PARTS}
        counts = {"qp_steps": [], "cg_iterations": [], "rebuilds": 0}
        for _ in range(repeats):
            t0 = time.perf_counter()
            K = el.matrix(alpha)
            t1 = time.perf_counter()
            solver.update(K)
            t2 = time.perf_counter()
            u_con = t * loads.unit_values
            rhs = el.rhs(alpha, u_con, t * loads.unit_force)
            t3 = time.perf_counter()
            u_free, info = solver.solve(rhs, x0=x0, rtol=rtol)
            t4 = time.perf_counter()
            el.expand(u_free, u_con)
            t5 = time.perf_counter()
            A, b = model.damage_problem(u, t)
            t6 = time.perf_counter()
            result = solve_box_qp(A, b, lower, 1.0, a0=alpha, rtol=damage_rtol)
            t7 = time.perf_counter()
            model.energies(u, alpha, t)
            model.energies(u, result.a, t)
            t8 = time.perf_counter()
            times["assembly"].append(t1 - t0)
            times["update"].append(t2 - t1 + info.time_setup)
            times["solve"].append(t4 - t3 - info.time_setup)
            times["rhs"].append(t3 - t2 + t5 - t4)
            times["problem"].append(t6 - t5)
            times["qp"].append(t7 - t6)
            times["energies"].append(t8 - t7)
            counts["qp_steps"].append(result.iterations)
            if info.kind == "amg":
                counts["cg_iterations"].append(info.iterations)
                counts["rebuilds"] += int(info.rebuilt)
        for _ in range(repeats):
            t0 = time.perf_counter()
            model.solve_u(alpha, t, s["u0"], rtol)
            times["solve_u"].append(time.perf_counter() - t0)
        med = {k: statistics.median(v) for k, v in times.items() if v}
        med["u_step"] = med["assembly"] + med["update"] + med["solve"] + med["rhs"]
        med["alpha_step"] = med["problem"] + med["qp"]
        med["iteration"] = med["u_step"] + med["alpha_step"] + med["energies"]
        med["qp_steps"] = statistics.median(counts["qp_steps"])
        if counts["cg_iterations"]:
            med["cg_iterations"] = statistics.median(counts["cg_iterations"])
        med["rebuilds"] = counts["rebuilds"]
        med["rtol"] = rtol
        med["index"] = s["index"]
        out.append(med)
    return out


def summarize(per_sample):
    """{part: (median, min, max)} over the sampled iterates."""
    out = {}
    for key in [k for k, _ in PARTS] + [k for k, _ in COUNTS]:
        v = [m[key] for m in per_sample if key in m]
        if v:
            out[key] = (statistics.median(v), min(v), max(v))
    return out


def nucleation_row(model, scene, t, previous, step, setting):
    """Alternate minimization at ``t`` from the converged ``previous`` state; one table row."""
    import numpy as np

    from fem3d.cracks import crack_tip
    from thinfilm.engine import Engine, StepRecord

    opts = dataclasses.replace(scene.solver.altmin, **{"omega": scene.solver.altmin.omega, **setting})
    tracker = Tracker(model)
    engine = Engine(tracker, opts)
    record = StepRecord(step, t)
    u0 = previous.u * (t / previous.t) if previous.t != 0 else previous.u  # Engine._warm_start
    tic, tic_cpu = time.perf_counter(), time.process_time()
    state = engine.alternate_minimization(t, previous.alpha, previous.alpha, u0, record, step)
    wall, cpu = time.perf_counter() - tic, time.process_time() - tic_cpu
    history = np.asarray(record.energy_history)
    _, chord, angle = crack_tip(model.mesh.points, state.alpha, (250.0, 250.0))
    changed = {k: v for k, v in setting.items() if k != "acceleration"}
    onset, front, tail, speed = phases(tracker.lengths, previous.surface / model.toughness,
                                       state.surface / model.toughness, scene.model.eps)
    return dict(acceleration=setting["acceleration"], options=", ".join(f"{k} = {v:g}" for k, v in changed.items()),
                omega=opts.omega, omega_front=opts.omega_front, omega_growth=opts.omega_growth,
                omega_tail=opts.omega_tail, tol=opts.tol, iterations=record.iterations, u_solves=record.u_solves,
                rejected=record.extrapolations_rejected, wall_s=wall, cpu_s=cpu,
                ms_u_per_solve=1e3 * record.time_u / max(record.u_solves, 1),
                ms_alpha_per_iteration=1e3 * record.time_alpha / max(record.iterations, 1),
                energy=state.total, elastic=state.elastic, surface=state.surface,
                crack_length=state.surface / model.toughness, tip_chord=chord, tip_angle=angle,
                onset=onset, front=front, tail=tail, front_speed=speed,
                largest_change=max(tracker.changes, default=0.0),
                monotone=bool(np.all(np.diff(history) <= 1e-12 * abs(history[0]))),
                max_alpha=float(state.alpha.max()))


def worker(spec):
    """Run one case (``spec``: JSON) in this process and print one ``RESULT`` line."""
    import numpy as np

    from fem3d.kind import build_mesh, build_model
    from thinfilm.scene import load_scene

    overrides = dict(spec["overrides"])
    t0 = time.perf_counter()
    scene = load_scene(spec["case"], overrides=overrides)
    mesh = build_mesh(scene)
    t1 = time.perf_counter()
    model = build_model(scene, mesh)
    t2 = time.perf_counter()
    el = model.elasticity
    row = dict(case=spec["name"], dim=mesh.dim, h=scene.mesh.h, h_coarse=scene.mesh.h_coarse, eps=scene.model.eps,
               nodes=mesh.n_nodes, cells=mesh.n_cells, dofs=el.n_dofs, free_dofs=int(el.free.size), nnz_K=el.nnz,
               solver=model.linear_solver.kind, mesh_s=t1 - t0, model_s=t2 - t1,
               base_gb=_rss_gb(), threads=" ".join(f"{k}={os.environ.get(k, '')}" for k in THREADS),
               evolution_acceleration=spec["acceleration"])
    cpu = time.process_time()
    states, records, pool, wall, jumped = evolve_to_nucleation(scene, model, mesh, spec["samples"],
                                                               spec["acceleration"])
    cpu = time.process_time() - cpu
    nucleation, previous = states[-1], states[-2]
    row.update(evolution_s=wall, evolution_cpu_s=cpu, evolution_gb=_rss_gb(), steps_run=len(states),
               evolution_iterations=sum(r.iterations for r in records),
               evolution_u_solves=sum(r.u_solves for r in records),
               t_nucleation=nucleation.t, t_previous=previous.t, nucleation_step=records[-1].index,
               nucleation_iterations=records[-1].iterations,
               crack_before=previous.surface / model.toughness, crack_after=nucleation.surface / model.toughness,
               nucleation_jump=jumped,
               kept_mb=sum(v.nbytes for p in pool for v in p.values() if hasattr(v, "nbytes")) / 1e6,
               amg_builds_evolution=getattr(model.linear_solver, "n_builds", None))
    k = np.unique(np.linspace(0, len(pool) - 1, min(spec["samples"], len(pool))).round().astype(int))
    samples = [pool[i] for i in k]
    print(f"  evolution {wall:.1f} s; timing {len(samples)} iterates of step {records[-1].index}",
          file=sys.stderr, flush=True)
    builds = getattr(model.linear_solver, "n_builds", 0)
    per_sample = time_parts(model, samples, previous.alpha, spec["repeats"], scene.solver.altmin.damage_rtol)
    row.update(per_sample=per_sample, summary=summarize(per_sample), sample_indices=[s["index"] for s in samples],
               amg_builds_timing=getattr(model.linear_solver, "n_builds", 0) - builds, repeats=spec["repeats"])
    nuc = []
    if spec.get("nucleation"):
        settings = [{"acceleration": "none"}, {"acceleration": "overrelax"}]
        step = records[-1].index
        for setting in settings:
            nuc.append(nucleation_row(model, scene, nucleation.t, previous, step, setting))
            print(f"  nucleation {setting}: {nuc[-1]['iterations']} iterations, {nuc[-1]['wall_s']:.1f} s",
                  file=sys.stderr, flush=True)
        if min(r["iterations"] for r in nuc) > TARGET_ITERATIONS and spec.get("extras", True):
            for setting in EXTRA_SETTINGS:
                nuc.append(nucleation_row(model, scene, nucleation.t, previous, step, setting))
                print(f"  nucleation {setting}: {nuc[-1]['iterations']} iterations, {nuc[-1]['wall_s']:.1f} s",
                      file=sys.stderr, flush=True)
    row["nucleation_rows"] = nuc
    row["peak_gb"] = _rss_gb()
    print("RESULT " + json.dumps(row, default=float), flush=True)


# ------------------------------------------------------------------------------------------
# the driver
# ------------------------------------------------------------------------------------------


def run_case(spec, timeout):
    cmd = [sys.executable, "-m", "benchmarks.bench_fem_lpanel", "--worker", json.dumps(spec)]
    env = dict(os.environ, PYTHONWARNINGS="ignore", **THREADS)
    tic = time.perf_counter()
    before = _python_ticks()
    print(f"case {spec['name']}: {spec['overrides']}", flush=True)
    try:
        out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=None, text=True, timeout=timeout, env=env, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return dict(case=spec["name"], status=f"killed after {timeout:.0f} s")
    after = _python_ticks()
    wall = time.perf_counter() - tic
    # other python processes' CPU over the case (those that started during it counted whole)
    others = sum(after[pid] - before.get(pid, 0) for pid in after) / os.sysconf("SC_CLK_TCK")
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            row = json.loads(line[7:])
            row["status"] = "ok"
            row["wall_case_s"] = wall
            row["others_cpu_pct"] = 100.0 * others / wall
            print(f"  {spec['name']}: {row['wall_case_s']:.1f} s wall", flush=True)
            return row
    return dict(case=spec["name"], status=f"crashed (exit {out.returncode})")


def ms(x):
    return f"{1e3 * x:.1f}" if x >= 0.0095 else f"{1e3 * x:.2f}"


def write_outputs(cases, command, total, checks, out):
    out.mkdir(parents=True, exist_ok=True)
    ok = [c for c in cases if c.get("status") == "ok"]
    csv_rows = []
    for c in cases:
        csv_rows.append(dict(table="cases", **{k: v for k, v in c.items()
                                              if not isinstance(v, (list, dict))}))
    for c in ok:
        for key, _ in PARTS + COUNTS:
            if key in c["summary"]:
                med, lo, hi = c["summary"][key]
                unit = "s" if key not in dict(COUNTS) else "count"
                csv_rows.append(dict(table="cost", case=c["case"], part=key, unit=unit, median=med, min=lo, max=hi,
                                     samples=len(c["per_sample"]), repeats=c["repeats"]))
        for r in c["nucleation_rows"]:
            csv_rows.append(dict(table="nucleation", case=c["case"], **r))
    fields = []
    for r in csv_rows:
        fields += [k for k in r if k not in fields]
    with open(out / "fem_lpanel.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(csv_rows)

    v = versions()
    env = ", ".join(f"{k}={v_}" for k, v_ in THREADS.items())
    lines = [
        "# fem3d on Winkler's L-panel: cost per alternate-minimization iteration, the nucleation step, memory",
        "",
        f"Command: `{command}`. {total / 60:.1f} min wall in all.",
        f"Machine: `{platform.platform()}`, {platform.machine()}, `os.cpu_count()` = {os.cpu_count()},"
        f" Python {platform.python_version()}; numpy {v['numpy']}, scipy {v['scipy']}, pyamg {v['pyamg']},"
        f" numba {v['numba']}. Each case ran in its own subprocess with {env} (PARDISO, OpenBLAS and the"
        " Numba kernels on one thread each).",
        "Machine checks (shared 2-core machine; idle = 1-min load average < 0.5 or no other python process"
        " above 20% CPU over 5 s):",
        "",
    ]
    lines += [f"- {c}" for c in checks]
    lines += ["", "## Cases", "",
              "Each case, in one subprocess: the scene's loads (2D: the case file's list; 3D: `load.steps` equal"
              " steps to 0.5 mm) with alternate minimization (`tol` of the scene, 1e-3; `acceleration` as listed) to"
              " the end of the nucleation step (the first step whose crack length S/(Gc T) grows by more than"
              " 4 eps, times the depth in 3D), then the timings (and in 2D the nucleation rows). Mesh sizes h /"
              " h_coarse / eps in mm. `RSS build`: `ru_maxrss` after building the mesh and the model (PARDISO's"
              " symbolic analysis included); `peak RSS run`: after the evolution; `at end`: after everything."
              " `other pythons`: the CPU that other python processes (other users' runs) took while the case ran,"
              " in % of one core (this case's own: 100).", ""]
    cols = ["case", "h / h_coarse / eps", "nodes", "cells", "dofs (free)", "nnz K_ff", "solver",
            "mesh + model [s]", "acceleration", "steps run", "t nucleation [mm]", "iterations (nucleation step)",
            "evolution wall (cpu) [s]", "RSS build [GB]", "peak RSS run [GB]", "peak RSS at end [GB]",
            "case wall [s]", "other pythons [% of a core]"]
    lines += ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for c in cases:
        if c.get("status") != "ok":
            lines.append(f"| {c['case']} | {c.get('status')} |" + " |" * (len(cols) - 2))
            continue
        lines.append(" | ".join([
            f"| {c['case']}", f"{c['h']:g} / {c['h_coarse']:g} / {c['eps']:g}", str(c["nodes"]), str(c["cells"]),
            f"{c['dofs']} ({c['free_dofs']})", str(c["nnz_K"]), c["solver"], f"{c['mesh_s']:.1f} + {c['model_s']:.1f}",
            c["evolution_acceleration"], str(c["steps_run"]),
            f"{c['t_nucleation']:g}" + ("" if c["nucleation_jump"] else " (no jump: largest growth)"),
            f"{c['evolution_iterations']} ({c['nucleation_iterations']})",
            f"{c['evolution_s']:.1f} ({c['evolution_cpu_s']:.1f})", f"{c['base_gb']:.2f}", f"{c['evolution_gb']:.2f}",
            f"{c['peak_gb']:.2f}", f"{c['wall_case_s']:.0f}", f"{c['others_cpu_pct']:.0f} |"]))

    lines += ["", "## Cost per alternate-minimization iteration", "",
              "Milliseconds: median over the sampled iterates of the nucleation step (from the sound state to the"
              " cracked one) of the median over the repeats, [least - largest] over the iterates. AMG: kept"
              " hierarchy, CG warm-started from the u the engine passed, at the rtol it asked"
              " (1e-2 x the last change of alpha, clipped to [1e-8, 1e-5]). Each case's"
              " iterates, repeats and the AMG rebuilds during the timings are listed below the table.", ""]
    header = ["part"] + [c["case"] for c in ok]
    lines += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for key, label in PARTS + COUNTS:
        cells = []
        for c in ok:
            s = c["summary"].get(key)
            if s is None:
                cells.append("")
            elif key in dict(COUNTS):
                cells.append(f"{s[0]:g} [{s[1]:g} - {s[2]:g}]")
            else:
                cells.append(f"{ms(s[0])} [{ms(s[1])} - {ms(s[2])}]")
        if any(cells):
            lines.append(f"| {label} | " + " | ".join(cells) + " |")
    lines.append("")
    for c in ok:
        lines.append(f"- {c['case']}: iterates {c['sample_indices']} of the nucleation step"
                     f" ({c['nucleation_iterations']} iterations; {c['kept_mb']:.1f} MB of kept iterates, in the"
                     f" peak RSS), {c['repeats']} repeats each"
                     + (f"; AMG hierarchies built: {c['amg_builds_evolution']} in the evolution,"
                        f" {c['amg_builds_timing']} during the timings" if c["solver"] == "amg" else ""))

    two = [c for c in ok if c["dim"] == 2]
    if two:
        c = two[0]
        lines += ["", "## Against the NGSolve figures (2D)", "",
                  "The NGSolve figures were measured on another machine and are not re-measured here. Speed-up:"
                  " NGSolve's fastest and slowest iteration over this run's median (the range over the iterates in"
                  f" brackets). Target: at least {TARGET_SPEEDUP:g}x.", "",
                  "| step | fem3d median [s] [range] | NGSolve [s] | speed-up vs NGSolve's fastest | speed-up vs"
                  " NGSolve's slowest | at least 5x |",
                  "|---|---|---|---|---|---|"]
        for key, label in (("u_step", "u-step (assembly + factorization + solve + rhs)"),
                           ("alpha_step", "alpha-step (problem + QP)")):
            med, lo, hi = c["summary"][key]
            lo_ng, hi_ng = NGSOLVE[key]
            met = "yes" if lo_ng / med >= TARGET_SPEEDUP else (
                "only against NGSolve's slower iterations" if hi_ng / med >= TARGET_SPEEDUP else "no")
            lines.append(f"| {label} | {med:.4f} [{lo:.4f} - {hi:.4f}] | {lo_ng:g} - {hi_ng:g} | {lo_ng / med:.1f}x |"
                         f" {hi_ng / med:.1f}x | {met} |")
        med, lo, hi = c["summary"]["iteration"]
        ng = (NGSOLVE["u_step"][0] + NGSOLVE["alpha_step"][0], NGSOLVE["u_step"][1] + NGSOLVE["alpha_step"][1])
        lines.append(f"| iteration (u + alpha + energies; NGSolve: u + alpha) | {med:.4f} [{lo:.4f} - {hi:.4f}] |"
                     f" {ng[0]:g} - {ng[1]:g} | {ng[0] / med:.1f}x | {ng[1] / med:.1f}x | |")

    nuc = [(c, r) for c in ok for r in c["nucleation_rows"]]
    if nuc:
        c0 = nuc[0][0]
        base = c0["nucleation_rows"][0]
        lines += ["", "## The nucleation step (2D)", "",
                  f"t = {c0['t_nucleation']:g} mm from the converged state at t = {c0['t_previous']:g} mm (crack"
                  f" length {c0['crack_before']:.4g} mm before), a fresh engine per row, the direct solver kept."
                  f" Ratios and the energy difference are to the plain row (`none`), measured in the same process."
                  f" NGSolve: {NGSOLVE['nucleation_iterations']} iterations; target: at most {TARGET_ITERATIONS}."
                  " `crack`: S/(Gc T) after the step [mm]; `tip`: chord from (250, 250) to the farthest node with"
                  " alpha >= 0.9, length [mm] and angle [deg]. `ms/u-solve`, `ms/iter alpha`: the engine's own"
                  " timers. `monotone`: the energy never rose over the accepted half-steps. Phases, from the crack"
                  " length of the damage at each u-solve: `onset` until it is 4 eps longer than before the step,"
                  " `front` until it is within 5% of its final growth, `tail` the rest; `front [mm/u-solve]` the"
                  " mean growth per u-solve over the front phase (h = "
                  f"{c0['h']:g} mm in the band).", ""]
        cols = ["acceleration", "options", "iterations", "it/base", "u-solves", "rejected", "wall [s]", "wall/base",
                "cpu [s]", "ms/u-solve", "ms/iter alpha", "energy [N mm]", "energy diff", "crack", "tip",
                "u-solves onset / front / tail", "front [mm/u-solve]", "monotone", "<= 50"]
        lines += ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
        for _, r in nuc:
            diff = (r["energy"] - base["energy"]) / base["energy"]
            cells = [r["acceleration"], r["options"] or "-", str(r["iterations"]),
                     f"{r['iterations'] / base['iterations']:.3f}", str(r["u_solves"]), str(r["rejected"]),
                     f"{r['wall_s']:.1f}", f"{r['wall_s'] / base['wall_s']:.3f}", f"{r['cpu_s']:.1f}",
                     f"{r['ms_u_per_solve']:.1f}", f"{r['ms_alpha_per_iteration']:.1f}", f"{r['energy']:.6g}",
                     f"{diff:+.2e}", f"{r['crack_length']:.4g}", f"{r['tip_chord']:.1f} at {r['tip_angle']:.1f}",
                     f"{r['onset']} / {r['front']} / {r['tail']}", f"{r['front_speed']:.2f}",
                     str(r["monotone"]), "yes" if r["iterations"] <= TARGET_ITERATIONS else "no"]
            lines.append("| " + " | ".join(cells) + " |")
    (out / "fem_lpanel.md").write_text("\n".join(lines) + "\n")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="tiny sizes, to test the script")
    ap.add_argument("--sizes3d", nargs="*", default=None, metavar="H,HC,EPS",
                    help="3D sizes (mm), e.g. 10,40,20 7,40,14; none: no 3D case")
    ap.add_argument("--no-2d", action="store_true", help="skip the 2D case")
    ap.add_argument("--steps3d", type=int, default=50, help="load steps of the 3D evolutions (to t_max = 0.5 mm)")
    ap.add_argument("--accel3d", default="overrelax", choices=("none", "overrelax"),
                    help="acceleration of the 3D evolutions")
    ap.add_argument("--samples", type=int, default=6, help="iterates of the nucleation step timed")
    ap.add_argument("--repeats", type=int, default=5, help="timings of each part on each iterate (2D)")
    ap.add_argument("--repeats3d", type=int, default=3, help="timings of each part on each iterate (3D)")
    ap.add_argument("--no-extras", action="store_true", help="only the none and overrelax nucleation rows")
    ap.add_argument("--no-wait", action="store_true", help="do not wait for an idle machine")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per case")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result files")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(json.loads(args.worker))
        return
    command = "python -m benchmarks.bench_fem_lpanel" + "".join(f" {a}" for a in (argv or sys.argv[1:]))
    scene2d = QUICK_2D if args.quick else SCENE_2D
    if args.sizes3d is None:
        sizes3d = QUICK_3D if args.quick else SIZES_3D
    else:
        sizes3d = [tuple(float(x) for x in s.split(",")) for s in args.sizes3d]
    common = dict(samples=args.samples)
    specs = []
    if not args.no_2d:
        specs.append(dict(name="2D direct", case=str(CASE_2D), overrides=scene2d, nucleation=True,
                          extras=not args.no_extras, acceleration="none", repeats=args.repeats, **common))
    for h, hc, eps in sizes3d:
        for linear in ("direct", "amg"):
            specs.append(dict(name=f"3D h {h:g} {linear}", case=str(CASE_3D),
                              overrides={"mesh.h": h, "mesh.h_coarse": hc, "model.eps": eps, "solver.linear": linear,
                                         "load.steps": args.steps3d},
                              acceleration=args.accel3d, repeats=args.repeats3d, **common))
    checks = []
    if not args.no_wait:
        idle, log, waited = wait_for_idle()
        checks.append(f"before the run: {log[-1]}" + ("" if idle else f" (not idle after {waited:.0f} min of"
                                                                          " waiting; ran anyway)")
                      + (f"; waited {waited:.0f} min ({len(log)} checks)" if len(log) > 1 else ""))
    started = time.perf_counter()
    cases = []
    for spec in specs:
        cases.append(run_case(spec, args.timeout))
        _, text = machine_check()
        checks.append(f"after {spec['name']}: {time.strftime('%H:%M:%S')} {text}")
        write_outputs(cases, command, time.perf_counter() - started, checks, args.out)  # partial results survive
    print((args.out / "fem_lpanel.md").read_text())


if __name__ == "__main__":
    main()
