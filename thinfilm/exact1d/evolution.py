"""Run an exact 1D scene: the global-minimizer evolution of :mod:`onedim` over load steps.

Two tracks are computed side by side: the grid track (every crack on the scene's grid) and
the refined track (new cracks moved off the grid by local minimization of (2.32)). Event
loads are located exactly in both, independently of the load steps, which only sample the
energy curves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from onedim.evolution import Event, Evolution
from onedim.partition import partition_elastic_coefficient
from thinfilm.steps import load_steps


@dataclass(frozen=True)
class Track:
    """The evolution of one track, sampled at the load steps.

    Attributes
    ----------
    t, elastic, surface, total : ndarray, shape (steps + 1,)
        Load and energies of the evolving state at each load step (``t[0] = 0``).
    cracks : list of tuple of float
        Crack positions at each load step.
    events : list of onedim.evolution.Event
        Every nucleation up to ``t_max``, at its exact load.
    event_coefficients : ndarray, shape (len(events) + 1,)
        ``sum_j (l_j + F(l_j))`` of the state before the first event and after each event:
        the state's energy branch is ``t^2/2 coef + n_cracks G/a``.
    """

    t: np.ndarray
    elastic: np.ndarray
    surface: np.ndarray
    total: np.ndarray
    cracks: list
    events: list
    event_coefficients: np.ndarray


def _record(evolutions, t_values, progress):
    samples = {name: {"elastic": [], "surface": [], "total": [], "cracks": []} for name in evolutions}
    for t in t_values:
        for name, evolution in evolutions.items():
            evolution.advance_to(t)
            elastic, surface, total = evolution.energies(t)
            rec = samples[name]
            rec["elastic"].append(elastic)
            rec["surface"].append(surface)
            rec["total"].append(total)
            rec["cracks"].append(tuple(float(c) for c in evolution.cracks))
        progress(1)
    return samples


def run_exact1d(scene, progress=lambda n: None):
    """Compute the exact evolution of an ``exact1d`` scene.

    Parameters
    ----------
    scene : thinfilm.scene.Exact1DScene
    progress : callable, optional
        Called with 1 after each load step (drives a progress bar).

    Returns
    -------
    dict
        ``{"refined": Track, "grid": Track}``.
    """
    m = scene.model
    t_values = load_steps(scene.load)
    evolutions = {
        "refined": Evolution(m.length, m.lam, m.toughness, scene.grid.cells, scene.load.t_max, refine=True),
        "grid": Evolution(m.length, m.lam, m.toughness, scene.grid.cells, scene.load.t_max, refine=False),
    }
    samples = _record(evolutions, t_values, progress)
    half = 0.5 * m.length
    tracks = {}
    for name, evolution in evolutions.items():
        states = [()] + [e.cracks for e in evolution.events]
        coefficients = np.array([partition_elastic_coefficient(c, -half, half, m.lam) for c in states])
        rec = samples[name]
        tracks[name] = Track(
            t=t_values,
            elastic=np.array(rec["elastic"]),
            surface=np.array(rec["surface"]),
            total=np.array(rec["total"]),
            cracks=rec["cracks"],
            events=list(evolution.events),
            event_coefficients=coefficients,
        )
    return tracks


__all__ = ["Track", "run_exact1d", "Event"]
