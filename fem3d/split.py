r"""Unilateral contact: which part of the strain energy the damage degrades (dissertation (4.10)-(4.12)).

The undamaged strain-energy density splits into a volumetric and a deviatoric part,

    psi0(e) = lam/2 tr(e)^2 + mu e:e = kappa/2 tr(e)^2 + mu e_D:e_D,

    kappa = lam + 2 mu / d,     e_D = e - tr(e)/d I,     e_D:e_D = e:e - tr(e)^2 / d,

``d`` the dimension (2D: in-plane trace and deviator, with the plane-stress ``lam*`` where the
model is plane stress, so ``kappa = lam* + mu``). A split writes the density as
``psi = g psi_plus + psi_minus``: the degradation ``g`` acts on ``psi_plus`` only, which alone
drives the damage (docs/model.md#unilateral-contact-splits):

=============  ======  ============================================  =======================
``split``      eq.     ``psi_plus``                                   ``psi_minus``
=============  ======  ============================================  =======================
``"none"``     (4.10)  ``psi0``                                       0
``"amor"``     (4.11)  ``kappa/2 tr+(e)^2 + mu e_D:e_D``              ``kappa/2 tr-(e)^2``
``"positive"`` (4.12)  ``H(tr e) psi0``                               ``(1 - H(tr e)) psi0``
=============  ======  ============================================  =======================

with ``tr+ = max(tr, 0)``, ``tr- = max(-tr, 0)``, ``H(x) = 1`` for ``x > 0`` else 0.
(4.11) (Amor, Marigo and Maurini) keeps a compressed material from softening in volume but
lets its shear drive the damage; (4.12) degrades nothing under compression.

The frozen switch
=================
On each point (a P1 cell; a quadrature point of a higher-order element) the sign of
``tr e`` decides the density. With the switch frozen at a given ``H`` (a boolean per point,
*tension*) every density is a quadratic form of ``e`` with effective Lame parameters: a cell's
stiffness ``(lam_H, mu_H)`` such that ``lam_H/2 tr^2 + mu_H e:e`` is its density at the
damage's degradation ``gbar``:

* ``"none"``: ``(gbar lam, gbar mu)``;
* ``"positive"``: ``f (lam, mu)`` with ``f = H gbar + 1 - H``;
* ``"amor"``: volumetric factor ``c = H gbar + 1 - H``, deviatoric factor ``gbar``:
  ``mu_H = gbar mu``, ``lam_H = c kappa - 2 gbar mu / d``.

With ``H`` the point's own tension, ``(lam_H, mu_H)`` give the true density and the true
stress, which is why the u-problem is solved by freezing the switch, solving the linear
problem, and updating the switch (:meth:`fem3d.model.FemModel.solve_u`). For (4.11) this is
the semi-smooth Newton method of a convex, piecewise-quadratic energy with a continuous
gradient: the quadratic of the frozen switch is the energy's second-order model at the
iterate, and a converged switch is the exact minimizer. (4.12) is discontinuous across
``tr e = 0`` wherever the damage is positive: the iteration is then a fixed point that may
not settle, and the solve keeps the iterate of least energy.
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPLITS", "bulk_modulus", "trace", "energy_parts", "tension", "effective_lame"]

#: The densities a scene may choose (``[model] split``).
SPLITS = ("none", "amor", "positive")


def bulk_modulus(lam: float, mu: float, d: int) -> float:
    """``kappa = lam + 2 mu / d``: the coefficient of ``tr(e)^2 / 2`` in the density."""
    return lam + 2.0 * mu / d


def trace(strain, d: int) -> np.ndarray:
    """``tr e`` of strains in Voigt order (the first ``d`` entries the normal strains),
    shape ``strain.shape[:-1]``."""
    return np.asarray(strain)[..., :d].sum(axis=-1)


def _squared_norm(strain, d):
    """``e:e`` of strains in Voigt order with tensor shear components."""
    e = np.asarray(strain)
    return (e[..., :d] ** 2).sum(axis=-1) + 2.0 * (e[..., d:] ** 2).sum(axis=-1)


def energy_parts(strain, lam: float, mu: float, d: int, split: str) -> tuple[np.ndarray, np.ndarray]:
    """``(psi_plus, psi_minus)``: the degraded and the intact part of the density.

    Parameters
    ----------
    strain : ndarray, shape (..., 3) in 2D or (..., 6) in 3D
        Voigt order with tensor shear components (:meth:`fem3d.elasticity.Elasticity.strain`).
    lam, mu : float
        Lame parameters of the density (2D plane stress: ``lam*``).
    d : {2, 3}
    split : {"none", "amor", "positive"}

    Returns
    -------
    psi_plus, psi_minus : ndarray, shape ``strain.shape[:-1]``
        Energy per volume, units of ``lam``; ``psi_plus + psi_minus = psi0``.
    """
    tr = trace(strain, d)
    ee = _squared_norm(strain, d)
    psi0 = 0.5 * lam * tr ** 2 + mu * ee
    if split == "none":
        return psi0, np.zeros_like(psi0)
    if split == "positive":
        on = tr > 0.0
        return np.where(on, psi0, 0.0), np.where(on, 0.0, psi0)
    if split == "amor":
        kappa = bulk_modulus(lam, mu, d)
        deviatoric = mu * np.maximum(ee - tr ** 2 / d, 0.0)   # >= 0; round-off may dip below
        return 0.5 * kappa * np.maximum(tr, 0.0) ** 2 + deviatoric, 0.5 * kappa * np.minimum(tr, 0.0) ** 2
    raise ValueError(f"split = {split!r} must be one of {', '.join(SPLITS)}")


def tension(strain, d: int) -> np.ndarray:
    """The switch ``H(tr e)``: True where ``tr e > 0``, shape ``strain.shape[:-1]``."""
    return trace(strain, d) > 0.0


def effective_lame(degradation, in_tension, lam: float, mu: float, d: int, split: str):
    """The Lame parameters of each point's density with its switch frozen (module docstring).

    Parameters
    ----------
    degradation : ndarray
        ``gbar``, the degradation at each point (times a buffer's modulus ratio, which
        multiplies both parts alike: pass ``gbar`` and scale the result).
    in_tension : ndarray of bool, same shape, or None
        The frozen switch ``H``; None: tension everywhere (no point compressed).
    lam, mu : float
    d : {2, 3}
    split : {"none", "amor", "positive"}

    Returns
    -------
    lam_H, mu_H : ndarray, the shape of ``degradation``
    """
    g = np.asarray(degradation, dtype=np.float64)
    if split == "none" or in_tension is None:
        # in tension every split degrades the whole density
        if split not in SPLITS:
            raise ValueError(f"split = {split!r} must be one of {', '.join(SPLITS)}")
        return g * lam, g * mu
    H = np.asarray(in_tension, dtype=bool)
    if H.shape != g.shape:
        raise ValueError(f"in_tension has shape {H.shape}, the degradation {g.shape}")
    volumetric = np.where(H, g, 1.0)
    if split == "positive":
        return volumetric * lam, volumetric * mu
    if split == "amor":
        return volumetric * bulk_modulus(lam, mu, d) - 2.0 * g * mu / d, g * mu
    raise ValueError(f"split = {split!r} must be one of {', '.join(SPLITS)}")
