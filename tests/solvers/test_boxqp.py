"""Tests of the bound-constrained damage solver :mod:`thinfilm.solvers.boxqp`.

The AT1 and AT2 damage problems are built here from the energy of docs/model.md, at fixed
elastic density ``W`` (the alpha-step of alternate minimization), per unit area on a
grid of spacing ``dx``::

    1/2 g(alpha) W + toughness / (4 c_m) (alpha^m / eta + eta |grad alpha|^2),
    g = (1 - alpha)^2,  c_1 = 2/3,  c_2 = 1/2

so that ``E(alpha) = 1/2 alpha.A.alpha - b.alpha + const`` with ``L`` the stiffness
Laplacian per unit area (``alpha.L.alpha`` = integral of ``|grad alpha|^2``, natural
boundary conditions)::

    AT1: A = diag(W) + toughness eta / (2 c_1) L,
         b = W - toughness / (4 c_1 eta)
    AT2: A = diag(W + toughness / (2 c_2 eta)) + toughness eta / (2 c_2) L,
         b = W
"""

import numpy as np
import pytest
import scipy.optimize
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.solvers import boxqp as damage
from thinfilm.solvers import kernels as damage_kernels
from thinfilm.solvers.boxqp import (
    BoxQPResult,
    DamageSolverError,
    box_qp_energy,
    kkt_residual,
    kkt_violation,
    solve_box_qp,
)

C_M = {1: 2.0 / 3.0, 2: 0.5}


# --------------------------------------------------------------------------------------
# Problem builders (sparse assembly, no Python loops over nodes)
# --------------------------------------------------------------------------------------


def laplacian_1d(n, dx):
    """Stiffness Laplacian per unit length, natural ends, shape (n, n)."""
    main = np.full(n, 2.0)
    main[[0, -1]] = 1.0
    off = -np.ones(n - 1)
    return sp.diags([off, main, off], [-1, 0, 1], format="csr") / dx**2


def laplacian_2d(nx, ny, dx):
    """5-point stiffness Laplacian per unit area on an nx-by-ny grid (x fastest)."""
    return (sp.kron(sp.identity(ny), laplacian_1d(nx, dx))
            + sp.kron(laplacian_1d(ny, dx), sp.identity(nx))).tocsr()


def at_problem(W, L, toughness, eta, at):
    """Matrix and right-hand side of the AT1/AT2 damage problem (module docstring)."""
    c_m = C_M[at]
    diagonal = W if at == 1 else W + toughness / (2 * c_m * eta)
    A = sp.csr_array(sp.diags(diagonal) + (toughness * eta / (2 * c_m)) * L)
    b = W - toughness / (4 * c_m * eta) if at == 1 else W.copy()
    return A, b


def damage_threshold(toughness, eta, at=1):
    """Uniform elastic density above which AT1 damage appears: toughness / (4 c_1 eta)."""
    return toughness / (4 * C_M[at] * eta)


def crack_band_density(nx, ny, eta, toughness=1.0, at=1, scale=1.0):
    """Elastic density on the unit square: sub-critical background, two crack bands.

    The bands (x = 0.3 and y = 0.6 + 0.1 x) carry 30 times the AT1 threshold, which
    drives damage to nearly 1 across them; ``scale`` multiplies everything (a load
    increment).
    """
    x, y = np.linspace(0, 1, nx), np.linspace(0, 1, ny)
    X, Y = np.meshgrid(x, y)  # shape (ny, nx): x is fastest after ravel
    dx = x[1] - x[0]
    thr = damage_threshold(toughness, eta, at)
    W = 0.4 * thr * (1 + 0.5 * np.sin(3 * X) * np.cos(2 * Y))
    W += 30 * thr * np.exp(-(((X - 0.3) / (1.5 * dx)) ** 2))
    W += 30 * thr * np.exp(-(((Y - 0.6 - 0.1 * X) / (1.5 * dx)) ** 2))
    return scale * W.ravel()


def grid_problem_2d(n, at, scale=1.0, eta_cells=4):
    dx = 1.0 / (n - 1)
    eta = eta_cells * dx
    W = crack_band_density(n, n, eta, at=at, scale=scale)
    return at_problem(W, laplacian_2d(n, n, dx), 1.0, eta, at)


# --------------------------------------------------------------------------------------
# Independent checks
# --------------------------------------------------------------------------------------


def assert_feasible_exactly(a, lower, upper):
    lower = np.broadcast_to(lower, a.shape)
    upper = np.broadcast_to(upper, a.shape)
    assert np.all(a >= lower) and np.all(a <= upper)


def assert_kkt(A, b, a, lower, upper, tol):
    """KKT conditions written out independently, scaled by the diagonal of A."""
    lower = np.broadcast_to(lower, a.shape)
    upper = np.broadcast_to(upper, a.shape)
    r = (A @ a - b) / A.diagonal()
    fixed = lower == upper
    at_lower = (a == lower) & ~fixed
    at_upper = (a == upper) & ~fixed
    free = ~(fixed | at_lower | at_upper)
    assert np.all(r[at_lower] >= -tol)
    assert np.all(r[at_upper] <= tol)
    assert np.all(np.abs(r[free]) <= tol)


def lbfgsb_reference(A, b, lower, upper):
    """Minimizer from SciPy's L-BFGS-B with tight tolerances (an independent solver)."""
    n = b.size
    lower = np.broadcast_to(lower, (n,))
    upper = np.broadcast_to(upper, (n,))

    def fun(a):
        Aa = A @ a
        return 0.5 * a @ Aa - b @ a, Aa - b

    out = scipy.optimize.minimize(
        fun, np.clip(np.zeros(n), lower, upper), jac=True, method="L-BFGS-B",
        bounds=list(zip(lower, upper)),
        options={"ftol": 1e-16, "gtol": 1e-12, "maxiter": 50_000, "maxcor": 50})
    return out.x


# --------------------------------------------------------------------------------------
# Analytic 1D cases
# --------------------------------------------------------------------------------------


def test_diagonal_matrix_gives_clipped_jacobi_point_exactly():
    rng = np.random.default_rng(0)
    n = 200
    d = rng.uniform(0.5, 3.0, n)
    b = rng.uniform(-2.0, 4.0, n)
    lower = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0.0, 0.5, n))
    res = solve_box_qp(sp.diags(d, format="csr"), b, lower, 1.0)
    expected = np.clip(b / d, lower, 1.0)
    # Clipped nodes hold the bound values themselves; free nodes b/d up to the
    # rounding of the Newton update a + (b - d a)/d (one ulp).
    clipped = (expected == lower) | (expected == 1.0)
    np.testing.assert_array_equal(res.a[clipped], expected[clipped])
    np.testing.assert_allclose(res.a, expected, rtol=4e-16, atol=0)
    assert res.iterations == 1
    assert res.n_upper > 0 and res.n_lower > 0 and res.n_free > 0


def test_at1_profile_around_a_fixed_crack_is_exact_in_1d():
    """With W = 0 and alpha = 1 imposed at x = 0, AT1 gives alpha = (1 - |x|/(2 eta))^2.

    When 2 eta / dx is an integer k, the discrete solution is that profile sampled at
    the nodes: a quadratic has an exact second difference, alpha_k = 0 is the free
    boundary, and the nodes beyond it have residual toughness/(8 c_1 eta) > 0.
    """
    n, k = 401, 24
    x = np.linspace(-0.5, 0.5, n)
    dx = x[1] - x[0]
    eta = k * dx / 2
    A, b = at_problem(np.zeros(n), laplacian_1d(n, dx), 1.0, eta, at=1)
    lower = np.zeros(n)
    lower[n // 2] = 1.0  # an existing crack: lower == upper == 1 there
    res = solve_box_qp(A, b, lower, 1.0)
    exact = np.clip(1 - np.abs(x) / (2 * eta), 0, None) ** 2
    np.testing.assert_allclose(res.a, exact, rtol=0, atol=1e-12)
    assert res.a[n // 2] == 1.0 and res.n_fixed == 1
    assert res.n_free == 2 * (k - 1)
    assert np.all(res.a[np.abs(x) >= 2 * eta - 1e-12] == 0.0)


def test_upper_bound_active_on_a_band_with_analytic_profile_1d():
    """A band driven beyond alpha = 1 sits on the upper bound; outside it, the AT1
    profile (1 - dist/(2 eta))^2 from the band's edge (exact, as above)."""
    n, k = 301, 16
    x = np.linspace(0, 1, n)
    dx = x[1] - x[0]
    eta = k * dx / 2
    band = (x >= 0.4 - 1e-12) & (x <= 0.5 + 1e-12)
    W = np.where(band, 50.0, 0.0)
    A, b = at_problem(W, laplacian_1d(n, dx), 1.0, eta, at=1)
    b[band] = 10 * A.diagonal()[band]  # pushes the band far past alpha = 1
    res = solve_box_qp(A, b, 0.0, 1.0)
    dist = np.maximum(np.maximum(0.4 - x, x - 0.5), 0.0)
    exact = np.clip(1 - dist / (2 * eta), 0, None) ** 2
    np.testing.assert_allclose(res.a, exact, rtol=0, atol=1e-12)
    assert np.all(res.a[band] == 1.0)
    assert res.n_upper == np.count_nonzero(band)
    assert_kkt(A, b, res.a, 0.0, 1.0, 1e-8)


# --------------------------------------------------------------------------------------
# Realistic AT1 / AT2 problems against an independent solver
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("at", [1, 2])
def test_2d_grid_matches_lbfgsb(at):
    A, b = grid_problem_2d(40, at, eta_cells=2)
    res = solve_box_qp(A, b, 0.0, 1.0)
    assert isinstance(res, BoxQPResult) and res.converged
    assert_feasible_exactly(res.a, 0.0, 1.0)
    assert_kkt(A, b, res.a, 0.0, 1.0, 1e-8)
    assert res.kkt_residual == pytest.approx(kkt_residual(A, b, res.a, 0.0, 1.0), abs=1e-15)
    ref = lbfgsb_reference(A, b, 0.0, 1.0)
    np.testing.assert_allclose(res.a, ref, atol=1e-6)
    # Ours is the minimizer: no higher than the reference, up to round-off.
    e_ref = box_qp_energy(A, b, ref)
    assert res.energy <= e_ref + 1e-12 * abs(e_ref)
    assert res.energy == pytest.approx(box_qp_energy(A, b, res.a), rel=1e-12)
    if at == 1:
        assert res.n_free > 0 and res.n_lower > b.size // 3  # damage localized
        assert res.a.max() > 0.9
    else:
        assert res.n_free == b.size  # AT2: every node damaged a little


@pytest.mark.parametrize("at", [1, 2])
def test_1d_irreversible_step_matches_lbfgsb(at):
    """A second load step: lower = previous damage, part of it active."""
    n = 300
    x = np.linspace(0, 1, n)
    dx = x[1] - x[0]
    eta = 5 * dx
    L = laplacian_1d(n, dx)
    thr = damage_threshold(1.0, eta, at)
    W1 = thr * (0.5 + 3 * np.exp(-((x - 0.3) / 0.02) ** 2) + 2 * np.exp(-((x - 0.7) / 0.03) ** 2))
    A1, b1 = at_problem(W1, L, 1.0, eta, at)
    first = solve_box_qp(A1, b1, 0.0, 1.0)
    W2 = W1 * (1 + 0.3 * np.sin(9 * x))  # grows at some places, shrinks at others
    A2, b2 = at_problem(W2, L, 1.0, eta, at)
    res = solve_box_qp(A2, b2, first.a, 1.0, a0=first.a)
    assert_feasible_exactly(res.a, first.a, 1.0)
    assert_kkt(A2, b2, res.a, first.a, 1.0, 1e-8)
    assert res.n_lower > 0 and res.n_free > 0
    np.testing.assert_allclose(res.a, lbfgsb_reference(A2, b2, first.a, 1.0), atol=1e-6)


@pytest.mark.parametrize("seed", range(6))
def test_non_m_matrix_random_spd_matches_lbfgsb(seed):
    """Dense-ish random SPD matrices (positive off-diagonals: not an M-matrix, the
    plain active-set method can cycle) with random bounds, fixed nodes, a bad a0."""
    rng = np.random.default_rng(seed)
    n = 40
    B = rng.standard_normal((n, n)) * (rng.random((n, n)) < 0.3)
    A = sp.csr_array(B.T @ B + 0.05 * np.eye(n))
    b = 3 * rng.standard_normal(n)
    lower = rng.uniform(-1.0, 0.5, n) * (rng.random(n) < 0.5)
    upper = np.maximum(lower, rng.uniform(0.0, 2.0, n))
    fixed = rng.random(n) < 0.1
    upper[fixed] = lower[fixed]
    res = solve_box_qp(A, b, lower, upper, a0=rng.uniform(-2, 2, n), rtol=1e-10)
    assert_feasible_exactly(res.a, lower, upper)
    assert_kkt(A, b, res.a, lower, upper, 1e-10)
    assert np.all(np.diff(res.energies) <= 0.0)
    np.testing.assert_allclose(res.a, lbfgsb_reference(A, b, lower, upper), atol=1e-5)


def test_linear_solvers_agree():
    A, b = grid_problem_2d(30, at=1)
    rtol = 1e-11  # the solutions then agree to about 1e-9
    results = [
        solve_box_qp(A, b, 0.0, 1.0, rtol=rtol, linear_solver="direct"),
        solve_box_qp(A, b, 0.0, 1.0, rtol=rtol, linear_solver="cg"),
        solve_box_qp(A, b, 0.0, 1.0, rtol=rtol, linear_solver="auto", direct_max_free=0),
        solve_box_qp(A, b, 0.0, 1.0, rtol=rtol,
                     linear_solver=lambda A_ff, rhs, tol: spla.spsolve(A_ff.tocsc(), rhs)),
    ]
    assert results[0].linear_iterations == 0 and results[1].linear_iterations > 0
    for res in results[1:]:
        np.testing.assert_allclose(res.a, results[0].a, atol=1e-9)
        assert_kkt(A, b, res.a, 0.0, 1.0, rtol)


def test_tolerance_is_invariant_under_scaling_of_the_energy():
    A, b = grid_problem_2d(20, at=1)
    res = solve_box_qp(A, b, 0.0, 1.0)
    scaled = solve_box_qp(1e6 * A, 1e6 * b, 0.0, 1.0)
    assert scaled.iterations == res.iterations
    assert scaled.kkt_residual == pytest.approx(res.kkt_residual, rel=1e-6, abs=1e-14)
    np.testing.assert_allclose(scaled.a, res.a, atol=1e-10)


# --------------------------------------------------------------------------------------
# Safeguard, warm start, failure
# --------------------------------------------------------------------------------------


def test_energy_never_increases_checked_independently():
    A, b = grid_problem_2d(30, at=1)
    energies = []
    res = solve_box_qp(A, b, 0.0, 1.0,
                       callback=lambda it, a: energies.append(box_qp_energy(A, b, a)))
    assert len(energies) == res.iterations >= 5
    e = np.array([box_qp_energy(A, b, np.zeros(b.size))] + energies)
    assert np.all(np.diff(e) <= 1e-13 * np.abs(e).max())
    assert np.all(np.diff(res.energies) <= 0.0)
    np.testing.assert_allclose(res.energies, e, rtol=1e-10)
    assert res.energies.shape == res.kkt_residuals.shape == (res.iterations + 1,)


def test_safeguard_survives_a_wrong_newton_direction():
    """A reduced solver that returns the wrong sign makes every Newton point uphill:
    the safeguard must reject them, fall back on projected-gradient steps, never raise
    the energy, and still converge to the minimizer."""
    A, b = grid_problem_2d(12, at=2)
    ref = solve_box_qp(A, b, 0.0, 1.0)
    res = solve_box_qp(A, b, 0.0, 1.0, rtol=1e-6, max_iter=500,
                       linear_solver=lambda A_ff, rhs, tol: -spla.spsolve(A_ff.tocsc(), rhs))
    assert set(res.steps) == {"projected-gradient"}
    assert np.all(np.diff(res.energies) <= 0.0)
    assert_feasible_exactly(res.a, 0.0, 1.0)
    assert_kkt(A, b, res.a, 0.0, 1.0, 1e-6)
    np.testing.assert_allclose(res.a, ref.a, atol=1e-4)


@pytest.mark.parametrize("at", [1, 2])
def test_warm_start_needs_few_iterations(at):
    """A small load increment from the previous solution (lower = previous damage)."""
    A, b = grid_problem_2d(60, at)
    cold = solve_box_qp(A, b, 0.0, 1.0)
    A2, b2 = grid_problem_2d(60, at, scale=1.002)
    warm = solve_box_qp(A2, b2, cold.a, 1.0, a0=cold.a)
    assert warm.iterations <= 3
    assert_kkt(A2, b2, warm.a, cold.a, 1.0, 1e-8)
    if at == 1:  # (AT2 damages every node at once: 1 iteration even cold)
        assert solve_box_qp(A2, b2, 0.0, 1.0).iterations >= 2 * warm.iterations
    # Restarting from a solution of the same problem costs no step at all.
    again = solve_box_qp(A2, b2, cold.a, 1.0, a0=warm.a)
    assert again.iterations == 0 and again.steps == ()


def test_non_convergence_raises_with_residual_and_iterations():
    A, b = grid_problem_2d(40, at=1)
    with pytest.raises(DamageSolverError) as info:
        solve_box_qp(A, b, 0.0, 1.0, max_iter=1)
    err = info.value
    assert isinstance(err, RuntimeError)
    assert err.iterations == 1 and err.kkt_residual > 1e-8
    message = str(err)
    assert "KKT residual" in message and f"{err.kkt_residual:.3e}" in message
    assert "after 1 iterations" in message
    assert err.result is not None and not err.result.converged
    assert_feasible_exactly(err.result.a, 0.0, 1.0)

    quiet = solve_box_qp(A, b, 0.0, 1.0, max_iter=1, raise_on_failure=False)
    assert not quiet.converged and quiet.iterations == 1


# --------------------------------------------------------------------------------------
# Degenerate sets and inputs
# --------------------------------------------------------------------------------------


def test_fixed_nodes_lower_equals_upper():
    A, b = grid_problem_2d(20, at=1)
    n = b.size
    rng = np.random.default_rng(3)
    lower = np.zeros(n)
    upper = np.ones(n)
    fixed = rng.random(n) < 0.2
    lower[fixed] = upper[fixed] = rng.uniform(0, 1, np.count_nonzero(fixed))
    res = solve_box_qp(A, b, lower, upper)
    np.testing.assert_array_equal(res.a[fixed], lower[fixed])
    assert res.n_fixed == np.count_nonzero(fixed)
    assert res.n_fixed + res.n_free + res.n_lower + res.n_upper == n
    assert_kkt(A, b, res.a, lower, upper, 1e-8)
    np.testing.assert_allclose(res.a, lbfgsb_reference(A, b, lower, upper), atol=1e-6)

    everything_fixed = solve_box_qp(A, b, lower, lower)
    np.testing.assert_array_equal(everything_fixed.a, lower)
    assert everything_fixed.iterations == 0 and everything_fixed.n_fixed == n


def test_all_nodes_active():
    n = 50
    dx = 1.0 / (n - 1)
    eta = 4 * dx
    L = laplacian_1d(n, dx)
    # Below the damage threshold everywhere: the sound state is optimal at once.
    A, b = at_problem(np.full(n, 0.5 * damage_threshold(1.0, eta)), L, 1.0, eta, at=1)
    res = solve_box_qp(A, b, 0.0, 1.0)
    assert res.iterations == 0 and res.n_lower == n and res.n_free == 0
    np.testing.assert_array_equal(res.a, np.zeros(n))
    # Driven beyond 1 everywhere: one step with an empty free set puts all on 1.
    res = solve_box_qp(A, 2 * A.diagonal() + 1.0, 0.0, 1.0)
    assert res.iterations == 1 and res.n_upper == n and res.n_free_history == (0,)
    np.testing.assert_array_equal(res.a, np.ones(n))


def test_infeasible_initial_guess_is_projected():
    A, b = grid_problem_2d(20, at=1)
    n = b.size
    lower = np.where(np.arange(n) % 7 == 0, 0.3, 0.0)
    a0 = np.random.default_rng(1).uniform(-1.0, 2.0, n)
    res = solve_box_qp(A, b, lower, 1.0, a0=a0)
    assert res.a0_projected == np.count_nonzero((a0 < lower) | (a0 > 1.0))
    assert_feasible_exactly(res.a, lower, 1.0)
    cold = solve_box_qp(A, b, lower, 1.0)
    np.testing.assert_allclose(res.a, cold.a, atol=1e-9)
    assert np.all(np.diff(res.energies) <= 0.0)
    # The caller's array is not modified.
    assert a0.min() < 0


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(lower=np.r_[0.0, 0.9, 0.0], upper=np.r_[1.0, 0.5, 1.0]),
         r"lower\[1\] = 0.9 > upper\[1\] = 0.5"),
        (dict(b=np.ones(4)), r"b.shape = \(4,\): must be \(3,\)"),
        (dict(b=np.r_[1.0, np.nan, 0.0]), r"b\[1\] = nan: must be finite"),
        (dict(a0=np.r_[0.0, 0.0, np.inf]), r"a0\[2\] = inf"),
        (dict(upper=np.nan), "upper = nan"),
        (dict(A=sp.csr_array(np.diag([1.0, 0.0, 1.0]))),
         r"A\[1, 1\] = 0.0: the diagonal of A must be > 0"),
        (dict(A=sp.csr_array(np.array([[1.0, np.nan, 0], [np.nan, 1, 0], [0, 0, 1]]))),
         "non-finite entry in row 0"),
        (dict(A=np.eye(3)), "must be a scipy.sparse"),
        (dict(rtol=0.0), "rtol = 0.0: must be a finite number > 0"),
        (dict(max_iter=-1), "max_iter = -1: must be an integer >= 0"),
        (dict(linear_solver="cholesky"),
         "linear_solver = 'cholesky': must be one of auto, direct, cg"),
    ],
)
def test_invalid_input_is_reported(kwargs, match):
    args = dict(A=sp.csr_array(2 * np.eye(3)), b=np.ones(3), lower=0.0, upper=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        solve_box_qp(args.pop("A"), args.pop("b"), args.pop("lower"), args.pop("upper"), **args)


def test_empty_problem():
    res = solve_box_qp(sp.csr_array((0, 0)), np.zeros(0), 0.0, 1.0)
    assert res.a.shape == (0,) and res.iterations == 0 and res.converged


# --------------------------------------------------------------------------------------
# Kernels against their NumPy references
# --------------------------------------------------------------------------------------


def _random_state(n=500, seed=0):
    rng = np.random.default_rng(seed)
    A, b = grid_problem_2d(int(np.sqrt(n)), at=1)
    n = b.size
    lower = np.where(rng.random(n) < 0.3, rng.uniform(0, 0.5, n), 0.0)
    upper = np.where(rng.random(n) < 0.1, lower, 1.0)
    a = np.clip(rng.uniform(-0.5, 1.5, n), lower, upper)
    return A, b, lower, upper, a


def test_prediction_kernel_matches_reference():
    A, b, lower, upper, a = _random_state()
    r = A @ a - b
    dinv = 1.0 / A.diagonal()
    n = b.size
    status, z, dz, violation = (np.empty(n, np.int8), np.empty(n), np.empty(n), np.empty(n))
    damage_kernels.predict_all(a, r, lower, upper, dinv, status, z, dz, violation)
    ref = damage_kernels.predict_reference(a, r, lower, upper, dinv)
    for got, want in zip((status, z, dz, violation), ref):
        np.testing.assert_array_equal(got, want)
    assert {0, 1, 2, 3} <= set(np.unique(status).tolist())
    np.testing.assert_allclose(violation, kkt_violation(r, a, lower, upper) * dinv)
    # The subset kernel writes the same values on the listed nodes only.
    nodes = np.arange(0, n, 3, dtype=np.int64)
    status2 = np.full(n, 9, np.int8)
    damage_kernels.predict_nodes(nodes, a, r, lower, upper, dinv, status2, z, dz, violation)
    np.testing.assert_array_equal(status2[nodes], ref[0][nodes])
    assert np.all(np.delete(status2, nodes) == 9)


def test_reduced_system_kernel_matches_reference():
    A, b, lower, upper, a = _random_state(seed=1)
    n = b.size
    r = A @ a - b
    dz = np.where(np.random.default_rng(2).random(n) < 0.2, 0.1, 0.0)
    free = np.flatnonzero(np.random.default_rng(3).random(n) < 0.4)
    dz[free] = 0.0
    local = np.full(n, -1, np.int64)
    local[free] = np.arange(free.size)
    indptr, indices, data, rhs = damage_kernels.extract_free_system(A.indptr, A.indices, A.data,
                                                            free, local, r, dz)
    A_ff = sp.csr_array((data, indices, indptr), shape=(free.size,) * 2)
    A_ref, rhs_ref = damage_kernels.extract_free_system_reference(A, free, r, dz)
    np.testing.assert_allclose(A_ff.toarray(), A_ref.toarray(), rtol=0, atol=0)
    np.testing.assert_allclose(rhs, rhs_ref, rtol=1e-14, atol=1e-12)


def test_local_step_matches_full_products():
    A, b, lower, upper, a = _random_state(seed=4)
    n = b.size
    r = A @ a - b
    rng = np.random.default_rng(5)
    nodes = np.sort(rng.choice(n, n // 5, replace=False)).astype(np.int64)
    values = rng.uniform(0, 1, nodes.size)
    s = values - a[nodes]
    new = a.copy()
    new[nodes] = values
    full = new - a

    step = damage.LocalStep(A)
    d_energy, slope = step.evaluate(nodes, s, r)
    assert slope == pytest.approx(float(full @ r), rel=1e-12)
    assert d_energy == pytest.approx(float(full @ r) + 0.5 * float(full @ (A @ full)), rel=1e-12)
    assert d_energy == pytest.approx(box_qp_energy(A, b, new) - box_qp_energy(A, b, a), rel=1e-9)
    # A second evaluation (a backtracked step) must not accumulate onto the first.
    d_half, _ = step.evaluate(nodes, 0.5 * s, r)
    assert d_half == pytest.approx(0.5 * float(full @ r) + 0.125 * float(full @ (A @ full)),
                                   rel=1e-12)
    step.evaluate(nodes, s, r)
    a2, r2 = a.copy(), r.copy()
    changed = step.apply(nodes, values, a2, r2)
    np.testing.assert_array_equal(a2, new)
    np.testing.assert_allclose(r2, A @ new - b, atol=1e-12 * np.abs(r).max())
    np.testing.assert_array_equal(np.sort(changed), np.flatnonzero(np.abs(A) @ (full != 0)))
    assert not step._As.any() and not step._marked.any()


def test_residual_rows_kernel():
    A, b, lower, upper, a = _random_state(seed=7)
    r = np.full(b.size, np.nan)
    rows = np.arange(3, b.size, 5, dtype=np.int64)
    damage_kernels.residual_rows(A.indptr, A.indices, A.data, a, b, rows, r)
    np.testing.assert_allclose(r[rows], (A @ a - b)[rows], rtol=1e-13, atol=1e-12)
    assert np.isnan(np.delete(r, rows)).all()


def test_split_and_prepare_kernels():
    status = np.array([0, 3, 2, 0, 1, 4], np.int8)
    free, moving = damage_kernels.split_step_nodes(status)
    np.testing.assert_array_equal(free, [0, 3])
    np.testing.assert_array_equal(moving, [1, 5])

    lower = np.array([0.0, 0.2, 0.0])
    upper = np.array([1.0, 0.2, 0.5])
    a0 = np.array([-1.0, 0.7, 0.3])
    a, dinv = np.empty(3), np.empty(3)
    out = damage_kernels.prepare(np.ones(3), lower, upper, a0, np.array([2.0, 4.0, 1.0]), a, dinv)
    assert out == (0, 0, 2)
    np.testing.assert_array_equal(a, [0.0, 0.2, 0.3])
    np.testing.assert_array_equal(dinv, [0.5, 0.25, 1.0])
    bad_diag = np.array([2.0, 4.0, -1.0])
    assert damage_kernels.prepare(np.ones(3), lower, upper, a0, bad_diag, a, dinv)[:2] == (6, 2)


def test_pcg_kernel_solves_to_the_scaled_tolerance():
    A, _ = grid_problem_2d(30, at=2)
    rhs = np.random.default_rng(6).standard_normal(A.shape[0])
    dinv = 1.0 / A.diagonal()
    x = np.zeros_like(rhs)
    iterations, residual = damage_kernels.pcg_jacobi(A.indptr, A.indices, A.data, rhs, dinv,
                                              1e-11, 1000, x)
    assert 0 < iterations < 1000 and residual <= 1e-11
    assert np.max(np.abs(A @ x - rhs) * dinv) <= 1e-10
    # Not positive definite: reported as a breakdown.
    x = np.zeros(2)
    M = sp.csr_array(np.array([[1.0, 2.0], [2.0, 1.0]]))
    _, residual = damage_kernels.pcg_jacobi(M.indptr, M.indices, M.data, np.array([1.0, -1.0]),
                                     np.ones(2), 1e-12, 10, x)
    assert residual == -1.0


def test_count_classes_kernel():
    a = np.array([0.0, 0.5, 1.0, 0.2, 0.0])
    lower = np.array([0.0, 0.0, 0.0, 0.2, 0.0])
    upper = np.array([1.0, 1.0, 1.0, 0.2, 0.0])
    assert damage_kernels.count_classes(a, lower, upper) == (1, 1, 1, 2)
