"""Quasi-static evolution with irreversibility (dissertation Algorithm 2.2), event by event.

Algorithm 2.2 re-runs the global minimizer (Algorithm 2.1) inside every existing fragment at
each load step and keeps all old cracks. Its result then depends on the load step: events
are only known to lie between two steps. Here every nucleation is located exactly instead:

* A fragment of ``m`` cells cracks at the smallest load ``t`` where its best partition beats
  the uncut fragment. The energy gap ``min_Y (t^2/2 (A_Y - A_0) + m_Y G/a)`` is a minimum of
  non-increasing functions of ``t`` (cracks only release elastic energy), so the predicate
  "some partition is better" is monotone in ``t`` and bisection brackets the event load to a
  relative ``1e-13``. The partition found just above it then gives the event load in closed
  form (:func:`onedim.partition.nucleation_load`), independent of bisection and load step.
* Optionally the new cut points are refined off the grid by a local continuous minimization
  of (2.32) (:func:`onedim.partition.refine_cracks`), and the event load is recomputed for
  the refined positions, so positions and loads converge as the grid is refined.
* Fragments evolve independently, so the evolution is a queue of pending nucleations, one per
  fragment, popped in order of load. A new fragment is optimal uncut when it is born (else
  its parent's partition was not optimal), so its own nucleation lies at a later load.

The grid track (``refine=False``) keeps every cut on the global grid of ``cells`` cells; the
refined track gives each fragment its own grid of about the same cell size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from onedim import dynprog
from onedim.fragment import fragment_coefficient
from onedim.partition import (
    fragment_lengths,
    nucleation_load,
    partition_elastic_coefficient,
    refine_cracks,
)

#: Relative width of the final bisection bracket of an event load.
BISECTION_RTOL = 1e-13
#: Events closer than this (relative) in load are reported as one.
EVENT_MERGE_RTOL = 1e-9


@dataclass(frozen=True)
class Event:
    """A nucleation event.

    Attributes
    ----------
    t : float
        Load at which the event happens.
    cracks : tuple of float
        All crack positions after the event, sorted.
    new_cracks : tuple of float
        The cracks created at this event, sorted.
    """

    t: float
    cracks: tuple
    new_cracks: tuple


@dataclass
class _Nucleation:
    t: float
    a: float
    b: float
    cuts: np.ndarray


class Evolution:
    """The exact quasi-static evolution of a film ``(-length/2, length/2)`` under bending.

    Parameters
    ----------
    length : float
        Film length ``l0`` (units of L).
    lam : float
        Internal length scale ``lambda``.
    toughness : float
        ``G/a``, the energy of one crack.
    cells : int
        Number of grid cells on the film (>= 2).
    t_max : float
        Largest load considered.
    refine : bool, optional
        Refine new cut points off the grid (default True).
    locate_nucleation : callable, optional
        Kernel ``(coef, t_lo, t_hi, toughness, rtol) -> (t, cuts)`` bracketing a fragment's
        nucleation load; defaults to the Numba kernel of :mod:`onedim.dynprog`
        (:mod:`onedim.reference` has the NumPy one).

    Notes
    -----
    Call :meth:`advance_to` with increasing loads; :attr:`events` lists what happened so far
    and :attr:`cracks` the current crack set.
    """

    def __init__(self, length, lam, toughness, cells, t_max, refine=True,
                 locate_nucleation: Callable = dynprog.locate_nucleation):
        self.length = float(length)
        self.lam = float(lam)
        self.toughness = float(toughness)
        self.cells = int(cells)
        self.t_max = float(t_max)
        self.refine = bool(refine)
        self.h = self.length / self.cells
        self._locate_nucleation = locate_nucleation
        self.t = 0.0
        self.cracks: list[float] = []
        self.events: list[Event] = []
        self._pending: list[_Nucleation] = []
        self._coef_cache: dict[tuple[int, float], np.ndarray] = {}
        self._add_fragment(-0.5 * self.length, 0.5 * self.length, 0.0)

    # -- one fragment -------------------------------------------------------------------
    def _coef(self, m, h):
        key = (m, h)
        if key not in self._coef_cache:
            coef = np.zeros(m + 1)
            coef[1:] = fragment_coefficient(h * np.arange(1, m + 1), self.lam)
            self._coef_cache[key] = coef
        return self._coef_cache[key]

    def _add_fragment(self, a, b, t_birth):
        """Locate the nucleation of fragment (a, b) after load t_birth, if before t_max."""
        if self.refine:
            m = max(1, int(round((b - a) / self.h)))
            h = (b - a) / m
        else:
            m = int(round((b - a) / self.h))
            h = self.h
        if m < 2:
            return
        coef = self._coef(m, h)
        t_cracked, cut_index = self._locate_nucleation(coef, t_birth, self.t_max, self.toughness, BISECTION_RTOL)
        if not math.isfinite(t_cracked):
            return
        cuts = a + h * cut_index
        if self.refine:
            cuts = refine_cracks(cuts, a, b, self.lam, h)
        t_event = nucleation_load(cuts, a, b, self.lam, self.toughness)
        # Closed form and bracket agree to round-off on the grid; refinement can only lower
        # the load, and no event precedes the birth of its fragment.
        t_event = max(min(t_event, t_cracked), t_birth)
        self._pending.append(_Nucleation(t_event, a, b, cuts))

    # -- the evolution ------------------------------------------------------------------
    def advance_to(self, t):
        """Apply, in order of load, every nucleation at a load ``<= t``.

        Parameters
        ----------
        t : float
            Target load, not below the current one and not above ``t_max``.

        Returns
        -------
        list of Event
            The events that happened on the way (also appended to :attr:`events`).
        """
        new_events = []
        while self._pending:
            nxt = min(self._pending, key=lambda n: n.t)
            if nxt.t > t:
                break
            self._pending.remove(nxt)
            self.cracks = sorted(self.cracks + list(nxt.cuts))
            points = np.concatenate(([nxt.a], nxt.cuts, [nxt.b]))
            for a, b in zip(points[:-1], points[1:]):
                self._add_fragment(a, b, nxt.t)
            last = new_events[-1] if new_events else (self.events[-1] if self.events else None)
            if last is not None and abs(nxt.t - last.t) <= EVENT_MERGE_RTOL * nxt.t:
                merged = Event(last.t, tuple(self.cracks), tuple(sorted(last.new_cracks + tuple(nxt.cuts))))
                if new_events:
                    new_events[-1] = merged
                self.events[-1] = merged
            else:
                event = Event(float(nxt.t), tuple(self.cracks), tuple(float(c) for c in nxt.cuts))
                new_events.append(event)
                self.events.append(event)
        self.t = t
        return new_events

    def energies(self, t=None):
        """Elastic, surface and total energy of the current crack set at load ``t``.

        Parameters
        ----------
        t : float or ndarray, optional
            Load(s); defaults to the current load.

        Returns
        -------
        elastic, surface, total : float or ndarray
        """
        t = self.t if t is None else np.asarray(t, dtype=float)
        half = 0.5 * self.length
        elastic = 0.5 * t**2 * partition_elastic_coefficient(self.cracks, -half, half, self.lam)
        surface = len(self.cracks) * self.toughness
        return elastic, surface, elastic + surface

    def fragment_lengths(self):
        """Lengths of the current fragments, shape (number of cracks + 1,)."""
        half = 0.5 * self.length
        return fragment_lengths(self.cracks, -half, half)


def evolve(length, lam, toughness, cells, t_max, refine=True, **kernels):
    """Run :class:`Evolution` to ``t_max`` and return its events.

    Parameters
    ----------
    length, lam, toughness, cells, t_max, refine
        As for :class:`Evolution`.
    **kernels
        ``locate_nucleation`` override.

    Returns
    -------
    list of Event
    """
    evolution = Evolution(length, lam, toughness, cells, t_max, refine=refine, **kernels)
    evolution.advance_to(t_max)
    return evolution.events
