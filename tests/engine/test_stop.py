"""The energy stop of alternate minimization (``stop = "energy"``): its test on synthetic
histories, and on a coarse indentation against the change stop."""

from __future__ import annotations

import numpy as np
import pytest

from pathlib import Path

from thinfilm.engine import AltMinOptions, Engine
from thinfilm.engine.evolution import SETTLED_WINDOW
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.scene import parse_scene

ROOT = Path(__file__).resolve().parents[2]

TOL = 1e-3


class _Options:
    """What ``Engine._energy_settled`` reads of an engine: its options."""

    def __init__(self, **options):
        self.altmin = AltMinOptions(tol=TOL, **options)


def settled(energies, kkt, changes, **options):
    return Engine._energy_settled(_Options(**options), list(energies), kkt, list(changes))


def geometric(limit, amplitude, q, n):
    """Energies ``limit + amplitude q^k``, k = 0..n-1, and falling changes of alpha."""
    k = np.arange(n)
    return limit + amplitude * q**k, 0.1 * q**k


def test_the_remaining_decrease_of_a_geometric_tail_is_exact():
    """For E_k = E + c q^k the test's estimate d_k / (1 - q) is E_(k-1) - E, the distance of
    the previous iterate to the limit: the stop fires once that falls below energy_tol |E|."""
    limit, amplitude, q = 10.0, 1e-3, 0.8
    fired = None
    for n in range(SETTLED_WINDOW + 2, 200):
        energies, changes = geometric(limit, amplitude, q, n)
        if settled(energies, 0.0, changes, energy_tol=1e-6):
            fired = n
            break
    assert fired is not None
    # the first n with amplitude q^(n-2) <= 1e-6 * E_(n-1), to round-off
    gap = amplitude * q ** np.arange(200)
    expected = next(n for n in range(SETTLED_WINDOW + 2, 200)
                    if gap[n - 2] <= 1e-6 * (limit + gap[n - 1]) * (1 + 1e-9))
    assert fired == expected


def test_no_stop_while_the_decrease_grows():
    """Leaving a saddle: the energy barely moves, then faster and faster."""
    energies = 10.0 - 1e-12 * 1.5 ** np.arange(8)
    changes = 1e-4 * 0.9 ** np.arange(8)  # even with falling changes
    assert not settled(energies, 0.0, changes, energy_tol=1e-6)


@pytest.mark.parametrize("spoil", ["kkt", "changes", "increase", "short"])
def test_each_condition_is_needed(spoil):
    energies, changes = geometric(10.0, 1e-9, 0.5, 12)
    kkt = 0.0
    assert settled(energies, kkt, changes)
    if spoil == "kkt":
        kkt = 10.0 * TOL * 1.01  # above kkt_factor tol (default 10)
    elif spoil == "changes":
        changes[-1] = changes[-2] * 1.1
    elif spoil == "increase":
        energies[-1] = energies[-2] + 1e-15
    else:
        energies, changes = energies[:SETTLED_WINDOW + 1], changes[:SETTLED_WINDOW + 1]
    assert not settled(energies, kkt, changes)


def _indentation(stop):
    """The main job's indentation on a coarse grid (80 x 80 cells, eta = 2 dx) to t = 0.6,
    tol 1e-4; returns the engine's work, records and states."""
    text = (ROOT / "cases" / "indentation.toml").read_text()
    for old, new in (("cells = [320, 320]", "cells = [80, 80]"), ("eta = 0.005", "eta = 0.02"),
                     ("t_max = 1.0", "t_max = 0.6"), ("steps = 20", "steps = 10"),
                     ("snapshots = [0.3, 0.5, 0.7, 0.9, 1.0]", "snapshots = [0.6]"),
                     ('acceleration = "overrelax"', f'acceleration = "overrelax"\ntol = 1e-4\nstop = "{stop}"')):
        assert old in text, old
        text = text.replace(old, new)
    scene = parse_scene(text)
    grid = build_grid(scene.domain)
    engine = Engine.from_options(make_model(scene, grid), scene.solver)
    records, states = engine.run(np.linspace(0.0, 0.6, 11))
    return engine.work["iterations"], records, states


def test_energy_stop_on_the_indentation_keeps_the_evolution_with_fewer_iterations():
    """Where the change of alpha settles slowly (ring cracks forming under the indenter), the
    energy stop ends steps earlier: fewer iterations, and the same evolution within 1e-4 of
    the energy and 0.01 of the damage at every step (the measured differences are 2.6e-5 and
    1.6e-3: a step stopped earlier also starts the next one elsewhere)."""
    n_change, records_change, states_change = _indentation("change")
    n_energy, records_energy, states_energy = _indentation("energy")
    assert sum(r.stopped_by_energy for r in records_change) == 0
    assert sum(r.stopped_by_energy for r in records_energy) >= 3
    assert n_energy < 0.9 * n_change
    for a, b in zip(states_energy, states_change):
        assert abs(a.total - b.total) <= 1e-4 * abs(b.total)
        assert np.max(np.abs(a.alpha - b.alpha)) <= 0.01
    assert states_change[-1].alpha.max() > 0.99  # it cracked
    for before, after in zip(states_energy[:-1], states_energy[1:]):
        assert np.all(after.alpha >= before.alpha) and np.all(after.alpha <= 1.0)
    for r in records_energy[1:]:
        assert np.isfinite(r.kkt)
        history = np.array(r.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * max(1.0, abs(history[0])))
