"""Numba kernels of the discrete plate + Winkler energy and of the Ambrosio-Tortorelli terms.

Arrays and scalars in, arrays or floats out; no set-up, no validation (see
:mod:`thinfilm.plate.operators`, which calls these with the right dtypes). The discrete energy
they implement is defined in :mod:`thinfilm.plate.operators`; in short, at node ``n`` with second
differences ``a = D_xx u`` and ``b = D_yy u`` (each may be missing on a free edge, or use a
mirrored ghost node on a clamped edge) the bending density is
``Q_n(a, b) = qa a^2 + qb b^2 + 2 qab a b`` with ``(qa, qb, qab)`` from :func:`node_form`,
and on each cell the twist density is ``2 (1 - nu) d^2``, ``d = D_xy u`` at the cell centre.

Conventions shared by every kernel
----------------------------------
- Grid: ``nx`` cells in x; ``ny`` cells in y, ``ny = 0`` for a 1D grid. Node ``(i, j)`` has
  flat index ``j (nx + 1) + i``. Spacings ``hx``, ``hy`` (``hy`` is ignored in 1D).
- ``clamped``: int64 array of 4 flags, edges ``x0, x1, y0, y1`` (the last two 0 in 1D).
- Nodal fields: C-contiguous float64 of length ``(nx + 1)(ny + 1)``.
- ``g``: the degradation ``(1 - alpha)^2 + k_res`` at the nodes; on a cell the mean of its
  four corners is used, so the energy stays linear in the nodal ``g``.
- Values of ``u`` on clamped nodes are ignored (taken as 0): the clamp ``u = 0`` is part of
  the energy, not of the data.
- Sums that must be reproducible (energies) run serially, in index order, without fastmath.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

# Kinds of a node in one direction: how the second difference in that direction is formed.
INTERIOR = 0  # (u[-1] - 2 u[0] + u[+1]) / h^2
GHOST_LO = 1  # clamped edge at the low end: mirrored ghost u[-1] = u[+1]
GHOST_HI = 2  # clamped edge at the high end: mirrored ghost u[+1] = u[-1]
MISSING = 3  # free edge: no second difference in the normal direction
ABSENT = 4  # 1D grid: no y direction at all


@njit(cache=True)
def axis_kind(i, n, clamped_lo, clamped_hi):
    """Kind of node index ``i`` in a direction with ``n`` cells (``n = 0``: direction absent)."""
    if n == 0:
        return ABSENT
    if i == 0:
        return GHOST_LO if clamped_lo != 0 else MISSING
    if i == n:
        return GHOST_HI if clamped_hi != 0 else MISSING
    return INTERIOR


@njit(cache=True)
def d2_coefficient(kind, offset):
    """Coefficient (times ``h^2``) of the node at ``offset`` in {-1, 0, 1} in the second
    difference of a node of the given kind."""
    if kind == INTERIOR:
        return -2.0 if offset == 0 else 1.0
    if kind == GHOST_LO:
        # u_{-1} = u_{+1}: (2 u_{+1} - 2 u_0) / h^2
        return -2.0 if offset == 0 else (2.0 if offset == 1 else 0.0)
    if kind == GHOST_HI:
        return -2.0 if offset == 0 else (2.0 if offset == -1 else 0.0)
    return 0.0


@njit(cache=True)
def node_form(kx, ky, nu):
    """Coefficients ``(qa, qb, qab)`` of the nodal bending density ``qa a^2 + qb b^2 + 2 qab a b``.

    Both second differences present: ``a^2 + b^2 + 2 nu a b``. Only the tangential one ``a``
    present (node on a free edge normal to y): the density with the free-edge condition
    ``M_nn = b + nu a = 0`` eliminated, ``(1 - nu^2) a^2``; likewise for ``b``. Free-free
    corner: 0 (both moments vanish there). 1D: ``a^2``.
    """
    has_x = kx <= GHOST_HI
    if ky == ABSENT:
        return (1.0 if has_x else 0.0), 0.0, 0.0
    has_y = ky <= GHOST_HI
    if has_x and has_y:
        return 1.0, 1.0, nu
    if has_x:
        return 1.0 - nu * nu, 0.0, 0.0
    if has_y:
        return 0.0, 1.0 - nu * nu, 0.0
    return 0.0, 0.0, 0.0


@njit(cache=True)
def trapezoid_weight(i, n, h):
    """1D trapezoidal weight of node ``i`` of ``n`` cells (1.0 if the direction is absent)."""
    if n == 0:
        return 1.0
    if i == 0 or i == n:
        return 0.5 * h
    return h


@njit(cache=True)
def is_clamped(i, j, nx, ny, clamped):
    """True if node ``(i, j)`` lies on a clamped edge."""
    if (clamped[0] != 0 and i == 0) or (clamped[1] != 0 and i == nx):
        return True
    if ny > 0 and ((clamped[2] != 0 and j == 0) or (clamped[3] != 0 and j == ny)):
        return True
    return False


@njit(cache=True)
def masked(u, nx, ny, clamped):
    """``u`` itself if no edge is clamped, else a copy with the clamped nodes set to 0."""
    if clamped[0] == 0 and clamped[1] == 0 and clamped[2] == 0 and clamped[3] == 0:
        return u
    um = u.copy()
    n1 = nx + 1
    for j in range(ny + 1):
        for i in range(n1):
            if is_clamped(i, j, nx, ny, clamped):
                um[j * n1 + i] = 0.0
    return um


@njit(cache=True)
def second_differences(u, i, j, nx, ny, hx, hy, clamped):
    """``(kx, ky, a, b)``: kinds and second differences ``a = D_xx u``, ``b = D_yy u`` at node
    ``(i, j)`` (0.0 where missing)."""
    n1 = nx + 1
    p = j * n1 + i
    kx = axis_kind(i, nx, clamped[0], clamped[1])
    ky = axis_kind(j, ny, clamped[2], clamped[3])
    a = 0.0
    if kx <= GHOST_HI:
        for s in (-1, 0, 1):
            c = d2_coefficient(kx, s)
            if c != 0.0:
                a += c * u[p + s]
        a /= hx * hx
    b = 0.0
    if ky <= GHOST_HI:
        for s in (-1, 0, 1):
            c = d2_coefficient(ky, s)
            if c != 0.0:
                b += c * u[p + s * n1]
        b /= hy * hy
    return kx, ky, a, b


@njit(cache=True)
def cell_twist(u, ic, jc, nx, hx, hy):
    """Mixed difference ``d = D_xy u`` at the centre of cell ``(ic, jc)``."""
    n1 = nx + 1
    p = jc * n1 + ic
    return (u[p] - u[p + 1] - u[p + n1] + u[p + n1 + 1]) / (hx * hy)


@njit(cache=True)
def cell_degradation(g, ic, jc, nx):
    """Degradation on cell ``(ic, jc)``: the mean of ``g`` at its four corners."""
    n1 = nx + 1
    p = jc * n1 + ic
    return 0.25 * (g[p] + g[p + 1] + g[p + n1] + g[p + n1 + 1])


# ---------------------------------------------------------------------------------------
# (a) the u-matrix: fixed pattern, values written row by row
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def entry_in_pattern(i, j, di, dj, nx, ny, clamped):
    """True if the u-matrix has an entry at row ``(i, j)``, column ``(i + di, j + dj)``.

    The pattern is the 13-point stencil ``|di| + |dj| <= 2`` cut to the grid (5 points in
    1D); rows and columns of clamped nodes keep only their diagonal.
    """
    iq = i + di
    jq = j + dj
    if iq < 0 or iq > nx or jq < 0 or jq > ny:
        return False
    if di == 0 and dj == 0:
        return True
    if is_clamped(i, j, nx, ny, clamped) or is_clamped(iq, jq, nx, ny, clamped):
        return False
    return True


@njit(cache=True)
def fast_range(n, clamped_lo, clamped_hi):
    """Index range ``[lo, hi]`` of rows whose whole stencil (distance 2) is interior and free
    of clamped nodes, so the constant-coefficient formulas apply."""
    lo = 3 if clamped_lo != 0 else 2
    hi = n - 3 if clamped_hi != 0 else n - 2
    return lo, hi


@njit(cache=True)
def plate_pattern(nx, ny, clamped):
    """CSR pattern ``(indptr, indices)`` (int64, sorted columns) of the u-matrix.

    Built once per grid and set of clamped edges. Row ``p`` lists its columns in the order
    ``dj = -2..2`` (outer), ``di = -2..2`` (inner), which is increasing flat index.
    """
    n1 = nx + 1
    n_nodes = n1 * (ny + 1)
    reach_y = 2 if ny > 0 else 0
    full = 13 if ny > 0 else 5  # entries of a row whose whole stencil is free and inside
    i_lo, i_hi = fast_range(nx, clamped[0], clamped[1])
    j_lo, j_hi = fast_range(ny, clamped[2], clamped[3])
    indptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for j in range(ny + 1):
        fast_j = ny == 0 or (j_lo <= j <= j_hi)
        for i in range(n1):
            if fast_j and i_lo <= i <= i_hi:
                indptr[j * n1 + i + 1] = full
                continue
            count = 0
            for dj in range(-reach_y, reach_y + 1):
                r = 2 - abs(dj)
                for di in range(-r, r + 1):
                    if entry_in_pattern(i, j, di, dj, nx, ny, clamped):
                        count += 1
            indptr[j * n1 + i + 1] = count
    for p in range(n_nodes):
        indptr[p + 1] += indptr[p]
    indices = np.empty(indptr[n_nodes], dtype=np.int64)
    for j in range(ny + 1):
        fast_j = ny == 0 or (j_lo <= j <= j_hi)
        for i in range(n1):
            pos = indptr[j * n1 + i]
            fast = fast_j and i_lo <= i <= i_hi
            for dj in range(-reach_y, reach_y + 1):
                r = 2 - abs(dj)
                for di in range(-r, r + 1):
                    if fast or entry_in_pattern(i, j, di, dj, nx, ny, clamped):
                        indices[pos] = (j + dj) * n1 + i + di
                        pos += 1
    return indptr, indices


@njit(cache=True)
def plate_row(i, j, g, nx, ny, hx, hy, nu, winkler, clamped, buf):
    """Row ``(i, j)`` of the full Hessian of the discrete energy into ``buf[di + 2, dj + 2]``.

    ``buf`` (5 x 5 float64) is overwritten. The row gathers the contributions of every term
    that contains node ``p = (i, j)``: the nodal bending terms at ``p`` and at its four
    neighbours, the twist terms of the (up to) four cells around ``p``, and the foundation.
    """
    n1 = nx + 1
    for a in range(5):
        for b in range(5):
            buf[a, b] = 0.0
    inv_hx2 = 1.0 / (hx * hx)
    inv_hy2 = 1.0 / (hy * hy)
    # nodal bending terms 1/2 w g Q(a, b) at n = p + (ox, oy)
    for t in range(5):
        ox = 0
        oy = 0
        if t == 1:
            ox = -1
        elif t == 2:
            ox = 1
        elif t == 3:
            oy = -1
        elif t == 4:
            oy = 1
        i_n = i + ox
        j_n = j + oy
        if i_n < 0 or i_n > nx or j_n < 0 or j_n > ny:
            continue
        kx = axis_kind(i_n, nx, clamped[0], clamped[1])
        ky = axis_kind(j_n, ny, clamped[2], clamped[3])
        qa, qb, qab = node_form(kx, ky, nu)
        wg = trapezoid_weight(i_n, nx, hx) * trapezoid_weight(j_n, ny, hy) * g[j_n * n1 + i_n]
        # coefficients of u_p in a_n and b_n
        ca_p = d2_coefficient(kx, -ox) * inv_hx2 if oy == 0 else 0.0
        cb_p = d2_coefficient(ky, -oy) * inv_hy2 if ox == 0 else 0.0
        fa = wg * (qa * ca_p + qab * cb_p)  # d(energy)/d(a_n) per unit u_p, times a_n's stencil
        fb = wg * (qb * cb_p + qab * ca_p)
        for s in (-1, 0, 1):
            buf[ox + s + 2, oy + 2] += fa * d2_coefficient(kx, s) * inv_hx2
            buf[ox + 2, oy + s + 2] += fb * d2_coefficient(ky, s) * inv_hy2
    # twist terms 1/2 (hx hy) gc 2 (1 - nu) d^2 of the cells around p
    if ny > 0:
        scale = 2.0 * (1.0 - nu) / (hx * hy)  # (hx hy) * 2 (1 - nu) / (hx hy)^2
        for cy in range(2):
            for cx in range(2):
                ic = i - cx
                jc = j - cy
                if ic < 0 or ic >= nx or jc < 0 or jc >= ny:
                    continue
                f = scale * cell_degradation(g, ic, jc, nx)
                s_p = 1.0 if cx == cy else -1.0
                for qy in range(2):
                    for qx in range(2):
                        s_q = 1.0 if qx == qy else -1.0
                        buf[qx - cx + 2, qy - cy + 2] += f * s_p * s_q
    buf[2, 2] += winkler * trapezoid_weight(i, nx, hx) * trapezoid_weight(j, ny, hy)


@njit(cache=True)
def interior_row_2d(g, p, i, j, n1, nx, hx, hy, nu, winkler, data, pos):
    """The 13 entries of an interior 2D row, written to ``data[pos:pos + 13]`` in pattern order.

    Equal to :func:`plate_row` for such rows (the node terms are all ``a^2 + b^2 + 2 nu a b``
    with weight ``hx hy``, the four cells exist), written out to avoid its generic loops,
    which cost more (docs/speed.md#the-plate-solvers-2d-grids-2-cores).
    """
    rx = 1.0 / (hx * hx)
    ry = 1.0 / (hy * hy)
    rxy = nu * rx * ry
    area = hx * hy
    wc = area * g[p]
    we = area * g[p + 1]
    ww = area * g[p - 1]
    wn = area * g[p + n1]
    ws = area * g[p - n1]
    scale = 0.5 * (1.0 - nu) / area  # 2 (1 - nu) / (hx hy) times the 1/4 of the corner mean
    # twist factors of the cells north-east, north-west, south-east, south-west of p
    f_ne = scale * (g[p] + g[p + 1] + g[p + n1] + g[p + n1 + 1])
    f_nw = scale * (g[p] + g[p - 1] + g[p + n1] + g[p + n1 - 1])
    f_se = scale * (g[p] + g[p + 1] + g[p - n1] + g[p - n1 + 1])
    f_sw = scale * (g[p] + g[p - 1] + g[p - n1] + g[p - n1 - 1])
    data[pos + 0] = ry * ry * ws  # (0, -2)
    data[pos + 1] = rxy * (ww + ws) + f_sw  # (-1, -1)
    data[pos + 2] = -2.0 * (ry * ry + rxy) * (wc + ws) - f_sw - f_se  # (0, -1)
    data[pos + 3] = rxy * (we + ws) + f_se  # (1, -1)
    data[pos + 4] = rx * rx * ww  # (-2, 0)
    data[pos + 5] = -2.0 * (rx * rx + rxy) * (wc + ww) - f_nw - f_sw  # (-1, 0)
    data[pos + 6] = (
        (4.0 * rx * rx + 4.0 * ry * ry + 8.0 * rxy) * wc
        + rx * rx * (we + ww)
        + ry * ry * (wn + ws)
        + f_ne + f_nw + f_se + f_sw
        + winkler * area
    )  # (0, 0)
    data[pos + 7] = -2.0 * (rx * rx + rxy) * (wc + we) - f_ne - f_se  # (1, 0)
    data[pos + 8] = rx * rx * we  # (2, 0)
    data[pos + 9] = rxy * (ww + wn) + f_nw  # (-1, 1)
    data[pos + 10] = -2.0 * (ry * ry + rxy) * (wc + wn) - f_ne - f_nw  # (0, 1)
    data[pos + 11] = rxy * (we + wn) + f_ne  # (1, 1)
    data[pos + 12] = ry * ry * wn  # (0, 2)


@njit(cache=True)
def interior_row_1d(g, p, hx, winkler, data, pos):
    """The 5 entries of an interior 1D row (density ``a^2``, weight ``hx``)."""
    rx2 = 1.0 / (hx * hx * hx * hx)
    wc = hx * g[p]
    we = hx * g[p + 1]
    ww = hx * g[p - 1]
    data[pos + 0] = rx2 * ww
    data[pos + 1] = -2.0 * rx2 * (wc + ww)
    data[pos + 2] = rx2 * (4.0 * wc + we + ww) + winkler * hx
    data[pos + 3] = -2.0 * rx2 * (wc + we)
    data[pos + 4] = rx2 * we


@njit(cache=True, parallel=True)
def plate_values(g, nx, ny, hx, hy, nu, winkler, clamped, indptr, data):
    """Write the u-matrix values for degradation ``g`` into ``data`` (pattern of
    :func:`plate_pattern`), in place. Rows of clamped nodes get the diagonal of the full
    Hessian and nothing else."""
    n1 = nx + 1
    reach_y = 2 if ny > 0 else 0
    i_lo, i_hi = fast_range(nx, clamped[0], clamped[1])
    j_lo, j_hi = fast_range(ny, clamped[2], clamped[3])
    for j_ in prange(ny + 1):
        j = np.int64(j_)  # prange indices are uint64: keep index arithmetic signed
        buf = np.empty((5, 5), dtype=np.float64)
        fast_j = ny == 0 or (j_lo <= j <= j_hi)
        for i in range(n1):
            p = j * n1 + i
            if fast_j and i_lo <= i <= i_hi:
                if ny > 0:
                    interior_row_2d(g, p, i, j, n1, nx, hx, hy, nu, winkler, data, indptr[p])
                else:
                    interior_row_1d(g, p, hx, winkler, data, indptr[p])
                continue
            plate_row(i, j, g, nx, ny, hx, hy, nu, winkler, clamped, buf)
            pos = indptr[p]
            for dj in range(-reach_y, reach_y + 1):
                r = 2 - abs(dj)
                for di in range(-r, r + 1):
                    if entry_in_pattern(i, j, di, dj, nx, ny, clamped):
                        data[pos] = buf[di + 2, dj + 2]
                        pos += 1


# ---------------------------------------------------------------------------------------
# (b) matrix-free apply
# ---------------------------------------------------------------------------------------
@njit(cache=True, parallel=True)
def plate_apply(u, g, nx, ny, hx, hy, nu, winkler, clamped, mx, my, tw, y):
    """``y = K(g) u`` without forming K, in two passes (moments, then their divergence).

    Equal to the CSR matrix of :func:`plate_values` times ``u`` up to round-off: free rows
    ignore ``u`` on clamped nodes, clamped rows return their diagonal times ``u``.
    ``mx``, ``my`` (length n_nodes) and ``tw`` (length max(nx ny, 1)) are work arrays.
    """
    n1 = nx + 1
    um = masked(u, nx, ny, clamped)
    rx = 1.0 / (hx * hx)
    ry = 1.0 / (hy * hy)
    area = hx * hy if ny > 0 else hx
    twist = 0.5 * (1.0 - nu) / (hx * hy)  # (hx hy) 2 (1 - nu) * (1/4 corner mean) / (hx hy)^2
    # pass 1: weighted moments w g dQ/da / 2, w g dQ/db / 2 at nodes, and the twist moment of
    # the cell above-right of each node (one sweep over u and g, rows j and j + 1 in cache)
    for j_ in prange(ny + 1):
        j = np.int64(j_)  # prange indices are uint64: keep index arithmetic signed
        interior_j = ny > 0 and 0 < j < ny
        for i in range(n1):
            p = j * n1 + i
            if j < ny and i < nx:
                tw[j * nx + i] = (
                    twist
                    * (g[p] + g[p + 1] + g[p + n1] + g[p + n1 + 1])
                    * (um[p] - um[p + 1] - um[p + n1] + um[p + n1 + 1])
                )
            if 0 < i < nx and (interior_j or ny == 0):
                a = (um[p - 1] - 2.0 * um[p] + um[p + 1]) * rx
                if ny == 0:
                    mx[p] = area * g[p] * a
                    my[p] = 0.0
                else:
                    b = (um[p - n1] - 2.0 * um[p] + um[p + n1]) * ry
                    mx[p] = area * g[p] * (a + nu * b)
                    my[p] = area * g[p] * (b + nu * a)
                continue
            kx, ky, a, b = second_differences(um, i, j, nx, ny, hx, hy, clamped)
            qa, qb, qab = node_form(kx, ky, nu)
            wg = trapezoid_weight(i, nx, hx) * trapezoid_weight(j, ny, hy) * g[p]
            mx[p] = wg * (qa * a + qab * b)
            my[p] = wg * (qb * b + qab * a)
    # pass 2: y = D^T moments + foundation
    i_lo, i_hi = fast_range(nx, clamped[0], clamped[1])
    j_lo, j_hi = fast_range(ny, clamped[2], clamped[3])
    for j_ in prange(ny + 1):
        j = np.int64(j_)  # prange indices are uint64: keep index arithmetic signed
        buf = np.empty((5, 5), dtype=np.float64)
        fast_j = ny == 0 or (j_lo <= j <= j_hi)
        for i in range(n1):
            p = j * n1 + i
            if fast_j and i_lo <= i <= i_hi:
                acc = winkler * area * um[p] + rx * (mx[p - 1] - 2.0 * mx[p] + mx[p + 1])
                if ny > 0:
                    c = j * nx + i
                    acc += ry * (my[p - n1] - 2.0 * my[p] + my[p + n1])
                    acc += tw[c] - tw[c - 1] - tw[c - nx] + tw[c - nx - 1]
                y[p] = acc
                continue
            if is_clamped(i, j, nx, ny, clamped):
                plate_row(i, j, g, nx, ny, hx, hy, nu, winkler, clamped, buf)
                y[p] = buf[2, 2] * u[p]
                continue
            acc = winkler * trapezoid_weight(i, nx, hx) * trapezoid_weight(j, ny, hy) * um[p]
            for o in (-1, 0, 1):
                i_n = i + o
                if 0 <= i_n <= nx:
                    kx = axis_kind(i_n, nx, clamped[0], clamped[1])
                    acc += d2_coefficient(kx, -o) * rx * mx[p + o]
            if ny > 0:
                for o in (-1, 0, 1):
                    j_n = j + o
                    if 0 <= j_n <= ny:
                        ky = axis_kind(j_n, ny, clamped[2], clamped[3])
                        acc += d2_coefficient(ky, -o) * ry * my[p + o * n1]
                for cy in range(2):
                    for cx in range(2):
                        ic = i - cx
                        jc = j - cy
                        if 0 <= ic < nx and 0 <= jc < ny:
                            s_p = 1.0 if cx == cy else -1.0
                            acc += s_p * tw[jc * nx + ic]
            y[p] = acc


# ---------------------------------------------------------------------------------------
# (c) energies
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def plate_energy(u, g, w, nx, ny, hx, hy, nu, winkler, clamped):
    """``(bending, foundation)`` energies of the discrete plate, serial sums.

    ``bending = 1/2 sum_n omega_n g_n Q_n + 1/2 sum_c (hx hy) gc_c 2 (1 - nu) d_c^2`` and
    ``foundation = winkler/2 sum_n omega_n (u_n - w_n)^2`` (``omega`` the node weights, ``w``
    the substrate displacement).
    """
    n1 = nx + 1
    um = masked(u, nx, ny, clamped)
    bending = 0.0
    foundation = 0.0
    for j in range(ny + 1):
        for i in range(n1):
            p = j * n1 + i
            kx, ky, a, b = second_differences(um, i, j, nx, ny, hx, hy, clamped)
            qa, qb, qab = node_form(kx, ky, nu)
            weight = trapezoid_weight(i, nx, hx) * trapezoid_weight(j, ny, hy)
            bending += 0.5 * weight * g[p] * (qa * a * a + qb * b * b + 2.0 * qab * a * b)
            r = um[p] - w[p]
            foundation += 0.5 * winkler * weight * r * r
    half_twist = (1.0 - nu) * hx * hy
    for jc in range(ny):
        for ic in range(nx):
            d = cell_twist(um, ic, jc, nx, hx, hy)
            bending += half_twist * cell_degradation(g, ic, jc, nx) * d * d
    return bending, foundation


@njit(cache=True, parallel=True)
def bending_density(u, nx, ny, hx, hy, nu, clamped, e):
    """Nodal undamaged bending energy, lumped: ``e_n = omega_n Q_n + 1/4 sum_{c ni n} (hx hy) 2 (1 - nu) d_c^2``.

    Written into ``e`` in place (energy units: already multiplied by the quadrature weights).
    The bending energy at degradation ``g`` is exactly ``1/2 sum_n g_n e_n``, because a cell
    takes the mean of the ``g`` of its corners; ``e`` is the alpha-problem's diagonal.
    """
    n1 = nx + 1
    um = masked(u, nx, ny, clamped)
    quarter_twist = 0.5 * (1.0 - nu) * hx * hy  # 1/4 * (hx hy) * 2 (1 - nu)
    for j_ in prange(ny + 1):
        j = np.int64(j_)  # prange indices are uint64: keep index arithmetic signed
        for i in range(n1):
            kx, ky, a, b = second_differences(um, i, j, nx, ny, hx, hy, clamped)
            qa, qb, qab = node_form(kx, ky, nu)
            weight = trapezoid_weight(i, nx, hx) * trapezoid_weight(j, ny, hy)
            acc = weight * (qa * a * a + qb * b * b + 2.0 * qab * a * b)
            if ny > 0:
                for cy in range(2):
                    for cx in range(2):
                        ic = i - cx
                        jc = j - cy
                        if 0 <= ic < nx and 0 <= jc < ny:
                            d = cell_twist(um, ic, jc, nx, hx, hy)
                            acc += quarter_twist * d * d
            e[j * n1 + i] = acc


@njit(cache=True)
def surface_energy(alpha, nx, ny, hx, hy, eta, toughness, at):
    """AT surface energy ``toughness/(4 c_m) [sum_n omega_n alpha_n^m / eta + eta sum_e omega_e (D alpha)_e^2]``.

    ``m = at`` (1 or 2), ``c_1 = 2/3``, ``c_2 = 1/2``. The gradient lives on grid edges
    (forward differences): an x-edge ``(i, j)-(i+1, j)`` has weight ``hx * omega_y_j``, so its
    term is ``omega_y_j / hx (alpha_{i+1,j} - alpha_{i,j})^2``; likewise for y-edges. Serial sum.
    """
    c_m = 2.0 / 3.0 if at == 1 else 0.5
    n1 = nx + 1
    volume = 0.0
    gradient = 0.0
    for j in range(ny + 1):
        wy = trapezoid_weight(j, ny, hy)
        for i in range(n1):
            p = j * n1 + i
            a = alpha[p]
            volume += trapezoid_weight(i, nx, hx) * wy * (a if at == 1 else a * a)
            if i < nx:
                da = alpha[p + 1] - a
                gradient += wy / hx * da * da
            if j < ny:
                da = alpha[p + n1] - a
                gradient += trapezoid_weight(i, nx, hx) / hy * da * da
    return toughness / (4.0 * c_m) * (volume / eta + eta * gradient)


# ---------------------------------------------------------------------------------------
# (d) the alpha-problem: a fixed-pattern gradient Laplacian
# ---------------------------------------------------------------------------------------
@njit(cache=True)
def laplacian_pattern(nx, ny, hx, hy):
    """The edge Laplacian ``L`` with ``alpha.L.alpha = sum_e omega_e (D alpha)_e^2`` as CSR.

    Returns ``(indptr, indices, data, diag_pos)``: a 5-point (3-point in 1D) pattern with
    sorted columns, its values, and the position in ``data`` of each row's diagonal. The
    alpha-problem matrix shares this pattern; only its diagonal depends on ``u``.
    """
    n1 = nx + 1
    n_nodes = n1 * (ny + 1)
    indptr = np.zeros(n_nodes + 1, dtype=np.int64)
    for j in range(ny + 1):
        for i in range(n1):
            count = 1
            if i > 0:
                count += 1
            if i < nx:
                count += 1
            if j > 0:
                count += 1
            if j < ny:
                count += 1
            indptr[j * n1 + i + 1] = count
    for p in range(n_nodes):
        indptr[p + 1] += indptr[p]
    nnz = indptr[n_nodes]
    indices = np.empty(nnz, dtype=np.int64)
    data = np.empty(nnz, dtype=np.float64)
    diag_pos = np.empty(n_nodes, dtype=np.int64)
    for j in range(ny + 1):
        wy = trapezoid_weight(j, ny, hy)
        for i in range(n1):
            p = j * n1 + i
            wx = trapezoid_weight(i, nx, hx)
            k_west = wy / hx if i > 0 else 0.0
            k_east = wy / hx if i < nx else 0.0
            k_south = wx / hy if j > 0 else 0.0
            k_north = wx / hy if j < ny else 0.0
            pos = indptr[p]
            if j > 0:
                indices[pos] = p - n1
                data[pos] = -k_south
                pos += 1
            if i > 0:
                indices[pos] = p - 1
                data[pos] = -k_west
                pos += 1
            indices[pos] = p
            data[pos] = k_west + k_east + k_south + k_north
            diag_pos[p] = pos
            pos += 1
            if i < nx:
                indices[pos] = p + 1
                data[pos] = -k_east
                pos += 1
            if j < ny:
                indices[pos] = p + n1
                data[pos] = -k_north
                pos += 1
    return indptr, indices, data, diag_pos
