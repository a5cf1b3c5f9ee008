"""Running a scene: ``run(scene, outdir)``, and the run of every kind the engine drives.

The data flow of one run::

    scene -> its kind (thinfilm.kinds) -> Setup: the model, its discretization, ...
          -> Engine (thinfilm.engine): load steps, alternate minimization, backtracking...
          -> each finished step appended to results.h5 and committed (thinfilm.results)
          -> summary.json and figures, made from the file alone (thinfilm.plots, thinfilm.xdmf)

:class:`EvolutionKind` implements a kind's ``run``, ``plot`` and ``info`` for models driven by
the engine; a kind derives from it and writes :meth:`~EvolutionKind.setup` (build the model
and describe its discretization) and :meth:`~EvolutionKind.parameters`, and may add a
summary, figures and report lines of its own.
"""

from __future__ import annotations

import json
import logging
import signal
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from thinfilm import kinds
from thinfilm.engine.evolution import Engine
from thinfilm.results.info import seconds
from thinfilm.results.reader import Results
from thinfilm.results.writer import ResultsWriter, ResumeError, check_stored_inputs, write_summary
from thinfilm.resume import input_digests
from thinfilm.steps import load_steps
from thinfilm.threads import ThreadGovernor, threads_line, threads_summary

__all__ = ["run", "Setup", "EvolutionKind", "RunInterrupted", "load_steps", "peak_force_line", "json_list"]

log = logging.getLogger("thinfilm")


def run(scene, outdir, progress=lambda n: None, resume=False, threads=None):
    """Run a validated scene of any kind and write its results, summary and figures.

    Parameters
    ----------
    scene : object
        A scene from :func:`thinfilm.scene.load_scene`.
    outdir : str or Path
    progress : callable
        Called with the number of newly finished steps.
    resume : bool
        Continue ``outdir/results.h5`` from its last finished step (kinds that can).
    threads : "auto" or int, optional
        Threads of the numerical libraries (:mod:`thinfilm.threads`), over the scene's
        ``[solver] threads``; they never change a result.

    Returns
    -------
    dict
        ``results``, ``summary``, ``figures`` (paths) and ``report`` (lines for the user).
    """
    return kinds.get(scene.kind).run(scene, Path(outdir), progress=progress, resume=resume, threads=threads)


def peak_force_line(t, force, displacement=None):
    """``"peak force F at t = ... (displacement d)"``: the largest recorded force of a run
    (``/steps/force``; steps without one, NaN, are skipped), or None if none was recorded.
    The same line for every kind: ``thinfilm run``'s report and ``thinfilm info``."""
    force = np.asarray(force, dtype=float)
    if not np.isfinite(force).any():
        return None
    k = int(np.nanargmax(force))
    line = f"peak force {force[k]:.6g} at t = {float(t[k]):.6g}"
    if displacement is not None:
        line += f" (displacement {float(displacement[k]):.6g})"
    return line


def json_list(values):
    """Per-step values for ``summary.json``: floats, None where NaN (JSON has no NaN)."""
    return [None if not np.isfinite(v) else float(v) for v in np.asarray(values, dtype=float)]


@dataclass
class Setup:
    """What a kind builds from a scene for one run of the engine.

    Attributes
    ----------
    model : thinfilm.engine.protocol.FractureModel
    discretization : StructuredGrid or SimplexMesh
        How the model's nodes are laid out (:mod:`thinfilm.discretization`).
    components : dict
        Values per node of ``u`` and ``alpha`` if not 1 (a vector displacement).
    sizes : dict
        Values per step of ``u`` or ``alpha`` if more than the nodes' (a P2 displacement's
        edge midpoints follow its nodes' values: :class:`thinfilm.results.writer.ResultsWriter`).
    constant : dict
        Fields stored once in the results, ``{name: ndarray (n_nodes,)}``.
    groups : dict
        Attribute-only groups of the results file, ``{name: attrs}`` (e.g. ``material``).
    guess : callable or None
        ``guess(t) -> alpha or None``: a damage field to start each step from
        (:meth:`thinfilm.engine.evolution.Engine.run`).
    observe : callable or None
        ``observe(u, alpha, t) -> {name: float}``: the kind's own per-step values (e.g. a
        reaction force), stored in ``/steps`` under the names of :attr:`observables`.
    observables : tuple of str
    log : list of str
        Lines for the run log (what was built).
    adaptive : object or None
        A discretization that refines itself during the run (the model, an
        :class:`thinfilm.engine.protocol.AdaptiveMesh`): its ``description()`` is each step's
        mesh, with its :class:`thinfilm.discretization.Refinement`, stored with the step, and
        ``restore(refinement)`` rebuilds the model on a stored refinement (a resumed run).
    """

    model: object
    discretization: object
    components: dict = field(default_factory=dict)
    sizes: dict = field(default_factory=dict)
    constant: dict = field(default_factory=dict)
    groups: dict = field(default_factory=dict)
    guess: Callable | None = None
    observe: Callable | None = None
    observables: tuple = ()
    log: list = field(default_factory=list)
    adaptive: object | None = None


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


class EvolutionKind:
    """A model kind driven by the engine: ``run``, ``plot`` and ``info`` from a few hooks.

    A subclass sets :attr:`name` and writes :meth:`parse`, :meth:`setup` and
    :meth:`parameters`; the other hooks have defaults. :attr:`title`, :attr:`labels` and
    :attr:`length_unit` word its figures.
    """

    name = ""
    resumable = True
    #: Datasets every results file of the kind has (checked when one is opened).
    required_datasets = ("fields/u", "fields/alpha")
    #: Axis and colour-bar labels of the figures.
    labels = {"alpha": r"damage $\alpha$", "u": "displacement u", "energy": "energy"}
    #: The unit of lengths (axes of the field figures).
    length_unit = "L"
    #: The reader of the kind's results files (a subclass of :class:`Results` with the
    #: readings its figures and summary use).
    results_class = Results

    # -- hooks -------------------------------------------------------------------------------
    def parse(self, source, data, text):  # pragma: no cover - every kind writes its own
        raise NotImplementedError

    def setup(self, scene) -> Setup:  # pragma: no cover
        """Build the model for a run (may raise :class:`thinfilm.scene.SceneError`)."""
        raise NotImplementedError

    def parameters(self, scene) -> dict:  # pragma: no cover
        """The attributes of ``/parameters`` (``t_max`` and ``steps`` among them)."""
        raise NotImplementedError

    def inputs(self, scene) -> dict:
        """The files the scene reads, ``{scene key: path}`` (a mesh, a field file); their
        SHA-256 is stored with the results, and a resume whose files changed is refused
        (:func:`thinfilm.resume.check_inputs`). By default none."""
        return {}

    def estimate(self, scene):
        """What the run needs (:class:`thinfilm.resources.Estimate`), from the scene alone;
        by default from its load steps (:func:`thinfilm.resources.steps_estimate`): a kind
        whose nodes the scene tells adds theirs."""
        from thinfilm.resources import steps_estimate

        return steps_estimate(scene)

    def warnings(self, scene) -> list[str]:
        """Warnings for the user before the run starts (e.g. an unresolved length)."""
        return []

    def summary(self, scene, results) -> dict:
        """The kind's own entries of ``summary.json``, from the open :class:`Results`."""
        return {}

    def report(self, scene, results, summary) -> list[str]:
        """Lines printed at the end of ``thinfilm run`` (before the list of files)."""
        return []

    def figures(self, results, outdir) -> list:
        """The kind's own figures of the evolution (paths; None for one not drawn)."""
        return []

    def constant_figures(self, results, outdir) -> list:
        """The kind's figures of fields stored once (paths)."""
        return []

    def overlay(self, results, ax, t) -> list:
        """Draw on a 2D panel of the field at load ``t`` (the snapshot figures); returns the
        artists to name in the figure's legend (none by default)."""
        return []

    def title(self, parameters) -> str:
        """The model in a few words, for figure titles."""
        return self.name

    def figure_labels(self, parameters) -> dict:
        """The figures' labels for a run of these ``/parameters``: :attr:`labels` by
        default; a kind whose units are the scene's words them per run."""
        return self.labels

    def figure_length_unit(self, parameters) -> str:
        """The unit of the field figures' axes for a run of these ``/parameters``:
        :attr:`length_unit` by default."""
        return self.length_unit

    def physical(self, results) -> dict | None:
        """The SI value of the run's units, if it has non-dimensional ones and a material
        (:func:`thinfilm.plate.units.physical_scales`: ``length``, ``energy``, ``force`` and
        their unit names); None by default (the scene's own units)."""
        return None

    # -- what the hooks make ---------------------------------------------------------------------
    def run(self, scene, outdir, progress=lambda n: None, resume=False, threads=None):
        """Run a scene and write ``results.h5``, ``summary.json`` and the figures.

        Every finished step is in ``results.h5`` (flushed and committed) as soon as it is done,
        so a run killed at any instant leaves a valid file that has every step finished before
        the kill (:mod:`thinfilm.results.journal`), and ``resume=True`` continues it from its
        last finished step to the same results as an uninterrupted run; the scene may extend the
        stored one's loads (:mod:`thinfilm.resume`), and the run then continues to the new
        ``t_max`` as one uninterrupted run to it would. Ctrl-C finishes and saves
        the current step, closes the file and raises :class:`RunInterrupted` (a second Ctrl-C
        stops at once); a solver failure (:class:`thinfilm.engine.evolution.EvolutionError`)
        propagates with the finished steps saved.

        The numerical libraries' threads are set before the first step and, with ``"auto"``,
        again after each step (:class:`thinfilm.threads.ThreadGovernor`); ``threads`` (the
        command line's) overrides the scene's. Each step's count is stored in
        ``/steps/threads``, the setting in the root attribute ``threads``.

        Returns
        -------
        dict
            ``results``, ``summary``, ``figures`` (paths), ``report`` (lines) and ``events``
            (the kind's summary's events, if any).
        """
        outdir = Path(outdir)
        results = outdir / "results.h5"
        inputs = input_digests(self.inputs(scene))
        if resume:  # the input files before anything is computed (the writer checks the rest)
            check_stored_inputs(results, inputs)
        # made first: with "auto" it measures the machine's load while the model is set up
        governor = ThreadGovernor(threads if threads is not None else scene.solver.threads)
        setup = self.setup(scene)  # may refuse the scene (SceneError): nothing logged or written yet
        for line in setup.log:
            log.info(line)
        for message in self.warnings(scene):
            log.warning(message)
        outdir.mkdir(parents=True, exist_ok=True)
        engine = Engine.from_options(setup.model, scene.solver)
        writer = None
        try:
            writer = ResultsWriter(results, scene, self.parameters(scene), setup.discretization,
                                   components=setup.components, sizes=setup.sizes,
                                   observables=setup.observables + ("threads",),
                                   constant=setup.constant, groups=setup.groups, resume=resume, inputs=inputs)
            writer.write_attribute("threads", json.dumps(governor.record()))
            history = writer.history(all_alpha=scene.solver.backtrack.kind != "none") if resume else []
            refinement = writer.stored_refinement() if resume else None
            if setup.adaptive is not None and refinement is not None and refinement.passes:
                setup.adaptive.restore(refinement)   # the model on the mesh the run had reached
        except OSError as err:
            # a kill leaves the file as it was at its last commit (thinfilm.results.journal):
            # what cannot be read here was damaged otherwise (cut short by a copy, a full disk)
            if writer is not None:
                writer.close()
            if not resume:
                raise
            raise ResumeError(f"{results} cannot be read back to resume it ({' '.join(str(err).split())});"
                              " run with --force to start over") from None
        t_values = load_steps(scene.load)
        if writer.continuation is not None and writer.continuation.extended:
            c = writer.continuation
            log.info(f"extending {results} from {c.planned_before - 1} to {c.planned - 1} steps"
                     f" (t_max {c.t_max_before:g} -> {float(t_values[-1]):g})")
        if history:
            log.info(f"resuming {results} after step {len(history) - 1} (t = {history[-1].t:g})")
            stored = np.array([state.t for state in history])
            if not np.array_equal(stored, t_values[: stored.size]):
                # written before the loads were exact decimals (thinfilm.steps): the evolution
                # continues from the stored steps at this version's loads
                log.warning(f"the loads stored in {results} differ from this version's by up to"
                            f" {np.max(np.abs(stored - t_values[: stored.size])):.3g}; the run continues at"
                            " this version's loads")
            progress(len(history))
        log.info(f"threads: {governor.start()} for MKL, OpenMP and Numba ({governor.describe()})")
        with _StopOnInterrupt() as stop:
            def on_step(record, state):
                observed = setup.observe(state.u, state.alpha, state.t) if setup.observe else {}
                mesh = setup.adaptive.description() if setup.adaptive is not None else None
                writer.write_step(record, state, {**observed, "threads": governor.current}, mesh=mesh)  # the step's
                governor.update()  # for the next step
                if stop.requested:
                    raise KeyboardInterrupt

            try:
                engine.run(t_values, on_step=on_step, progress=progress, history=history, guess=setup.guess)
            except KeyboardInterrupt:
                raise RunInterrupted(results, writer.trim()) from None
            finally:
                writer.close()
        with self.results_class(results) as res:
            extra = self.summary(scene, res)
            summary = write_summary(outdir / "summary.json", scene, res, extra)
            report = self.report(scene, res, extra)
            # the open reader: what the summary measured (a film's crack metrics) is drawn, not redone
            figures = self.plot(res, outdir)  # with the scene's snapshot loads, stored in the file
        return {"results": results, "summary": summary, "figures": figures, "report": report,
                "events": extra.get("events", [])}

    def plot(self, results, outdir=None, loads=None, animate=False):
        """Every figure of a results file of this kind, and its XDMF index."""
        from thinfilm.plots import plot_run

        return plot_run(results, outdir, loads=loads, animate=animate, opener=self.results_class)

    def info(self, f, steps) -> list[str]:
        """``thinfilm info``'s lines on the solver's work (timings, iterations, stability) and,
        for a kind that records a force, its peak (:func:`peak_force_line`)."""
        n = len(steps["t"])
        if "time_total" not in steps:
            return []
        t = steps["t"]

        def total(name):
            return steps[name].sum() if name in steps else 0

        lines = [f"timings (summed over the {n} finished steps):",
                 f"  wall time     {seconds(float(total('time_total')))}",
                 f"  u-solves      {seconds(float(total('time_u')))}"
                 f" ({int(total('u_solves'))} solves, {int(total('u_solves_skipped'))} skipped)",
                 f"  alpha-solves  {seconds(float(total('time_alpha')))}",
                 f"  iterations    {int(total('iterations'))} alternate-minimization iterations"
                 f" (most in one step: {int(steps['iterations'].max()) if n else 0})",
                 f"  backtracks    {int(total('backtracks'))}; trials (search, stability)"
                 f" {int(total('trials'))} ({int(total('trials_accepted'))} kept)"]
        threads = threads_summary(f.attrs.get("threads"), steps.get("threads"))
        if threads is not None:
            lines.append("  " + threads_line(threads))
        if "force" in steps and n:
            force = peak_force_line(t, steps["force"], steps.get("displacement"))
            if force is not None:
                lines.append(force)
        if "lowest_curvature" in steps and n and np.isfinite(steps["lowest_curvature"]).any():
            curvature = steps["lowest_curvature"]
            checked = np.isfinite(curvature)
            unstable = np.flatnonzero(checked & (curvature < 0))
            lines.append(f"stability: {int(total('saddles_left'))} saddle(s) left; lowest curvature at the kept"
                         f" states {np.nanmin(curvature):.3g} toughness/eta"
                         + (f"; still negative at t = {', '.join(f'{t[k]:.4g}' for k in unstable)}"
                            if len(unstable) else ""))
        return lines
