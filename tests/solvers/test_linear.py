"""Tests of the u-problem linear solvers (thinfilm.solvers.linear) on plate-like test systems."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from tests.solvers.plate_system import crack_bands, grid_coords, plate_test_matrix
from thinfilm.plate.grid import Grid
from thinfilm.plate.operators import PlateOperator, near_nullspace
from thinfilm.solvers.linear import (
    ROUNDOFF_BACKWARD_ERROR,
    AMGSolver,
    DirectSolver,
    LinearSolverError,
    backward_error,
    make_solver,
    pardiso_available,
)

M = 48  # nodes per side: 2304 unknowns, fast for every kind
RTOL = 1e-8
# lam = 2: at this resolution a realistic lam = 31.6 makes the Winkler term dominate (easy for
# every solver); lam = 2 keeps the plate term in charge, as on the production grids.
WINKLER = 4.0 * 2.0**4

DIRECT_BACKENDS = ["superlu"] + (["pardiso"] if pardiso_available() else [])
# single precision: PARDISO's factorization in float32, each solve refined by CG to rtol
SINGLE = [("direct", {"backend": "pardiso", "precision": "single"})] if pardiso_available() else []
ALL_KINDS = [("direct", {"backend": b}) for b in DIRECT_BACKENDS] + SINGLE + [("amg", {})]
KIND_IDS = [f"direct-{b}" for b in DIRECT_BACKENDS] + ["direct-pardiso-single"] * len(SINGLE) + ["amg"]


def bending_load(m, winkler=WINKLER, t=1.0):
    """Right-hand side ``winkler * h^2 * w_t`` for the pure-bending load ``w_t = -t x^2 / 2``."""
    c = grid_coords(m)
    return winkler * (-t * c[:, 0] ** 2 / 2) / (m - 1) ** 2


def relres(K, f, u):
    return np.linalg.norm(f - K @ u) / np.linalg.norm(f)


@pytest.fixture(scope="module")
def cracked():
    """A cracked plate and the same plate with the diagonal crack grown by 2 cells."""
    K1 = plate_test_matrix(crack_bands(M), winkler=WINKLER)
    K2 = plate_test_matrix(crack_bands(M, grow=2), winkler=WINKLER)
    return K1, K2, bending_load(M), grid_coords(M)


# ---------------------------------------------------------------------------- test matrix
def test_test_matrix_is_symmetric_with_rigid_nullspace():
    m = 10
    K = plate_test_matrix(np.zeros(m * m), winkler=0.0, nu=0.3).toarray()
    assert np.abs(K - K.T).max() <= 1e-12 * np.abs(K).max()
    w = np.linalg.eigvalsh(K)
    assert np.all(w[:3] < 1e-10 * w[-1]) and w[3] > 1e-6 * w[-1]  # exactly 3 zero modes
    c = grid_coords(m)
    for v in (np.ones(m * m), c[:, 0], c[:, 1]):
        assert np.linalg.norm(K @ v) < 1e-9 * np.abs(K).max()
    assert np.linalg.norm(K @ (c[:, 0] * c[:, 1])) > 1e-3  # twist is not a zero mode


def test_test_matrix_pattern_does_not_depend_on_damage():
    K1 = plate_test_matrix(np.zeros(M * M))
    K2 = plate_test_matrix(crack_bands(M))
    assert np.array_equal(K1.indptr, K2.indptr) and np.array_equal(K1.indices, K2.indices)
    row = K1[(M // 2) * M + M // 2]  # an interior node couples to 13 nodes
    assert row.nnz == 13


# ---------------------------------------------------------------------------- accuracy
@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_solves_to_requested_tolerance_and_matches_spsolve(cracked, kind, opts):
    K1, _, f, c = cracked
    ref = spla.spsolve(K1.tocsc(), f)
    s = make_solver(kind, K1, near_nullspace=near_nullspace(c), **opts)
    s.update(K1)
    for rtol in (1e-6, RTOL):
        u, info = s.solve(f, rtol=rtol)
        assert np.all(np.isfinite(u))
        assert info.residual <= rtol
        assert relres(K1, f, u) <= rtol * 1.01  # the reported residual is the true one
        assert info.time >= 0.0 and info.rtol == rtol
    assert np.linalg.norm(u - ref) / np.linalg.norm(ref) < 1e-5


@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_callable_form_updates_then_solves(cracked, kind, opts):
    K1, K2, f, c = cracked
    s = make_solver(kind, K1, near_nullspace=near_nullspace(c), **opts)
    u1, _ = s(K1, f)
    u2, info = s(K2, f, x0=u1)
    assert relres(K2, f, u2) <= RTOL
    assert not np.allclose(u1, u2)


@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_callable_form_takes_values_rewritten_in_place(cracked, kind, opts):
    # The plate operator returns one matrix object with its values rewritten: a second call
    # with the same object must solve the new values, not reuse the old factorization.
    K1, K2, f, c = cracked
    K = K1.copy()
    s = make_solver(kind, K, near_nullspace=near_nullspace(c), **opts)
    s(K, f)
    K.data[:] = K2.data
    u, _ = s(K, f)
    assert relres(K2, f, u) <= RTOL


def test_direct_refactorizes_only_after_update(cracked):
    K1, K2, f, _ = cracked
    s = DirectSolver(K1)
    s.update(K1)
    _, i1 = s.solve(f)
    _, i2 = s.solve(2 * f)
    s.update(K2)
    u, i3 = s.solve(f)
    assert i1.rebuilt and not i2.rebuilt and i3.rebuilt
    assert relres(K2, f, u) <= RTOL


@pytest.mark.skipif(not pardiso_available(), reason="single precision needs PARDISO")
@pytest.mark.parametrize("rtol", [1e-5, 1e-8])
def test_single_precision_is_refined_to_the_asked_residual(cracked, rtol):
    """The float32 factorization alone is far from rtol; CG refines each solve to it, and the
    result agrees with the double-precision solve as the residual bound allows."""
    K1, _, f, _ = cracked
    exact, _ = DirectSolver(K1, backend="pardiso", precision="double")(K1, f)
    single = DirectSolver(K1, backend="pardiso", precision="single")
    u, info = single(K1, f, rtol=rtol)
    assert single.kind == "direct:pardiso-single" and single.precision == "single"
    assert info.iterations >= 1  # the refinement ran: the float32 solve alone misses rtol
    assert info.residual <= rtol and relres(K1, f, u) <= rtol * 1.01
    # the energy-norm error of an approximate solve is bounded by its residual:
    # ||u - u*||_K^2 = r.K^-1 r <= |r|^2 / lambda_min(K)
    lam_min = spla.eigsh(K1, k=1, sigma=0, which="LM", return_eigenvectors=False)[0]
    error = u - exact
    assert float(error @ (K1 @ error)) <= (np.linalg.norm(f - K1 @ u) ** 2 / lam_min) * 1.01 + 1e-30


@pytest.mark.skipif(not pardiso_available(), reason="single precision needs PARDISO")
def test_single_precision_refinement_starts_from_a_close_x0(cracked):
    """After a small change of K (the crack grown by 2 cells), the last solution is a closer
    start than the float32 solve: fewer refinement steps, the same residual bound; a start
    far off (zeros) is not taken."""
    K1, K2, f, _ = cracked
    single = DirectSolver(K1, backend="pardiso", precision="single")
    u1, _ = single(K1, f, rtol=1e-8)
    _, cold = single(K2, f, rtol=1e-8)
    u2, warm = single(K2, f, x0=u1, rtol=1e-8)
    assert relres(K2, f, u1) < 0.1  # the start taken
    assert warm.residual <= 1e-8 and relres(K2, f, u2) <= 1e-8 * 1.01
    assert warm.iterations < cold.iterations
    _, zero = single(K2, f, x0=np.zeros_like(f), rtol=1e-8)
    assert zero.iterations == cold.iterations


def test_precision_auto_rule_and_refusals(cracked, monkeypatch):
    import thinfilm.solvers.linear.direct as direct

    K1 = cracked[0]
    assert DirectSolver(K1, backend="superlu").precision == "double"
    with pytest.raises(ValueError, match="needs the PARDISO backend"):
        DirectSolver(K1, backend="superlu", precision="single")
    with pytest.raises(ValueError, match="precision"):
        DirectSolver(K1, precision="half")
    if pardiso_available():
        assert DirectSolver(K1, backend="pardiso").precision == "double"  # below the threshold
        monkeypatch.setattr(direct, "AUTO_SINGLE_MIN_UNKNOWNS", K1.shape[0])
        assert DirectSolver(K1, backend="pardiso").precision == "single"
        assert make_solver("direct", K1, precision="double").precision == "double"


def test_superlu_reused_order_matches_first_factorization(cracked):
    K1, K2, f, _ = cracked
    s = DirectSolver(K1, backend="superlu")
    s.update(K1)
    s.solve(f)  # orders with MMD_AT_PLUS_A
    s.update(K2)
    u, info = s.solve(f)  # reuses the order (NATURAL on the permuted matrix)
    fresh = DirectSolver(K2, backend="superlu")
    _, ref = fresh(K2, f)
    assert info.residual <= max(10 * ref.residual, 1e-12)
    ref_u = spla.spsolve(K2.tocsc(), f)
    assert np.linalg.norm(u - ref_u) / np.linalg.norm(ref_u) < 1e-6


# ---------------------------------------------------------------------------- AMG reuse
def test_amg_hierarchy_kept_across_small_damage_changes(cracked):
    K1, _, f, c = cracked
    s = AMGSolver(K1, near_nullspace=near_nullspace(c))
    s.update(K1)
    u, first = s.solve(f)
    assert first.rebuilt and first.iterations <= 60
    for grow in (1, 2, 3, 4):
        K = plate_test_matrix(crack_bands(M, grow=grow), winkler=WINKLER)
        s.update(K)
        u, info = s.solve(f)  # cold start: compare raw counts with the first solve
        assert not info.rebuilt
        assert info.iterations <= first.iterations + 5
        assert relres(K, f, u) <= RTOL
    assert s.n_builds == 1


def test_amg_rebuilds_when_convergence_degrades(cracked):
    _, K2, f, c = cracked
    K0 = plate_test_matrix(np.zeros(M * M), winkler=WINKLER)  # built on the intact plate
    s = AMGSolver(K0, near_nullspace=near_nullspace(c), rebuild_factor=1.5, min_rebuild_iterations=1)
    s.update(K0)
    _, first = s.solve(f)
    s.update(K2)  # cracked everywhere: the kept coarse levels no longer fit
    u, stale = s.solve(f)
    assert not stale.rebuilt and relres(K2, f, u) <= RTOL
    assert stale.iterations > 1.5 * first.iterations
    u, again = s.solve(f)
    assert again.rebuilt and s.n_builds == 2
    assert again.iterations < stale.iterations
    assert relres(K2, f, u) <= RTOL


def test_amg_stale_hierarchy_that_fails_is_rebuilt_and_retried(cracked):
    _, K2, f, c = cracked
    K0 = plate_test_matrix(np.zeros(M * M), winkler=WINKLER)
    s = AMGSolver(K0, near_nullspace=near_nullspace(c), maxiter=25)
    s.update(K0)
    s.solve(f)
    s.update(K2)
    u, info = s.solve(f)  # the stale hierarchy needs more than 25: rebuild within the call
    assert info.rebuilt and s.n_builds == 2
    assert relres(K2, f, u) <= RTOL


def test_warm_start_reduces_iterations(cracked):
    K1, K2, f, c = cracked
    s = AMGSolver(K1, near_nullspace=near_nullspace(c))
    s.update(K1)
    u1, _ = s.solve(f)
    s.update(K2)
    _, cold = s.solve(f)
    u2, warm = s.solve(f, x0=u1)
    assert warm.iterations < cold.iterations
    assert relres(K2, f, u2) <= RTOL
    # and a looser per-call tolerance costs fewer iterations still
    _, loose = s.solve(f, x0=u1, rtol=1e-5)
    assert loose.iterations < warm.iterations and loose.residual <= 1e-5


# ---------------------------------------------------------------------------- hard cases
def cut_band(m):
    """alpha = 1 on a 3-node band at x = 0 that cuts the plate in two."""
    c = grid_coords(m)
    h = 1.0 / (m - 1)
    return (np.abs(c[:, 0]) <= 1.01 * h).astype(float)


HARD = [
    pytest.param(dict(lam=2.0, k_res=1e-6, cut=False), id="lam2"),
    pytest.param(dict(lam=1e3, k_res=1e-6, cut=False), id="lam1e3"),
    pytest.param(dict(lam=2.0, k_res=1e-10, cut=True), id="lam2-cut-kres1e-10"),
    pytest.param(dict(lam=31.6, k_res=1e-10, cut=True), id="lam32-cut-kres1e-10"),
    pytest.param(dict(lam=1e3, k_res=1e-10, cut=True), id="lam1e3-cut-kres1e-10"),
]


@pytest.mark.parametrize("case", HARD)
@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_hard_cases_converge_or_raise_never_nan(case, kind, opts):
    winkler = 4.0 * case["lam"] ** 4
    alpha = cut_band(M) if case["cut"] else crack_bands(M)
    K = plate_test_matrix(alpha, winkler=winkler, k_res=case["k_res"])
    c = grid_coords(M)
    # a load that bends each half differently, so the cut matters
    f = winkler * (-(c[:, 0] ** 2) / 2 + 0.1 * c[:, 1] * (c[:, 0] > 0)) / (M - 1) ** 2
    s = make_solver(kind, K, near_nullspace=near_nullspace(c), **opts)
    s.update(K)
    try:
        u, info = s.solve(f, rtol=RTOL)
    except LinearSolverError as err:
        assert isinstance(err, RuntimeError)
        assert "residual" in str(err) and "iterations" in str(err)
        assert err.iterations >= 0
        return
    assert np.all(np.isfinite(u))
    assert info.residual <= RTOL and relres(K, f, u) <= RTOL * 1.01


# ---------------------------------------------------------------------------- errors
def test_nonconvergence_raises_with_residual_and_iterations(cracked):
    K1, _, f, c = cracked
    s = AMGSolver(K1, near_nullspace=near_nullspace(c), maxiter=2)
    s.update(K1)
    with pytest.raises(LinearSolverError, match=r"residual .* after \d+ iterations") as exc:
        s.solve(f, rtol=1e-12)
    assert exc.value.iterations >= 2 and exc.value.residual > 1e-12
    assert isinstance(exc.value, RuntimeError)


@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_indefinite_matrix_raises_not_nan(cracked, kind, opts):
    K1, _, f, c = cracked
    K = K1.copy()
    K.data[K.indices == np.repeat(np.arange(K.shape[0]), np.diff(K.indptr))] *= -1.0
    if kind == "amg":
        opts = {**opts, "maxiter": 50}  # fail fast
    s = make_solver(kind, K1, near_nullspace=near_nullspace(c), **opts)
    s.update(K)
    try:
        u, info = s.solve(f)
    except LinearSolverError as err:
        assert "iterations" in str(err)
        return
    # a direct LU of a symmetric indefinite matrix may still solve it: then it must be right
    assert np.all(np.isfinite(u)) and relres(K, f, u) <= RTOL


def test_bad_inputs_are_rejected(cracked):
    K1, _, f, c = cracked
    with pytest.raises(ValueError, match="kind"):
        make_solver("cholesky", K1)
    with pytest.raises(ValueError, match="near_nullspace"):
        make_solver("amg", K1)
    with pytest.raises(ValueError, match="unknown"):
        make_solver("direct", K1, smoother="gs")
    s = make_solver("direct", K1)
    with pytest.raises(ValueError, match="pattern"):
        s.update(K1 + sp.eye(K1.shape[0], k=M + 7, format="csr"))
    bad = K1.copy()
    bad.data[5] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        s.update(bad)
    s.update(K1)
    with pytest.raises(ValueError, match="shape"):
        s.solve(f[:-1])


def test_zero_rhs_gives_zero(cracked):
    K1, _, f, c = cracked
    for kind in ("direct", "amg"):
        s = make_solver(kind, K1, near_nullspace=near_nullspace(c))
        u, info = s(K1, np.zeros_like(f))
        assert not np.any(u) and info.residual == 0.0


def test_auto_picks_direct_for_small_systems(cracked):
    K1, _, _, c = cracked
    assert isinstance(make_solver("auto", K1, near_nullspace=near_nullspace(c)), DirectSolver)


def test_amg_on_a_1d_beam_uses_near_nullspace_1_x():
    n = 400
    h = 1.0 / (n - 1)
    d2 = sp.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(n - 2, n)) / h**2
    # lam = 31.6: with lam = 2 at this h, rtol = 1e-8 is below the double-precision floor
    # of the true residual (spsolve itself reaches only 2e-7)
    K = ((d2.T @ d2 + 4e6 * sp.identity(n)) * h).tocsr()
    x = np.linspace(-0.5, 0.5, n)
    f = 4e6 * h * (-(x**2) / 2)
    s = make_solver("amg", K, near_nullspace=near_nullspace(x))
    u, info = s(K, f)
    assert relres(K, f, u) <= RTOL
    assert np.linalg.norm(u - spla.spsolve(K.tocsc(), f)) <= 1e-5 * np.linalg.norm(u)


@pytest.mark.parametrize("kind,opts", ALL_KINDS, ids=KIND_IDS)
def test_tolerance_below_round_off_returns_the_round_off_limited_solution(cracked, kind, opts):
    # No solve can reach rtol = 1e-20; the answer is the solution at the round-off floor
    # (normwise backward error of a few eps), with its true residual reported.
    K1, _, f, c = cracked
    s = make_solver(kind, K1, near_nullspace=near_nullspace(c), **opts)
    s.update(K1)
    u, info = s.solve(f, rtol=1e-20)
    assert info.residual == pytest.approx(relres(K1, f, u), rel=1e-6) and 1e-20 < info.residual < 1e-9
    assert backward_error(K1, f, u) <= ROUNDOFF_BACKWARD_ERROR
    exact = spla.spsolve(K1.tocsc(), f)
    assert np.linalg.norm(u - exact) <= 1e-8 * np.linalg.norm(exact)


def test_biharmonic_film_beyond_the_residual_floor_is_solved_to_round_off():
    # The relative residual of an exact-to-round-off solution of the 1D film grows like n^4:
    # about 5e-4 at 6400 cells, far above the engine's u-solve tolerances. The direct solver
    # must return that solution, not fail on it; two independent factorizations agree.
    from thinfilm.plate.grid import Grid
    from thinfilm.plate.operators import PlateOperator

    grid = Grid.line(-0.25, 0.25, 6400)
    plate = PlateOperator(grid, nu=0.0, winkler=4e4, k_res=1e-6)
    K = plate.matrix(np.zeros(grid.n_nodes))
    f = plate.rhs(-0.5 * grid.x**2)
    u, info = make_solver("direct", K)(K, f, rtol=1e-6)
    assert info.residual > 1e-5  # the floor really is above the tolerance asked for
    assert backward_error(K, f, u) <= ROUNDOFF_BACKWARD_ERROR
    reference = spla.splu(K.tocsc()).solve(f)
    assert np.abs(u - reference).max() <= 1e-4 * np.abs(reference).max()


def test_a_solution_above_the_round_off_floor_still_raises(cracked):
    # The floor is no excuse for an unconverged iteration: two CG steps stay far above it.
    K1, _, f, c = cracked
    s = make_solver("amg", K1, near_nullspace=near_nullspace(c), maxiter=2)
    with pytest.raises(LinearSolverError, match="did not reach"):
        s(K1, f, rtol=1e-10)


@pytest.mark.parametrize("kind", ["direct", "amg"])
def test_solvers_on_the_real_plate_operator(kind):
    # The model's own matrix (thinfilm.plate.operators), cracked by a band across the plate.
    import scipy.sparse.linalg as spla_

    from thinfilm.plate.grid import Grid
    from thinfilm.plate.operators import PlateOperator

    grid = Grid.rectangle(-0.5, 0.5, 60, -0.3, 0.3, 36)
    plate = PlateOperator(grid, 0.3, 4e4, 1e-6, clamped=("x0",))
    X, Y = grid.coordinates
    alpha = np.where(np.abs(X - 0.1) < 0.03, 1.0, 0.0)
    K = plate.matrix(alpha)
    f = plate.rhs(-0.5 * X**2)
    solver = make_solver(kind, K, near_nullspace=near_nullspace(np.column_stack(grid.coordinates)))
    solver.update(K)
    u, info = solver.solve(f, rtol=1e-10)
    exact = spla_.spsolve(K.tocsc(), f)
    assert np.linalg.norm(u - exact) <= 1e-7 * np.linalg.norm(exact)
    assert info.residual <= 1e-10


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_the_test_system_is_the_model_operator_away_from_the_edges(nu):
    # The test matrix is assembled independently of the model's kernels; two nodes away from
    # every edge (where both use whole node weights h^2) its rows must be the model's, to
    # round-off, for a damaged plate.
    m = 24
    alpha = crack_bands(m)
    K = plate_test_matrix(alpha, nu=nu, winkler=WINKLER, k_res=1e-6)
    grid = Grid.rectangle(-0.5, 0.5, m - 1, -0.5, 0.5, m - 1)
    K_model = PlateOperator(grid, nu, WINKLER, 1e-6).matrix(alpha)
    inner = np.arange(m * m).reshape(m, m)[2:-2, 2:-2].ravel()
    diff = (K - K_model).tocsr()[inner]
    assert abs(diff).max() <= 1e-12 * abs(K_model).max()
    assert abs(K_model.tocsr()[inner]).max() > 0


# Run in a process of its own: MKL fixes its threads and its reproducibility branch when it
# loads, and this test process runs it on one thread (tests/conftest.py).
_REPEATED_FACTORIZATIONS = """
import hashlib, numpy as np, scipy.sparse as sp
from thinfilm.solvers.linear import DirectSolver, pardiso_reproducible
m = 120
rng = np.random.default_rng(0)
L = sp.diags([np.ones(m - 1), -2.0 * np.ones(m), np.ones(m - 1)], [-1, 0, 1])
laplace = sp.kronsum(L, L)
K = (laplace @ sp.diags(1e-3 + rng.random(m * m)) @ laplace + 1e-2 * sp.identity(m * m)).tocsr()
f = rng.random(m * m)
solver = DirectSolver(K, backend="pardiso")
digests = set()
for _ in range(16):
    u, _ = solver(K, f)  # a new numeric factorization each time
    digests.add(hashlib.sha256(u.tobytes()).hexdigest())
print(pardiso_reproducible(), len(digests))
"""


@pytest.mark.skipif(not pardiso_available(), reason="pypardiso not installed")
@pytest.mark.parametrize("cbwr, branch", [(None, 2), ("COMPATIBLE", 3)])
def test_pardiso_on_two_threads_gives_the_same_bits_every_time(cbwr, branch):
    """Sixteen factorizations and solves of one system (a variable-coefficient biharmonic on
    a 120 x 120 grid) on two MKL threads give one solution, bit for bit: the solver turns on
    MKL's conditional numerical reproducibility (branch AUTO), or keeps the branch MKL_CBWR
    names. (Without it, MKL_CBWR empty, the loop gave two solutions 3e-12 apart in most
    processes.)"""
    import os
    import subprocess
    import sys

    from tests.helpers import ROOT

    env = {k: v for k, v in os.environ.items() if k != "MKL_CBWR"}
    env.update(PYTHONPATH=str(ROOT), MKL_NUM_THREADS="2", **({"MKL_CBWR": cbwr} if cbwr else {}))
    done = subprocess.run([sys.executable, "-c", _REPEATED_FACTORIZATIONS], env=env, cwd=ROOT, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == [str(branch), "1"]
