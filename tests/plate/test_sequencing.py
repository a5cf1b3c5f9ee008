"""Grid sequencing (``[solver] coarse``): interpolation of a coarse run's damage, and a fine
run started from it against the same fine run started from its previous step only."""

import h5py
import numpy as np
import pytest

from thinfilm.plate.grid import Grid
from thinfilm.run import run
from thinfilm.scene import SceneError
from thinfilm.plate.sequencing import CoarseDamage

from tests.helpers import load_case


def _write_results(path, grid, t_values, alphas):
    """A minimal plate results file: grid, finished steps and damage fields."""
    with h5py.File(path, "w") as f:
        f.attrs["kind"] = "plate"
        g = f.create_group("grid")
        g.attrs["dim"] = grid.dim
        g["x"] = grid.x
        if grid.dim == 2:
            g["y"] = grid.y
        f["steps/t"] = np.asarray(t_values, float)
        f["fields/alpha"] = np.asarray(alphas, float)
        f["fields/u"] = np.zeros_like(np.asarray(alphas, float))


def test_coarse_damage_is_bilinear_and_zero_outside(tmp_path):
    # A field linear in x and y is reproduced exactly by bilinear interpolation inside the
    # coarse domain; fine nodes outside it get no damage, and a load the coarse run did not
    # compute gives no start.
    coarse = Grid.rectangle(-0.4, 0.4, 8, -0.4, 0.4, 8)
    x, y = coarse.coordinates
    field = 0.5 + 0.5 * x + 0.25 * y
    _write_results(tmp_path / "coarse.h5", coarse, [0.0, 0.5], [np.zeros(coarse.n_nodes), field])
    fine = Grid.rectangle(-0.5, 0.5, 40, -0.5, 0.5, 40)
    guess = CoarseDamage(tmp_path / "coarse.h5", fine)
    alpha = guess(0.5)
    xf, yf = fine.coordinates
    inside = (np.abs(xf) <= 0.4 + 1e-12) & (np.abs(yf) <= 0.4 + 1e-12)
    assert np.allclose(alpha[inside], 0.5 + 0.5 * xf[inside] + 0.25 * yf[inside], atol=1e-12)
    assert np.all(alpha[~inside] == 0.0)
    assert guess(0.25) is None
    assert np.all(guess(0.0) == 0.0)


def test_coarse_damage_1d_and_dimension_check(tmp_path):
    coarse = Grid.line(0.0, 1.0, 10)
    _write_results(tmp_path / "c.h5", coarse, [1.0], [coarse.x ** 2])
    fine = Grid.line(0.0, 1.0, 40)
    alpha = CoarseDamage(tmp_path / "c.h5", fine)(1.0)
    # Piecewise-linear interpolation of x^2 between nodes h apart errs by at most h^2 / 4.
    assert np.max(np.abs(alpha - fine.x ** 2)) <= 0.1 ** 2 / 4 + 1e-12
    assert np.allclose(alpha[::4], coarse.x ** 2)
    with pytest.raises(ValueError, match="1D run cannot start a 2D"):
        CoarseDamage(tmp_path / "c.h5", Grid.rectangle(0, 1, 4, 0, 1, 4))


#: The Fig. 2.7 strip (``cases/fig2_7.toml``) with eta = 1/120 fixed and no backtracking, to t = 6.5.
STRIP = {"model.eta_dx": None, "model.eta": 1 / 120, "load.t_max": 6.5, "load.steps": 13,
         "solver.backtrack": "none"}


@pytest.fixture(scope="module")
def strip_runs(tmp_path_factory):
    """The Fig. 2.7 strip (eta = 1/120, no backtracking: it cracks at t = 6.5) on 200 x 40
    cells, and on 300 x 60 both from its previous steps and from the 200 x 40 run."""
    root = tmp_path_factory.mktemp("sequencing")
    runs = {}
    for name, cells, coarse in (("coarse", [200, 40], None), ("plain", [300, 60], None),
                                ("sequenced", [300, 60], str(root / "coarse" / "results.h5"))):
        run(load_case("fig2_7", {**STRIP, "domain.cells": cells, "solver.coarse": coarse}), root / name)
        with h5py.File(root / name / "results.h5", "r") as f:
            runs[name] = {key: f["steps"][key][()] for key in ("t", "total", "iterations")}
            runs[name]["alpha"] = f["fields/alpha"][-1]
    return runs


def test_sequenced_strip_cracks_where_the_exact_solution_does(strip_runs):
    # Measured: plain alternate minimization on 300 x 60 forms the nine cracks in 60
    # iterations, pulled 0.003-0.013 towards the centre of the strip (-0.3967, ..., 0.3967,
    # as in the fig2_7 case); started from the 200 x 40 run's cracks it needs 4 and keeps
    # them at 0, +-0.1, ..., +-0.4, the exact 1D positions, at a total energy 0.37% lower.
    plain, sequenced = strip_runs["plain"], strip_runs["sequenced"]
    assert np.array_equal(plain["t"], sequenced["t"])
    # Before t = 6.5 there is no damage: the same elastic energies.
    assert np.allclose(plain["total"][:-1], sequenced["total"][:-1], rtol=1e-9)
    grid = Grid.rectangle(-0.5, 0.5, 300, -0.1, 0.1, 60)
    centre = slice(30 * 301, 31 * 301)  # the nodes of y = 0
    for result in (plain, sequenced):
        cracked = np.flatnonzero(result["alpha"][centre] >= 0.9)
        groups = np.split(grid.x[cracked], np.flatnonzero(np.diff(cracked) > 1) + 1)
        positions = np.array([g.mean() for g in groups])
        assert positions.size == 9
        assert np.max(np.abs(positions - np.linspace(-0.4, 0.4, 9))) <= 0.015
    # The sequenced state is at least as low as the plain one, reached in at most a third of
    # the iterations.
    assert sequenced["total"][-1] <= plain["total"][-1] * (1 + 1e-9)
    assert sequenced["iterations"][-1] <= plain["iterations"][-1] / 3


def test_coarse_key_errors(tmp_path):
    strip = {**STRIP, "domain.cells": [30, 6]}
    with pytest.raises(SceneError, match=r"solver\.coarse.*no such file"):
        load_case("fig2_7", {**strip, "solver.coarse": str(tmp_path / "missing.h5")})
    with pytest.raises(SceneError, match=r"solver\.coarse.*must be the path"):
        load_case("fig2_7", {**strip, "solver.coarse": 3})
    coarse = Grid.rectangle(-0.5, 0.5, 10, -0.1, 0.1, 2)
    _write_results(tmp_path / "other.h5", coarse, [0.0], [np.zeros(coarse.n_nodes)])
    with h5py.File(tmp_path / "other.h5", "a") as f:
        f.create_group("parameters").attrs.update({"at": 1, "nu": 0.3, "lam": 31.62, "toughness": 1.0,
                                                   "eta": 0.01, "load": "bending"})
    with pytest.raises(SceneError, match=r"solver\.coarse.*eta = 0\.01"):
        load_case("fig2_7", {**strip, "solver.coarse": str(tmp_path / "other.h5")})
