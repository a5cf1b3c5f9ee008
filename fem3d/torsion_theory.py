"""The classical double-torsion model: the two-torsion-bar compliance (4.1), the energy release
rate (4.2), Fuller's correction (4.3)-(4.4) and the load at which G reaches Gc.

Each of the specimen's two arms (width W/2, thickness T, on either side of the crack) is a bar
twisted over the crack length a by the torque of the load P/2 about the moment arm ``Wm``. A
bar of width b and thickness T has the torsion constant ``b T^3 / 3`` (thin strip), so the
load-point compliance is ``C(a) = 6 Wm^2 (1 + nu) a / (W T^3 E)`` (the printed (4.1) lacks the
factor a; with it, ``G = P^2 / (2 T) dC/da`` is (4.2);
docs/model.md#where-the-dissertation-is-wrong-or-ambiguous).

Fuller's correction, ``C_F = C / psi`` and ``G_F = G / psi``, with
``psi(tau) = 1 - 0.6302 tau + 1.2 tau exp(-pi / tau)``, accounts for the finite thickness of
the arms (0.6302 = 192 / pi^5 is the Saint-Venant term of a rectangle's torsion constant). The
dissertation prints ``tau = T/W``; each arm is W/2 wide, so the rectangle's thickness over width
is ``tau = 2T/W``, which also matches the printed validity condition ``2T/W <= 1``. Both
readings are here, ``"2T/W"`` the default
(docs/model.md#where-the-dissertation-is-wrong-or-ambiguous).

``load_offset`` (not in the dissertation): with the loading points at a distance ``l`` from the
mid-line instead of on it, the moment arm of each torsion bar is ``Wm - l``, and every formula
takes ``Wm - l`` for ``Wm``. The dissertation's formulas are ``load_offset = 0``.

Units: any consistent set (mm, N, MPa: compliance in mm/N, its slope in 1/N, G in N/mm).
"""

from __future__ import annotations

import math

__all__ = ["compliance_slope", "compliance", "release_rate", "psi", "critical_load", "READINGS"]

#: Fuller's argument tau for each reading of (4.4): ``"2T/W"`` (the default) or ``"T/W"`` (printed).
READINGS = ("2T/W", "T/W")


def _arm(support, load_offset):
    arm = float(support) - float(load_offset)
    if not arm > 0.0:
        raise ValueError(f"support = {support!r} must be > load_offset = {load_offset!r}")
    return arm


def psi(width, thickness, reading="2T/W"):
    """Fuller's correction factor (4.4), ``psi(tau) = 1 - 0.6302 tau + 1.2 tau exp(-pi / tau)``.

    Parameters
    ----------
    width, thickness : float
        W and T (same unit).
    reading : {"2T/W", "T/W"}
        The argument ``tau``: ``2T/W`` (each arm's thickness over its width W/2; default) or
        ``T/W`` (as printed).

    Returns
    -------
    float
        psi, below 1: the corrected specimen is more compliant.
    """
    if reading not in READINGS:
        raise ValueError(f"reading = {reading!r} must be one of {READINGS}")
    tau = (2.0 if reading == "2T/W" else 1.0) * float(thickness) / float(width)
    return 1.0 - 0.6302 * tau + 1.2 * tau * math.exp(-math.pi / tau)


def compliance_slope(E, nu, width, thickness, support, load_offset=0.0, fuller=None):
    """dC/da of the two-torsion-bar model, ``6 Wm^2 (1 + nu) / (W T^3 E)`` (4.1), divided by
    Fuller's psi if ``fuller`` names a reading (``"2T/W"`` or ``"T/W"``; None: classical).

    Returns
    -------
    float
        In 1/(E times length^2): 1/N with mm and MPa.
    """
    arm = _arm(support, load_offset)
    slope = 6.0 * arm**2 * (1.0 + nu) / (width * thickness**3 * E)
    return slope if fuller is None else slope / psi(width, thickness, fuller)


def compliance(a, E, nu, width, thickness, support, load_offset=0.0, fuller=None):
    """The load-point compliance ``C(a) = a dC/da`` (4.1), a the crack length measured from the
    load line (length / force)."""
    return a * compliance_slope(E, nu, width, thickness, support, load_offset, fuller)


def release_rate(P, E, nu, width, thickness, support, load_offset=0.0, fuller=None):
    """The energy release rate (4.2), ``G = P^2 / (2 T) dC/da = 3 P^2 Wm^2 (1 + nu) / (W T^4 E)``,
    independent of the crack length (divided by psi with ``fuller``)."""
    return P**2 / (2.0 * thickness) * compliance_slope(E, nu, width, thickness, support, load_offset, fuller)


def critical_load(Gc, E, nu, width, thickness, support, load_offset=0.0, fuller=None):
    """The load at which (4.2) reaches ``Gc``: ``P = sqrt(2 T Gc / (dC/da))``
    (``sqrt(Gc W T^4 E / (3 Wm^2 (1 + nu)))`` classically; times ``sqrt(psi)`` with ``fuller``)."""
    return math.sqrt(2.0 * thickness * Gc / compliance_slope(E, nu, width, thickness, support, load_offset, fuller))
