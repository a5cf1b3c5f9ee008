"""The AT1 bar of :mod:`examples.bar.model` as a model kind of its own (``kind = "bar"``).

This is what a new model kind needs, and all it needs: a scene parser, a
:class:`thinfilm.run.Setup` (the model and its discretization, here a 1D mesh of segments)
and its parameters. Registered (:func:`thinfilm.kinds.register`), it runs through the
toolkit's own scene reader, engine, results file, XDMF index, figures and command line, none
of which knows it. ``examples/README.md`` walks through each hook; ``examples/bar/bar.toml``
is a scene of it, run by ``python -m examples.bar run examples/bar/bar.toml``.

Scene::

    [model]
    kind = "bar"
    L = 1.0           # length
    E = 1.0           # Young's modulus
    Gc = 1.0          # toughness outside the weak band (0.9 Gc inside)
    ell = 0.05        # regularization length
    elements = 200    # even: the middle of the bar is a node
    [load]
    t_max = 3.0       # the end's last displacement u(L)
    steps = 30
    [solver]          # the engine's options, as for every kind (docs/scenes.md#solver)
    backtrack = "standard"
    [output]          # optional
    snapshots = [1.0, 1.5, 3.0]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from examples.bar.model import Bar
from thinfilm.discretization import SimplexMesh
from thinfilm.run import EvolutionKind, Setup
from thinfilm.scene import SceneError, SolverSettings, Table, read_snapshots, read_solver, require_tables

__all__ = ["BarLoad", "BarScene", "BarKind", "KIND"]


@dataclass(frozen=True)
class BarLoad:
    """``u(L) = t``, ``t`` in ``[0, t_max]`` in ``steps`` equal steps.

    The run reads ``t_max`` and ``steps`` (:func:`thinfilm.steps.load_steps`) and the solver
    settings ``proportional`` (whether backtracking may scale states with ``t``).

    Attributes
    ----------
    t_max : float
        The last load (the unit of ``L``).
    steps : int
        Number of load steps after ``t = 0``.
    proportional : bool
        Always True: the whole load grows with ``t``.
    """

    t_max: float
    steps: int
    proportional = True


@dataclass(frozen=True)
class BarScene:
    """A validated bar scene: what :meth:`BarKind.parse` returns.

    Frozen, so that nothing changes a scene after it was checked. Besides the model's own
    values, the toolkit reads ``kind``, ``load``, ``solver``, ``text``, ``source``,
    ``overrides`` and ``snapshots`` of every scene (the results file stores the scene's text
    and source; the figures draw the snapshot loads).

    Attributes
    ----------
    L, E, Gc, ell : float
        As in :class:`examples.bar.model.Bar`.
    elements : int
        Number of elements (even).
    load : BarLoad
    solver : thinfilm.scene.SolverSettings
        The ``[solver]`` table: the engine's options.
    text : str
        The scene's TOML text.
    source : str
        The scene file (for messages).
    kind : str
        ``"bar"``.
    overrides : str or None
        The ``--set`` overrides (set by the scene reader, not by the kind).
    snapshots : tuple of float or None
        The loads of the snapshot figures (``[output] snapshots``).
    """

    L: float
    E: float
    Gc: float
    ell: float
    elements: int
    load: BarLoad
    solver: SolverSettings
    text: str
    source: str
    kind: str = "bar"
    overrides: str | None = None
    snapshots: tuple | None = None


class BarKind(EvolutionKind):
    """``kind = "bar"``: the AT1 bar in tension of :mod:`examples.bar.model`.

    :class:`thinfilm.run.EvolutionKind` implements ``run``, ``plot`` and ``info`` from the
    hooks below; every other hook keeps its default (no summary of its own, no extra
    figures, no warnings).
    """

    name = "bar"
    # The words of the generic figures (energy curves, field snapshots).
    labels = {"alpha": r"damage $\alpha$", "u": "displacement u (m)", "energy": "energy (J)"}
    length_unit = "m"

    def parse(self, source, data, text):
        """Validate a bar scene's tables.

        Parameters
        ----------
        source : str
            The scene file (for messages).
        data : dict
            The scene as TOML read it.
        text : str
            Its text.

        Returns
        -------
        BarScene

        Raises
        ------
        thinfilm.scene.SceneError
            Naming the key, its value and what is allowed, for a missing or unknown table or
            key, a value of the wrong type or out of range.
        """
        # Table refuses unknown keys (with the closest valid one suggested): a misspelt key
        # is an error, not a silent default.
        require_tables(source, data, ("model", "load"), ("solver", "output"))
        model = Table(source, "model", data["model"], ("kind", "L", "E", "Gc", "ell", "elements"))
        load = Table(source, "load", data["load"], ("t_max", "steps"))
        elements = model.integer("elements", minimum=2)
        if elements % 2:
            # A check of the kind's own: the same one-line message as the built-in checks.
            raise SceneError(source, model.path("elements"),
                             f"= {elements}: must be even (the middle of the bar is a node)")
        bar_load = BarLoad(t_max=load.number("t_max", minimum=0), steps=load.integer("steps", minimum=2))
        # The engine's options, read and checked as for every kind; the load is proportional,
        # so every backtracking test is allowed.
        solver, _ = read_solver(source, data.get("solver", {}), proportional=True)
        return BarScene(L=model.number("L", minimum=0), E=model.number("E", minimum=0),
                        Gc=model.number("Gc", minimum=0), ell=model.number("ell", minimum=0), elements=elements,
                        load=bar_load, solver=solver, text=text, source=source,
                        snapshots=read_snapshots(source, data.get("output", {}), bar_load.t_max))

    def setup(self, scene):
        """Build the bar and describe its mesh for one run.

        Parameters
        ----------
        scene : BarScene

        Returns
        -------
        thinfilm.run.Setup
            The model, its nodes and segments (``SimplexMesh``, points of shape
            ``(elements + 1, 1)``, cells ``(elements, 2)``), the axial force as an observable
            of every step, and a line for the run log.
        """
        bar = Bar(L=scene.L, E=scene.E, Gc=scene.Gc, ell=scene.ell, n=scene.elements)
        cells = np.column_stack([np.arange(bar.n), np.arange(1, bar.n + 1)])

        def observe(u, alpha, t):
            # The axial force: the same in every element at equilibrium; read at the loaded end.
            return {"force": float(bar.E * bar.element_stiffness(alpha)[-1] * (u[-1] - u[-2]) / bar.h)}

        return Setup(model=bar, discretization=SimplexMesh(bar.x[:, None], cells), observe=observe,
                     observables=("force",), log=[f"bar of {bar.n} elements, t_c = {bar.critical_load():.6g}"])

    def parameters(self, scene):
        """The attributes of the results file's ``/parameters`` group.

        ``t_max`` and ``steps`` are required (resuming and ``thinfilm info`` read them), and
        ``snapshots`` if the scene has them (the snapshot figures read their loads from the
        file alone); the rest is what a reader of the file needs to rebuild the model.

        Parameters
        ----------
        scene : BarScene

        Returns
        -------
        dict
        """
        return {"L": scene.L, "E": scene.E, "Gc": scene.Gc, "ell": scene.ell, "elements": scene.elements,
                "t_max": scene.load.t_max, "steps": scene.load.steps,
                **({"snapshots": scene.snapshots} if scene.snapshots else {})}

    def title(self, parameters):
        """The model in a few words, for figure titles.

        Parameters
        ----------
        parameters : dict
            As :meth:`parameters` wrote them (read back from the results file).

        Returns
        -------
        str
        """
        return f"AT1 bar, ell = {parameters['ell']:g}"


#: The kind, as the toolkit's own kinds define it (``thinfilm.kinds.BUILTIN`` names modules
#: that define ``KIND``). Importing this module does not register it: the caller does
#: (``examples/bar/__main__.py``, or a test for the length of one test).
KIND = BarKind()
