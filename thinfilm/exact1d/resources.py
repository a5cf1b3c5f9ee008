"""The memory and time an exact 1D run needs, from its scene alone (:mod:`thinfilm.resources`).

With ``m`` cells and ``S + 1`` load steps::

    memory  = BASE_BYTES + m CELL_BYTES + (S + 1) STEP_BYTES
    seconds >= passes m^2/2 PASS_SECONDS + (S + 1) STEP_SECONDS

* ``CELL_BYTES``: the fragment coefficients ``k h + F(k h)`` of both tracks (cached per fragment
  size) and the two work arrays of each pass of Algorithm 2.1 (:mod:`onedim.dynprog`), float64.
* ``STEP_BYTES``: each step's energies and crack positions in both tracks (Python floats and
  tuples), then their arrays, the results file and the curves of the figures, with the
  allocator's overhead on small Python objects.
* A pass of Algorithm 2.1 over the whole film costs ``m^2/2`` inner iterations,
  ``PASS_SECONDS`` each. Each track makes at least one (is the film cracked by ``t_max``?),
  and if it cracks, the bisection of the first event's load to a relative ``1e-13`` makes at
  least 45 (``log2(1e13) = 43`` halvings, the two ends and the optimal cuts): a lower bound,
  since the fragments born later cost more passes. The film surely cracks by ``t_max`` if one
  crack at its middle node beats it uncut there (:func:`onedim.partition.nucleation_load`).
* ``STEP_SECONDS``: advancing both tracks to a step and recording it.

The constants were measured on runs of moderate size (docs/speed.md#memory-and-time-estimates).
"""

from __future__ import annotations

from onedim.partition import nucleation_load
from thinfilm.resources import BASE_BYTES, Estimate, Size, count, duration, size

__all__ = ["CELL_BYTES", "STEP_BYTES", "PASS_SECONDS", "STEP_SECONDS", "estimate"]

#: Bytes per cell (both tracks' fragment coefficients, the work arrays of a pass).
CELL_BYTES = 140.0
#: Bytes per load step (both tracks' records, the results, the figures' curves).
STEP_BYTES = 600.0
#: Seconds per inner iteration of a pass of Algorithm 2.1.
PASS_SECONDS = 0.9e-9
#: Seconds per load step (both tracks).
STEP_SECONDS = 0.2e-3
#: Passes over the whole film per track at the least when its first event is located.
EVENT_PASSES = 45


def _cracks(model, cells, t_max):
    """Whether the film surely cracks by ``t_max``: one crack at the node nearest its middle
    beats the uncut film there."""
    half = 0.5 * model.length
    middle = -half + model.length / cells * (cells // 2)
    return nucleation_load([middle], -half, half, model.lam, model.toughness) <= t_max


def _needs(model, cells, steps, t_max):
    passes = 2 * (EVENT_PASSES if _cracks(model, cells, t_max) else 1)
    memory = BASE_BYTES + cells * CELL_BYTES + (steps + 1) * STEP_BYTES
    seconds = passes * 0.5 * cells**2 * PASS_SECONDS + (steps + 1) * STEP_SECONDS
    return memory, seconds, passes


def estimate(scene):
    """The :class:`thinfilm.resources.Estimate` of an exact 1D scene: memory and time, blamed on
    ``grid.cells`` or ``load.steps``."""
    m, cells, steps, t_max = scene.model, scene.grid.cells, scene.load.steps, scene.load.t_max
    memory, seconds, passes = _needs(m, cells, steps, t_max)
    alone_cells = _needs(m, cells, 2, t_max)
    alone_steps = _needs(m, 2, steps, t_max)
    sizes = (Size("grid.cells", cells, alone_cells[0], cells * CELL_BYTES, alone_cells[1], "use fewer cells"),
             Size("load.steps", steps, alone_steps[0], (steps + 1) * STEP_BYTES, alone_steps[1], "use fewer steps"))
    memory_detail = f"{count(cells)} cells x {size(CELL_BYTES)} and {count(steps + 1)} steps x {size(STEP_BYTES)}"
    time_detail = (f"{passes} passes of Algorithm 2.1 over the {count(cells)} cells, {count(cells)}^2/2 x"
                   f" {PASS_SECONDS * 1e9:g} ns each: {duration(passes * 0.5 * cells**2 * PASS_SECONDS)};"
                   f" {count(steps + 1)} steps x {STEP_SECONDS * 1e3:g} ms: {duration((steps + 1) * STEP_SECONDS)}")
    return Estimate(memory, memory_detail, sizes, seconds, time_detail)
