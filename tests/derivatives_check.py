"""Finite-difference checks of a model's :class:`thinfilm.engine.protocol.EnergyDerivatives`,
shared by the derivative tests of the bar, the finite elements and the plate."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from thinfilm.engine.protocol import EnergyDerivatives

#: The steps of the order fits (directions of unit RMS entries).
STEPS = (1e-2, 5e-3, 2.5e-3)


def observed_order(steps, errors) -> float:
    """The slope of ``log(error)`` against ``log(h)``, a least-squares fit."""
    return float(np.polyfit(np.log(steps), np.log(errors), 1)[0])


def check_energy_derivatives(model, u, alpha, t, seed=0, steps=STEPS, smallest=1e-4, exact=1e-8,
                             quadratic_alpha=True):
    """Assert the gradient and the Hessian blocks of ``model`` at ``(u, alpha, t)``.

    * ``u_from_free(free_u(u), t) == u`` and the blocks' shapes;
    * the gradient against central differences of ``E = P + S`` along random directions
      ``(du, dalpha)``: the error falls like ``h^2`` (fitted order 2 +- 0.3 over ``steps``)
      and is below ``smallest`` (relative to ``|g| |d|``) at the smallest step;
    * ``H d`` against central differences of the gradient, ``(g(x + h d) - g(x - h d)) / 2h``:
      the same order and bound, relative to ``|H d|``;
    * along ``(0, dalpha)`` and ``(du, 0)`` the gradient is quadratic (``g(alpha)`` is, and E
      is quadratic in ``u``), so the central difference is exact: ``(K_ua dalpha,
      K_aa dalpha)`` and ``(K_uu du, K_ua^T du)`` to ``exact`` (relative), each block alone;
      with ``quadratic_alpha=False`` (the cohesive law's rational ``g``) only along ``(du, 0)``.

    Parameters
    ----------
    model : EnergyDerivatives and FractureModel
    u : ndarray
        The full displacement, its constrained dofs at their values at ``t``.
    alpha : ndarray, shape (n_alpha,)
    t : float
    """
    assert isinstance(model, EnergyDerivatives)
    rng = np.random.default_rng(seed)
    x = model.free_u(u)
    np.testing.assert_allclose(model.u_from_free(x, t), u, rtol=0, atol=0)
    n_u, n_a = x.size, alpha.size
    g_u, g_a = model.energy_gradient(u, alpha, t)
    K_uu, K_ua, K_aa = model.hessian_blocks(u, alpha, t)
    assert g_u.shape == (n_u,) and g_a.shape == (n_a,)
    assert K_uu.shape == (n_u, n_u) and K_ua.shape == (n_u, n_a) and K_aa.shape == (n_a, n_a)
    assert all(sp.issparse(K) for K in (K_uu, K_ua, K_aa))

    def energy(xu, a):
        return sum(model.energies(model.u_from_free(xu, t), a, t))

    def gradient(xu, a):
        return np.concatenate(model.energy_gradient(model.u_from_free(xu, t), a, t))

    def hessian(du, da):
        return np.concatenate([K_uu @ du + K_ua @ da, K_ua.T @ du + K_aa @ da])

    g = np.concatenate([g_u, g_a])
    for _ in range(2):
        du, da = rng.standard_normal(n_u), rng.standard_normal(n_a)
        d = np.concatenate([du, da])
        first, second = [], []
        Hd = hessian(du, da)
        for h in steps:
            fd = (energy(x + h * du, alpha + h * da) - energy(x - h * du, alpha - h * da)) / (2 * h)
            first.append(abs(fd - g @ d) / (np.linalg.norm(g) * np.linalg.norm(d)))
            fd = (gradient(x + h * du, alpha + h * da) - gradient(x - h * du, alpha - h * da)) / (2 * h)
            second.append(np.linalg.norm(fd - Hd) / np.linalg.norm(Hd))
        for errors in (first, second):
            assert abs(observed_order(steps, errors) - 2.0) < 0.3, (errors, observed_order(steps, errors))
            assert errors[-1] < smallest, errors
        h = steps[0]
        zero_u, zero_a = np.zeros(n_u), np.zeros(n_a)
        for du_, da_ in ((zero_u, da), (du, zero_a)) if quadratic_alpha else ((du, zero_a),):
            fd = (gradient(x + h * du_, alpha + h * da_) - gradient(x - h * du_, alpha - h * da_)) / (2 * h)
            expected = hessian(du_, da_)
            for part, ref in ((fd[:n_u], expected[:n_u]), (fd[n_u:], expected[n_u:])):
                assert np.linalg.norm(part - ref) <= exact * np.linalg.norm(ref), (np.linalg.norm(part - ref),
                                                                                  np.linalg.norm(ref))


def interior_damage(rng, n, low=0.1, high=0.8):
    """Random damage away from the bounds, shape (n,)."""
    return rng.uniform(low, high, n)
