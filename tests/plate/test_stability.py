"""The stability check: the reduced energy's Hessian against second differences of the
reduced energy itself, its eigenpairs, and an evolution that leaves a symmetric saddle."""

import json

import h5py
import numpy as np
import pytest

from thinfilm.plate import stability
from thinfilm.cli import main
from thinfilm.plate.energy import total_energy
from thinfilm.plate.grid import Grid
from thinfilm.solvers.linear import make_solver
from thinfilm.plate.model import crack_profile
from thinfilm.plate.operators import GridDamage, PlateOperator

from tests.helpers import CASES

# The small indenter of Fig. 2.14 (R = 0.1, winkler = 6.4e7, G/a = 1.5) at t = 0.06, on a
# coarse grid, with a damage spot a little off the centre (no symmetry to hide errors).
RADIUS, T = 0.1, 0.06


def _problem(cells=40):
    grid = Grid.rectangle(-0.1, 0.1, cells, -0.1, 0.1, cells)
    x, y = grid.coordinates
    plate = PlateOperator(grid, 0.3, 6.4e7, 1e-6)
    damage = GridDamage(grid, 0.01, 1.5, 1)
    r2, rc2 = x**2 + y**2, RADIUS**2 * T * (2 - T)
    w = np.where(r2 < rc2, RADIUS * (1 - T) - np.sqrt(np.maximum(RADIUS**2 - r2, 0.0)), 0.0)
    alpha = 0.9 * crack_profile(np.hypot(x - 0.002, y + 0.003), 0.01, 1)
    return grid, plate, damage, w, alpha


def _reduced_energy(plate, damage, w, alpha):
    """``min_u E(u, alpha)``, computed directly."""
    K = plate.matrix(alpha)
    solver = make_solver("direct", K)
    solver.update(K)
    u, _ = solver.solve(plate.rhs(w))
    return total_energy(plate, damage, u, alpha, w)


@pytest.fixture(scope="module")
def problem():
    grid, plate, damage, w, alpha = _problem()
    lower = np.zeros(grid.n_nodes)
    modes = stability.lowest_modes(plate, damage, alpha, w, lower, k=3)
    return grid, plate, damage, w, alpha, modes


def test_hessian_is_the_second_derivative_of_the_reduced_energy(problem):
    """``d.H.d`` against ``(E_r(a + e d) - 2 E_r(a) + E_r(a - e d)) / e^2``, which converges to it
    at second order in ``e``: for the lowest mode and for random directions on the free nodes."""
    grid, plate, damage, w, alpha, modes = problem
    K = plate.matrix(alpha).copy()
    solver = make_solver("direct", K)
    solver.update(K)
    hessian = stability.reduced_hessian(plate, damage, modes.u, alpha, modes.free, lambda v: solver.solve(v)[0])
    rng = np.random.default_rng(3)
    directions = [modes.modes[0]]
    for _ in range(2):
        d = np.zeros(grid.n_nodes)
        d[modes.free] = rng.standard_normal(len(modes.free))
        directions.append(d)
    e0 = _reduced_energy(plate, damage, w, alpha)
    for d in directions:
        exact = d[modes.free] @ hessian(d[modes.free])
        errors = []
        for eps in (1e-2, 1e-3):
            second = (_reduced_energy(plate, damage, w, alpha + eps * d) - 2 * e0
                      + _reduced_energy(plate, damage, w, alpha - eps * d)) / eps**2
            errors.append(abs(second / exact - 1))
        assert errors[1] < 2e-5
        assert errors[1] < errors[0] / 30   # second order (100x in exact arithmetic)


def test_eigenpairs(problem, monkeypatch):
    """The modes are eigenvectors: their Rayleigh quotients (weighted by the nodes' areas) are
    their eigenvalues, the eigenvalues ascend, and the dense solver (few free nodes) and
    LOBPCG give the same ones."""
    grid, plate, damage, w, alpha, modes = problem
    K = plate.matrix(alpha).copy()
    solver = make_solver("direct", K)
    solver.update(K)
    hessian = stability.reduced_hessian(plate, damage, modes.u, alpha, modes.free, lambda v: solver.solve(v)[0])
    weights = grid.weights[modes.free]
    assert np.all(np.diff(modes.eigenvalues) >= 0)
    for value, mode in zip(modes.eigenvalues, modes.modes):
        v = mode[modes.free]
        residual = hessian(v) - value * weights * v
        assert np.linalg.norm(residual) < 1e-3 * abs(value) * np.linalg.norm(weights * v)
    # A larger spot: more free nodes than the dense limit, so LOBPCG; then forced dense.
    big = crack_profile(np.maximum(np.hypot(*grid.coordinates) - 0.01, 0), 0.01, 1) * 0.95
    lower = np.zeros(grid.n_nodes)
    iterative = stability.lowest_modes(plate, damage, big, w, lower, k=3, tol=1e-5)
    assert len(iterative.free) > stability.DENSE_NODES
    monkeypatch.setattr(stability, "DENSE_NODES", len(iterative.free))
    dense = stability.lowest_modes(plate, damage, big, w, lower, k=3)
    np.testing.assert_allclose(iterative.eigenvalues, dense.eigenvalues, rtol=1e-6)


def test_no_free_nodes_means_nothing_to_check():
    grid, plate, damage, w, alpha = _problem()
    modes = stability.lowest_modes(plate, damage, alpha, w, lower=alpha, k=3)
    assert len(modes.free) == 0 and modes.lowest == np.inf


# The Fig. 2.14 scene (G/a = 1.5) on a coarse grid up to the load where its D4-symmetric
# disk of damage is a saddle (t = 0.065): with the check the evolution leaves it.
#: The small indenter at G/a = 1.5 (``cases/indentation_branching_G15.toml``) on a quarter of its
#: domain, to the load where its symmetric disk of damage is a saddle.
OVERRIDES = {"domain.x": [-0.1, 0.1], "domain.y": [-0.1, 0.1], "domain.cells": [80, 80], "load.t_max": 0.065,
             "load.steps": 13, "output.snapshots": [0.03, 0.065]}


def _settings(overrides):
    """The overrides as ``--set`` options of the command line."""
    return [f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]


def _run(tmp_path, name, overrides):
    scene = CASES / "indentation_branching_G15.toml"
    assert main(["run", str(scene), "--out", str(tmp_path / name), "--quiet"] + _settings(overrides)) == 0
    with h5py.File(tmp_path / name / "results.h5", "r") as f:
        return {k: v[()] for k, v in f["steps"].items()}, f["fields/alpha"][-1].reshape(81, 81)


def test_the_evolution_leaves_a_symmetric_saddle(tmp_path, capsys):
    plain_steps, plain_alpha = _run(tmp_path, "plain", OVERRIDES)
    steps, alpha = _run(tmp_path, "checked", {**OVERRIDES, "solver.stability": True})
    # Without the check: a disk of damage, symmetric under the square's rotations, no curvature.
    assert np.abs(plain_alpha - plain_alpha.T).max() < 1e-6
    assert np.all(np.isnan(plain_steps["lowest_curvature"]))
    assert plain_alpha.max() > 0.9
    # With it: a step's state was a saddle, left along a mode that picks a direction; the
    # steps before it are the same, the ones from it on lower.
    left = np.flatnonzero(steps["saddles_left"])
    assert len(left) >= 1
    k = left[0]
    np.testing.assert_allclose(steps["total"][:k], plain_steps["total"][:k], rtol=1e-9)
    assert np.all(steps["total"][k:] < plain_steps["total"][k:] - 1e-6)
    assert steps["total"][-1] < plain_steps["total"][-1] - 1e-4
    assert np.abs(alpha - alpha.T).max() > 0.3
    # The kept states are stable (elastic steps: no free node, +inf).
    assert np.all(steps["lowest_curvature"][1:] > -1e-3)
    capsys.readouterr()
    assert main(["info", str(tmp_path / "checked" / "results.h5")]) == 0
    assert f"stability: {int(steps['saddles_left'].sum())} saddle(s) left" in capsys.readouterr().out


@pytest.mark.parametrize("overrides, key", [({"solver.stability": True, "domain.symmetry": "d4"}, "solver.stability"),
                                            ({"solver.stability_tol": -1}, "solver.stability_tol")])
def test_bad_stability_options(tmp_path, capsys, overrides, key):
    scene = CASES / "indentation_branching_G15.toml"
    out = tmp_path / "out"
    assert main(["run", str(scene), "--out", str(out), "--quiet"] + _settings({**OVERRIDES, **overrides})) == 2
    err = capsys.readouterr().err.strip()
    assert key in err and "\n" not in err
    assert not out.exists()
