"""Run a plate scene: grid, model, engine, results written step by step.

The data flow of DESIGN.md: scene -> :class:`thinfilm.model.PlateModel` -> evolution engine
(:class:`thinfilm.evolution.Engine`) -> step records and fields, each appended to
``results.h5`` and flushed as soon as the step is done -> ``summary.json`` and figures,
made from the file.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from thinfilm.cracks import centre_line, crack_positions
from thinfilm.evolution import AltMinOptions, BacktrackOptions, Engine, SearchOptions
from thinfilm.grid import Grid
from thinfilm.io import PlateResultsWriter, read_plate, write_plate_summary
from thinfilm.linsolve import make_solver
from thinfilm.model import PlateModel

log = logging.getLogger("thinfilm")


def build_grid(domain):
    """The structured grid of a :class:`thinfilm.scene.Domain`."""
    if domain.dim == 1:
        return Grid.line(domain.x[0], domain.x[1], domain.cells[0])
    return Grid.rectangle(domain.x[0], domain.x[1], domain.cells[0], domain.y[0], domain.y[1], domain.cells[1])


def bending_load(grid):
    """``w_t = -t x^2 / 2`` (pure bending), as a function of t; proportional."""
    w1 = -0.5 * grid.coordinates[0] ** 2
    return lambda t: t * w1


def resolution_warnings(scene):
    """Warnings for scenes whose regularization cannot resolve the expected pattern.

    The damage band has width ``~ 4 eta``; the plate's response decays over ``1/lam`` and
    cracks of the exact 1D solution are at least ``~ 3/lam`` apart, so ``eta lam`` well below
    1 is needed (SOLVER_NOTES.md: ``eta lam = 0.53`` goes diffuse on the Fig. 2.7 strip, 0.26
    resolves it).
    """
    m = scene.model
    out = []
    if m.eta * m.lam > 0.4:
        out.append(f"eta * lam = {m.eta * m.lam:.2f} > 0.4: the regularization length is not small against the"
                   f" decay length 1/lam = {1 / m.lam:.4g}; damage may go diffuse and cracks merge")
    if m.eta < 2.0 * scene.domain.dx:
        out.append(f"eta = {m.eta:.4g} is less than 2 grid cells (dx = {scene.domain.dx:.4g}): the damage"
                   " profile is not resolved and the crack energy is overestimated")
    return out


def make_model(scene, grid):
    """The :class:`PlateModel` of a plate scene."""
    m = scene.model
    if scene.load.kind != "bending":  # pragma: no cover - the scene parser allows only bending
        raise ValueError(f"load.kind = {scene.load.kind!r}")
    plate_nu = m.nu if grid.dim == 2 else 0.0
    model = PlateModel(grid, plate_nu, m.winkler, m.k_res, m.eta, m.toughness, m.at, bending_load(grid),
                       proportional=True, linear_solver=None, trial_radius=m.eta)
    model.linear_solver = make_solver(scene.solver.linear, model.plate.matrix(np.zeros(grid.n_nodes)),
                                      coords=np.column_stack(grid.coordinates))
    return model


def make_engine(scene, model):
    """The evolution engine with the scene's solver options."""
    s = scene.solver
    return Engine(
        model,
        AltMinOptions(tol=s.tol, max_iter=s.max_iter, acceleration=s.acceleration, omega=s.omega),
        BacktrackOptions(kind=s.backtrack, delta=s.backtrack_delta, interval=s.backtrack_interval,
                         direction=s.backtrack_direction, scope=s.backtrack_scope),
        SearchOptions(enabled=s.search, delta=s.search_delta),
    )


def crack_events(grid, t, alpha):
    """Crack events of a run: the steps where the crack set along ``y = 0`` changes.

    Parameters
    ----------
    grid : Grid
    t : ndarray, shape (n,)
    alpha : ndarray, shape (n, n_nodes)

    Returns
    -------
    list of (float, ndarray)
        ``(t, crack positions)`` at the first step and every step where the number of cracks
        (local maxima of alpha above 0.9) changes.
    """
    events, last = [], 0
    for ti, a in zip(t, alpha):
        x, line = centre_line(grid, a)
        cracks = crack_positions(x, line)
        if len(cracks) != last:
            events.append((float(ti), cracks))
            last = len(cracks)
    return events


def run_plate(scene, outdir, progress=lambda n: None):
    """Run a plate scene and write ``results.h5``, ``summary.json`` and the figures.

    Parameters
    ----------
    scene : thinfilm.scene.PlateScene
    outdir : Path
    progress : callable
        Called with the number of newly finished steps.

    Returns
    -------
    dict
        Paths of what was written (``results``, ``summary``, ``figures``) and the
        ``events``.
    """
    outdir = Path(outdir)
    outdir.mkdir(parents=True, exist_ok=True)
    for message in resolution_warnings(scene):
        log.warning(message)
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    engine = make_engine(scene, model)
    t_values = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    results = outdir / "results.h5"
    writer = PlateResultsWriter(results, scene, grid)
    try:
        engine.run(t_values, on_step=writer.write_step, progress=progress)
    finally:
        writer.close()
    data = read_plate(results)
    events = crack_events(grid, data["steps"]["t"], data["alpha"])
    summary = write_plate_summary(outdir / "summary.json", scene, data, events)
    from thinfilm.plots import plot_plate

    figures = plot_plate(results, outdir)
    return {"results": results, "summary": summary, "figures": figures, "events": events}
