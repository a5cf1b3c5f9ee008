"""The closed-form fragment: F (2.31), E*_t (2.30) and v* (2.29) against independent checks."""

import mpmath as mp
import numpy as np
import pytest
from scipy.integrate import quad

from onedim.fragment import (
    fragment_coefficient,
    fragment_displacement,
    fragment_energy,
    fragment_energy_derivative_F,
    lam_from_winkler,
    scaling_F,
    scaling_F_second_derivative,
    winkler_from_lam,
)

# lam * l from 1e-8 to 1e4, for a few lam: the range the issue asks to be accurate on.
X_VALUES = np.logspace(-8, 4, 97)
LAMS = [0.37, 10.0, 31.62, 1000.0]


def _F_mp(length, lam):
    x = mp.mpf(lam) * mp.mpf(length)
    return 2 * (mp.cos(x) - mp.cosh(x)) / (mp.mpf(lam) * (mp.sin(x) + mp.sinh(x)))


@pytest.mark.parametrize("lam", LAMS)
def test_F_and_coefficient_match_high_precision(lam):
    # l + F(l) ~ l x^4/180 for small x: 16 digits of it need about 4*8 + 16 more working
    # digits in the direct formula, hence 120.
    lengths = X_VALUES / lam
    F = scaling_F(lengths, lam)
    coef = fragment_coefficient(lengths, lam)
    with mp.workdps(120):
        F_exact = np.array([float(_F_mp(l, lam)) for l in lengths])
        coef_exact = np.array([float(mp.mpf(l) + _F_mp(l, lam)) for l in lengths])
    assert np.max(np.abs(F / F_exact - 1.0)) < 1e-12
    assert np.max(np.abs(coef / coef_exact - 1.0)) < 1e-12
    assert np.all(np.isfinite(F)) and np.all(coef > 0.0)


def test_energy_is_t_squared_half_coefficient():
    assert fragment_energy(0.3, 10.0, 2.0) == pytest.approx(2.0 * fragment_coefficient(0.3, 10.0), rel=1e-15)


def test_limits_of_F():
    lam = 10.0
    # F -> -l as l -> 0, with l + F ~ lam^4 l^5 / 180 (series of the module docstring).
    l = 1e-6
    assert scaling_F(l, lam) == pytest.approx(-l, rel=1e-15)
    assert fragment_coefficient(l, lam) == pytest.approx(lam**4 * l**5 / 180.0, rel=1e-9)
    # F -> -2/lam as l -> infinity; lam l = 1e4 must not overflow.
    assert scaling_F(1e3, lam) == pytest.approx(-2.0 / lam, rel=1e-15)
    assert fragment_coefficient(1e3, lam) == pytest.approx(1e3 - 2.0 / lam, rel=1e-15)


@pytest.mark.parametrize("lam", [10.0, 31.62])
def test_derivatives_of_F_match_high_precision(lam):
    # Up to lam l = 60, where F' ~ e^-x is 1e-26 of F: numerical differentiation in mpmath
    # then still has 50 digits to spare.
    lengths = np.logspace(-4, np.log10(60.0), 41) / lam
    d1 = fragment_energy_derivative_F(lengths, lam)
    d2 = scaling_F_second_derivative(lengths, lam)
    with mp.workdps(80):
        d1_exact = np.array([float(mp.diff(lambda s: _F_mp(s, lam), mp.mpf(l))) for l in lengths])
        d2_exact = np.array([float(mp.diff(lambda s: _F_mp(s, lam), mp.mpf(l), 2)) for l in lengths])
    assert np.max(np.abs(d1 - d1_exact) / np.abs(d1_exact)) < 1e-10
    # F'' is only the Newton Hessian of the position refinement: a few digits suffice, and
    # for short fragments it is a difference of nearly equal terms.
    mask = lengths * lam > 1e-2
    assert np.max(np.abs(d2 - d2_exact)[mask] / np.abs(d2_exact[mask])) < 1e-8


def test_lam_and_winkler_are_inverse():
    assert lam_from_winkler(winkler_from_lam(31.62)) == pytest.approx(31.62, rel=1e-15)
    assert winkler_from_lam(10.0) == pytest.approx(4e4)


CASES = [(0.5, 10.0, 1.0), (0.05, 10.0, 0.7), (1.0, 31.62, 5.36), (2.0, 200.0, 3.0), (0.01, 1.0, 2.0)]


@pytest.mark.parametrize("length, lam, t", CASES)
def test_displacement_solves_the_ode_and_the_free_end_conditions(length, lam, t):
    winkler = 4.0 * lam**4
    x = np.linspace(-length / 2, length / 2, 201)
    v = [fragment_displacement(x, length, lam, t, derivative=k) for k in range(5)]
    scale = [np.max(np.abs(vk)) for vk in v]
    # Each analytic derivative is the finite-difference derivative of the previous one: the
    # basis rotation is checked independently of the formula it produces. Fourth-order
    # central differences with a step well inside the decay length 1/lam.
    step = 1e-3 * min(length, 1.0 / lam)
    xi = x[2:-2]
    for k in range(4):
        def vk(s):
            return fragment_displacement(xi + s, length, lam, t, k)

        fd = (8.0 * (vk(step) - vk(-step)) - (vk(2 * step) - vk(-2 * step))) / (12.0 * step)
        roundoff = 100.0 * np.finfo(float).eps * scale[k] / step  # FD cancellation bound
        assert np.max(np.abs(fd - v[k + 1][2:-2])) < 1e-6 * scale[k + 1] + roundoff
    # v'''' + winkler v = 0 in the interior.
    assert np.max(np.abs(v[4] + winkler * v[0])) < 1e-10 * max(scale[4], winkler * scale[0])
    # Free ends: bending moment v'' - t = 0 and shear v''' = 0 at x = +-l/2.
    ends = np.array([-length / 2, length / 2])
    assert np.allclose(fragment_displacement(ends, length, lam, t, 2), t, rtol=1e-10, atol=0)
    assert np.max(np.abs(fragment_displacement(ends, length, lam, t, 3))) < 1e-10 * scale[3]
    # v* is even.
    assert np.allclose(v[0], v[0][::-1], rtol=1e-12, atol=1e-14 * scale[0])


@pytest.mark.parametrize("length, lam, t", CASES)
def test_displacement_energy_equals_closed_form(length, lam, t):
    winkler = 4.0 * lam**4

    def density(x):
        v = fragment_displacement(x, length, lam, t)
        v2 = fragment_displacement(x, length, lam, t, 2)
        return 0.5 * (v2 - t) ** 2 + 0.5 * winkler * v**2

    energy, _ = quad(density, -length / 2, length / 2, epsabs=0.0, epsrel=1e-13, limit=400)
    assert energy == pytest.approx(float(fragment_energy(length, lam, t)), rel=1e-10)


def test_displacement_is_the_minimizer():
    # Perturbing v* by any admissible function raises the energy (second variation > 0,
    # first variation = 0): check on a few smooth perturbations.
    length, lam, t = 0.3, 10.0, 1.0
    winkler = 4.0 * lam**4

    def energy(eps, k):
        def density(x):
            phi = np.cos(k * np.pi * x / length) + 0.3 * x
            phi2 = -(k * np.pi / length) ** 2 * np.cos(k * np.pi * x / length)
            v = fragment_displacement(x, length, lam, t) + eps * phi
            v2 = fragment_displacement(x, length, lam, t, 2) + eps * phi2
            return 0.5 * (v2 - t) ** 2 + 0.5 * winkler * v**2

        return quad(density, -length / 2, length / 2, epsabs=0.0, epsrel=1e-13, limit=200)[0]

    for k in (1, 2, 3):
        e0, ep, em = energy(0.0, k), energy(1e-4, k), energy(-1e-4, k)
        assert ep > e0 and em > e0
        assert abs(ep - em) < 1e-6 * (ep - e0)  # first variation vanishes


def test_no_overflow_at_large_lam_l():
    x = np.linspace(-5.0, 5.0, 11)
    v = fragment_displacement(x, 10.0, 1000.0, 1.0, derivative=2)  # lam l = 1e4
    assert np.all(np.isfinite(v))
    assert v[0] == pytest.approx(1.0, rel=1e-12) and v[-1] == pytest.approx(1.0, rel=1e-12)
