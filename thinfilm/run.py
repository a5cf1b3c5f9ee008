"""Run a plate scene: grid, model, engine, results written step by step.

The data flow of DESIGN.md: scene -> :class:`thinfilm.plate.model.PlateModel` -> evolution engine
(:class:`thinfilm.engine.evolution.Engine`) -> step records and fields, each appended to
``results.h5`` and flushed as soon as the step is done -> ``summary.json`` and figures,
made from the file.
"""

from __future__ import annotations

import logging
import math
import signal
import threading
from pathlib import Path

import numpy as np

from thinfilm.plate import loads
from thinfilm.engine.evolution import AltMinOptions, BacktrackOptions, Engine, SearchOptions, StabilityOptions
from thinfilm.plate.grid import Grid
from thinfilm.plate.imperfection import toughness_factor
from thinfilm.io import PlateResultsWriter, write_plate_summary
from thinfilm.solvers.linear import make_solver
from thinfilm.plate.model import PlateModel
from thinfilm.results import PlateResults
from thinfilm.scene import SceneError
from thinfilm.plate.sequencing import CoarseDamage
from thinfilm.plate.symmetry import GridSymmetry

log = logging.getLogger("thinfilm")


def build_grid(domain):
    """The structured grid of a :class:`thinfilm.scene.Domain`."""
    if domain.dim == 1:
        return Grid.line(domain.x[0], domain.x[1], domain.cells[0])
    return Grid.rectangle(domain.x[0], domain.x[1], domain.cells[0], domain.y[0], domain.y[1], domain.cells[1])


def make_load(scene, grid):
    """The scene's substrate displacement (:mod:`thinfilm.plate.loads`)."""
    load = scene.load
    if load.kind == "bending":
        return loads.bending(grid)
    if load.kind == "cantilever":
        return loads.cantilever(grid)
    if load.kind == "indenter":
        return loads.indenter(grid, load.radius)
    return loads.field(grid, load.field)


def resolution_warnings(scene):
    """Warnings for scenes whose regularization cannot resolve the expected pattern.

    The damage band has width ``~ 4 eta``; the plate's response decays over ``1/lam`` and
    cracks of the exact 1D solution are at least ``~ 3/lam`` apart, so ``eta lam`` well below
    1 is needed (SOLVER_NOTES.md: ``eta lam = 0.53`` goes diffuse on the Fig. 2.7 strip, 0.26
    resolves it). An indenter whose contact disk comes within a few decay lengths of a free
    edge feels the edge (and would better be run on a larger domain).
    """
    m, dom = scene.model, scene.domain
    out = []
    if m.eta * m.lam > 0.4:
        out.append(f"eta * lam = {m.eta * m.lam:.2f} > 0.4: the regularization length is not small against the"
                   f" decay length 1/lam = {1 / m.lam:.4g}; damage may go diffuse and cracks merge")
    if m.eta < 2.0 * dom.dx:
        out.append(f"eta = {m.eta:.4g} is less than 2 grid cells (dx = {dom.dx:.4g}): the damage"
                   " profile is not resolved and the crack energy is overestimated")
    if scene.load.kind == "indenter":
        t = scene.load.t_max
        contact = scene.load.radius * math.sqrt(t * (2.0 - t))
        edges = [abs(v) for v in dom.x] + ([abs(v) for v in dom.y] if dom.y else [])
        gap = min(edges) - contact
        if gap < 3.0 / m.lam:
            out.append(f"the contact radius reaches {contact:.4g} at t = {t:g}, {gap:.4g} from a free edge: less than"
                       f" 3 decay lengths (3/lam = {3 / m.lam:.4g}); the edge changes the cracks")
    return out


def describe(scene):
    """Lines for the run log: the non-dimensional groups, the decay length, the grid."""
    m, dom = scene.model, scene.domain
    lines = []
    if scene.material is not None:
        mat = scene.material
        g = mat.groups()
        lines.append(f"material: E = {mat.E:.4g} Pa, nu = {mat.nu:g}, h = {mat.h:.4g} m, Gc = {mat.Gc:.4g} J/m^2,"
                     f" K_b = {mat.bond_stiffness:.4g} Pa/m, L = {mat.L:.4g} m")
        lines.append(f"groups (2.13): K~ = {g['K_tilde']:.4g}, G~ = {g['G_tilde']:.4g}, a = h/L = {g['a']:.4g}"
                     f" -> winkler = K~/a^4 = {g['winkler']:.4g}, toughness = G~/a = {g['toughness']:.4g}")
    lines.append(f"decay length 1/lam = {1 / m.lam:.4g} (lam = {m.lam:.4g}, winkler = {m.winkler:.4g});"
                 f" eta = {m.eta:.4g} = {m.eta / dom.dx:.3g} dx; eta * lam = {m.eta * m.lam:.3g}")
    if m.toughness_noise > 0:
        lines.append(f"imperfect film: toughness G/a = {m.toughness:g} exp({m.toughness_noise:g} xi), xi Gaussian with"
                     f" correlation length {m.toughness_noise_length:.4g} ({m.toughness_noise_length / dom.dx:.3g} dx),"
                     f" seed {m.toughness_noise_seed}")
    return lines


def make_model(scene, grid):
    """The :class:`PlateModel` of a plate scene."""
    m = scene.model
    load = make_load(scene, grid)
    plate_nu = m.nu if grid.dim == 2 else 0.0
    symmetry = make_symmetry(scene, grid, load)
    factor = toughness_factor(grid, m.toughness_noise, m.toughness_noise_length, m.toughness_noise_seed, symmetry)
    model = PlateModel(grid, plate_nu, m.winkler, m.k_res, m.eta, m.toughness, m.at, load.w,
                       proportional=load.proportional, linear_solver=None, clamped=load.clamped,
                       trial_radius=m.eta, symmetry=symmetry, toughness_factor=factor)
    coords = np.column_stack(grid.coordinates)
    if symmetry is not None:
        coords = coords[symmetry.representative]
    model.linear_solver = make_solver(scene.solver.linear, model.reduced_matrix(np.zeros(grid.n_nodes)),
                                      coords=coords)
    return model


def make_symmetry(scene, grid, load):
    """The :class:`GridSymmetry` of ``[domain] symmetry`` (None for ``"none"``), after
    checking that the clamped edges and the load are invariant under it.

    Raises
    ------
    SceneError
        If they are not: the restriction would then solve another problem.
    """
    group = scene.domain.symmetry
    if group == "none":
        return None
    symmetry = GridSymmetry(grid, group)
    if not symmetry.maps_edges(load.clamped):
        raise SceneError(scene.source, "domain.symmetry",
                         f'= "{group}": the clamped edges ({", ".join(load.clamped)}) are not mapped onto'
                         f' themselves by its mirrors; use "none" or a group that keeps them')
    # Every load of the run (a non-proportional load may change shape with t).
    for t in np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)[1:]:
        w = load.w(t)
        scale = float(np.max(np.abs(w)))
        asymmetry = symmetry.asymmetry(w)
        # Not to round-off: node coordinates are mirrored only to round-off, which the
        # indenter's sqrt(R^2 - r^2) amplifies near the contact edge (5e-9 of |w| at t = 1).
        if asymmetry > 1e-6 * scale:
            raise SceneError(scene.source, "domain.symmetry",
                             f'= "{group}": the load ({scene.load.kind}) at t = {t:g} is not invariant under its'
                             f" mirrors (largest difference {asymmetry:.3g} against |w| <= {scale:.3g});"
                             ' use "none" or a group the load has')
    return symmetry


def make_engine(scene, model):
    """The evolution engine with the scene's solver options."""
    s = scene.solver
    return Engine(
        model,
        AltMinOptions(tol=s.tol, max_iter=s.max_iter, acceleration=s.acceleration, omega=s.omega),
        BacktrackOptions(kind=s.backtrack, delta=s.backtrack_delta, interval=s.backtrack_interval,
                         direction=s.backtrack_direction, scope=s.backtrack_scope),
        SearchOptions(enabled=s.search, delta=s.search_delta),
        StabilityOptions(enabled=s.stability, tol=s.stability_tol),
    )


def crack_events(t, cracks):
    """Crack events of a run: the steps where the number of cracks changes.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Loads of the steps.
    cracks : sequence of ndarray
        Crack positions at each step (:meth:`thinfilm.results.PlateResults.cracks`).

    Returns
    -------
    list of (float, ndarray)
        ``(t, crack positions)`` at every step where the number of cracks changes.
    """
    events, last = [], 0
    for ti, positions in zip(t, cracks):
        if len(positions) != last:
            events.append((float(ti), positions))
            last = len(positions)
    return events


class RunInterrupted(Exception):
    """A run stopped by the user (Ctrl-C) after saving its finished steps."""

    def __init__(self, results, steps_done):
        super().__init__(f"interrupted; {steps_done} finished step(s) saved in {results}")
        self.results, self.steps_done = results, steps_done


class _StopOnInterrupt:
    """Ctrl-C during an evolution: finish and save the current step, then stop.

    A ``KeyboardInterrupt`` raised wherever the signal lands can be lost (inside a weakref
    callback or a destructor Python prints and ignores it: seen in about one interrupt in
    three), so the first SIGINT only sets :attr:`requested`, which the step callback turns
    into a clean stop. It also restores the default handler, so a second Ctrl-C stops at
    once (the steps already saved stay valid). Outside the main thread signals cannot be
    handled, and nothing is changed.
    """

    def __init__(self):
        self.requested = False
        self._previous = None

    def _handler(self, signum, frame):
        self.requested = True
        signal.signal(signal.SIGINT, signal.default_int_handler)

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)


def run_plate(scene, outdir, progress=lambda n: None, resume=False):
    """Run a plate scene and write ``results.h5``, ``summary.json`` and the figures.

    Every finished step is in ``results.h5`` (flushed) as soon as it is done, so a run that
    is killed leaves a valid file, and ``resume=True`` continues it from its last finished
    step to the same results as an uninterrupted run. Ctrl-C finishes and saves the current
    step, closes the file and raises :class:`RunInterrupted` (a second Ctrl-C stops at
    once); a solver failure (:class:`thinfilm.engine.evolution.EvolutionError`) propagates with
    the finished steps saved.

    Parameters
    ----------
    scene : thinfilm.scene.PlateScene
    outdir : Path
    progress : callable
        Called with the number of newly finished steps.
    resume : bool
        Continue ``outdir/results.h5`` (written by the same scene text).

    Returns
    -------
    dict
        Paths of what was written (``results``, ``summary``, ``figures``) and the
        ``events``.
    """
    outdir = Path(outdir)
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)   # may refuse the scene (SceneError): nothing logged or written yet
    for line in describe(scene):
        log.info(line)
    for message in resolution_warnings(scene):
        log.warning(message)
    outdir.mkdir(parents=True, exist_ok=True)
    if model.symmetry is not None:
        log.info(f'symmetry "{model.symmetry.group}": u and alpha invariant under its mirrors;'
                 f" u-solves of {model.symmetry.n_orbits} unknowns instead of {grid.n_nodes}")
    engine = make_engine(scene, model)
    t_values = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    guess = None
    if scene.solver.coarse is not None:
        guess = CoarseDamage(scene.solver.coarse, grid)
        log.info(f"grid sequencing: each step starts from the damage of {scene.solver.coarse}"
                 f" ({guess.t.size} steps) at the same load")
    results = outdir / "results.h5"
    factor = model.damage.toughness_factor
    writer = PlateResultsWriter(results, scene, grid, resume=resume,
                                toughness=None if factor is None else scene.model.toughness * factor)
    history = writer.history(all_alpha=scene.solver.backtrack != "none") if resume else []
    if history:
        log.info(f"resuming {results} after step {len(history) - 1} (t = {history[-1].t:g})")
        progress(len(history))
    with _StopOnInterrupt() as stop:
        def on_step(record, state):
            writer.write_step(record, state)
            if stop.requested:
                raise KeyboardInterrupt

        try:
            engine.run(t_values, on_step=on_step, progress=progress, history=history, guess=guess)
        except KeyboardInterrupt:
            raise RunInterrupted(results, writer.trim()) from None
        finally:
            writer.close()
    with PlateResults(results) as res:
        events = crack_events(res.t, res.cracks())
        summary = write_plate_summary(outdir / "summary.json", scene, res, events)
    from thinfilm.plots import plot_plate

    figures = plot_plate(results, outdir)  # with the scene's snapshot loads, stored in the file
    return {"results": results, "summary": summary, "figures": figures, "events": events}
