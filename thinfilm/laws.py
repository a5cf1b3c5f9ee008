r"""Damage laws: the geometric function ``w`` and the degradation function ``g`` of a
phase-field model of fracture.

Every model of the toolkit has the energy (``docs/model.md``)::

    E(u, alpha) = Int g(alpha) psi(e(u)) + Gc / c_w Int ( w(alpha) / eta + eta |grad alpha|^2 )

with ``0 <= alpha <= 1``, ``w(0) = 0``, ``w(1) = 1``, ``g(0) = 1``, ``g(1) = 0`` and
``c_w = 4 Int_0^1 sqrt(w(s)) ds``, so that a fully formed straight crack costs ``Gc`` per unit
area (``thinfilm.damage.c_m`` is ``c_w / 4``). A law gives ``w``, ``g`` and their first two
derivatives, vectorized over nodal values:

- **AT1** (``w = alpha``, ``g = (1 - alpha)^2``, ``c_w = 8/3``) and **AT2** (``w = alpha^2``):
  the Ambrosio-Tortorelli laws of the dissertation. Their damage energy at fixed ``u`` is
  quadratic, and the engine solves its damage step as one box-constrained QP.
- **PF-CZM**, the phase-field cohesive zone model of J.-Y. Wu (J. Mech. Phys. Solids 103,
  2017; with V. P. Nguyen, J. Mech. Phys. Solids 119, 2018): ``w = 2 alpha - alpha^2``
  (``c_w = pi``) and the rational degradation::

      g(a) = (1 - a)^p / ((1 - a)^p + Q(a)),   Q(a) = a1 a (1 + a2 a + a2 a3 a^2),
      a1 = 4 E Gc / (pi eta ft^2)

  with ``(p, a2, a3)`` per softening law. ``a1`` puts the onset of damage of a bar in
  uniaxial tension at the stress ``ft`` (``-g'(0) psi = Gc w'(0) / (c_w eta)`` at
  ``psi = ft^2 / (2 E)``), whatever ``eta``: the strength and the softening curve are the
  material's, ``eta`` only a width. (docs/model.md#the-cohesive-law.)
"""

from __future__ import annotations

import math

import numpy as np

from thinfilm.options import real_in_range

__all__ = ["DamageLaw", "AT1", "AT2", "CohesiveLaw", "SOFTENING", "LAWS", "law_from_name", "opening",
           "softening_curve"]

#: ``(p, a2, a3)`` of Wu's degradation for each softening curve: linear (exact: the bar's
#: traction-separation curve is then linear), exponential and Cornelissen et al.'s concrete
#: curve (both fitted).
SOFTENING = {
    "linear": (2.0, -0.5, 0.0),
    "exponential": (2.5, 2.0 ** (5.0 / 3.0) - 3.0, 0.0),
    "cornelissen": (2.0, 1.3868, 0.6567),
}

#: The names a scene's ``[model] law`` takes.
LAWS = ("at1", "at2", "czm")


class DamageLaw:
    """A damage law: ``w``, ``g`` and their derivatives on arrays of damage values.

    Attributes
    ----------
    name : str
        ``"at1"``, ``"at2"`` or ``"czm"``.
    c_w : float
        ``4 Int_0^1 sqrt(w)``: the surface energy is ``Gc / c_w Int (w / eta + eta |grad alpha|^2)``.
    quadratic : bool
        ``g`` and ``w`` are polynomials of degree at most 2, so the damage energy at fixed
        ``u`` is quadratic (one box QP per damage step).
    """

    name: str
    c_w: float
    quadratic: bool

    def w(self, a):
        """``w(a)``, shape of ``a``."""
        raise NotImplementedError

    def dw(self, a):
        """``w'(a)``."""
        raise NotImplementedError

    def d2w(self, a):
        """``w''(a)``."""
        raise NotImplementedError

    def g(self, a):
        """``g(a)`` (without the residual stiffness ``k_res``, which the elasticity adds)."""
        raise NotImplementedError

    def dg(self, a):
        """``g'(a)``."""
        raise NotImplementedError

    def d2g(self, a):
        """``g''(a)``."""
        raise NotImplementedError

    def __repr__(self):
        return f"{type(self).__name__}()"


class _AT(DamageLaw):
    quadratic = True

    def g(self, a):
        a = np.asarray(a, dtype=float)
        return (1.0 - a) ** 2

    def dg(self, a):
        return -2.0 * (1.0 - np.asarray(a, dtype=float))

    def d2g(self, a):
        return np.full(np.shape(a), 2.0)


class AT1(_AT):
    """AT1: ``w = a``, ``g = (1 - a)^2``, ``c_w = 8/3``."""

    name, c_w = "at1", 8.0 / 3.0

    def w(self, a):
        return np.asarray(a, dtype=float).copy()

    def dw(self, a):
        return np.ones(np.shape(a))

    def d2w(self, a):
        return np.zeros(np.shape(a))


class AT2(_AT):
    """AT2: ``w = a^2``, ``g = (1 - a)^2``, ``c_w = 2``."""

    name, c_w = "at2", 2.0

    def w(self, a):
        return np.asarray(a, dtype=float) ** 2

    def dw(self, a):
        return 2.0 * np.asarray(a, dtype=float)

    def d2w(self, a):
        return np.full(np.shape(a), 2.0)


class CohesiveLaw(DamageLaw):
    """Wu's phase-field cohesive zone model (module docstring).

    Parameters
    ----------
    E : float
        Young's modulus of the material that cracks, > 0 (stress).
    Gc : float
        Fracture energy, > 0 (energy per area).
    ft : float
        Tensile strength, > 0 (stress).
    eta : float
        Regularization length, > 0.
    softening : {"linear", "exponential", "cornelissen"}

    Attributes
    ----------
    p, a1, a2, a3 : float
        The degradation's constants.
    """

    name, c_w, quadratic = "czm", math.pi, False

    def __init__(self, E, Gc, ft, eta, softening="linear"):
        if softening not in SOFTENING:
            raise ValueError(f"softening = {softening!r} must be one of {', '.join(SOFTENING)}")
        self.E = real_in_range("E", E, 0.0, math.inf, True, True)
        self.Gc = real_in_range("Gc", Gc, 0.0, math.inf, True, True)
        self.ft = real_in_range("ft", ft, 0.0, math.inf, True, True)
        self.eta = real_in_range("eta", eta, 0.0, math.inf, True, True)
        self.softening = softening
        self.p, self.a2, self.a3 = SOFTENING[softening]
        self.a1 = 4.0 * self.E * self.Gc / (math.pi * self.eta * self.ft ** 2)

    def __repr__(self):
        return (f"CohesiveLaw(E={self.E!r}, Gc={self.Gc!r}, ft={self.ft!r}, eta={self.eta!r},"
                f" softening={self.softening!r})")

    def w(self, a):
        a = np.asarray(a, dtype=float)
        return a * (2.0 - a)

    def dw(self, a):
        return 2.0 - 2.0 * np.asarray(a, dtype=float)

    def d2w(self, a):
        return np.full(np.shape(a), -2.0)

    def _parts(self, a):
        """``N = (1 - a)^p``, ``Q`` and their first two derivatives."""
        a = np.asarray(a, dtype=float)
        p, a1, a2, a3 = self.p, self.a1, self.a2, self.a3
        s = np.maximum(1.0 - a, 0.0)
        N = s ** p
        dN = -p * s ** (p - 1.0)
        d2N = p * (p - 1.0) * s ** (p - 2.0)          # p >= 2 for every softening law
        Q = a1 * a * (1.0 + a2 * a + a2 * a3 * a * a)
        dQ = a1 * (1.0 + 2.0 * a2 * a + 3.0 * a2 * a3 * a * a)
        d2Q = a1 * (2.0 * a2 + 6.0 * a2 * a3 * a)
        return N, dN, d2N, Q, dQ, d2Q

    def g(self, a):
        N, _, _, Q, _, _ = self._parts(a)
        return N / (N + Q)

    def dg(self, a):
        # g = N / D, D = N + Q: g' = (N' Q - N Q') / D^2
        N, dN, _, Q, dQ, _ = self._parts(a)
        return (dN * Q - N * dQ) / (N + Q) ** 2

    def d2g(self, a):
        # (N' Q - N Q')' = N'' Q - N Q''; g'' = (N'' Q - N Q'') / D^2 - 2 (N' Q - N Q') D' / D^3
        N, dN, d2N, Q, dQ, d2Q = self._parts(a)
        D = N + Q
        return (d2N * Q - N * d2Q) / D ** 2 - 2.0 * (dN * Q - N * dQ) * (dN + dQ) / D ** 3


def opening(law, sigma):
    """The crack opening of the cohesive law's 1D band at the stress ``sigma``: its exact
    traction-separation curve ``w(sigma)``.

    A bar in uniaxial stress ``sigma`` localizes in a band whose damage, with ``psi =
    sigma^2 / (2 E g^2)``, has the first integral ``Gc / c_w (w(a) / eta - eta a'^2) =
    sigma^2 / (2 E) (1 / g(a) - 1)``; the band's peak damage ``a_c`` has ``a' = 0`` and the
    opening is the band's strain beyond the elastic one,
    ``w = 2 Int_0^a_c sigma / E (1 / g - 1) / a' da`` (the 1D analysis of Wu 2017). Quadrature (scipy).

    Parameters
    ----------
    law : CohesiveLaw
    sigma : float
        Stress, in (0, ft).

    Returns
    -------
    float
        Opening (length).
    """
    from scipy.integrate import quad
    from scipy.optimize import brentq

    E, Gc, eta, c_w = law.E, law.Gc, law.eta, law.c_w

    def excess(a):     # >= 0 inside the band: a'^2 eta^2
        return float(law.w(a)) - c_w * eta * sigma ** 2 / (2.0 * E * Gc) * (1.0 / float(law.g(a)) - 1.0)

    peak = brentq(excess, 1e-12, 1.0 - 1e-12, xtol=1e-15)

    def integrand(a):
        return sigma / E * (1.0 / float(law.g(a)) - 1.0) * eta / np.sqrt(max(excess(a), 1e-300))

    return 2.0 * quad(integrand, 0.0, peak, limit=400)[0]


def softening_curve(name, ft, Gc, w):
    """The named softening law's traction at the opening ``w`` (what the cohesive law's
    ``(p, a2, a3)`` reproduce: exactly for ``"linear"``, fitted for the others):
    linear ``ft (1 - w / w_c)``, ``w_c = 2 Gc / ft``; exponential ``ft exp(-ft w / Gc)``;
    Cornelissen et al. (1986) ``ft [(1 + (c1 x)^3) exp(-c2 x) - x (1 + c1^3) exp(-c2)]``,
    ``x = w / w_c``, ``c1 = 3``, ``c2 = 6.93``, ``w_c = 5.1361 Gc / ft``; 0 beyond ``w_c``."""
    w = np.asarray(w, dtype=float)
    if name == "linear":
        return ft * np.maximum(1.0 - w / (2.0 * Gc / ft), 0.0)
    if name == "exponential":
        return ft * np.exp(-ft * w / Gc)
    if name == "cornelissen":
        c1, c2, x = 3.0, 6.93, w / (5.1361 * Gc / ft)
        return ft * np.where(x < 1.0, (1.0 + (c1 * x) ** 3) * np.exp(-c2 * x) - x * (1.0 + c1 ** 3) * np.exp(-c2),
                             0.0)
    raise ValueError(f"softening = {name!r} must be one of {', '.join(SOFTENING)}")


def law_from_name(name, *, E=None, Gc=None, ft=None, eta=None, softening="linear"):
    """The law named ``name`` (:data:`LAWS`); ``"czm"`` needs ``E``, ``Gc``, ``ft``, ``eta``."""
    if name == "at1":
        return AT1()
    if name == "at2":
        return AT2()
    if name == "czm":
        return CohesiveLaw(E, Gc, ft, eta, softening)
    raise ValueError(f"law = {name!r} must be one of {', '.join(LAWS)}")
