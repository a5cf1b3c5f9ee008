"""The discrete plate + Winkler operator and the alpha-problem: structure and consistency.

Kernels against their NumPy references, symmetry and definiteness of the u-matrix, gradients
against finite differences of the discrete energy, the quadratic form of the alpha-problem,
1D/2D consistency, hard parameter ranges. Convergence to exact solutions is in
``test_plate_convergence.py``. Timings at 1000^2 and 1500^2 nodes: ``benchmarks/bench_operator.py``.
"""

from __future__ import annotations


import numpy as np
import pytest
import scipy.sparse.linalg as spla

from thinfilm.plate import energy
from thinfilm.plate.grid import Grid
from thinfilm.plate.kernels import reference
from thinfilm.plate.operators import GridDamage, PlateOperator

GRID_2D = Grid.rectangle(-0.5, 0.5, 9, -0.3, 0.3, 7)  # hx != hy, a few interior rows
GRID_1D = Grid.line(-0.5, 0.5, 11)
BCS_2D = [(), ("x0",), ("x0", "x1", "y0", "y1"), ("y1",), ("x1", "y0")]
BCS_1D = [(), ("x0",), ("x0", "x1")]
CASES = [(GRID_2D, bc) for bc in BCS_2D] + [(GRID_1D, bc) for bc in BCS_1D]
IDS = [f"{g.dim}d-{'+'.join(bc) or 'free'}" for g, bc in CASES]


def random_state(grid, plate, seed=0):
    rng = np.random.default_rng(seed)
    alpha = rng.random(grid.n_nodes)
    u = plate.constrain(rng.standard_normal(grid.n_nodes))
    w = rng.standard_normal(grid.n_nodes)
    return alpha, u, w


def band_alpha(grid, width=2):
    """alpha = 1 on a band of nodes across the plate (x near 0), 0 elsewhere: the crack cuts
    the plate in two."""
    X = grid.coordinates[0]
    alpha = np.zeros(grid.n_nodes)
    alpha[np.abs(X) <= (width - 0.5) * grid.hx] = 1.0
    return alpha


def quadratic_constant(plate, w):
    return 0.5 * plate.winkler * plate.grid.weights @ (w * w)


# ------------------------------------------------------------------------------------------
# grid
# ------------------------------------------------------------------------------------------
def test_grid_layout_and_weights():
    g = Grid.rectangle(0.0, 2.0, 4, -1.0, 0.5, 3)
    assert g.shape == (4, 5) and g.n_nodes == 20 and g.n_cells == 12 and g.dim == 2
    X, Y = g.coordinates
    k = g.index(3, 2)
    assert k == 2 * 5 + 3 and X[k] == 1.5 and Y[k] == 0.0
    np.testing.assert_array_equal(X.reshape(g.shape)[1], g.x)  # rows of constant y
    assert g.weights.sum() == pytest.approx(3.0)
    assert g.integrate(X * Y) == pytest.approx(2.0 * (0.125 - 0.5), rel=1e-14)  # bilinear: exact
    np.testing.assert_array_equal(g.edge_nodes("x0"), [0, 5, 10, 15])
    line = Grid.line(-1.0, 1.0, 4)
    assert line.shape == (5,) and line.dim == 1 and line.hy == 1.0 and line.weights.sum() == pytest.approx(2.0)
    assert not g.weights.flags.writeable
    assert Grid.rectangle(0, 2, 4, -1, 0.5, 3) == g  # frozen value object


@pytest.mark.parametrize(
    "kwargs, match",
    [
        (dict(x0=0.0, x1=1.0, nx=1), "nx"),
        (dict(x0=1.0, x1=0.0, nx=4), "x1"),
        (dict(x0=0.0, x1=1.0, nx=4, y0=0.0, y1=1.0, ny=1), "ny"),
        (dict(x0=0.0, x1=float("nan"), nx=4), "x1"),
    ],
)
def test_grid_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        Grid(**kwargs)


def test_operator_validation():
    with pytest.raises(ValueError, match="nu"):
        PlateOperator(GRID_2D, 1.0, 1.0, 1e-6)
    with pytest.raises(ValueError, match="winkler"):
        PlateOperator(GRID_2D, 0.3, -1.0, 1e-6)
    with pytest.raises(ValueError, match="'y0'"):
        PlateOperator(GRID_1D, 0.3, 1.0, 1e-6, clamped=("y0",))
    with pytest.raises(ValueError, match="at"):
        GridDamage(GRID_2D, 0.1, 1.0, at=3)
    plate = PlateOperator(GRID_2D, 0.3, 1.0, 1e-6)
    with pytest.raises(ValueError, match="alpha"):
        plate.matrix(np.zeros(3))


# ------------------------------------------------------------------------------------------
# kernels against the NumPy references
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("grid, clamped", CASES, ids=IDS)
@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_kernels_match_reference(grid, clamped, nu):
    plate = PlateOperator(grid, nu, 7.0, 1e-2, clamped)
    alpha, u, w = random_state(grid, plate)
    g = plate.degradation(alpha)
    args = (grid.nx, grid.ny, grid.hx, grid.hy, nu, 7.0, plate.clamped_flags)

    K = plate.matrix(alpha)
    pattern = reference.plate_pattern(grid.nx, grid.ny, plate.clamped_flags)
    assert [list(K.indices[K.indptr[p] : K.indptr[p + 1]]) for p in range(grid.n_nodes)] == pattern
    K_ref = reference.plate_matrix(g, *args)
    scale = abs(K_ref).max()
    assert abs(K - K_ref).max() <= 1e-14 * scale

    y = plate.apply(alpha, u)
    u_any = np.random.default_rng(5).standard_normal(grid.n_nodes)  # nonzero on clamped nodes too
    np.testing.assert_allclose(y, reference.plate_apply(u, g, *args), rtol=0, atol=1e-13 * np.abs(y).max())
    np.testing.assert_allclose(plate.apply(alpha, u_any), K @ u_any, rtol=0, atol=1e-13 * np.abs(K @ u_any).max())

    bending, foundation = energy.elastic_energies(plate, u, alpha, w)
    bending_ref, foundation_ref = reference.plate_energy(u, g, w, *args)
    assert bending == pytest.approx(bending_ref, rel=1e-13)
    assert foundation == pytest.approx(foundation_ref, rel=1e-13)

    e = energy.bending_density(plate, u)
    e_ref = reference.bending_density(u, *args[:5], plate.clamped_flags)
    np.testing.assert_allclose(e, e_ref, rtol=1e-13, atol=1e-13 * e.max())
    assert 0.5 * g @ e == pytest.approx(bending, rel=1e-13)  # lumping is exact


@pytest.mark.parametrize("grid", [GRID_2D, GRID_1D], ids=["2d", "1d"])
@pytest.mark.parametrize("at", [1, 2])
def test_damage_kernels_match_reference(grid, at):
    damage = GridDamage(grid, eta=0.15, toughness=2.0, at=at)
    alpha = np.random.default_rng(1).random(grid.n_nodes)
    L_ref = reference.laplacian(grid.nx, grid.ny, grid.hx, grid.hy)
    assert abs(damage.laplacian - L_ref).max() <= 1e-14 * abs(L_ref).max()
    S = energy.surface_energy(damage, alpha)
    S_ref = reference.surface_energy(alpha, grid.nx, grid.ny, grid.hx, grid.hy, 0.15, 2.0, at)
    assert S == pytest.approx(S_ref, rel=1e-13)
    # a linear alpha has |grad alpha| = const: the gradient sum is exact
    X = grid.coordinates[0]
    assert alpha_gradient_sum(damage, 0.3 * X) == pytest.approx(0.09 * grid.weights.sum(), rel=1e-13)


def alpha_gradient_sum(damage, alpha):
    return float(alpha @ (damage.laplacian @ alpha))


# ------------------------------------------------------------------------------------------
# the u-matrix: pattern reuse, symmetry, definiteness, zero modes
# ------------------------------------------------------------------------------------------
def test_matrix_is_rewritten_in_place():
    plate = PlateOperator(GRID_2D, 0.3, 10.0, 1e-6, clamped=("x0",))
    K1 = plate.matrix(np.zeros(GRID_2D.n_nodes))
    indices, data = K1.indices.copy(), K1.data
    values0 = K1.data.copy()
    half = np.full(GRID_2D.n_nodes, 0.5)
    K2 = plate.matrix(half)
    assert K2 is K1 and K2.data is data  # same object, same buffer
    np.testing.assert_array_equal(K2.indices, indices)
    assert not np.allclose(K2.data, values0)
    fresh = PlateOperator(GRID_2D, 0.3, 10.0, 1e-6, clamped=("x0",)).matrix(half)
    np.testing.assert_array_equal(K2.data, fresh.data)
    assert plate.nnz == K1.nnz


@pytest.mark.parametrize("grid, clamped", CASES, ids=IDS)
@pytest.mark.parametrize("damage", ["intact", "random", "band"])
def test_matrix_symmetric_positive_definite(grid, clamped, damage):
    plate = PlateOperator(grid, 0.3, 4 * 10.0**4, k_res=1e-10, clamped=clamped)
    alpha = {
        "intact": np.zeros(grid.n_nodes),
        "random": np.random.default_rng(2).random(grid.n_nodes),
        "band": band_alpha(grid),
    }[damage]
    K = plate.matrix(alpha).toarray()
    assert np.abs(K - K.T).max() <= 1e-15 * np.abs(K).max()
    np.linalg.cholesky(K)  # raises LinAlgError if not positive definite
    assert np.linalg.eigvalsh(K).min() > 0


@pytest.mark.parametrize(
    "grid, n_modes", [(Grid.rectangle(-0.5, 0.5, 8, -0.3, 0.3, 6), 3), (GRID_1D, 2)], ids=["2d", "1d"]
)
@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_free_plate_without_foundation_has_rigid_modes_only(grid, n_modes, nu):
    """winkler = 0, free edges: the kernel is exactly {1, x[, y]} (the closure neither removes
    nor adds zero-energy modes)."""
    plate = PlateOperator(grid, nu, 0.0, k_res=0.0)
    K = plate.matrix(np.zeros(grid.n_nodes)).toarray()
    ev = np.linalg.eigvalsh(K)
    assert np.sum(ev < 1e-9 * ev.max()) == n_modes
    assert ev[n_modes] > 1e-6 * ev.max()
    for mode in (np.ones(grid.n_nodes), *grid.coordinates):
        assert np.abs(K @ mode).max() < 1e-10 * ev.max()


# ------------------------------------------------------------------------------------------
# energies: gradients and the quadratic alpha-problem
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("grid, clamped", CASES, ids=IDS)
def test_u_gradient_matches_finite_differences(grid, clamped):
    plate = PlateOperator(grid, 0.3, 5.0, 1e-3, clamped)
    alpha, u, w = random_state(grid, plate, seed=3)
    K = plate.matrix(alpha)
    gradient = K @ u - plate.rhs(w)
    gradient[plate.clamped_nodes] = 0.0  # the energy does not depend on clamped values
    fd = np.empty(grid.n_nodes)
    eps = 1e-5
    for k in range(grid.n_nodes):
        up, um = u.copy(), u.copy()
        up[k] += eps
        um[k] -= eps
        fd[k] = (plate.elastic_energy(up, alpha, w) - plate.elastic_energy(um, alpha, w)) / (2 * eps)
    # the energy is quadratic: central differences are exact up to round-off
    assert np.abs(fd - gradient).max() <= 1e-7 * np.abs(gradient).max()
    # and E = 1/2 u.K.u - rhs.u + const on admissible u
    quad = 0.5 * u @ (K @ u) - plate.rhs(w) @ u + quadratic_constant(plate, w)
    assert plate.elastic_energy(u, alpha, w) == pytest.approx(quad, rel=1e-12)


@pytest.mark.parametrize("grid, clamped", [CASES[0], CASES[1], CASES[-2]], ids=[IDS[0], IDS[1], IDS[-2]])
@pytest.mark.parametrize("at", [1, 2])
def test_alpha_problem_quadratic_form(grid, clamped, at):
    plate = PlateOperator(grid, 0.3, 5.0, 1e-3, clamped)
    damage = GridDamage(grid, eta=0.2, toughness=3.0, at=at)
    _, u, w = random_state(grid, plate, seed=4)
    A, b = energy.damage_problem(plate, damage, u)
    const = energy.damage_problem_constant(plate, u, w)
    assert abs(A - A.T).max() <= 1e-15 * abs(A).max()
    rng = np.random.default_rng(6)
    for alpha in (rng.random(grid.n_nodes), np.zeros(grid.n_nodes), band_alpha(grid)):
        direct = energy.total_energy(plate, damage, u, alpha, w)
        assert 0.5 * alpha @ (A @ alpha) - b @ alpha + const == pytest.approx(direct, rel=1e-12)
        # gradient in alpha = A alpha - b, against central differences of the direct energy
        eps = 1e-5
        fd = np.empty(grid.n_nodes)
        for k in range(grid.n_nodes):
            ap, am = alpha.copy(), alpha.copy()
            ap[k] += eps
            am[k] -= eps
            e_plus = energy.total_energy(plate, damage, u, ap, w)
            e_minus = energy.total_energy(plate, damage, u, am, w)
            fd[k] = (e_plus - e_minus) / (2 * eps)
        gradient = A @ alpha - b
        assert np.abs(fd - gradient).max() <= 1e-6 * np.abs(gradient).max()
    # the matrix is rewritten in place and keeps its pattern
    A2, _ = energy.damage_problem(plate, damage, 2.0 * u)
    assert A2 is A


@pytest.mark.parametrize("grid,clamped", CASES, ids=IDS)
@pytest.mark.parametrize("at", [1, 2])
def test_nodal_energy_sums_to_total(grid, clamped, at):
    plate = PlateOperator(grid, 0.3, 5.0, 1e-3, clamped)
    damage = GridDamage(grid, eta=0.2, toughness=3.0, at=at)
    alpha, _, w = random_state(grid, plate, seed=8)
    u = np.random.default_rng(9).standard_normal(grid.n_nodes)  # clamped values ignored
    nodal = energy.nodal_energy(plate, damage, u, alpha, w)
    assert nodal.shape == (grid.n_nodes,)
    assert nodal.sum() == pytest.approx(energy.total_energy(plate, damage, u, alpha, w), rel=1e-12)


# ------------------------------------------------------------------------------------------
# 1D and 2D: the same code
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("clamped", [(), ("x0",)])
def test_strip_without_poisson_reproduces_1d(clamped):
    """nu = 0, load depending on x only: the 2D strip's solution is the 1D one on every row
    and its energy is width x the 1D energy, to round-off."""
    nx, lam = 40, 6.0
    winkler = 4 * lam**4
    line = Grid.line(-0.5, 0.5, nx)
    strip = Grid.rectangle(-0.5, 0.5, nx, -0.1, 0.15, 5)
    p1 = PlateOperator(line, 0.0, winkler, 1e-6, clamped)
    p2 = PlateOperator(strip, 0.0, winkler, 1e-6, clamped)
    load = lambda x: -(x**2) / 2 + 0.3 * np.sin(3 * x)  # noqa: E731
    w1, w2 = load(line.coordinates[0]), load(strip.coordinates[0])
    alpha1 = np.where(np.abs(line.x - 0.1) < 0.06, 0.9, 0.0)  # x-only damage too
    alpha2 = np.tile(alpha1, strip.ny + 1)
    u1 = spla.spsolve(p1.matrix(alpha1).tocsc(), p1.rhs(w1))
    u2 = spla.spsolve(p2.matrix(alpha2).tocsc(), p2.rhs(w2))
    U2 = u2.reshape(strip.shape)
    assert np.abs(U2 - u1[None, :]).max() <= 1e-12 * np.abs(u1).max()
    width = strip.y1 - strip.y0
    e1 = energy.elastic_energy(p1, u1, alpha1, w1)
    e2 = energy.elastic_energy(p2, u2, alpha2, w2)
    assert e2 == pytest.approx(width * e1, rel=1e-13)
    # same for a y-independent u directly, without a solve
    e1u = energy.elastic_energy(p1, p1.constrain(w1), alpha1, 0 * w1)
    e2u = energy.elastic_energy(p2, p2.constrain(w2), alpha2, 0 * w2)
    assert e2u == pytest.approx(width * e1u, rel=1e-13)


# ------------------------------------------------------------------------------------------
# hard cases
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("lam", [2.0, 10.0, 100.0, 1e3])
@pytest.mark.parametrize("clamped", [(), ("x0",)])
def test_hard_cases_no_nan(lam, clamped):
    """Stiff foundation up to winkler = 4e12, k_res = 1e-10, a band of alpha = 1 cutting the
    plate in two: assembly and a direct solve stay finite, the residual small."""
    grid = Grid.rectangle(-0.5, 0.5, 40, -0.25, 0.25, 20)
    plate = PlateOperator(grid, 0.3, 4 * lam**4, k_res=1e-10, clamped=clamped)
    alpha = band_alpha(grid)
    w = -(grid.coordinates[0] ** 2) / 2
    K = plate.matrix(alpha)
    assert np.all(np.isfinite(K.data))
    b = plate.rhs(w)
    u = spla.spsolve(K.tocsc(), b)
    assert np.all(np.isfinite(u))
    assert np.linalg.norm(K @ u - b) <= 1e-8 * np.linalg.norm(b)
    y = plate.apply(alpha, u)
    assert np.all(np.isfinite(y))
    P = plate.elastic_energy(u, alpha, w)
    assert np.isfinite(P) and P >= 0


def test_linear_operator_matches_matrix():
    plate = PlateOperator(GRID_2D, 0.3, 10.0, 1e-6, clamped=("y0",))
    alpha, u, _ = random_state(GRID_2D, plate, seed=8)
    op = plate.linear_operator(alpha)
    K = plate.matrix(alpha)
    plate.apply(np.zeros(GRID_2D.n_nodes), u)  # must not disturb op's work arrays
    np.testing.assert_allclose(op @ u, K @ u, rtol=0, atol=1e-13 * np.abs(K @ u).max())
