"""Algorithm 2.1 kernels against brute-force enumeration and their NumPy reference."""

import itertools

import numpy as np
import pytest
from scipy.integrate import quad

from onedim import dynprog, reference
from onedim.fragment import fragment_coefficient, fragment_displacement
from onedim.partition import nucleation_load, partition_energy


def _coef(m, length, lam):
    coef = np.zeros(m + 1)
    coef[1:] = fragment_coefficient(length / m * np.arange(1, m + 1), lam)
    return coef


def _brute_force(m, length, lam, toughness, t):
    """Minimal energy and cuts over all 2^(m-1) partitions of m cells, via (2.32)."""
    h = length / m
    best, best_cuts = np.inf, ()
    for n in range(m):
        for cuts in itertools.combinations(range(1, m), n):
            energy = partition_energy(np.array(cuts) * h, 0.0, length, lam, toughness, t)[2]
            if energy < best:
                best, best_cuts = energy, cuts
    return best, best_cuts


@pytest.mark.parametrize("t", [0.5, 0.9, 1.3, 2.5, 6.0])
def test_dynamic_programming_finds_the_brute_force_minimum(t):
    m, length, lam, toughness = 11, 0.8, 10.0, 0.05
    coef = _coef(m, length, lam)
    best = dynprog.best_partition_energies(coef, t, toughness)
    energy, cuts = _brute_force(m, length, lam, toughness, t)
    assert best[m] == pytest.approx(energy, rel=1e-13)
    found = dynprog.optimal_cuts(coef, t, toughness)
    # The optimum may be degenerate (mirror images): compare energies, not only cut sets.
    e_found = partition_energy(found * length / m, 0.0, length, lam, toughness, t)[2]
    assert e_found == pytest.approx(energy, rel=1e-13)
    if len(found) == 0:
        assert cuts == ()


@pytest.mark.parametrize("m", [1, 2, 7, 200])
def test_kernels_agree_with_numpy_reference(m):
    coef = _coef(m, 1.0, 31.62)
    for t in (0.5, 5.0, 9.0):
        assert np.array_equal(dynprog.best_partition_energies(coef, t, 1.0),
                              reference.best_partition_energies(coef, t, 1.0))
        assert np.array_equal(dynprog.optimal_cuts(coef, t, 1.0), reference.optimal_cuts(coef, t, 1.0))
    a = dynprog.locate_nucleation(coef, 0.0, 12.0, 1.0, 1e-13)
    b = reference.locate_nucleation(coef, 0.0, 12.0, 1.0, 1e-13)
    assert a[0] == b[0] and np.array_equal(a[1], b[1])


def test_located_nucleation_brackets_the_closed_form_load():
    m, length, lam, toughness = 1000, 1.0, 31.62, 1.0
    coef = _coef(m, length, lam)
    t_cracked, cuts = dynprog.locate_nucleation(coef, 0.0, 12.0, toughness, 1e-13)
    assert len(cuts) == 9
    t_closed = nucleation_load(cuts * length / m, 0.0, length, lam, toughness)
    assert abs(t_cracked - t_closed) < 1e-12 * t_closed
    # Just below: uncut is optimal; at the bracket end: cut.
    below = t_closed * (1 - 1e-9)
    assert dynprog.best_partition_energies(coef, below, toughness)[m] == 0.5 * below**2 * coef[m]
    assert len(dynprog.optimal_cuts(coef, t_cracked, toughness)) == 9


def test_no_nucleation_below_t_max_returns_inf():
    coef = _coef(100, 0.1, 10.0)
    t, cuts = dynprog.locate_nucleation(coef, 0.0, 1.0, 0.05, 1e-13)
    assert t == np.inf and cuts.size == 0


@pytest.mark.parametrize("cracks", [[0.0], [-0.2, 0.05, 0.3], [-0.047, 0.176, -0.224]])
def test_partition_energy_equals_the_relaxed_fragments(cracks):
    # Proposition 1 from first principles: integrate the energy density of the exact
    # displacement of every fragment (2.29) and add G/a per crack.
    length, lam, toughness, t = 0.8, 10.0, 0.05, 1.3
    winkler = 4 * lam**4
    points = np.concatenate(([-length / 2], np.sort(cracks), [length / 2]))
    total = toughness * len(cracks)
    for a, b in zip(points[:-1], points[1:]):
        l = b - a

        def density(x):
            v = fragment_displacement(x, l, lam, t)
            v2 = fragment_displacement(x, l, lam, t, 2)
            return 0.5 * (v2 - t) ** 2 + 0.5 * winkler * v**2

        total += quad(density, -l / 2, l / 2, epsabs=0.0, epsrel=1e-13, limit=200)[0]
    elastic, surface, energy = partition_energy(cracks, -length / 2, length / 2, lam, toughness, t)
    assert energy == pytest.approx(total, rel=1e-10)
    assert surface == toughness * len(cracks)
