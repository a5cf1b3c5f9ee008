"""The registry of model kinds: what a scene's ``[model] kind`` names.

A kind is one folder of the toolkit (or of another package) with a module that defines
``KIND``, an object with the attributes of :class:`ModelKind`. The scene reader, the run, the
results reader, the plots and the command line find it here, by name, and know nothing else
about it. The built-in kinds are listed in :data:`BUILTIN` by module path and imported only
when a scene or results file asks for them (so a bad scene is refused before the numerical
stack of its kind is loaded). Another package registers its kind with :func:`register`, or
by one line in :data:`BUILTIN` if it ships with the toolkit.

Most kinds are driven by the evolution engine: they derive from
:class:`thinfilm.run.EvolutionKind`, which implements ``run``, ``plot`` and ``info`` from a
few hooks (build the model and describe its discretization; parameters; summary; extra
figures). A kind that computes its results otherwise (the exact 1D solution) implements the
three itself.
"""

from __future__ import annotations

import importlib
from typing import Protocol

__all__ = ["ModelKind", "BUILTIN", "register", "names", "get"]


class ModelKind(Protocol):
    """What the toolkit needs from a model kind.

    Attributes
    ----------
    name : str
        The scene's ``[model] kind``.
    resumable : bool
        Whether ``thinfilm run --resume`` can continue a run of this kind.
    """

    name: str
    resumable: bool

    def parse(self, source: str, data: dict, text: str):
        """Validate a scene's TOML tables (``data``); return the frozen scene or raise
        :class:`thinfilm.scene.SceneError`."""

    def run(self, scene, outdir, progress, resume: bool, threads=None) -> dict:
        """Compute and write ``results.h5``, ``summary.json`` and figures into ``outdir``;
        return ``{"results", "summary", "figures", "report"}`` (``report``: lines to print).
        ``threads`` (``"auto"``, an integer or None for the scene's) sets the numerical
        libraries' threads (:mod:`thinfilm.threads`)."""

    def plot(self, results, outdir, loads=None, animate: bool = False) -> list:
        """Draw every figure of a results file of this kind; return their paths."""

    def info(self, f, steps: dict) -> list[str]:
        """Lines of ``thinfilm info`` particular to this kind (the open HDF5 file ``f`` and its
        finished steps' records ``steps``)."""

    # Optional: ``compare(results, outdir) -> (paths, lines)``, the run drawn against an exact
    # counterpart (``thinfilm compare``; the film against the exact 1D evolution), with
    # ``check_compare(scene)`` raising SceneError for a scene that has none;
    # ``estimate(scene) -> thinfilm.resources.Estimate``, what a run needs (memory, time),
    # which the command line checks against the machine before anything is built.


#: Kinds that ship with the toolkit: name -> module that defines ``KIND``.
BUILTIN = {
    "exact1d": "thinfilm.exact1d.kind",
    "plate": "thinfilm.plate.kind",
    "fem": "fem3d.kind",
}

_registered: dict[str, ModelKind] = {}


def register(kind: ModelKind) -> ModelKind:
    """Make ``kind`` known by its ``name`` (replacing a kind of that name); returns it."""
    _registered[kind.name] = kind
    return kind


def unregister(name: str) -> None:
    """Forget the kind registered as ``name`` (a built-in one is found again on demand)."""
    _registered.pop(name, None)


def names() -> tuple[str, ...]:
    """The names of every known kind, built-in first."""
    return tuple(BUILTIN) + tuple(name for name in _registered if name not in BUILTIN)


def get(name: str) -> ModelKind:
    """The kind called ``name``.

    Raises
    ------
    KeyError
        If no kind has that name.
    """
    if name in _registered:
        return _registered[name]
    if name not in BUILTIN:
        raise KeyError(f"unknown model kind {name!r} (known: {', '.join(names())})")
    kind = importlib.import_module(BUILTIN[name]).KIND
    _registered[name] = kind
    return kind
