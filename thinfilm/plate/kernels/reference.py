"""Plain NumPy references of the kernels in :mod:`thinfilm.plate.kernels.stencil`, for tests.

Written independently of the kernels, in operator form: the discrete energy of
:mod:`thinfilm.plate.operators` is assembled from 1D difference matrices combined by Kronecker
products (``scipy.sparse`` only as a container for matrix products), and the Hessian is
``sum D^T diag(coefficients) D``. Slow and memory-hungry: small grids only.

The same function signatures as the kernels are not kept; each reference takes the grid
sizes, spacings and parameters explicitly and returns what the kernel computes.
``closure="naive"`` gives the first-order free-edge closure that drops the missing second
differences (density ``u_tt^2`` on a free edge instead of ``(1 - nu^2) u_tt^2``), kept only
to measure why it is not used.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

EDGE_FLAGS = ("x0", "x1", "y0", "y1")


def _trapezoid(n: int, h: float) -> np.ndarray:
    if n == 0:
        return np.ones(1)
    w = np.full(n + 1, h)
    w[[0, -1]] = 0.5 * h
    return w


def _second_difference_1d(n: int, h: float, clamped_lo: bool, clamped_hi: bool) -> sp.csr_matrix:
    """(n+1) x (n+1) second difference; free ends have zero rows, clamped ends a mirrored ghost."""
    d = np.zeros((n + 1, n + 1))
    for i in range(1, n):
        d[i, i - 1 : i + 2] = (1.0, -2.0, 1.0)
    if clamped_lo:
        d[0, 0:2] = (-2.0, 2.0)
    if clamped_hi:
        d[n, n - 1 : n + 1] = (2.0, -2.0)
    return sp.csr_matrix(d / h**2)


def _forward_difference_1d(n: int, h: float) -> sp.csr_matrix:
    """n x (n+1) forward difference (u_{i+1} - u_i) / h."""
    d = np.zeros((n, n + 1))
    for i in range(n):
        d[i, i : i + 2] = (-1.0, 1.0)
    return sp.csr_matrix(d / h)


def _average_1d(n: int) -> sp.csr_matrix:
    d = np.zeros((n, n + 1))
    for i in range(n):
        d[i, i : i + 2] = 0.5
    return sp.csr_matrix(d)


def clamped_mask(nx: int, ny: int, clamped) -> np.ndarray:
    """Boolean nodal mask of the clamped nodes (flat)."""
    m = np.zeros((ny + 1, nx + 1), dtype=bool)
    c = dict(zip(EDGE_FLAGS, (bool(f) for f in clamped)))
    m[:, 0] |= c["x0"]
    m[:, -1] |= c["x1"]
    if ny > 0:
        m[0, :] |= c["y0"]
        m[-1, :] |= c["y1"]
    return m.ravel()


def operators(nx, ny, hx, hy, nu, clamped, closure="natural"):
    """Difference operators and nodal quadratic-form coefficients of the bending energy.

    Returns
    -------
    dict with ``Dxx``, ``Dyy`` (nodes x nodes), ``Dxy`` (cells x nodes), ``avg`` (cells x
    nodes, mean of the four corners), ``qa, qb, qab`` (nodal coefficients of
    ``qa a^2 + qb b^2 + 2 qab a b``), ``w`` (node weights), ``cell_area``.
    """
    c = dict(zip(EDGE_FLAGS, (bool(f) for f in clamped)))
    one_d = ny == 0
    Ix = sp.identity(nx + 1, format="csr")
    Iy = sp.identity(ny + 1, format="csr")
    D2x = _second_difference_1d(nx, hx, c["x0"], c["x1"])
    Dxx = sp.kron(Iy, D2x, format="csr")
    has_x = np.ones(nx + 1, dtype=bool)
    has_x[0] = c["x0"]
    has_x[-1] = c["x1"]
    if one_d:
        Dyy = sp.csr_matrix((nx + 1, nx + 1))
        Dxy = sp.csr_matrix((0, nx + 1))
        avg = sp.csr_matrix((0, nx + 1))
        qa = has_x.astype(float)
        qb = np.zeros(nx + 1)
        qab = np.zeros(nx + 1)
        cell_area = hx
    else:
        D2y = _second_difference_1d(ny, hy, c["y0"], c["y1"])
        Dyy = sp.kron(D2y, Ix, format="csr")
        Dxy = sp.kron(_forward_difference_1d(ny, hy), _forward_difference_1d(nx, hx), format="csr")
        avg = sp.kron(_average_1d(ny), _average_1d(nx), format="csr")
        has_y = np.ones(ny + 1, dtype=bool)
        has_y[0] = c["y0"]
        has_y[-1] = c["y1"]
        HX = np.broadcast_to(has_x[None, :], (ny + 1, nx + 1))
        HY = np.broadcast_to(has_y[:, None], (ny + 1, nx + 1))
        both = HX & HY
        only_x = HX & ~HY
        only_y = ~HX & HY
        edge_factor = (1.0 - nu * nu) if closure == "natural" else 1.0
        if closure not in ("natural", "naive"):
            raise ValueError(f"closure = {closure!r} must be 'natural' or 'naive'")
        qa = (both * 1.0 + only_x * edge_factor).ravel()
        qb = (both * 1.0 + only_y * edge_factor).ravel()
        qab = (both * nu).ravel()
        cell_area = hx * hy
    w = np.outer(_trapezoid(ny, hy), _trapezoid(nx, hx)).ravel()
    return dict(Dxx=Dxx, Dyy=Dyy, Dxy=Dxy, avg=avg, qa=qa, qb=qb, qab=qab, w=w, cell_area=cell_area)


def plate_pattern(nx, ny, clamped):
    """Sets of columns of each row: the 13-point (1D: 5-point) stencil cut to the grid,
    clamped rows and columns reduced to the diagonal. Returns a list of sorted lists."""
    cm = clamped_mask(nx, ny, clamped)
    rows = []
    for j in range(ny + 1):
        for i in range(nx + 1):
            p = j * (nx + 1) + i
            cols = []
            for jq in range(max(j - 2, 0), min(j + 2, ny) + 1):
                for iq in range(max(i - 2, 0), min(i + 2, nx) + 1):
                    q = jq * (nx + 1) + iq
                    if abs(iq - i) + abs(jq - j) > 2:
                        continue
                    if q != p and (cm[p] or cm[q]):
                        continue
                    cols.append(q)
            rows.append(sorted(cols))
    return rows


def plate_matrix(g, nx, ny, hx, hy, nu, winkler, clamped, closure="natural") -> sp.csr_matrix:
    """The u-matrix: the Hessian of the discrete energy, clamped rows/columns reduced to the
    diagonal. Reference of ``plate_pattern`` + ``plate_values``."""
    op = operators(nx, ny, hx, hy, nu, clamped, closure)
    wg = op["w"] * g
    Dxx, Dyy = op["Dxx"], op["Dyy"]
    K = (
        Dxx.T @ sp.diags(wg * op["qa"]) @ Dxx
        + Dyy.T @ sp.diags(wg * op["qb"]) @ Dyy
        + Dxx.T @ sp.diags(wg * op["qab"]) @ Dyy
        + Dyy.T @ sp.diags(wg * op["qab"]) @ Dxx
        + sp.diags(winkler * op["w"])
    )
    if ny > 0:
        gbar = op["avg"] @ g
        K = K + op["Dxy"].T @ sp.diags(2.0 * (1.0 - nu) * op["cell_area"] * gbar) @ op["Dxy"]
    K = sp.csr_matrix(K)
    free = (~clamped_mask(nx, ny, clamped)).astype(float)
    diag = K.diagonal()
    K = sp.diags(free) @ K @ sp.diags(free) + sp.diags((1.0 - free) * diag)
    return sp.csr_matrix(K)


def plate_apply(u, g, nx, ny, hx, hy, nu, winkler, clamped) -> np.ndarray:
    """``K(g) u`` in operator (divergence of moments) form; reference of ``plate_apply``."""
    op = operators(nx, ny, hx, hy, nu, clamped)
    cm = clamped_mask(nx, ny, clamped)
    um = np.where(cm, 0.0, u)
    a = op["Dxx"] @ um
    b = op["Dyy"] @ um
    wg = op["w"] * g
    y = op["Dxx"].T @ (wg * (op["qa"] * a + op["qab"] * b)) + op["Dyy"].T @ (wg * (op["qb"] * b + op["qab"] * a))
    if ny > 0:
        y += op["Dxy"].T @ (2.0 * (1.0 - nu) * op["cell_area"] * (op["avg"] @ g) * (op["Dxy"] @ um))
    y += winkler * op["w"] * um
    diag = plate_matrix(g, nx, ny, hx, hy, nu, winkler, clamped).diagonal()
    return np.where(cm, diag * u, y)


def plate_energy(u, g, w, nx, ny, hx, hy, nu, winkler, clamped, closure="natural"):
    """``(bending, foundation)``; reference of ``plate_energy``."""
    op = operators(nx, ny, hx, hy, nu, clamped, closure)
    um = np.where(clamped_mask(nx, ny, clamped), 0.0, u)
    a = op["Dxx"] @ um
    b = op["Dyy"] @ um
    bending = 0.5 * np.sum(op["w"] * g * (op["qa"] * a**2 + op["qb"] * b**2 + 2.0 * op["qab"] * a * b))
    if ny > 0:
        d = op["Dxy"] @ um
        bending += (1.0 - nu) * op["cell_area"] * np.sum((op["avg"] @ g) * d**2)
    foundation = 0.5 * winkler * np.sum(op["w"] * (um - w) ** 2)
    return bending, foundation


def bending_density(u, nx, ny, hx, hy, nu, clamped):
    """Lumped undamaged bending energy ``e``; reference of ``bending_density``."""
    op = operators(nx, ny, hx, hy, nu, clamped)
    um = np.where(clamped_mask(nx, ny, clamped), 0.0, u)
    a = op["Dxx"] @ um
    b = op["Dyy"] @ um
    e = op["w"] * (op["qa"] * a**2 + op["qb"] * b**2 + 2.0 * op["qab"] * a * b)
    if ny > 0:
        d = op["Dxy"] @ um
        e += op["avg"].T @ (2.0 * (1.0 - nu) * op["cell_area"] * d**2)
    return e


def surface_energy(alpha, nx, ny, hx, hy, eta, toughness, at):
    """AT surface energy; reference of ``surface_energy``."""
    c_m = 2.0 / 3.0 if at == 1 else 0.5
    A = np.asarray(alpha).reshape(ny + 1, nx + 1)
    wx = _trapezoid(nx, hx)
    wy = _trapezoid(ny, hy)
    volume = np.sum(np.outer(wy, wx) * A**at)
    gradient = np.sum(wy[:, None] / hx * np.diff(A, axis=1) ** 2)
    if ny > 0:
        gradient += np.sum(wx[None, :] / hy * np.diff(A, axis=0) ** 2)
    return toughness / (4.0 * c_m) * (volume / eta + eta * gradient)


def laplacian(nx, ny, hx, hy) -> sp.csr_matrix:
    """Edge Laplacian ``L`` with ``alpha.L.alpha`` = the gradient sum; reference of
    ``laplacian_pattern``."""
    wx = _trapezoid(nx, hx)
    wy = _trapezoid(ny, hy)
    Gx = sp.kron(sp.identity(ny + 1), _forward_difference_1d(nx, 1.0))
    L = Gx.T @ sp.diags(np.repeat(wy / hx, nx)) @ Gx
    if ny > 0:
        Gy = sp.kron(_forward_difference_1d(ny, 1.0), sp.identity(nx + 1))
        L = L + Gy.T @ sp.diags(np.tile(wx / hy, ny)) @ Gy
    return sp.csr_matrix(L)
