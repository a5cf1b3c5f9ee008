"""Geometric multigrid as a CG preconditioner for the plate + Winkler operator with damage.

A measurement, not a solver of the toolkit: does a plain geometric V-cycle make CG iterations
independent of the grid (O(N) solves) on the 13-point plate operator of
:func:`tests.solvers.plate_system.plate_test_matrix`, and how much do the crack bands of
:func:`tests.solvers.plate_system.crack_bands` (coefficient down to ``1e-6``) hurt it?

The hierarchy:

- 1D transfer on a line of n nodes: coarse nodes are every other fine node, node 0 and the
  last node always kept (for even n the last coarse interval is one fine cell long). Fine
  nodes between coarse ones are interpolated by 4-point Lagrange (cubic) polynomials through
  the nearest coarse nodes, one-sided at the ends, at the actual node positions, or by linear
  interpolation. Fourth-order operators need transfer orders ``m_P + m_R > 4`` (Hemker);
  with ``R = P^T`` linear gives 2 + 2 = 4, cubic 4 + 4 = 8, and the table shows what the
  missing order costs.
- 2D: ``P = kron(P_y, P_x)``, matching the row-major node index ``iy * m + ix``.
- Galerkin coarse operators ``A_{l+1} = P^T A_l P`` (they stay SPD and take the damage into
  the coarse levels without a rediscretization), down to at most ``COARSE_MAX`` unknowns,
  solved by a dense Cholesky factorization.
- A symmetric V-cycle: ``nu`` forward Gauss-Seidel sweeps before the coarse correction and
  ``nu`` backward sweeps after (the adjoint), so the cycle is a symmetric positive definite
  operator and a valid CG preconditioner.

Each case runs preconditioned CG from ``x0 = 0`` to ``||f - K u|| <= 1e-8 ||f||`` (2-norm),
with the right-hand side of ``benchmarks/bench_usolve.py``: the foundation load of pure
bending, ``f = winkler h^2 w`` with ``w = -x^2/2``, so the iteration counts compare with that
benchmark's cold AMG solves. Damage is ``alpha = 0`` (none) or ``crack_bands(m)``;
nu = 0.3, winkler = 4e6, k_res = 1e-6. For m <= 500 the same matrix is also solved by PARDISO
(pypardiso: analysis + factorization + solve; SuperLU with MMD ordering when pypardiso is
missing) for a ratio.

Run every heavy case single-threaded and niced when the machine is shared::

    OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 NUMBA_NUM_THREADS=1 \\
        nice -n 19 python -m benchmarks.bench_gmg --sizes 125 250 500 1000

    python -m benchmarks.bench_gmg --sizes 125 250     # smoke check, under a minute

The W-cycle and two-grid rows of ``gmg.md`` come from further invocations (``--cycle W``,
``--coarse-max``), listed there; rows are merged into ``gmg.csv`` by size, damage, transfer,
sweeps, cycle and number of levels, and ``--report`` rewrites ``gmg.md`` from the CSV alone.

Writes ``benchmarks/results/gmg.csv`` and ``gmg.md`` (``--out`` another folder).
"""

from __future__ import annotations

import argparse
import csv
import math
import resource
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

RESULTS = Path(__file__).resolve().parent / "results"
COARSE_MAX = 2500      # the coarsest level: a dense Cholesky of at most 2500^2 doubles (50 MB)
DIRECT_MAX_M = 500     # the direct comparison only where it costs seconds
FIELDS = ["m", "unknowns", "nnz", "damage", "transfer", "sweeps", "cycle", "levels", "coarse_n",
          "op_complexity", "setup_s", "iterations", "converged", "ritz_min", "ritz_below_01",
          "ritz_cond", "relres", "solve_s",
          "per_iter_s", "total_s", "direct_kind", "direct_s", "ratio_total_direct",
          "peak_gb", "command"]
KEY = ("m", "damage", "transfer", "sweeps", "cycle", "levels")


# What the recorded run showed; written under the table (the numbers are those of gmg.csv).
FINDINGS = """
## Findings

- *Undamaged, cubic transfer: O(N).* CG iterations 13 / 20 / 19 / 19 (one sweep) and
  9 / 14 / 13 / 13 (two sweeps) at 125^2 ... 1000^2: a rise from three levels (125^2) to four
  (250^2), flat from there on (pure bending, ``winkler = 1``, behaves alike: 11 / 17 / 16 up to
  500^2, two sweeps; measured with ``GeometricMG`` directly, not in the table). The smallest
  Ritz value stays at 0.15-0.22 (condition number 4.5-6.5). Time per iteration grows like N
  (0.058 s at 500^2, 0.20 s at 1000^2, one sweep), setup 1.8 s at 1000^2, operator complexity
  3.2 (Galerkin stencils of 77, then up to 121 points): 5.6 s for a solve at 1000^2.
- *Linear transfer (order 2 + 2 = 4, below Hemker's bound):* 14 / 24 / 31 / 45 iterations
  undamaged, smallest Ritz value 0.31 / 0.12 / 0.084 / 0.047: they degrade with N, as the rule
  predicts. An iteration costs 40% of a cubic one (operator complexity 1.5, 21-point coarse
  stencils), so at these sizes it is still faster (4.3 s against 5.6 s at 1000^2), but not O(N).
- *Damage breaks it.* With the crack bands: 13 / 26 / 67 / 185 iterations (cubic, one sweep),
  132 with two sweeps and 230 / 188 with linear transfers at 1000^2; about x2.8 per doubling of
  m. The smallest Ritz value falls about 8x per doubling (0.091 / 0.013 / 0.0015 at 250^2 /
  500^2 / 1000^2, condition 11 / 77 / 664, roughly h^3) and the Ritz values below 0.1 number
  1 / 12 / 36: a growing spread of poorly corrected modes, not a few outliers that a fixed
  deflation space would remove. Not a V-cycle defect: the two-grid method (exact coarse solve)
  needs 21 and 51 iterations at 250^2 and 500^2, the W-cycle 23 and 53, against 11 / 11 without
  damage. Presumably polynomial interpolation across a crack one to two cells wide cannot
  represent error that jumps across it, and such error can vary smoothly along each crack.
- *Against the direct solve:* at 500^2, single-threaded PARDISO (analysis + factorization +
  solve) takes 2.6-3.3 s; GMG (cubic, one sweep) 1.6 s undamaged (0.56 of it) but 4.3 s cracked
  (1.43; linear transfers 2.0 s, 0.67). The project's threaded PARDISO re-solve (kept analysis)
  is 1.2 s there (`usolve.md`). Against pyamg's smoothed aggregation on the same cracked
  matrices (cold solves from zero in `usolve.md`: 35 / 57 / 79 iterations at 250^2 / 500^2 /
  1000^2), GMG starts lower and grows faster. Its cold solve at 1000^2 (39 s, one thread) still
  beats AMG's first solve (52 s with setup, two threads); its iteration count does not.
- *Extrapolated to 1500^2, cracked* (iterations x 1.5^1.47, the growth from 500^2 to 1000^2;
  time per iteration and setup x 2.25; one thread): cubic about 340 iterations x 0.45 s = 150 s,
  linear about 430 x 0.19 s = 80 s, against 21 s for PARDISO's re-solve and 23 s for AMG's warm
  re-solve (`usolve.md`, two threads). Undamaged it would take about 12.5 s (cubic: 19
  iterations x 0.44 s + 4 s setup), but the solves that matter are the damaged ones. A
  geometric multigrid for this problem needs operator-dependent transfers at the cracks (what
  AMG provides); plain geometric transfers do not reach O(N) here.
"""


# ------------------------------------------------------------------------------------------
# Transfer operators
# ------------------------------------------------------------------------------------------

def coarse_indices(n):
    """Fine-node indices of the coarse nodes of a line of n nodes.

    Every other node from 0, plus the last node when n is even (then the last coarse interval
    spans one fine cell instead of two), so both ends of the plate stay grid nodes on every
    level and the free edges are represented exactly.

    Parameters
    ----------
    n : int
        Fine nodes on the line, n >= 2.

    Returns
    -------
    idx : ndarray of int
        Increasing, ``idx[0] == 0`` and ``idx[-1] == n - 1``.
    """
    idx = np.arange(0, n, 2)
    if idx[-1] != n - 1:
        idx = np.append(idx, n - 1)
    return idx


def _lagrange_weights(nodes, x):
    """Weights of the Lagrange polynomial through ``nodes`` evaluated at ``x``."""
    w = np.ones(len(nodes))
    for j, xj in enumerate(nodes):
        for k, xk in enumerate(nodes):
            if k != j:
                w[j] *= (x - xk) / (xj - xk)
    return w


def prolongation_1d(x, order="cubic"):
    """Interpolation from the coarse nodes of :func:`coarse_indices` to all fine nodes of a line.

    Coarse nodes are injected. A fine node between coarse nodes ``c_j < x < c_{j+1}`` takes
    the polynomial through ``c_{j-1}, c_j, c_{j+1}, c_{j+2}`` (cubic), shifted to the four
    nearest coarse nodes on one side at the ends, or through ``c_j, c_{j+1}`` (linear). The
    weights are computed at the actual node positions ``x``: with an even number of nodes the
    last coarse interval is half as long, and from then on the coarse lines are not uniform.
    Weights taken from node indices instead (midpoint weights 1/2, or -1/16, 9/16) no longer
    reproduce polynomials near that end, and the V-cycle degraded with every level: pure
    bending (``winkler = 1``), cubic, 2 sweeps, 11 / 38 / 86 CG iterations at 125^2 / 250^2 /
    500^2, against 11 / 17 / 16 with the positions (and 14 at 513^2, where every line stays
    uniform).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Increasing positions of the fine nodes (any unit).
    order : {"cubic", "linear"}

    Returns
    -------
    P : scipy.sparse.csr_matrix, shape (n, n_coarse)
        Rows sum to one; cubic reproduces polynomials of degree 3, linear of degree 1.
    xc : ndarray, shape (n_coarse,)
        Positions of the coarse nodes, for the next level.
    """
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    c = coarse_indices(n)
    xc = x[c]
    nc = len(c)
    npts = min({"cubic": 4, "linear": 2}[order], nc)
    rows, cols, vals = [], [], []
    pos = np.full(n, -1)
    pos[c] = np.arange(nc)
    for i in range(n):
        if pos[i] >= 0:
            rows.append(i), cols.append(pos[i]), vals.append(1.0)
            continue
        j = np.searchsorted(c, i) - 1          # c[j] < i < c[j + 1]
        lo = j - (npts // 2 - 1)               # centred stencil ...
        lo = min(max(lo, 0), nc - npts)        # ... made one-sided at the ends
        stencil = np.arange(lo, lo + npts)
        w = _lagrange_weights(xc[stencil], x[i])
        rows.extend([i] * npts), cols.extend(stencil), vals.extend(w)
    return sp.csr_matrix((vals, (rows, cols)), shape=(n, nc)), xc


def prolongation_2d(x, order="cubic"):
    """``kron(P_y, P_x)`` for a square tensor grid in row-major order (index ``iy * m + ix``).

    Parameters
    ----------
    x : ndarray, shape (m,)
        Node positions along either side (the grid is the same in x and y).
    order : {"cubic", "linear"}

    Returns
    -------
    P : scipy.sparse.csr_matrix, shape (m*m, mc*mc)
    xc : ndarray, shape (mc,)
        Coarse node positions.
    """
    P1, xc = prolongation_1d(x, order)
    # kron(A, B)[(i*m + k), (j*mc + l)] = A[i, j] B[k, l]: the slow (first) factor acts on iy.
    return sp.kron(P1, P1, format="csr"), xc


# ------------------------------------------------------------------------------------------
# The hierarchy and the V-cycle
# ------------------------------------------------------------------------------------------

class GeometricMG:
    """Galerkin geometric multigrid hierarchy with a symmetric Gauss-Seidel V-cycle.

    Parameters
    ----------
    A : scipy.sparse.csr_matrix, shape (m*m, m*m)
        The SPD fine operator on an m x m grid, row-major.
    order : {"cubic", "linear"}
        Interpolation of the transfer operators.
    sweeps : int
        Gauss-Seidel sweeps before (forward) and after (backward) each coarse correction.
    coarse_max : int
        Coarsen until a level has at most this many unknowns.
    """

    def __init__(self, A, order="cubic", sweeps=1, coarse_max=COARSE_MAX, cycle="V"):
        m = int(round(math.sqrt(A.shape[0])))
        x = np.arange(m, dtype=np.float64)  # node positions in fine cells, kept per level
        self.sweeps = sweeps
        self.gamma = {"V": 1, "W": 2}[cycle]
        self.A, self.P, self.R = [A.tocsr()], [], []
        while m * m > coarse_max and m > 4:
            P, x = prolongation_2d(x, order)
            m = len(x)
            R = P.T.tocsr()
            Ac = (R @ self.A[-1] @ P).tocsr()
            Ac.sort_indices()
            self.P.append(P), self.R.append(R), self.A.append(Ac)
        # Dense Cholesky of the coarsest Galerkin operator: exact, and symmetric to rounding
        # (an LU with pivoting would make the preconditioner slightly non-symmetric). Above
        # COARSE_MAX (two-grid experiments only) a sparse LU, symmetric to solver precision.
        if self.A[-1].shape[0] <= COARSE_MAX:
            fac = sla.cho_factor(self.A[-1].toarray(), lower=True)
            self.coarse_solve = lambda b: sla.cho_solve(fac, b)
        else:
            import scipy.sparse.linalg as spla

            self.coarse_solve = spla.splu(self.A[-1].tocsc(), permc_spec="MMD_AT_PLUS_A").solve

    @property
    def operator_complexity(self):
        """Sum of nnz over all levels divided by nnz of the finest."""
        return sum(a.nnz for a in self.A) / self.A[0].nnz

    def vcycle(self, b, level=0):
        """One symmetric V-cycle (W-cycle if ``cycle="W"``) for ``A_level x = b`` from 0.

        Parameters
        ----------
        b : ndarray
            Right-hand side on that level.
        level : int

        Returns
        -------
        x : ndarray
        """
        from pyamg.relaxation.relaxation import gauss_seidel

        if level == len(self.A) - 1:
            return self.coarse_solve(b)
        A = self.A[level]
        x = np.zeros_like(b)
        gauss_seidel(A, x, b, iterations=self.sweeps, sweep="forward")
        rc = self.R[level] @ (b - A @ x)
        # gamma = 2 coarse iterations (W-cycle): e = B rc, then e += B (rc - A_c e); the
        # composition 2B - B A_c B is symmetric whenever B is, so the cycle stays symmetric.
        e = self.vcycle(rc, level + 1)
        for _ in range(self.gamma - 1):
            if level + 1 < len(self.A) - 1:
                e += self.vcycle(rc - self.A[level + 1] @ e, level + 1)
        x += self.P[level] @ e
        gauss_seidel(A, x, b, iterations=self.sweeps, sweep="backward")
        return x


def pcg(A, b, precond, rtol=1e-8, maxiter=300):
    """Preconditioned conjugate gradients from ``x0 = 0``.

    Stops at ``||b - A x|| <= rtol ||b||`` on the recursively updated residual (the caller
    checks the true residual).

    Returns
    -------
    x : ndarray
    iterations : int
    converged : bool
    ritz : ndarray
        Eigenvalues of the Lanczos tridiagonal matrix built from the CG coefficients: Ritz
        values of the preconditioned operator ``M^-1 A``, whose extremes converge first; they
        tell a few isolated small eigenvalues (deflatable) from a spread of them.
    """
    x = np.zeros_like(b)
    r = b.copy()
    bnorm = np.linalg.norm(b)
    z = precond(r)
    p = z.copy()
    rz = r @ z
    alphas, betas = [], []
    converged = False
    for _ in range(maxiter):
        q = A @ p
        a = rz / (p @ q)
        alphas.append(a)
        x += a * p
        r -= a * q
        if np.linalg.norm(r) <= rtol * bnorm:
            converged = True
            break
        z = precond(r)
        rz_new = r @ z
        betas.append(rz_new / rz)
        p *= betas[-1]
        p += z
        rz = rz_new
    # Lanczos matrix of CG: diagonal 1/a_j + b_{j-1}/a_{j-1}, off-diagonal sqrt(b_j)/a_j.
    a, bt = np.array(alphas), np.array(betas[:len(alphas) - 1])
    diag = 1.0 / a
    diag[1:] += bt / a[:-1]
    ritz = sla.eigvalsh_tridiagonal(diag, np.sqrt(bt) / a[:-1]) if len(a) > 1 else diag
    return x, len(alphas), converged, np.sort(ritz)


# ------------------------------------------------------------------------------------------
# Measurements
# ------------------------------------------------------------------------------------------

def _peak_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e6


def direct_solve(K, f):
    """Time of one direct solve from scratch (analysis + factorization + solve).

    Returns
    -------
    kind : str
    seconds : float
    relres : float
    """
    import scipy.sparse.linalg as spla

    try:
        import pypardiso
    except ImportError:
        pypardiso = None
    t = time.perf_counter()
    if pypardiso is not None:
        kind = "pardiso"
        solver = pypardiso.PyPardisoSolver()
        solver.set_matrix_type(2)  # real SPD: Cholesky, as the toolkit's backend uses
        u = solver.solve(sp.triu(K, format="csr"), f)
        solver.free_memory(everything=True)
    else:
        kind = "superlu"
        lu = spla.splu(K.tocsc(), permc_spec="MMD_AT_PLUS_A",
                       options=dict(SymmetricMode=True))
        u = lu.solve(f)
    dt = time.perf_counter() - t
    return kind, dt, float(np.linalg.norm(f - K @ u) / np.linalg.norm(f))


def run_size(m, transfers, sweeps_list, maxiter, cycle="V", coarse_max=COARSE_MAX, rtol=1e-8,
             log=print):
    """All cases at one grid size.

    Returns
    -------
    rows : list of dict
    """
    from tests.solvers.plate_system import crack_bands, grid_coords, plate_test_matrix

    winkler = 4e6
    coords = grid_coords(m)
    f = winkler * (-coords[:, 0] ** 2 / 2) / (m - 1) ** 2  # winkler * h^2 * w, as bench_usolve
    rows = []
    for damage in ("none", "cracks"):
        alpha = np.zeros(m * m) if damage == "none" else crack_bands(m)
        K = plate_test_matrix(alpha, nu=0.3, winkler=winkler, k_res=1e-6)
        direct = ("", float("nan"))
        if m <= DIRECT_MAX_M:
            kind, dt, res = direct_solve(K, f)
            direct = (kind, dt)
            log(f"  m={m} {damage}: {kind} {dt:.2f} s (relres {res:.1e})")
        for order in transfers:
            t = time.perf_counter()
            mg = GeometricMG(K, order=order, cycle=cycle, coarse_max=coarse_max)
            setup = time.perf_counter() - t
            # The hierarchy does not depend on the sweeps: one setup, timed once, serves both.
            for nu in sweeps_list:
                mg.sweeps = nu
                t = time.perf_counter()
                u, its, ok, ritz = pcg(K, f, mg.vcycle, rtol=rtol, maxiter=maxiter)
                solve = time.perf_counter() - t
                relres = float(np.linalg.norm(f - K @ u) / np.linalg.norm(f))
                total = setup + solve
                row = dict(m=m, unknowns=m * m, nnz=K.nnz, damage=damage, transfer=order,
                           sweeps=nu, cycle=cycle, levels=len(mg.A), coarse_n=mg.A[-1].shape[0],
                           op_complexity=round(mg.operator_complexity, 3),
                           setup_s=round(setup, 3), iterations=its, converged=ok,
                           ritz_min=round(float(ritz[0]), 4),
                           ritz_below_01=int((ritz < 0.1).sum()),
                           ritz_cond=round(float(ritz[-1] / ritz[0]), 1),
                           relres=f"{relres:.2e}", solve_s=round(solve, 3),
                           per_iter_s=round(solve / its, 4), total_s=round(total, 3),
                           direct_kind=direct[0], direct_s=round(direct[1], 3),
                           ratio_total_direct=round(total / direct[1], 2)
                           if direct[0] else "", peak_gb=round(_peak_gb(), 2))
                rows.append(row)
                log(f"  m={m} {damage} {order} nu={nu}: {its} its{'' if ok else ' (cap)'}, "
                    f"setup {setup:.2f} s, solve {solve:.2f} s, "
                    f"OC {mg.operator_complexity:.2f}, peak {row['peak_gb']} GB")
            del mg
    return rows


def load_rows(path):
    """Rows of an earlier ``gmg.csv`` (empty if there is none)."""
    if not path.exists():
        return []
    with open(path) as fh:
        return list(csv.DictReader(fh))


def write_outputs(rows, out):
    """Write ``gmg.csv`` and ``gmg.md`` from all rows (each carries its command)."""
    out.mkdir(parents=True, exist_ok=True)
    rows = sorted(rows, key=lambda r: (int(r["m"]), -int(r["levels"]), r["cycle"],
                                       r["damage"] != "none", r["transfer"], int(r["sweeps"])))
    commands = sorted({r["command"] for r in rows})
    with open(out / "gmg.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=FIELDS)
        w.writeheader()
        w.writerows(rows)
    lines = [
        "# Geometric multigrid as a CG preconditioner (plate + Winkler, 13-point stencil)",
        "",
        "Commands (rows merged by size, damage, transfer, sweeps and cycle): "
        + ", ".join(f"`{c}`" for c in commands),
        "",
        "Environment: `OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 "
        "NUMBA_NUM_THREADS=1 nice -n 19` on the 2-core machine while other timings ran on it:",
        "one thread everywhere, PARDISO included, so the direct times here are not the "
        "threaded ones of `usolve.md`.",
        "",
        "Problem: `plate_test_matrix`, nu = 0.3, winkler = 4e6, k_res = 1e-6; damage `none` "
        "(alpha = 0) or `cracks` (`crack_bands(m)`, alpha = 1 in the cores). Right-hand side "
        "`f = winkler h^2 (-x^2/2)` (as `bench_usolve`), CG from x0 = 0 to relative residual "
        "1e-8. V-cycle: Galerkin coarse operators, `nu` forward Gauss-Seidel sweeps before and "
        "`nu` backward after, dense Cholesky on the coarsest level. `OC` = operator complexity; "
        "`total` = setup + solve; `direct` = analysis + factorization + solve of the same "
        "matrix; `*` = not converged within the iteration cap. `cycle` W: two coarse-level "
        "cycles per level; `levels` 2: a two-grid method, sparse LU on the coarse level "
        "(`--coarse-max`). `Ritz`: eigenvalue estimates of the preconditioned operator from "
        "the CG coefficients (smallest, how many below 0.1, largest / smallest).",
        "",
        "| nodes | damage | transfer | nu | cycle | levels (coarsest n) | OC | its "
        "| Ritz min (# < 0.1), cond | setup [s] "
        "| solve [s] | per it [s] | total [s] | direct [s] | total / direct | peak GB |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        its = f"{r['iterations']}" + ("" if r["converged"] in (True, "True") else "*")
        d = f"{r['direct_s']} ({r['direct_kind']})" if r["direct_kind"] else ""
        lines.append(
            f"| {r['m']}^2 | {r['damage']} | {r['transfer']} | {r['sweeps']} | {r['cycle']} | "
            f"{r['levels']} ({r['coarse_n']}) | {r['op_complexity']} | {its} | "
            f"{r['ritz_min']} ({r['ritz_below_01']}), {r['ritz_cond']} | {r['setup_s']} "
            f"| {r['solve_s']} | {r['per_iter_s']} | {r['total_s']} | {d} | "
            f"{r['ratio_total_direct']} | {r['peak_gb']} |")
    lines += ["", "`peak GB` is the process's peak so far (cases run in one process, in order)."]
    (out / "gmg.md").write_text("\n".join(lines) + "\n" + FINDINGS)


def main(argv=None):
    """Command line: sizes, transfers, sweeps; writes the result files."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[125, 250, 500, 1000])
    ap.add_argument("--transfers", nargs="+", default=["cubic", "linear"],
                    choices=["cubic", "linear"])
    ap.add_argument("--sweeps", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--cycle", default="V", choices=["V", "W"])
    ap.add_argument("--coarse-max", type=int, default=COARSE_MAX,
                    help="coarsen to at most this many unknowns (above 2500: sparse LU; a "
                         "two-grid method with e.g. 70000 at 250^2 and 500^2)")
    ap.add_argument("--maxiter", type=int, default=300, help="CG iteration cap")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder of the result files")
    ap.add_argument("--report", action="store_true",
                    help="only rewrite gmg.md from gmg.csv (no measurement)")
    args = ap.parse_args(argv)
    if args.report:
        write_outputs(load_rows(args.out / "gmg.csv"), args.out)
        print((args.out / "gmg.md").read_text())
        return
    command = "python -m benchmarks.bench_gmg " + " ".join(sys.argv[1:] if argv is None
                                                           else argv)
    # Rows of earlier invocations stay unless this one measures the same case again.
    merged = {tuple(str(r[k]) for k in KEY): r for r in load_rows(args.out / "gmg.csv")}
    for m in args.sizes:
        t = time.perf_counter()
        for r in run_size(m, args.transfers, args.sweeps, args.maxiter, cycle=args.cycle,
                          coarse_max=args.coarse_max):
            r["command"] = command
            merged[tuple(str(r[k]) for k in KEY)] = r
        print(f"m={m}: {time.perf_counter() - t:.1f} s", flush=True)
        write_outputs(list(merged.values()), args.out)  # partial results survive a cut
    print((args.out / "gmg.md").read_text())


if __name__ == "__main__":
    main()
