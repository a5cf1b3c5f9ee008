"""Error of the regularized evolution against the exact 1D evolution, versus wall time.

Each run is a whole quasi-static evolution (:class:`thinfilm.engine.evolution.Engine` on the scene's
loads) in a fresh subprocess, timed after a warm-up (Numba kernels loaded) from the model's
assembly to the last step, and compared with the exact evolution of :mod:`onedim` (the
global minimizer; events located exactly, energies of the exact crack set at each load, as
:func:`thinfilm.plate.compare.exact_counterpart` does). Cases:

``fig2_5``
    ``cases/fig2_5.toml`` (1D, l0 = 0.5, lam = 10, G/a = 0.05, backtracking standard,
    100 load steps to t = 3): 200, 400, 800, 1600 cells with eta = 10 dx, and 400, 800,
    1600 cells with eta = 0.00625 fixed; variants {plain, over-relaxed} x {search, none}.
``fig2_7``
    ``cases/fig2_7.toml`` (the 2D strip (-0.5, 0.5) x (-0.1, 0.1), lam = 31.62, G/a = 1,
    nu = 0.3, backtracking standard, 70 steps to t = 7): 300 x 60, 450 x 90, 600 x 120
    with eta = 2.5 dx, and with eta = 1/120 fixed; plain and over-relaxed, no search; and
    one run with the nucleation search (300 x 60, plain) for its cost and what it finds.
``fig2_6``
    ``cases/fig2_6.toml`` (1D, l0 = 0.8, 1280 cells): the crack sequence with {search, none}
    x {backtracking standard, deep} against the exact, asymmetric one.

Errors: the load of each nucleation (the first load step with as many cracks as the exact
event; "missed" if none) relative to the exact load, and the crossing load of the energy
branches of the last state before and the first state after it (both scale exactly with
t^2 at fixed damage, so the crossing lies between the two steps and is free of the
load-step quantization); the crack positions at the event (max deviation; mirror image
allowed for fig2_6); the total energy (per unit width in 2D) relative to the exact one at the
load steps before the first event and between events, leaving out the steps within one load
step of an exact event. Cost: wall and CPU time, alternate-minimization iterations,
u-solves, backtracks and search trials of the whole evolution (``engine.work``: undone steps
and rejected trials included), and the ratio of the wall time to that of the ``base``
variant (plain, no search, standard backtracking) on the same grid, measured in the same
invocation.

Runs shorter than ``--repeat-below`` seconds (60) are run ``--repeat`` times (3) and the
fastest wall and CPU times kept (the machine is shared). A run that needs more than
``--timeout`` seconds (default 360; ``--search-timeout``, 600, for the one 2D run with the
search, which needs about 400 s) is killed and listed as skipped, with how far it got.
A 1D film of 1600 cells or more solves its u-problem to round-off only: the relative
residual of an exact-to-round-off solution grows like dx^-4 (about 2e-6 at 1600 cells), and
the linear solvers accept such a solution (normwise backward error below 1e-13) whatever
tolerance was asked for.

Accepted search trials are counted as they happen (``engine.work["trials_accepted"]``): the
step whose search finds a crack is usually undone by the backtrack that crack triggers,
and its StepRecord, with its ``trials_accepted``, is dropped.

Usage (from the repository root)::

    python -m benchmarks.bench_evolution                       # everything, ~40 min
    python -m benchmarks.bench_evolution --quick               # a subset, ~5 min
    python -m benchmarks.bench_evolution --cases fig2_5 fig2_6 # rows are merged into the CSV

Writes ``benchmarks/results/evolution.csv`` (one row per run, merged by run), ``evolution.md``
and ``evolution.png``, and ``evolution.json`` (every run's step data, for merging later
invocations and for ``--report-only``, which redraws the table and figure from it).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"
CASES_DIR = ROOT / "cases"

CASES = ("fig2_5", "fig2_7", "fig2_6")
#: The film of each case for the exact solution: (x0, x1, width); lam and G/a from the scene.
GEOMETRY = {"fig2_5": (-0.25, 0.25, 1.0), "fig2_6": (-0.4, 0.4, 1.0), "fig2_7": (-0.5, 0.5, 0.2)}

VARIANTS_1D = [("plain", "none", True), ("plain", "none", False),
               ("overrelax", "overrelax", True), ("overrelax", "overrelax", False)]


def variant_name(spec):
    name = "plain" if spec["acceleration"] == "none" else "overrelax"
    name += " + search" if spec["search"] else ""
    if spec["backtrack"] != "standard":
        name += f", backtrack {spec['backtrack']}"
    return name


def run_key(spec):
    cells = "x".join(str(c) for c in spec["cells"])
    return (f"{spec['case']}|{cells}|{spec['eta']:.9g}|{spec['acceleration']}|"
            f"{int(spec['search'])}|{spec['backtrack']}")


def plan(cases, quick):
    """The runs, in order: list of spec dicts."""
    specs = []

    def add(**spec):
        spec["key"] = run_key(spec)
        if spec["key"] not in {s["key"] for s in specs}:
            specs.append(spec)

    if "fig2_5" in cases:
        length = 0.5
        grids = [(c, 10 * length / c) for c in ((200, 400, 800) if quick else (200, 400, 800, 1600))]
        if not quick:
            grids += [(c, 0.00625) for c in (400, 800, 1600)]
        for cells, eta in grids:
            for _, acceleration, search in VARIANTS_1D:
                add(case="fig2_5", cells=[cells], eta=eta, acceleration=acceleration, search=search,
                    backtrack="standard")
    if "fig2_7" in cases:
        grids = [(300, 60)] if quick else [(300, 60), (450, 90), (600, 120)]
        pairs = [(g, 2.5 / g[0]) for g in grids] + [(g, 1.0 / 120.0) for g in grids]
        for g, eta in pairs:
            for acceleration in ("none", "overrelax"):
                add(case="fig2_7", cells=list(g), eta=eta, acceleration=acceleration, search=False,
                    backtrack="standard")
        add(case="fig2_7", cells=[300, 60], eta=1.0 / 120.0, acceleration="none", search=True,
            backtrack="standard")
    if "fig2_6" in cases:
        for backtrack in (("standard",) if quick else ("standard", "deep")):
            for search in (True, False):
                add(case="fig2_6", cells=[1280], eta=10 * 0.8 / 1280, acceleration="none", search=search,
                    backtrack=backtrack)
    return specs


# ------------------------------------------------------------------------------------------
# worker: one run in this process
# ------------------------------------------------------------------------------------------

def make_scene(spec, cells=None, steps=None):
    from thinfilm.scene import load_scene

    scene = load_scene(CASES_DIR / f"{spec['case']}.toml")
    cells = tuple(spec["cells"] if cells is None else cells)
    domain = dataclasses.replace(scene.domain, cells=cells)
    model = dataclasses.replace(scene.model, eta=float(spec["eta"]))
    options = scene.solver
    solver = dataclasses.replace(options, altmin=dataclasses.replace(options.altmin, acceleration=spec["acceleration"]),
                                 search=dataclasses.replace(options.search, enabled=bool(spec["search"])),
                                 backtrack=dataclasses.replace(options.backtrack, kind=spec["backtrack"]))
    load = scene.load if steps is None else dataclasses.replace(scene.load, steps=steps)
    return dataclasses.replace(scene, domain=domain, model=model, solver=solver, load=load)


def through_width(grid, alpha, cracks, eta):
    """How many of the centre-line cracks reach across the strip (alpha >= 0.9 within 2 eta
    of the crack's x on every row)."""
    if grid.dim == 1:
        return len(cracks)
    field = np.asarray(alpha).reshape(grid.shape)
    x = np.asarray(grid.x)
    count = 0
    for c in cracks:
        near = np.abs(x - c) <= 2.0 * eta
        count += bool(np.all(field[:, near].max(axis=1) >= 0.9))
    return count


def evolve_scene(scene, progress=False):
    """Run a scene; returns (grid, records, states, engine, timings).

    With ``progress``, print one ``PROGRESS`` JSON line per computed step (what a killed run
    got through is read from them)."""
    from thinfilm.plate.cracks import centre_line, crack_positions
    from thinfilm.engine import Engine
    from thinfilm.plate.kind import build_grid, make_model

    timings = {"time_u": 0.0, "time_alpha": 0.0, "steps_computed": 0, "last_step": 0}

    def on_step(record, state):
        timings["time_u"] += record.time_u
        timings["time_alpha"] += record.time_alpha
        timings["steps_computed"] += 1
        timings["last_step"] = record.index
        if progress:
            x, line = centre_line(grid, state.alpha)
            print("PROGRESS " + json.dumps({
                "step": record.index, "t": record.t, "elapsed": time.perf_counter() - start,
                "work": dict(engine.work), "cracks": [round(float(v), 4) for v in crack_positions(x, line)],
                "trials_accepted": engine.work["trials_accepted"]}), flush=True)

    start, start_cpu = time.perf_counter(), time.process_time()
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    engine = Engine.from_options(model, scene.solver)
    timings["engine"] = engine
    t_values = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    try:
        records, states = engine.run(t_values, on_step=on_step)
    finally:
        timings["wall"] = time.perf_counter() - start
        timings["cpu"] = time.process_time() - start_cpu
    return grid, records, states, engine, timings


def strength_limit(scene):
    """Load at which the elastic (alpha = 0) state first meets the AT1 damage criterion.

    Alternate minimization leaves the sound film elastic until then (the alpha-problem at
    alpha = 0 has ``b = e - (G/a)/(4 c_m eta) w <= 0``); ``e`` scales with t^2."""
    from thinfilm.plate.kind import build_grid, make_model

    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    zero = np.zeros(model.n_alpha)
    u = model.solve_u(zero, 1.0, None, 1e-3)
    e = model.plate.bending_density(u)
    _, b = model.damage_problem(u, 1.0)
    linear = e - b  # the load-independent part of b
    ratio = float(np.max(e[linear > 0] / linear[linear > 0])) if np.any(linear > 0) else 0.0
    return 1.0 / math.sqrt(ratio) if ratio > 0 else math.inf


def worker(spec):
    """Run one spec and print one JSON line."""
    import warnings

    warnings.filterwarnings("ignore")
    from thinfilm.plate.cracks import centre_line, crack_positions
    from thinfilm.plate.results import crack_events

    row = {"key": spec["key"], "status": "ok", "notes": []}
    # Warm-up: load every Numba kernel (and import everything) outside the timing.
    small = [40] if len(spec["cells"]) == 1 else [30, 6]
    try:
        warm = make_scene(spec, cells=small, steps=4)
        warm = dataclasses.replace(warm, model=dataclasses.replace(warm.model, eta=3 * warm.domain.dx))
        evolve_scene(warm)
    except Exception:
        pass
    scene = make_scene(spec)
    row["t_strength"] = strength_limit(scene)
    try:
        grid, records, states, engine, timings = evolve_scene(scene, progress=True)
    except Exception as exc:  # EvolutionError and anything else: report, do not hide
        row.update(status="failed", error=f"{type(exc).__name__}: {str(exc)[:300]}")
        print("RESULT " + json.dumps(row), flush=True)
        return

    t = np.array([s.t for s in states])
    cracks, through = [], []
    for s in states:
        x, line = centre_line(grid, s.alpha)
        c = crack_positions(x, line)
        cracks.append([round(float(v), 6) for v in c])
        through.append(through_width(grid, s.alpha, c, scene.model.eta))
    events = crack_events(t, [np.array(c) for c in cracks])
    row.update(
        wall=timings["wall"], cpu=timings["cpu"], time_u=timings["time_u"], time_alpha=timings["time_alpha"],
        steps_computed=timings["steps_computed"], work=dict(engine.work),
        trials_accepted=int(engine.work["trials_accepted"]),
        trials_accepted_kept_steps=int(sum(r.trials_accepted for r in records)),
        extrapolations_rejected=int(sum(r.extrapolations_rejected for r in records)),
        t=t.tolist(), elastic=[r.elastic for r in records], surface=[r.surface for r in records],
        total=[r.total for r in records], cracks=cracks, through=through,
        events=[[float(te), [round(float(v), 4) for v in c]] for te, c in events],
        nodes=int(grid.n_nodes), dx=float(scene.domain.dx),
    )
    print("RESULT " + json.dumps(row), flush=True)


# ------------------------------------------------------------------------------------------
# parent: run the plan, compare with the exact evolution, write the tables
# ------------------------------------------------------------------------------------------

def run_spec(spec, timeout):
    cmd = [sys.executable, "-m", "benchmarks.bench_evolution", "--worker", json.dumps(spec)]
    env = dict(os.environ, PYTHONWARNINGS="ignore")
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    load_before = os.getloadavg()[0]
    start = time.perf_counter()
    try:
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env, cwd=ROOT)
    except subprocess.TimeoutExpired as exc:
        out = exc.stdout or b""
        out = out.decode(errors="replace") if isinstance(out, bytes) else out
        last, kept, changes, count = None, 0, [], 0
        for line in out.splitlines():
            if line.startswith("PROGRESS "):
                last = json.loads(line[9:])
                kept = last["trials_accepted"]
                if len(last["cracks"]) != count:
                    count = len(last["cracks"])
                    changes.append(f"{last['t']:.2f}: {count}")
        note = f"skipped: longer than {timeout:.0f} s (killed)"
        row = {"key": spec["key"], "status": "skipped", "load": load_before, "partial": last}
        if last is not None:
            w = last["work"]
            note += (f"; by then at step {last['step']} (t = {last['t']:.2f}) after {last['elapsed']:.0f} s:"
                     f" {w['iterations']} AM its, {w['u_solves']} u-solves, {w['backtracks']} backtracks,"
                     f" {w['trials']} trials ({kept} kept); crack counts along y = 0 (t: n):"
                     f" {', '.join(changes) or 'none'}")
        row["notes"] = [note]
        return row
    elapsed = time.perf_counter() - start
    for line in out.stdout.splitlines():
        if line.startswith("RESULT "):
            row = json.loads(line[7:])
            row["load"] = load_before
            row["process_s"] = elapsed
            return row
    return {"key": spec["key"], "status": "crashed", "load": load_before,
            "notes": [(out.stderr.strip().splitlines() or ["?"])[-1][:300]]}


_EXACT = {}


def exact_for(case, lam, toughness, t):
    """Exact events and total energy (per unit width) at the loads ``t``."""
    from thinfilm.plate.compare import exact_counterpart

    x0, x1, _ = GEOMETRY[case]
    key = (case, tuple(np.round(t, 12)))
    if key not in _EXACT:
        _EXACT[key] = exact_counterpart(x0, x1, lam, toughness, t)
    return _EXACT[key]


def crossing_load(row, k):
    """Load where the energy branch of state k (t^2-scaled at fixed damage) crosses that of k-1."""
    if k < 2:
        return math.nan
    t, P, S = row["t"], row["elastic"], row["surface"]
    slope = P[k - 1] / t[k - 1] ** 2 - P[k] / t[k] ** 2
    rise = S[k] - S[k - 1]
    if not (slope > 0 and rise > 0):
        return math.nan
    return math.sqrt(rise / slope)


def metrics(spec, row):
    """Errors of a finished run against the exact evolution (added to ``row``)."""
    from thinfilm.scene import load_scene

    scene = load_scene(CASES_DIR / f"{spec['case']}.toml")
    case = spec["case"]
    t = np.array(row["t"])
    dt = float(t[1] - t[0])
    width = GEOMETRY[case][2]
    exact = exact_for(case, scene.model.lam, scene.model.toughness, t)
    ev = [e for e in exact["events"] if e.t <= t[-1]]
    counts = np.array([len(c) for c in row["cracks"]])
    # Mirror image: the sign that brings the first crack of the run to the side of the exact one.
    sign = 1.0
    if case == "fig2_6":
        first = next((c for c in row["cracks"] if c), None)
        if first is not None and (first[0] > 0) != (ev[0].cracks[0] > 0):
            sign = -1.0
    row["mirror"] = sign < 0
    out = []
    for e in ev:
        n = len(e.cracks)
        hit = np.flatnonzero(counts >= n)
        if not hit.size:
            out.append({"exact_t": e.t, "n": n, "missed": True})
            continue
        k = int(hit[0])
        found = np.sort(sign * np.array(row["cracks"][k]))
        item = {"exact_t": e.t, "n": n, "missed": False, "t": float(t[k]), "count": int(counts[k]),
                "through": int(row["through"][k]), "t_err": (t[k] - e.t) / e.t}
        tc = crossing_load(row, k)
        item["t_cross"] = tc
        item["t_cross_err"] = (tc - e.t) / e.t if math.isfinite(tc) else math.nan
        if counts[k] == n:
            item["pos_err"] = float(np.max(np.abs(found - np.array(e.cracks))))
            item["cracks"] = found.tolist()
        else:
            item["pos_err"] = math.nan
        out.append(item)
    row["event_errors"] = out
    total = np.array(row["total"]) / width
    ex = exact["total"]
    rel = np.where(ex > 0, (total - ex) / np.where(ex > 0, ex, 1.0), np.nan)
    near = np.zeros(t.shape, bool)
    for e in ev:
        near |= np.abs(t - e.t) <= dt + 1e-12
    windows = [(t > 0) & (t < ev[0].t) & ~near] if ev else []
    for j, e in enumerate(ev):
        upper = ev[j + 1].t if j + 1 < len(ev) else np.inf
        windows.append((t > e.t) & (t < upper) & ~near)

    def extreme(mask):
        vals = rel[mask]
        vals = vals[np.isfinite(vals)]
        return float(vals[np.argmax(np.abs(vals))]) if vals.size else math.nan

    row["energy_pre"] = extreme(windows[0]) if windows else math.nan
    row["energy_after"] = [extreme(w) for w in windows[1:]]
    row["energy_last"] = float(rel[-1])
    after = [abs(v) for v in row["energy_after"] if math.isfinite(v)]
    row["energy_after_max"] = max(after) if after else math.nan
    return row


# -- formatting ----------------------------------------------------------------------------

def pct(x, digits=2):
    if x is None or not isinstance(x, (int, float)) or not math.isfinite(x):
        return ""
    return f"{100 * x:+.{digits}f}%"


def fnum(x, spec):
    if x is None or not isinstance(x, (int, float)) or not math.isfinite(x):
        return ""
    return format(x, spec)


def grid_label(spec):
    return " x ".join(str(c) for c in spec["cells"])


def eta_label(spec, row):
    dx = (GEOMETRY[spec["case"]][1] - GEOMETRY[spec["case"]][0]) / spec["cells"][0]
    return f"{spec['eta']:.5g} ({spec['eta'] / dx:.3g} dx)"


def series_of(spec):
    dx = (GEOMETRY[spec["case"]][1] - GEOMETRY[spec["case"]][0]) / spec["cells"][0]
    ratio = spec["eta"] / dx
    tags = []
    if spec["case"] == "fig2_5":
        if abs(ratio - 10) < 1e-9:
            tags.append("eta/dx = 10")
        if abs(spec["eta"] - 0.00625) < 1e-12:
            tags.append("eta = 0.00625")
    elif spec["case"] == "fig2_7":
        if abs(ratio - 2.5) < 1e-9:
            tags.append("eta/dx = 2.5")
        if abs(spec["eta"] - 1 / 120) < 1e-12:
            tags.append("eta = 1/120")
    return tags


def event_cell(item):
    if item is None:
        return ""
    if item["missed"]:
        return "missed"
    s = f"{item['t']:.2f} ({pct(item['t_err'], 1)})"
    if item["count"] != item["n"]:
        s += f", {item['count']} cracks"
    return s


def cross_cell(item):
    if item is None or item["missed"] or not math.isfinite(item.get("t_cross", math.nan)):
        return "missed" if item is not None and item["missed"] else ""
    return f"{item['t_cross']:.4f} ({pct(item['t_cross_err'])})"


def events_text(row, digits=3):
    parts = []
    for te, c in row.get("events", []):
        parts.append(f"{te:.2f}: {{{', '.join(f'{v:+.{digits}f}' for v in c)}}}")
    return "; ".join(parts) if parts else "none"


def cost_cells(row):
    w = row.get("work", {})
    return [fnum(row.get("wall"), ".1f"), fnum(row.get("cpu"), ".1f"), fnum(row.get("ratio"), ".2f"),
            str(w.get("iterations", "")), str(w.get("u_solves", "")), str(w.get("backtracks", "")),
            str(w.get("trials", "")) + (f" ({row['trials_accepted']} kept)" if w.get("trials") else "")]


def status_row(spec, row, ncols_before, ncols_total):
    cells = [row.get("status", "?")] + [""] * (ncols_total - ncols_before - 2)
    note = "; ".join(row.get("notes", []) + ([row["error"]] if row.get("error") else []))
    return cells + [note]


def table_fig2_5(specs, rows):
    header = ["series", "cells", "eta (eta/dx)", "t_s", "variant", "t1 step (err)", "t1 crossing (err)",
              "t2 step (err)", "t2 crossing (err)", "3-crack positions: max err", "E err before",
              "E err after 1st", "E err after 2nd", "wall [s]", "CPU [s]", "wall / base", "AM its",
              "u-solves", "backtracks", "trials", "events (t: cracks)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    order = sorted((s for s in specs if s["case"] == "fig2_5"),
                   key=lambda s: (0 if abs(s["eta"] / (0.5 / s["cells"][0]) - 10) < 1e-9 else 1, s["cells"][0],
                                  s["acceleration"], not s["search"]))
    for s in order:
        r = rows.get(s["key"])
        if r is None:
            continue
        lead = [", ".join(series_of(s)), grid_label(s), eta_label(s, r), fnum(r.get("t_strength"), ".3f"),
                variant_name(s)]
        if r.get("status") != "ok":
            lines.append("| " + " | ".join(lead + status_row(s, r, len(lead), len(header))) + " |")
            continue
        ee = r["event_errors"] + [None] * 2
        e1, e2 = ee[0], ee[1]
        after = r["energy_after"] + [math.nan] * 2
        cells = lead + [event_cell(e1), cross_cell(e1), event_cell(e2), cross_cell(e2),
                        fnum(e2.get("pos_err") if e2 and not e2["missed"] else None, ".4f"),
                        pct(r["energy_pre"]), pct(after[0]), pct(after[1])] + cost_cells(r)
        cells.append("; ".join([events_text(r)] + r.get("notes", [])))
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def table_fig2_7(specs, rows):
    header = ["series", "grid", "eta (eta/dx)", "t_s", "variant", "t9 step (err)", "t9 crossing (err)",
              "cracks at t9 (through-width)", "positions: max err", "E err before", "E err after",
              "E err at t = 7", "wall [s]", "CPU [s]", "wall / base", "AM its", "u-solves", "backtracks",
              "trials", "events (t: cracks along y = 0)"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    order = sorted((s for s in specs if s["case"] == "fig2_7"),
                   key=lambda s: (s["search"], 0 if abs(s["eta"] * s["cells"][0] - 2.5) < 1e-9 else 1,
                                  s["cells"][0], s["acceleration"]))
    for s in order:
        r = rows.get(s["key"])
        if r is None:
            continue
        lead = [", ".join(series_of(s)) or "search cost", grid_label(s), eta_label(s, r),
                fnum(r.get("t_strength"), ".2f"), variant_name(s)]
        if r.get("status") != "ok":
            lines.append("| " + " | ".join(lead + status_row(s, r, len(lead), len(header))) + " |")
            continue
        e = r["event_errors"][0] if r["event_errors"] else None
        after = r["energy_after"] + [math.nan]
        crack_cell = "" if e is None or e["missed"] else f"{e['count']} ({e['through']})"
        note = events_text(r, 3)
        if r.get("notes"):
            note += "; " + "; ".join(r["notes"])
        cells = lead + [event_cell(e), cross_cell(e), crack_cell,
                        fnum(e.get("pos_err") if e and not e["missed"] else None, ".4f"),
                        pct(r["energy_pre"]), pct(after[0]), pct(r["energy_last"])] + cost_cells(r) + [note]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def table_fig2_6(specs, rows):
    header = ["variant", "events (t: all cracks)", "matches exact sequence", "t errors (step)",
              "t errors (crossing)", "positions: max err", "E err after events (max)", "wall [s]",
              "wall / base", "AM its", "u-solves", "backtracks", "trials"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for s in (s for s in specs if s["case"] == "fig2_6"):
        r = rows.get(s["key"])
        if r is None:
            continue
        if r.get("status") != "ok":
            lines.append("| " + " | ".join([variant_name(s)] + status_row(s, r, 1, len(header))) + " |")
            continue
        ee = r["event_errors"]
        counts = [len(c) for _, c in r.get("events", [])]
        ok = counts == [1, 2, 3] and all(not e["missed"] and abs(e["t_err"]) <= 0.015 / e["exact_t"] + 1e-12
                                         and e.get("pos_err", 1) < 0.01 for e in ee)
        match = ("yes" + (" (mirror image)" if r.get("mirror") else "")) if ok else (
            "no: " + ("missed " + ", ".join(f"{e['exact_t']:.4f}" for e in ee if e["missed"])
                      if any(e["missed"] for e in ee) else f"crack counts {counts}"))
        terr = ", ".join("missed" if e["missed"] else pct(e["t_err"], 1) for e in ee)
        cerr = ", ".join("missed" if e["missed"] else pct(e["t_cross_err"]) for e in ee)
        perr = ", ".join("" if e["missed"] else fnum(e.get("pos_err"), ".4f") for e in ee)
        w = r.get("work", {})
        cells = [variant_name(s) + (" (scene default)" if s["search"] and s["backtrack"] == "standard" else ""),
                 events_text(r), match, terr, cerr, perr, pct(r["energy_after_max"]),
                 fnum(r.get("wall"), ".1f"), fnum(r.get("ratio"), ".2f"), str(w.get("iterations", "")),
                 str(w.get("u_solves", "")), str(w.get("backtracks", "")),
                 str(w.get("trials", "")) + (f" ({r['trials_accepted']} kept)" if w.get("trials") else "")]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def write_outputs(specs, rows, meta):
    RESULTS.mkdir(parents=True, exist_ok=True)
    fields = ["key", "case", "cells", "eta", "eta_dx", "acceleration", "search", "backtrack", "status",
              "t_strength", "t1", "t1_err", "t1_cross", "t1_cross_err", "t2", "t2_err", "t2_cross", "t2_cross_err",
              "t3", "t3_err", "t3_cross", "t3_cross_err", "pos_err_last_event", "energy_pre",
              "energy_after", "energy_after_max", "energy_last", "wall_s", "cpu_s", "time_u_s",
              "time_alpha_s", "ratio_to_base", "iterations", "u_solves", "backtracks", "trials",
              "trials_accepted", "trials_accepted_kept_steps", "steps_computed", "walls_s", "load_before",
              "events", "notes", "command"]
    with open(RESULTS / "evolution.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=fields)
        w.writeheader()
        for s in specs:
            r = rows.get(s["key"])
            if r is None:
                continue
            dx = (GEOMETRY[s["case"]][1] - GEOMETRY[s["case"]][0]) / s["cells"][0]
            out = {"key": s["key"], "case": s["case"], "cells": grid_label(s), "eta": f"{s['eta']:.9g}",
                   "eta_dx": f"{s['eta'] / dx:.4g}", "acceleration": s["acceleration"], "search": s["search"],
                   "backtrack": s["backtrack"], "status": r.get("status"), "load_before": r.get("load"),
                   "t_strength": r.get("t_strength"),
                   "notes": "; ".join(r.get("notes", []) + ([r["error"]] if r.get("error") else [])),
                   "command": r.get("command", meta["command"])}
            if r.get("status") == "ok":
                for j, e in enumerate(r["event_errors"][:3], start=1):
                    if e["missed"]:
                        out[f"t{j}"] = "missed"
                        continue
                    out.update({f"t{j}": e["t"], f"t{j}_err": e["t_err"], f"t{j}_cross": e["t_cross"],
                                f"t{j}_cross_err": e["t_cross_err"]})
                last = r["event_errors"][-1] if r["event_errors"] else None
                w_ = r["work"]
                out.update(pos_err_last_event=None if last is None or last["missed"] else last.get("pos_err"),
                           energy_pre=r["energy_pre"], energy_after=json.dumps(r["energy_after"]),
                           energy_after_max=r["energy_after_max"], energy_last=r["energy_last"],
                           wall_s=r["wall"], cpu_s=r["cpu"], time_u_s=r["time_u"], time_alpha_s=r["time_alpha"],
                           ratio_to_base=r.get("ratio"), iterations=w_["iterations"], u_solves=w_["u_solves"],
                           backtracks=w_["backtracks"], trials=w_["trials"], trials_accepted=r["trials_accepted"],
                           trials_accepted_kept_steps=r.get("trials_accepted_kept_steps"),
                           steps_computed=r["steps_computed"], events=json.dumps(r["events"]),
                           walls_s=json.dumps([round(v, 3) for v in r.get("walls", [r["wall"]])]))
            w.writerow(out)

    lines = [
        "# The regularized evolution against the exact 1D evolution: error versus wall time",
        "",
        f"Command: `{meta['command']}`. Whole benchmark: {meta['total_s'] / 60:.1f} min wall "
        f"({meta['runs']} runs, one at a time, each in a fresh process).",
        f"Machine: {os.cpu_count()} cores, {platform.machine()}, Python {platform.python_version()}, "
        f"numpy {np.__version__}; shared with other jobs (1-min load average before the runs "
        f"{meta['load_min']:.2f} to {meta['load_max']:.2f}; wall times vary up to 2x between runs of the shared "
        "machine, CPU time is the steadier number).",
        "",
        "Each run is a whole evolution (the scene's load steps, backtracking standard unless named), timed from "
        "the model's assembly to the last step after a warm-up. `step`: the first load step with as many cracks "
        "as the exact event (load-step quantization: dt = 0.03 for fig2_5, 0.1 for fig2_7, 0.015 for fig2_6); "
        "`crossing`: where the energy branches (t^2-scaled at fixed damage) of the last state before and the "
        "first state after the event cross, a sub-step estimate of the regularized nucleation load. `E err`: "
        "the total energy (per unit width in 2D) relative to the exact one, the extreme signed value over the "
        "load steps before the first exact event / between events, leaving out the steps within one load step "
        "of an exact event. `AM its`, `u-solves`, `backtracks`, `trials`: `engine.work` of the whole evolution "
        "(undone steps and trials included). `wall / base`: against the plain variant without search on the "
        f"same grid, same invocation. Runs shorter than {meta['repeat_below']:g} s are run {meta['repeat']} times "
        "and the fastest wall (and CPU) time is kept (all in the CSV); longer runs once; a run is killed and "
        f"listed as skipped after {meta['timeout']:g} s ({meta['search_timeout']:g} s for the one 2D run with the "
        "search). `t_s`: the load at which the uncracked film's elastic state first meets the AT1 damage "
        "criterion (the strength limit, ~ eta^-1/2): without the search, alternate minimization cannot start a "
        "crack before it; backtracking can then move the crack back to an earlier step.",
        "",
    ]
    if any(s["case"] == "fig2_5" for s in specs):
        lines += ["## Fig. 2.5 scene (1D, l0 = 0.5, lam = 10, G/a = 0.05)", "",
                  "Exact: t = 0.681568, one crack at 0; t = 1.619918, three cracks at 0, +-0.125.", ""]
        lines += table_fig2_5(specs, rows) + [""]
    if any(s["case"] == "fig2_7" for s in specs):
        lines += ["## Fig. 2.7 strip (2D, (-0.5, 0.5) x (-0.1, 0.1), lam = 31.62, G/a = 1, nu = 0.3)", "",
                  "Exact (1D film of length 1): t = 5.360678, nine cracks at 0, +-0.1, ..., +-0.4 (the next event,"
                  " 19 cracks at 8.49, is beyond t = 7). Cracks are read along y = 0 (alpha >= 0.9); "
                  "through-width: alpha >= 0.9 within 2 eta of the crack on every row. Energy per unit width "
                  "(divided by 0.2).", ""]
        lines += table_fig2_7(specs, rows) + [""]
    if any(s["case"] == "fig2_6" for s in specs):
        lines += ["## Fig. 2.6 scene (1D, l0 = 0.8, 1280 cells, eta = 10 dx): the crack sequence", "",
                  "Exact: 0.671401: -0.0469 (or its mirror image); 0.726447: + 0.1765; 0.915163: + -0.2235. "
                  "`matches`: crack counts 1, 2, 3, each event within one load step (0.015) and 0.01 in position "
                  "(mirror image allowed).", ""]
        ts = [rows[s["key"]].get("t_strength") for s in specs if s["case"] == "fig2_6" and s["key"] in rows]
        ts = [v for v in ts if v is not None]
        if ts:
            lines[-2] += f" Strength limit of the uncracked film t_s = {ts[0]:.3f}."
        lines += table_fig2_6(specs, rows) + [""]
    if any(s["case"] == "fig2_5" and not s["search"] for s in specs):
        lines += ["## Fig. 2.5 without the nucleation search (backtracking standard): events", ""]
        for s in sorted((s for s in specs if s["case"] == "fig2_5" and not s["search"]),
                        key=lambda s: (s["acceleration"], s["cells"][0], s["eta"])):
            r = rows.get(s["key"])
            if r is None or r.get("status") != "ok":
                continue
            lines.append(f"- {variant_name(s)}, {grid_label(s)} cells, eta = {eta_label(s, r)}: "
                         f"{events_text(r)}")
        lines.append("")
    if meta.get("findings"):
        lines += ["## Notes", ""] + meta["findings"] + [""]
    (RESULTS / "evolution.md").write_text("\n".join(lines))
    plot(specs, rows)


def plot(specs, rows):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    markers = {("none", False): "o", ("none", True): "s", ("overrelax", False): "^", ("overrelax", True): "D"}
    colors = {("none", False): "C0", ("none", True): "C1", ("overrelax", False): "C2", ("overrelax", True): "C3"}
    panels = [
        ("fig2_5", "energy1", "Fig. 2.5: |E err| after the 1st event"),
        ("fig2_5", "energy2", "Fig. 2.5: |E err| after the 2nd event (~1.35: missed)"),
        ("fig2_5", "load", "Fig. 2.5: |error| of the 1st nucleation load (crossing)"),
        ("fig2_7", "energy1", "Fig. 2.7: |E err| per width after nucleation (0.34: none)"),
        ("fig2_7", "load", "Fig. 2.7: |error| of the 9-crack load (crossing)"),
        ("fig2_7", "pos", "Fig. 2.7: 9 crack positions, max |error| (1e-4: exact)"),
    ]
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5))
    for ax, (case, what, title) in zip(axes.ravel(), panels):
        case_specs = [s for s in specs if s["case"] == case]
        for series in sorted({tag for s in case_specs for tag in series_of(s)} | {""}):
            for var in markers:
                pts = []
                for s in case_specs:
                    if (s["acceleration"], s["search"]) != var or s["backtrack"] != "standard":
                        continue
                    if (series and series not in series_of(s)) or (not series and series_of(s)):
                        continue
                    r = rows.get(s["key"])
                    if r is None or r.get("status") != "ok":
                        continue
                    if what.startswith("energy"):
                        j = int(what[-1]) - 1
                        y = abs(r["energy_after"][j]) if len(r["energy_after"]) > j else math.nan
                    elif what == "load":
                        e = r["event_errors"][0] if r["event_errors"] else None
                        y = abs(e["t_cross_err"]) if e and not e["missed"] else math.nan
                    else:
                        e = r["event_errors"][-1] if r["event_errors"] else None
                        y = e.get("pos_err", math.nan) if e and not e["missed"] else math.nan
                    if math.isfinite(y):
                        pts.append((r["wall"], max(y, 1e-4 if what == "pos" else 1e-6), s["cells"][0]))
                if not pts:
                    continue
                pts.sort(key=lambda p: p[2])
                fixed_ratio = series.startswith("eta/dx") or not series
                label = (f"{'plain' if var[0] == 'none' else 'overrelax'}{' + search' if var[1] else ''}"
                         f"{', ' + series if series else ''}")
                ax.loglog([p[0] for p in pts], [p[1] for p in pts], ("-" if fixed_ratio else "--"),
                          marker=markers[var], color=colors[var], mfc=colors[var] if fixed_ratio else "none",
                          label=label)
                for p in pts:
                    ax.annotate(str(p[2]), (p[0], p[1]), fontsize=6, xytext=(3, 3), textcoords="offset points")
        ax.set_title(title, fontsize=9)
        ax.set_xlabel("wall time of the evolution [s]")
        ax.grid(True, which="both", alpha=0.3)
        if ax.lines:
            ax.legend(fontsize=6)
    fig.suptitle("Regularized evolution against the exact one (points: cells in x; solid: eta/dx fixed, "
                 "dashed: eta fixed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(RESULTS / "evolution.png", dpi=120)
    plt.close(fig)


def load_old_rows():
    """Rows and specs of earlier invocations (evolution.json), merged with this one by run."""
    path = RESULTS / "evolution.json"
    if not path.exists():
        return {}, []
    data = json.loads(path.read_text())
    return data.get("rows", {}), data.get("specs", [])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    ap.add_argument("--quick", action="store_true",
                    help="a subset: fig2_5 at 200/400/800 cells (eta = 10 dx), fig2_7 at 300 x 60, fig2_6 with"
                         " standard backtracking")
    ap.add_argument("--timeout", type=float, default=360.0, help="seconds per run before it is skipped")
    ap.add_argument("--search-timeout", type=float, default=600.0,
                    help="seconds allowed to the one 2D run with the nucleation search (measured ~400 s)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="runs shorter than --repeat-below seconds are repeated; the fastest wall/CPU is kept")
    ap.add_argument("--repeat-below", type=float, default=60.0)
    ap.add_argument("--fresh", action="store_true", help="do not merge with the rows of earlier invocations")
    ap.add_argument("--report-only", action="store_true",
                    help="rewrite evolution.md/.csv/.png from evolution.json without running anything")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(json.loads(args.worker))
        return
    if args.report_only:
        data = json.loads((RESULTS / "evolution.json").read_text())
        write_outputs(data["specs"], data["rows"], data["meta"])
        print((RESULTS / "evolution.md").read_text())
        return
    given = sys.argv[1:] if argv is None else argv
    command = ("python -m benchmarks.bench_evolution " + " ".join(given)).strip()
    specs = plan(args.cases, args.quick)
    old_rows, old_specs = ({}, []) if args.fresh else load_old_rows()
    all_specs = list(old_specs)
    for s in specs:
        if s["key"] not in {o["key"] for o in all_specs}:
            all_specs.append(s)
    rows = dict(old_rows)
    start = time.perf_counter()
    loads = []
    for i, spec in enumerate(specs, 1):
        print(f"[{i}/{len(specs)}] {spec['case']} {grid_label(spec)} eta={spec['eta']:.5g} "
              f"{variant_name(spec)} ...", end=" ", flush=True)
        timeout = args.search_timeout if (spec["search"] and spec["case"] == "fig2_7") else args.timeout
        row = run_spec(spec, timeout)
        loads.append(row.get("load", math.nan))
        if row.get("status") == "ok" and args.repeat > 1 and row["wall"] < args.repeat_below:
            walls, cpus = [row["wall"]], [row["cpu"]]
            for _ in range(args.repeat - 1):
                again = run_spec(spec, args.timeout)
                if again.get("status") != "ok":
                    break
                if again["work"] != row["work"]:
                    row["notes"].append(f"a repeat did different work ({again['work']})")
                walls.append(again["wall"])
                cpus.append(again["cpu"])
            row["walls"], row["cpus"] = walls, cpus
            row["wall"], row["cpu"] = min(walls), min(cpus)
        row["command"] = command
        if row.get("status") == "ok":
            metrics(spec, row)
        rows[spec["key"]] = row
        print(f"{row.get('status')} {row.get('wall', math.nan):.1f} s", flush=True)
    # Ratios against the base variant (plain, no search, standard) of the same grid, this invocation.
    for s in specs:
        r = rows[s["key"]]
        base_key = run_key(dict(s, acceleration="none", search=False, backtrack="standard"))
        base = rows.get(base_key)
        if r.get("status") == "ok" and base is not None and base.get("status") == "ok" and \
                base_key in {x["key"] for x in specs}:
            r["ratio"] = r["wall"] / base["wall"]
    total = time.perf_counter() - start
    meta = {"command": command, "total_s": total, "runs": len(specs), "repeat": args.repeat,
            "repeat_below": args.repeat_below, "timeout": args.timeout,
            "search_timeout": args.search_timeout,
            "load_min": float(np.nanmin(loads)) if loads else math.nan,
            "load_max": float(np.nanmax(loads)) if loads else math.nan}
    # Keep every run's data for merging later invocations and for --report-only.
    (RESULTS / "evolution.json").write_text(json.dumps({"rows": rows, "specs": all_specs, "meta": meta}))
    write_outputs(all_specs, rows, meta)
    print((RESULTS / "evolution.md").read_text())
    print(f"whole benchmark: {total:.0f} s")


if __name__ == "__main__":
    main()
