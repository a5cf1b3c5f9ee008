"""The memory a thin-film run needs, from its scene alone (:mod:`thinfilm.resources`).

With ``N`` nodes, ``n`` unknowns of the u-problem (``N`` divided by the order of the
symmetry group) and ``S + 1`` load steps::

    memory = BASE_BYTES + N NODE_BYTES[dim, solver] + n factor_bytes(dim, n)   (direct solver only)
           + (S + 1) (16 N + STEP_BYTES)

* ``NODE_BYTES``: the peak, per node, of the model (grid, load, the plate matrix of 5 (1D) or
  13 (2D) entries per row, the damage operator's three matrices of 3 or 5, the solver's copy
  of the pattern and upper triangle) and of the engine's working fields during alternate
  minimization; with AMG, its hierarchy (3 near-nullspace vectors, rebuilt now and then).
* ``factor_bytes``: PARDISO's own memory (its ``iparm(16) + iparm(17)``: permanent memory and
  factors), outside Python's heap: 370 B per unknown in 1D; ``100 log2(n) - 112`` B per
  unknown in 2D, nested dissection's ``n log n`` fill. A single-precision factorization
  (``[solver] precision``) holds half of it.
* ``16 N`` per step: ``u`` and ``alpha`` of every finished step, which the engine keeps until
  the evolution ends (backtracking may return to any of them); ``STEP_BYTES``
  (:mod:`thinfilm.resources`): the step's records and its share of the figures.

The constants were measured with ``tracemalloc`` over whole runs
(docs/speed.md#memory-and-time-estimates); the whole is checked against measured runs in
``docs/scenes.md#sizes`` and ``tests/core/test_refusals.py``. A run's time depends on its
iterations, which the scene does not tell, so only its memory is estimated.
"""

from __future__ import annotations

import importlib.util
import math

from thinfilm.plate.symmetry import GROUPS
from thinfilm.resources import BASE_BYTES, STEP_BYTES, Estimate, Size, count, size
from thinfilm.solvers.linear import AUTO_SINGLE_MIN_UNKNOWNS, auto_kind

__all__ = ["NODE_BYTES", "FIELD_BYTES", "factor_bytes", "solver_kind", "memory", "estimate"]

#: Peak bytes per node of the model, its solver's arrays and the engine's working fields.
NODE_BYTES = {(1, "direct"): 530.0, (2, "direct"): 830.0, (1, "amg"): 1450.0, (2, "amg"): 4100.0}
#: Bytes per node per step of the fields the engine keeps (``u`` and ``alpha``, float64).
FIELD_BYTES = 16.0


def factor_bytes(dim, n):
    """Bytes per unknown of PARDISO's factorization of the u-problem with ``n`` unknowns."""
    if dim == 1:
        return 370.0
    return max(100.0 * math.log2(max(n, 2)) - 112.0, 370.0)


def solver_kind(linear, unknowns):
    """``"direct"`` or ``"amg"``: the scene's ``linear``, with ``"auto"`` chosen as
    :func:`thinfilm.solvers.linear.make_solver` chooses it (:func:`~thinfilm.solvers.linear.auto_kind`;
    whether PARDISO is installed is asked of the import system, without loading MKL)."""
    if linear != "auto":
        return linear
    return auto_kind(unknowns, importlib.util.find_spec("pypardiso") is not None)


def single_precision(precision, unknowns):
    """Whether the direct solver factors in single precision, as
    :class:`thinfilm.solvers.linear.DirectSolver` decides it (PARDISO asked of the import system)."""
    if precision != "auto":
        return precision == "single"
    return importlib.util.find_spec("pypardiso") is not None and unknowns >= AUTO_SINGLE_MIN_UNKNOWNS


def memory(cells, steps, linear="auto", symmetry="none", precision="auto"):
    """Bytes a run needs, and how they were reckoned.

    Parameters
    ----------
    cells : tuple of int
        ``(nx,)`` or ``(nx, ny)``.
    steps : int
    linear : {"auto", "direct", "amg"}
    symmetry : str
        A group of :data:`thinfilm.plate.symmetry.GROUPS` (the u-problem's unknowns are the
        nodes' orbits under it).
    precision : {"auto", "double", "single"}
        The direct solver's factorization (single: half the factor's bytes).

    Returns
    -------
    bytes : float
    detail : str
    model, steps : float
        The bytes of the model and its solver, and of the steps.
    """
    dim = len(cells)
    nodes = math.prod(c + 1 for c in cells)
    unknowns = max(nodes // 2 ** len(GROUPS[symmetry]), 1)
    kind = solver_kind(linear, unknowns)
    factor = factor_bytes(dim, unknowns) * (0.5 if single_precision(precision, unknowns) else 1.0)
    per_node = NODE_BYTES[dim, kind] + (unknowns / nodes * factor if kind == "direct" else 0.0)
    per_step = FIELD_BYTES * nodes + STEP_BYTES
    model, fields = nodes * per_node, (steps + 1) * per_step
    detail = (f"{count(nodes)} nodes x {size(per_node)} for the model and its {kind} solver, and"
              f" {count(steps + 1)} steps x {size(per_step)} for their fields and records")
    return BASE_BYTES + model + fields, detail, model, fields


def estimate(scene):
    """The :class:`thinfilm.resources.Estimate` of a plate scene: its memory, blamed on
    ``domain.cells`` if the grid alone (with the fewest steps) cannot fit, else on whichever of
    the model and the steps' fields and records needs more."""
    dom, load = scene.domain, scene.load
    linear, symmetry, precision = scene.solver.linear, dom.symmetry, scene.solver.precision
    total, detail, model, fields = memory(dom.cells, load.steps, linear, symmetry, precision)
    least_cells = tuple(2 for _ in dom.cells)
    cells_value = dom.cells[0] if dom.dim == 1 else list(dom.cells)
    sizes = (Size("domain.cells", cells_value, memory(dom.cells, 2, linear, symmetry, precision)[0], model,
                  remedy="use fewer cells"),
             Size("load.steps", load.steps, memory(least_cells, load.steps, linear, symmetry, precision)[0], fields,
                  remedy="use fewer steps"))
    return Estimate(total, detail, sizes)
