"""The manufactured solution of the elasticity convergence tests: a smooth displacement on the
unit square or cube, its derivatives and the body force that makes it an equilibrium.
"""

from __future__ import annotations

import numpy as np

# u_k(x) = prod_j sin(W[k, j] x_j + PH[k, j]) on the unit square or cube
W2 = np.pi * np.array([[1.0, 0.7], [0.6, 1.3]])
PH2 = np.array([[0.2, 0.5], [0.9, 0.1]])
W3 = np.pi * np.array([[0.9, 0.6, 0.5], [0.5, 1.1, 0.7], [0.8, 0.4, 1.0]])
PH3 = np.array([[0.2, 0.5, 0.3], [0.9, 0.1, 0.6], [0.4, 0.7, 0.2]])


def exact_fields(x, W, PH):
    """``u`` (n, d), ``grad u`` (n, d, d) (``[k, j] = du_k/dx_j``) and ``H`` (n, d, d, d)
    (``[k, i, j] = d^2 u_k / dx_i dx_j``) of the product-of-sines field at points ``x``."""
    d = x.shape[1]
    arg = x[:, None, :] * W[None] + PH[None]  # (n, k, j)
    s, c = np.sin(arg), np.cos(arg)
    u = s.prod(axis=2)
    grad = np.empty((x.shape[0], d, d))
    H = np.empty((x.shape[0], d, d, d))
    for j in range(d):
        others = np.prod(np.delete(s, j, axis=2), axis=2)
        grad[:, :, j] = W[:, j] * c[:, :, j] * others
        H[:, :, j, j] = -W[:, j] ** 2 * u
        for i in range(d):
            if i != j:
                rest = np.prod(np.delete(s, [i, j], axis=2), axis=2) if d == 3 else 1.0
                H[:, :, i, j] = W[:, i] * W[:, j] * c[:, :, i] * c[:, :, j] * rest
    return u, grad, H


def body_force(x, W, PH, lam, mu):
    """``f = -div sigma(u) = -(lam + mu) grad(div u) - mu lap u``."""
    _, _, H = exact_fields(x, W, PH)
    grad_div = np.einsum("nkik->ni", H)
    lap = np.einsum("nkii->nk", H)
    return -(lam + mu) * grad_div - mu * lap
