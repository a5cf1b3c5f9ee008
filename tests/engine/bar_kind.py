"""The AT1 bar of ``bar.py`` as a model kind of its own (``kind = "bar"``), outside the toolkit.

This is what a new model kind needs, and all it needs: a scene parser, a :class:`Setup` (the
model and its discretization, here a 1D mesh of segments) and its parameters. The tests
register it (:func:`thinfilm.kinds.register`) and run it through the toolkit's own scene
reader, run, results file, XDMF index, figures and command line, none of which knows it.

Scene::

    [model]
    kind = "bar"
    L = 1.0
    E = 1.0
    Gc = 1.0
    ell = 0.05
    elements = 200
    [load]
    t_max = 1.2
    steps = 12
    [solver]        # the engine's options, as for every kind
    backtrack = "standard"
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tests.engine.bar import Bar
from thinfilm.discretization import SimplexMesh
from thinfilm.run import EvolutionKind, Setup
from thinfilm.scene import SolverSettings, Table, read_snapshots, read_solver, require_tables


@dataclass(frozen=True)
class BarLoad:
    """``u(L) = t``, ``t`` in ``[0, t_max]`` in ``steps`` steps."""

    t_max: float
    steps: int
    proportional = True


@dataclass(frozen=True)
class BarScene:
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
    """``kind = "bar"``: the AT1 bar in tension of ``tests/engine/bar.py``."""

    name = "bar"
    labels = {"alpha": r"damage $\alpha$", "u": "displacement u (m)", "energy": "energy (J)"}
    length_unit = "m"

    def parse(self, source, data, text):
        require_tables(source, data, ("model", "load"), ("solver", "output"))
        model = Table(source, "model", data["model"], ("kind", "L", "E", "Gc", "ell", "elements"))
        load = Table(source, "load", data["load"], ("t_max", "steps"))
        elements = model.integer("elements", minimum=2)
        if elements % 2:
            model._fail("elements", elements, "must be even (the middle of the bar is a node)")
        bar_load = BarLoad(t_max=load.number("t_max", minimum=0), steps=load.integer("steps", minimum=2))
        solver, _ = read_solver(source, data.get("solver", {}), proportional=True)
        return BarScene(L=model.number("L", minimum=0), E=model.number("E", minimum=0),
                        Gc=model.number("Gc", minimum=0), ell=model.number("ell", minimum=0), elements=elements,
                        load=bar_load, solver=solver, text=text, source=source,
                        snapshots=read_snapshots(source, data.get("output", {}), bar_load.t_max))

    def setup(self, scene):
        bar = Bar(L=scene.L, E=scene.E, Gc=scene.Gc, ell=scene.ell, n=scene.elements)
        cells = np.column_stack([np.arange(bar.n), np.arange(1, bar.n + 1)])

        def observe(u, alpha, t):
            # The axial force: the same in every element at equilibrium; read at the loaded end.
            return {"force": float(bar.E * bar.element_stiffness(alpha)[-1] * (u[-1] - u[-2]) / bar.h)}

        return Setup(model=bar, discretization=SimplexMesh(bar.x[:, None], cells), observe=observe,
                     observables=("force",), log=[f"bar of {bar.n} elements, t_c = {bar.critical_load():.6g}"])

    def parameters(self, scene):
        return {"L": scene.L, "E": scene.E, "Gc": scene.Gc, "ell": scene.ell, "elements": scene.elements,
                "t_max": scene.load.t_max, "steps": scene.load.steps}

    def title(self, parameters):
        return f"AT1 bar, ell = {parameters['ell']:g}"
