"""The elastic fragment: closed-form minimal energy and displacement (dissertation 2.29-2.31).

A fragment of length ``l`` with free (traction-free) ends, bonded to a Winkler foundation of
stiffness ``winkler = K/a^4 = 4 lam^4`` and loaded by ``w_t(x) = -t x^2 / 2``. With
``v = u - w_t`` the energy is ``1/2 Int (v'' - t)^2 + winkler/2 Int v^2``; its minimizer
``v*`` solves ``v'''' + winkler v = 0`` with ``v'' = t`` and ``v''' = 0`` at both ends, and
its minimal value is

    E*_t(l) = t^2 / 2 (l + F(l)),
    F(l)    = 2 (cos(lam l) - cosh(lam l)) / (lam (sin(lam l) + sinh(lam l))).

Numerics. With ``x = lam l``: for small ``x`` the numerator ``cos x - cosh x`` and the sum
``l + F(l)`` (of order ``l x^4 / 180``) cancel catastrophically, so both are evaluated from
their power series, whose terms are all of one sign:

    cos x - cosh x = -2 A(x),  sin x + sinh x = 2 B(x),
    A = sum_k x^(4k+2) / (4k+2)!,   B = sum_k x^(4k+1) / (4k+1)!,
    lam (l + F) = (x B - 2 A) / B,   x B - 2 A = sum_{k>=1} 4k x^(4k+2) / (4k+2)!.

For large ``x`` the hyperbolic functions overflow (``cosh`` at ``x > 710``); dividing
numerator and denominator by ``e^x / 2`` leaves only ``exp(-x)`` factors. The switch is at
``x = 2``, where the series has converged to round-off with 10 terms and the direct form
loses at most one digit (``x + lam F`` is 0.16 there against terms of size 2).
"""

from __future__ import annotations

import math

import numpy as np

#: Below this value of ``lam * l`` the power series are used.
SERIES_SWITCH = 2.0
#: Number of series terms; at x = 2 the 10th term is below 1e-30 relative.
_N_TERMS = 10


def winkler_from_lam(lam):
    """Foundation stiffness ``K/a^4`` from the internal length scale ``lam``: ``4 lam^4``."""
    return 4.0 * np.asarray(lam, dtype=float) ** 4


def lam_from_winkler(winkler):
    """Internal length scale ``lam = winkler^(1/4) / sqrt(2)`` from ``winkler = K/a^4``."""
    return np.asarray(winkler, dtype=float) ** 0.25 / math.sqrt(2.0)


def _series_A_B_C(x):
    """Power series A(x), B(x) and C(x) = x B - 2 A for small x (see module docstring)."""
    x2 = x * x
    x4 = x2 * x2
    A = np.zeros_like(x)
    B = np.zeros_like(x)
    C = np.zeros_like(x)
    # term_A = x^(4k+2)/(4k+2)!, term_B = x^(4k+1)/(4k+1)!; sum the smallest terms first.
    terms_A, terms_B = [], []
    tA = x2 / 2.0
    tB = x.copy()
    for k in range(_N_TERMS):
        terms_A.append((k, tA))
        terms_B.append(tB)
        n = 4 * k + 2
        tA = tA * x4 / ((n + 1) * (n + 2) * (n + 3) * (n + 4))
        n = 4 * k + 1
        tB = tB * x4 / ((n + 1) * (n + 2) * (n + 3) * (n + 4))
    for (k, tA), tB in zip(reversed(terms_A), reversed(terms_B)):
        A += tA
        B += tB
        C += 4 * k * tA
    return A, B, C


def _split(lam, length):
    lam, length = np.broadcast_arrays(np.asarray(lam, dtype=float), np.asarray(length, dtype=float))
    x = lam * length
    return lam, length, x, x < SERIES_SWITCH


def scaling_F(length, lam):
    """The scaling function ``F(l)`` of (2.31).

    Parameters
    ----------
    length : float or array_like
        Fragment length ``l`` > 0 (units of L).
    lam : float or array_like
        Internal length scale ``lambda`` > 0 (units of 1/L); broadcast against ``length``.

    Returns
    -------
    ndarray
        ``F(l) = 2 (cos(lam l) - cosh(lam l)) / (lam (sin(lam l) + sinh(lam l)))``, in [-l, 0),
        relative error below 1e-13 for ``lam l`` in [1e-8, 1e4]. Tends to ``-l`` as
        ``l -> 0`` and to ``-2/lam`` as ``l -> infinity``.
    """
    lam, length, x, small = _split(lam, length)
    out = np.empty_like(x)
    if small.any():
        A, B, _ = _series_A_B_C(x[small])
        out[small] = -2.0 * A / (lam[small] * B)
    big = ~small
    if big.any():
        xb, e = x[big], np.exp(-x[big])
        num = 2.0 * np.cos(xb) * e - 1.0 - e * e
        den = 2.0 * np.sin(xb) * e + 1.0 - e * e
        out[big] = 2.0 * num / (lam[big] * den)
    return out[()] if out.ndim == 0 else out


def fragment_coefficient(length, lam):
    """``l + F(l)``: the minimal elastic energy of a fragment at ``t = 1``, times 2.

    Evaluated without cancellation (series below ``lam l = 2``): it behaves like
    ``lam^4 l^5 / 180`` for short fragments and ``l - 2/lam`` for long ones.

    Parameters
    ----------
    length, lam : float or array_like
        Fragment length and internal length scale, broadcast together.

    Returns
    -------
    ndarray
        ``l + F(l)`` >= 0, same shape as the broadcast inputs (units of L).
    """
    lam, length, x, small = _split(lam, length)
    out = np.empty_like(x)
    if small.any():
        _, B, C = _series_A_B_C(x[small])
        out[small] = C / (lam[small] * B)
    big = ~small
    if big.any():
        xb, e = x[big], np.exp(-x[big])
        num = 2.0 * np.cos(xb) * e - 1.0 - e * e
        den = 2.0 * np.sin(xb) * e + 1.0 - e * e
        out[big] = (xb + 2.0 * num / den) / lam[big]
    return out[()] if out.ndim == 0 else out


def fragment_energy(length, lam, t):
    """Minimal elastic energy ``E*_t(l) = t^2/2 (l + F(l))`` of a free fragment (2.30).

    Parameters
    ----------
    length, lam, t : float or array_like
        Fragment length, internal length scale and load, broadcast together.

    Returns
    -------
    ndarray
        Energy per unit width (non-dimensional, as in ``docs/model.md``).
    """
    return 0.5 * np.asarray(t, dtype=float) ** 2 * fragment_coefficient(length, lam)


def fragment_energy_derivative_F(length, lam):
    """``dF/dl = -4 sin(x) sinh(x) / (sin(x) + sinh(x))^2`` with ``x = lam l``.

    The numerator of the quotient rule collapses to this form exactly (no cancellation);
    ``sinh`` is scaled by ``e^-x`` so large ``x`` does not overflow. Tends to ``-1`` as
    ``l -> 0`` and to 0 as ``l -> infinity``.

    Parameters
    ----------
    length, lam : float or array_like
        Fragment length and internal length scale.

    Returns
    -------
    ndarray
        ``F'(l)`` (dimensionless).
    """
    lam, length, x, _ = _split(lam, length)
    e = np.exp(-x)
    sinh_scaled = -0.5 * np.expm1(-2.0 * x)  # sinh(x) e^-x
    out = -4.0 * np.sin(x) * sinh_scaled * e / (np.sin(x) * e + sinh_scaled) ** 2
    return out[()] if out.ndim == 0 else out


def scaling_F_second_derivative(length, lam):
    """``d^2F/dl^2 = -4 lam (sinh x - sin x)(cos x sinh x - sin x cosh x) / (sin x + sinh x)^3``.

    The quotient-rule numerator factors exactly into this product (``x = lam l``); the
    hyperbolic functions are scaled by ``e^-x``. Used as the Hessian of the crack-position
    refinement, where a few digits suffice.

    Parameters
    ----------
    length, lam : float or array_like

    Returns
    -------
    ndarray
        ``F''(l)`` (units of 1/L); ``lam^4 l^3 / 9`` for short fragments.
    """
    lam, length, x, _ = _split(lam, length)
    e = np.exp(-x)
    sinh_scaled = -0.5 * np.expm1(-2.0 * x)
    cosh_scaled = 0.5 * (1.0 + e * e)
    s, c = np.sin(x), np.cos(x)
    out = -4.0 * lam * (sinh_scaled - s * e) * (c * sinh_scaled - s * cosh_scaled) * e / (s * e + sinh_scaled) ** 3
    return out[()] if out.ndim == 0 else out


def _odd_series_N1(P):
    """``cos P sinh P - sin P cosh P = sum_j (-1)^(j+1) 4^(j+1) P^(4j+3) / (4j+3)!``."""
    P4 = P ** 4
    term = -4.0 * P ** 3 / 6.0
    total = np.zeros_like(P)
    terms = []
    for j in range(_N_TERMS):
        terms.append(term)
        n = 4 * j + 3
        term = -term * 4.0 * P4 / ((n + 1) * (n + 2) * (n + 3) * (n + 4))
    for term in reversed(terms):
        total += term
    return total


def fragment_displacement(x, length, lam, t, derivative=0):
    """The minimizing modified displacement ``v*(x) = u - w_t`` of a free fragment (2.29).

    ``v* = t / (lam^2 (sin(lam l) + sinh(lam l))) * (N1 cos(p) cosh(p) + N2 sin(p) sinh(p))``
    with ``p = lam x``, ``P = lam l / 2``, ``N1 = cos P sinh P - sin P cosh P`` and
    ``N2 = cos P sinh P + sin P cosh P``; it solves ``v'''' + 4 lam^4 v = 0`` with
    ``v'' = t``, ``v''' = 0`` at ``x = +-l/2``.

    Derivatives rotate the basis ``(cos p cosh p, sin p sinh p, cos p sinh p, sin p cosh p)``
    into itself, so any order is exact. Hyperbolic factors are scaled by ``e^-|p|`` and
    ``e^-P`` so that ``lam l`` up to 1e4 does not overflow.

    Parameters
    ----------
    x : array_like
        Positions in ``[-length/2, length/2]`` (units of L).
    length, lam, t : float
        Fragment length, internal length scale, load.
    derivative : int, optional
        Order of the x-derivative to return (0 for ``v*`` itself).

    Returns
    -------
    ndarray
        ``d^k v*/dx^k`` at ``x``, same shape as ``x``.
    """
    x = np.asarray(x, dtype=float)
    P = 0.5 * lam * length
    sP, cP = math.sin(P), math.cos(P)
    ch_P = 0.5 * (1.0 + math.exp(-2.0 * P))  # cosh(P) e^-P
    sh_P = -0.5 * math.expm1(-2.0 * P)  # sinh(P) e^-P
    if P < 1.0:
        N1 = float(_odd_series_N1(np.array(P))) * math.exp(-P)
    else:
        N1 = cP * sh_P - sP * ch_P
    N2 = cP * sh_P + sP * ch_P
    D = math.sin(2.0 * P) * math.exp(-2.0 * P) - 0.5 * math.expm1(-4.0 * P)  # (sin+sinh)(2P) e^-2P
    # Coefficients on (cc, ss, cs, sc); each derivative maps c -> lam * R c.
    c = np.array([N1, N2, 0.0, 0.0])
    for _ in range(derivative):
        c1, c2, c3, c4 = c
        c = lam * np.array([c3 + c4, -c3 + c4, c1 + c2, -c1 + c2])
    p = lam * x
    ap = np.abs(p)
    ch = 0.5 * (1.0 + np.exp(-2.0 * ap))  # cosh(p) e^-|p|
    sh = -0.5 * np.sign(p) * np.expm1(-2.0 * ap)  # sinh(p) e^-|p|
    cos_p, sin_p = np.cos(p), np.sin(p)
    basis_sum = c[0] * cos_p * ch + c[1] * sin_p * sh + c[2] * cos_p * sh + c[3] * sin_p * ch
    return t / (lam * lam * D) * np.exp(ap - P) * basis_sum
