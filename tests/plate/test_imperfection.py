"""Imperfect films: the random toughness field and the surface energy of a varying toughness."""

import json
import math

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.plate.energy import nodal_energy, surface_energy, total_energy
from thinfilm.plate.grid import Grid
from thinfilm.plate.imperfection import gaussian_field, toughness_factor
from thinfilm.plate.operators import GridDamage, PlateOperator
from thinfilm.plate.symmetry import GridSymmetry

from tests.helpers import CASES


def _correlation(xi, lag):
    """Empirical correlation of nodes ``lag`` apart along x and along y, averaged."""
    along_x = np.mean(xi[:, :-lag] * xi[:, lag:])
    along_y = np.mean(xi[:-lag, :] * xi[lag:, :])
    return 0.5 * (along_x + along_y)


@pytest.mark.parametrize("length_cells", [3.0, 6.0])
def test_field_covariance_is_the_stated_gaussian(length_cells):
    # Covariance exp(-r^2 / (2 l^2)): at r = l it is exp(-1/2) = 0.61 (a kernel of width l
    # instead of l / sqrt(2) would give exp(-1/4) = 0.78). Averaged over four seeds of a
    # 400^2 grid, the estimate's scatter is about 0.01 for these lengths.
    grid = Grid(0.0, 1.0, 400, 0.0, 1.0, 400)
    length = length_cells * grid.hx
    fields = [gaussian_field(grid, length, seed).reshape(grid.shape) for seed in range(4)]
    for lag in (int(length_cells), 2 * int(length_cells)):
        measured = np.mean([_correlation(xi, lag) for xi in fields])
        r = lag * grid.hx
        assert measured == pytest.approx(math.exp(-r**2 / (2 * length**2)), abs=0.04)
    for xi in fields:
        assert abs(xi.mean()) < 1e-12 and np.std(xi) == pytest.approx(1.0, rel=1e-12)


def test_field_is_reproducible_and_independent_nodes_for_zero_length():
    grid = Grid(0.0, 1.0, 60, 0.0, 0.5, 30)
    a, b, c = (gaussian_field(grid, 0.05, s) for s in (7, 7, 8))
    assert np.array_equal(a, b) and not np.allclose(a, c)
    white = gaussian_field(grid, 0.0, 1).reshape(grid.shape)
    assert abs(_correlation(white, 1)) < 0.05


def test_symmetric_field_for_a_restricted_run():
    grid = Grid(-1.0, 1.0, 40, -1.0, 1.0, 40)
    sym = GridSymmetry(grid, "d4")
    xi = gaussian_field(grid, 0.1, 3, symmetry=sym)
    assert sym.asymmetry(xi) == 0.0 and np.std(xi) == pytest.approx(1.0)
    assert GridSymmetry(grid, "d4").asymmetry(gaussian_field(grid, 0.1, 3)) > 0.5


def test_toughness_factor_is_log_normal():
    grid = Grid(0.0, 1.0, 200, 0.0, 1.0, 200)
    assert toughness_factor(grid, 0.0, 0.01, 0) is None
    f = toughness_factor(grid, 0.2, 0.01, 0)
    assert np.all(f > 0)
    assert np.std(np.log(f)) == pytest.approx(0.2, rel=1e-12) and abs(np.mean(np.log(f))) < 1e-12


@pytest.mark.parametrize("at", [1, 2])
def test_uniform_factor_is_the_uniform_film(at):
    grid = Grid(0.0, 1.0, 30, 0.0, 0.5, 15)
    e = np.random.default_rng(0).random(grid.n_nodes)
    alpha = np.random.default_rng(1).random(grid.n_nodes)
    plain = GridDamage(grid, 0.05, 1.3, at)
    ones = GridDamage(grid, 0.05, 1.3, at, toughness_factor=np.ones(grid.n_nodes))
    A0, b0 = plain.problem(e)
    A0 = A0.copy()
    A1, b1 = ones.problem(e)
    assert abs(A0 - A1).max() <= 1e-12 * abs(A0).max() and np.allclose(b0, b1, rtol=0, atol=1e-14)
    assert surface_energy(ones, alpha) == pytest.approx(surface_energy(plain, alpha), rel=1e-13)


@pytest.mark.parametrize("at", [1, 2])
def test_alpha_problem_matches_the_energy_of_a_varying_toughness(at):
    # E_h(u, alpha) = 1/2 alpha.A.alpha - b.alpha + const for any alpha, and the nodal split
    # sums to the total, with a strongly varying toughness.
    grid = Grid(0.0, 1.0, 24, 0.0, 0.75, 18)
    rng = np.random.default_rng(2)
    factor = toughness_factor(grid, 0.5, 0.1, 4)
    plate = PlateOperator(grid, 0.3, 500.0, 1e-6)
    damage = GridDamage(grid, 0.06, 0.8, at, toughness_factor=factor)
    u, w = rng.standard_normal(grid.n_nodes), rng.standard_normal(grid.n_nodes)
    from thinfilm.plate.energy import damage_problem, damage_problem_constant

    A, b = damage_problem(plate, damage, u)
    const = damage_problem_constant(plate, u, w)
    for _ in range(3):
        alpha = rng.random(grid.n_nodes)
        quadratic = 0.5 * alpha @ (A @ alpha) - b @ alpha + const
        total = total_energy(plate, damage, u, alpha, w)
        assert quadratic == pytest.approx(total, rel=1e-12)
        assert np.sum(nodal_energy(plate, damage, u, alpha, w)) == pytest.approx(total, rel=1e-12)


def test_surface_energy_of_a_varying_toughness_converges_at_second_order():
    # S = cs Int f (alpha / eta + eta |grad alpha|^2) for smooth f and alpha on (0, 1) x (0, 0.5),
    # against the integral by a fine tensor Gauss rule: the error falls at order 2.
    eta, toughness = 0.1, 1.0
    cs = toughness / (4 * 2 / 3)

    def f(x, y):
        return 1.0 + 0.5 * np.sin(np.pi * x) * np.cos(2 * np.pi * y)

    def alpha(x, y):
        return 0.5 * (1 + np.cos(np.pi * x)) * np.exp(-y)

    def grad2(x, y):
        ax = -0.5 * np.pi * np.sin(np.pi * x) * np.exp(-y)
        ay = -0.5 * (1 + np.cos(np.pi * x)) * np.exp(-y)
        return ax**2 + ay**2

    gx, gw = np.polynomial.legendre.leggauss(200)
    X, Y = np.meshgrid(0.5 * (gx + 1), 0.25 * (gx + 1), indexing="ij")
    W = np.outer(0.5 * gw, 0.25 * gw)
    exact = cs * np.sum(W * f(X, Y) * (alpha(X, Y) / eta + eta * grad2(X, Y)))
    errors, hs = [], []
    for n in (20, 40, 80):
        grid = Grid(0.0, 1.0, n, 0.0, 0.5, n // 2)
        x, y = grid.coordinates
        damage = GridDamage(grid, eta, toughness, 1, toughness_factor=f(x, y))
        errors.append(abs(surface_energy(damage, alpha(x, y)) - exact))
        hs.append(grid.hx)
    order = np.polyfit(np.log(hs), np.log(errors), 1)[0]
    assert 1.8 < order < 2.3, (errors, order)


#: The small indenter at G/a = 1.5 (``cases/indentation_branching_G15.toml``) as an imperfect
#: film, on a small domain, two steps.
NOISY = {"domain.x": [-0.06, 0.06], "domain.y": [-0.06, 0.06], "domain.cells": [24, 24], "model.eta": 0.01,
         "model.toughness_noise": 0.05, "model.toughness_noise_seed": 3, "load.t_max": 0.02, "load.steps": 2,
         "solver.acceleration": "none", "output.snapshots": [0.02]}


def run_noisy(tmp_path, overrides, *options):
    """``thinfilm run`` of the imperfect film with ``overrides`` (as ``--set`` options)."""
    scene = CASES / "indentation_branching_G15.toml"
    settings = [f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]
    return main(["run", str(scene), "--out", str(tmp_path / "noisy"), "--quiet", *options] + settings)


def test_run_stores_the_toughness_field_and_resume_checks_it(tmp_path, capsys):
    assert run_noisy(tmp_path, NOISY) == 0
    results = tmp_path / "noisy" / "results.h5"
    grid = Grid(-0.06, 0.06, 24, -0.06, 0.06, 24)
    with h5py.File(results, "r") as f:
        stored = f["fields/toughness"][()]
        p = dict(f["parameters"].attrs)
    assert np.array_equal(stored, 1.5 * toughness_factor(grid, 0.05, 0.01, 3))
    assert (p["toughness_noise"], p["toughness_noise_length"], p["toughness_noise_seed"]) == (0.05, 0.01, 3)
    assert (tmp_path / "noisy" / "toughness.png").is_file()
    # ParaView finds the field beside alpha and u at every step.
    import xml.etree.ElementTree as ET

    root = ET.parse(results.with_suffix(".xdmf")).getroot()
    steps = root.findall(".//Grid[@GridType='Uniform']")
    assert len(steps) == 3
    for step in steps:
        item = step.find("Attribute[@Name='toughness']/DataItem")
        assert item.text == "results.h5:/fields/toughness" and item.get("Dimensions") == "1 25 25"
    # Resuming a finished run with the same field is accepted ...
    assert run_noisy(tmp_path, NOISY, "--resume") == 0
    # ... one whose stored field this installation would not draw again is refused.
    with h5py.File(results, "r+") as f:
        f["fields/toughness"][0] *= 1.01
    capsys.readouterr()
    assert run_noisy(tmp_path, NOISY, "--resume") == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "toughness field" in errors[0]


@pytest.mark.parametrize("key, value, message", [
    ("toughness_noise", -0.1, "model.toughness_noise = -0.1: must be >= 0"),
    ("toughness_noise", 3.0, "model.toughness_noise = 3.0: must be in [0, 2]"),
    ("toughness_noise_length", -1.0, "model.toughness_noise_length = -1.0: must be >= 0"),
    ("toughness_noise_length", 0.5, "model.toughness_noise_length = 0.5: must be in [0, 0.12] (the domain's size)"),
    ("toughness_noise_seed", 1.5, "model.toughness_noise_seed = 1.5: must be an integer"),
])
def test_bad_noise_keys_are_one_line_exit_2(tmp_path, capsys, key, value, message):
    assert run_noisy(tmp_path, {**NOISY, f"model.{key}": value}) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not (tmp_path / "noisy").exists()


def test_arms_of_a_drawn_star_about_an_offset_centre():
    # Three straight cracks (a broken core 4 dx wide and AT1 profiles, eta = 2 dx) leaving (0.01, -0.005) at 10, 130
    # and 250 degrees, and a circle of radius 0.03 about that point.
    from thinfilm.plate.cracks import arms
    from thinfilm.plate.model import crack_profile

    x = y = np.linspace(-0.1, 0.1, 201)
    X, Y = np.meshgrid(x, y)
    cx, cy = 0.01, -0.005
    alpha = np.zeros_like(X)
    for angle in (10.0, 130.0, 250.0):
        d = np.array([math.cos(math.radians(angle)), math.sin(math.radians(angle))])
        along = (X - cx) * d[0] + (Y - cy) * d[1]
        across = np.abs(-(X - cx) * d[1] + (Y - cy) * d[0])
        distance = np.where(along > 0, across, np.hypot(X - cx, Y - cy))
        alpha = np.maximum(alpha, crack_profile(np.maximum(distance - 0.002, 0.0), 0.002, 1))  # a broken core
    found = np.sort(arms(alpha, x, y, 0.03, centre=(cx, cy)))
    assert found == pytest.approx([10.0, 130.0, 250.0], abs=1.0)
    assert len(arms(alpha, x, y, 0.03, centre=(cx, cy), threshold=1.01)) == 0   # nothing that high


def test_weak_zone_cracks_first_where_and_when_the_exact_energy_says():
    # The film of Fig. 2.5 (l0 = 0.5, lam = 10, G/a = 0.05, eta = 10 dx) with a weak zone: toughness
    # G exp(-0.3 exp(-(x - 0.1)^2 / (2 0.08^2))). A sharp crack at p lowers the exact energy (2.32)
    # once t^2 / 2 (F(l0) - F(p + l0/2) - F(l0/2 - p)) > G(p) (onedim's closed-form F): the perfect
    # film first cracks at 0 at t = 0.6816; the weak zone pulls the crack towards x = 0.1 and lowers
    # the load. The regularized film must crack between 0 and the weak zone's centre, within two
    # load steps (0.8%: the regularized crack's cost and release differ from the sharp crack's by
    # O(eta)) of the exact load of a crack where it put it (the nucleation search inserts trial
    # cracks where the energy density is largest relative to the toughness). With the toughness
    # factor in only one of the two AT terms, or in neither, the load would be off by 5% or more.
    from onedim.fragment import scaling_F
    from thinfilm.plate.cracks import crack_positions
    from thinfilm.engine import AltMinOptions, Engine, SearchOptions
    from thinfilm.solvers.linear import make_solver
    from thinfilm.plate.model import PlateModel

    lam, toughness, half = 10.0, 0.05, 0.25
    grid = Grid(-half, half, 800)
    x = np.asarray(grid.x)

    def factor(p):
        return np.exp(-0.3 * np.exp(-(p - 0.1) ** 2 / (2 * 0.08**2)))

    def exact_load(p):
        released = scaling_F(2 * half, lam) - scaling_F(half + p, lam) - scaling_F(half - p, lam)
        return math.sqrt(2 * toughness * factor(p) / released)

    model = PlateModel(grid, 0.0, 4 * lam**4, 1e-6, 10 * grid.hx, toughness, 1, lambda t: -0.5 * t * x**2,
                       proportional=True, linear_solver=None, toughness_factor=factor(x))
    model.linear_solver = make_solver("auto", model.reduced_matrix(np.zeros(grid.n_nodes)))
    engine = Engine(model, AltMinOptions(), search=SearchOptions(enabled=True))  # delta: 1e-3 G/a
    dt = 0.0025
    t = np.r_[0.0, np.arange(0.60, 0.66, dt)]
    records, states = engine.run(t)
    k = next(i for i, s in enumerate(states) if len(crack_positions(x, s.alpha)))
    (p,) = crack_positions(x, states[k].alpha)
    assert 0.0 < p < 0.1
    assert abs(t[k] - exact_load(p)) <= 2 * dt, (p, t[k], exact_load(p))
    assert t[k] < exact_load(0.0) and exact_load(0.0) < 0.6816   # earlier than the perfect film
