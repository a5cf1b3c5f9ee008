"""A plate-like test system for the linear solvers: an independent assembly of the plate +
Winkler stiffness on a square grid, and a realistic crack field.

The matrix is assembled here with scipy from first and second differences, apart from the
model's operator (:mod:`thinfilm.plate.operators`, Numba kernels writing into a fixed
pattern). Away from the edges the two agree row for row (``tests/solvers/test_linear.py``
checks it); at the edges this one weights every node equally where the model uses the
trapezoidal weights. The solver tests and ``benchmarks/bench_usolve.py`` use it.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

__all__ = ["plate_test_matrix", "grid_coords", "crack_bands"]


def _second_difference(m, h):
    """Shape (m - 2, m): second differences at the interior nodes of an m-node line, 1/h^2."""
    k = m - 2
    return sp.diags([np.ones(k), -2.0 * np.ones(k), np.ones(k)], [0, 1, 2], shape=(k, m),
                    format="csr") / h**2


def _first_difference(m, h):
    """Shape (m - 1, m): forward differences on the cells of an m-node line, 1/h."""
    k = m - 1
    return sp.diags([-np.ones(k), np.ones(k)], [0, 1], shape=(k, m), format="csr") / h


def plate_test_matrix(alpha, *, nu=0.3, winkler=4e6, k_res=1e-6, length=1.0):
    """Plate + Winkler stiffness on a square grid with free edges (a test system).

    Energy ``1/2 Int g(alpha) W(D^2 u) + winkler/2 Int u^2`` with
    ``W = u_xx^2 + u_yy^2 + 2 nu u_xx u_yy + 2 (1 - nu) u_xy^2``, ``g = (1 - alpha)^2 + k_res``,
    discretized by second differences where they exist (free edges), the mixed derivative
    on cells, and the edge-row density ``(1 - nu^2) u_tt^2`` where the normal second difference
    is missing (docs/model.md#free-and-clamped-edges). A 13-point stencil; SPD for ``winkler > 0``; without the
    foundation its null space is exactly {1, x, y}.

    Parameters
    ----------
    alpha : ndarray, shape (m, m) or (m*m,)
        Damage at the nodes of an m x m grid, row-major (index ``iy * m + ix``), in [0, 1].
    nu : float
        Poisson ratio.
    winkler : float
        Foundation stiffness ``K/a^4`` (``= 4 lam^4``), in units of the plate rigidity / L^4.
    k_res : float
        Residual stiffness in the degradation.
    length : float
        Side of the square domain.

    Returns
    -------
    K : scipy.sparse.csr_matrix, shape (m*m, m*m)
        Scaled by the cell area ``h^2`` (energy = ``1/2 u.K u``), sorted indices.
    """
    alpha = np.asarray(alpha, dtype=np.float64)
    m = int(round(math.sqrt(alpha.size)))
    if m * m != alpha.size or m < 4:
        raise ValueError(f"alpha must describe an m x m grid with m >= 4, got {alpha.size} nodes")
    h = length / (m - 1)
    g = ((1.0 - alpha) ** 2 + k_res).reshape(m, m)
    eye = sp.identity(m, format="csr")
    interior = eye[1:-1]
    d2, d1 = _second_difference(m, h), _first_difference(m, h)
    dxx = sp.kron(eye, d2, format="csr")      # rows: all iy, interior ix
    dyy = sp.kron(d2, eye, format="csr")      # rows: interior iy, all ix
    dxx_i = sp.kron(interior, d2, format="csr")
    dyy_i = sp.kron(d2, interior, format="csr")
    dxy = sp.kron(d1, d1, format="csr")       # rows: cells
    wxx = g[:, 1:-1].copy()
    wxx[[0, -1], :] *= 1.0 - nu**2           # y-edges: u_yy missing, M_nn = 0 eliminated
    wyy = g[1:-1, :].copy()
    wyy[:, [0, -1]] *= 1.0 - nu**2           # x-edges
    g_cell = 0.25 * (g[:-1, :-1] + g[1:, :-1] + g[:-1, 1:] + g[1:, 1:])
    cross = dxx_i.T @ sp.diags(nu * g[1:-1, 1:-1].ravel()) @ dyy_i
    K = (dxx.T @ sp.diags(wxx.ravel()) @ dxx
         + dyy.T @ sp.diags(wyy.ravel()) @ dyy
         + cross + cross.T
         + dxy.T @ sp.diags(2.0 * (1.0 - nu) * g_cell.ravel()) @ dxy
         + sp.diags(np.full(m * m, float(winkler))))
    K = (K * h**2).tocsr()
    K.sort_indices()
    return K


def grid_coords(m, length=1.0):
    """Node coordinates of the m x m test grid on ``(-length/2, length/2)^2``.

    Returns
    -------
    coords : ndarray, shape (m*m, 2)
        Columns x, y; row-major node order (``iy * m + ix``).
    """
    x = np.linspace(-0.5 * length, 0.5 * length, m)
    X, Y = np.meshgrid(x, x)
    return np.column_stack([X.ravel(), Y.ravel()])


def crack_bands(m, *, grow=0, eta_cells=4.0):
    """A realistic damage field on the m x m test grid of ``(-1/2, 1/2)^2``.

    A through crack at x = 0.1 (cuts the plate in two), a crack from the left edge ending on
    it (y = -0.2), a ring (centre (-0.15, 0.2), radius 0.15) and a partial diagonal crack from
    (0.15, 0.1) whose tip advances by ``grow`` cells. alpha = 1 on a core at least one node
    wide, with the AT1 profile ``(1 - d / 2 eta)^2`` around it, eta = ``eta_cells`` cells.

    Returns
    -------
    alpha : ndarray, shape (m*m,)
    """
    h = 1.0 / (m - 1)
    x = np.linspace(-0.5, 0.5, m)
    X, Y = np.meshgrid(x, x)
    eta = eta_cells * h
    d = np.abs(X - 0.1)
    d = np.minimum(d, np.where(X < 0.1, np.abs(Y + 0.2), np.inf))
    d = np.minimum(d, np.abs(np.hypot(X + 0.15, Y - 0.2) - 0.15))
    s_tip = 0.25 + grow * h
    e = 1.0 / math.sqrt(2.0)
    px, py = X - 0.15, Y - 0.1
    s = np.clip((px + py) * e, 0.0, s_tip)
    d = np.minimum(d, np.hypot(px - s * e, py - s * e))
    d = np.maximum(d - 0.75 * h, 0.0)  # the alpha = 1 core
    return (np.clip(1.0 - d / (2.0 * eta), 0.0, 1.0) ** 2).ravel()
