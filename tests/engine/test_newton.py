"""Newton on both fields (thinfilm/engine/newton.py) and its place in the engine: the
indefinite factorization's inertia, the KKT residual, quadratic convergence, the states it
ends at against tightly converged alternate minimization, and backtracking, the nucleation
search and the stability check on the states it returns."""

from __future__ import annotations

import dataclasses
import json

import h5py
import numpy as np
import pytest
import scipy.sparse as sp

from examples.bar.model import Bar
from tests.helpers import CASES, load_case
from thinfilm.cli import main
from thinfilm.engine import Engine
from thinfilm.engine.newton import kkt_residual, newton_minimize, state_kkt
from thinfilm.engine.options import AltMinOptions, NewtonOptions
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.scene import SceneError, read_solver
from thinfilm.solvers.boxqp import kkt_residual as damage_kkt
from thinfilm.solvers.linear import make_solver
from thinfilm.solvers.linear.indefinite import IndefiniteSolver
from thinfilm.solvers.work import WORK


def symmetric_with_spectrum(eigenvalues, seed):
    """A sparse symmetric matrix with the given eigenvalues (a random rotation of a diagonal)."""
    n = len(eigenvalues)
    q, _ = np.linalg.qr(np.random.default_rng(seed).standard_normal((n, n)))
    return sp.csr_matrix((q * eigenvalues) @ q.T)


@pytest.mark.parametrize("dense", [False, True])
@pytest.mark.parametrize("negative", [0, 1, 7])
def test_indefinite_solver_counts_the_signs_of_the_eigenvalues(dense, negative):
    rng = np.random.default_rng(negative)
    eigenvalues = np.concatenate([-rng.uniform(1e-3, 10.0, negative), rng.uniform(1e-3, 10.0, 40 - negative)])
    H = symmetric_with_spectrum(eigenvalues, seed=negative + 10)
    solver = IndefiniteSolver()
    if dense:
        solver.pardiso = False
    before = WORK.snapshot()
    inertia = solver.factor(H)
    assert (inertia.positive, inertia.negative, inertia.size) == (40 - negative, negative, 40)
    assert inertia.definite == (negative == 0)
    b = rng.standard_normal(40)
    x = solver.solve(b)
    condition = np.abs(eigenvalues).max() / np.abs(eigenvalues).min()
    assert np.linalg.norm(H @ x - b) <= 1e-10 * condition * np.linalg.norm(b)
    after = WORK.snapshot()
    assert (after[0] - before[0], after[1] - before[1]) == (1, 1)


def test_the_factorization_is_counted_once_per_matrix():
    K = sp.csr_matrix(sp.diags([2.0] * 30) - sp.eye(30, k=1) - sp.eye(30, k=-1))
    solver = make_solver("direct", K)
    before = WORK.snapshot()
    solver.update(K)
    solver.solve(np.ones(30))
    solver.solve(np.arange(30.0))
    solver.update(2.0 * K)
    solver.solve(np.ones(30))
    after = WORK.snapshot()
    assert (after[0] - before[0], after[1] - before[1]) == (2, 3)


def test_kkt_residual_is_the_damage_measure_and_the_relative_residual():
    rng = np.random.default_rng(3)
    n = 12
    A = sp.csr_matrix(sp.diags([4.0] * n) - sp.eye(n, k=1) - sp.eye(n, k=-1))
    b = rng.standard_normal(n)
    lower = np.where(np.arange(n) < 4, 0.2, 0.0)
    alpha = np.clip(rng.uniform(-0.2, 1.2, n), lower, 1.0)
    g_u, f = rng.standard_normal(5), rng.standard_normal(5)
    expected = max(damage_kkt(A, b, alpha, lower, 1.0), np.linalg.norm(g_u) / np.linalg.norm(f))
    g_alpha = A @ alpha - b
    assert kkt_residual(g_u, g_alpha, np.linalg.norm(f), alpha, lower, A.diagonal()) == pytest.approx(expected,
                                                                                                     rel=1e-13)
    # a state that solves the u-problem: only the damage part is left
    assert kkt_residual(np.zeros(5), g_alpha, 1.0, alpha, lower, A.diagonal()) == pytest.approx(
        damage_kkt(A, b, alpha, lower, 1.0), rel=1e-13)


def test_state_kkt_on_a_film_is_the_u_solves_residual():
    """At the u-solve's displacement the u-part vanishes to round-off; a perturbed
    displacement's is its relative residual ||K u - f|| / ||f|| (f the film's load)."""
    scene = load_case("indentation", {"domain.cells": [16, 16]})
    model = make_model(scene, build_grid(scene.domain))
    model.linear_solver = make_solver("direct", model.plate.matrix(np.zeros(model.n_alpha)))
    alpha = np.random.default_rng(1).uniform(0.0, 0.5, model.n_alpha)
    A, b = model.damage_problem(np.zeros(model.n_alpha), 0.5)
    u = model.solve_u(alpha, 0.5, None, 1e-12)
    lower = np.zeros(model.n_alpha)
    A, b = model.damage_problem(u, 0.5)
    damage_part = damage_kkt(A, b, alpha, lower, 1.0)
    assert state_kkt(model, u, alpha, lower, 0.5) == pytest.approx(damage_part, rel=1e-9)
    v = u + 1e-3 * np.random.default_rng(2).standard_normal(u.size)
    f = model.plate.rhs(model.load(0.5))
    residual = np.linalg.norm(model.plate.matrix(alpha) @ v - f) / np.linalg.norm(f)
    assert state_kkt(model, v, alpha, lower, 0.5) == pytest.approx(max(residual, damage_kkt(
        *model.damage_problem(v, 0.5), alpha, lower, 1.0)), rel=1e-9)


@pytest.fixture(scope="module")
def bar():
    return Bar(n=200)


def loads(bar):
    return np.linspace(0.0, 1.5 * bar.critical_load(), 16)


def test_newton_converges_quadratically_from_a_loose_state():
    """The indentation film (48^2 cells) at its fifth load step, from alternate minimization
    stopped at a change of 1e-2: Newton reaches 1e-12 in a few steps, the residual falling at
    least quadratically once it is small (r_{k+1} <= 1e3 r_k^2 above the round-off floor)."""
    scene = load_case("indentation", {"domain.cells": [48, 48]})
    model = make_model(scene, build_grid(scene.domain))
    t = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    _, states = Engine(model, AltMinOptions(tol=1e-2)).run(t[:6])
    state, lower = states[-1], states[-2].alpha
    result = newton_minimize(model, state.u, state.alpha, lower, state.t, NewtonOptions(tol=1e-12))
    assert result.converged and result.kkt <= 1e-12 and result.steps <= 5
    r = np.array(result.residuals)
    assert r[0] > 1e-5
    pairs = np.flatnonzero((r[:-1] < 1e-3) & (r[1:] > 1e-13))
    assert pairs.size >= 2
    assert np.all(r[pairs + 1] <= 1e3 * r[pairs] ** 2)
    assert result.elastic + result.surface <= state.total
    assert np.all(result.alpha >= lower) and np.all(result.alpha <= 1.0)


def test_newton_states_are_those_of_converged_alternate_minimization(bar):
    """The bar's evolution with Newton ends every step at a KKT point (1e-6) of no higher
    energy than alternate minimization's; through the step where the crack snaps, at the
    states of alternate minimization converged to 1e-9. (Later steps start from a cracked
    state whose plain alternate minimization stops, at a KKT point, after two iterations, and
    alternate minimization to 1e-9 creeps on along a direction of negative curvature to a
    lower one: two KKT points, not a difference of accuracy.)"""
    t = loads(bar)
    _, tight = Engine(bar, AltMinOptions(tol=1e-9)).run(t)
    plain_records, plain = Engine(bar, AltMinOptions()).run(t)
    engine = Engine(bar, AltMinOptions(), newton=NewtonOptions(method="newton"))
    assert engine.uses_newton
    records, states = engine.run(t)
    snap = next(i for i, s in enumerate(tight) if s.alpha.max() > 0.5)
    for k, (record, state) in enumerate(zip(records, states)):
        assert record.kkt_final <= 1e-6
        assert state.total <= plain[k].total * (1 + 1e-12) + 1e-15
        if k <= snap:
            assert state.total == pytest.approx(tight[k].total, rel=1e-8, abs=1e-12)
            np.testing.assert_allclose(state.alpha, tight[k].alpha, atol=1e-5)
    # every step is handed over (alternate minimization's own stop is polished), and each
    # attempt's factorization counted (the bar's own u-solves are not the toolkit's: uncounted)
    assert all(r.factorizations >= r.newton_attempts >= 1 for r in records)


def test_newton_needs_the_derivatives_and_auto_asks_the_model(bar, monkeypatch):
    class NoDerivatives:
        n_alpha, proportional, toughness = bar.n_alpha, True, 1.0
        solve_u, damage_problem, energies = bar.solve_u, bar.damage_problem, bar.energies

    with pytest.raises(ValueError, match="derivatives"):
        Engine(NoDerivatives(), newton=NewtonOptions(method="newton"))
    assert not Engine(NoDerivatives(), newton=NewtonOptions(method="auto")).uses_newton
    assert not Engine(bar, newton=NewtonOptions(method="auto")).uses_newton
    monkeypatch.setattr(Bar, "newton_pays", True)
    assert Engine(bar, newton=NewtonOptions(method="auto")).uses_newton
    assert not Engine(bar, newton=NewtonOptions(method="altmin")).uses_newton


def test_scene_key_nonlinear_is_read_and_checked(tmp_path):
    settings, _ = read_solver("scene.toml", {"nonlinear": "newton", "newton_switch": 0.05}, proportional=True)
    assert settings.newton.method == "newton" and settings.newton.switch == 0.05
    with pytest.raises(SceneError, match=r"solver\.nonlinear.*bogus"):
        read_solver("scene.toml", {"nonlinear": "bogus"}, proportional=True)
    with pytest.raises(SceneError, match=r"solver\.newton_shift"):
        read_solver("scene.toml", {"newton_shift": 1e5}, proportional=True)


def film(overrides=None):
    scene = load_case("fig2_5", overrides or {})
    return scene, make_model(scene, build_grid(scene.domain))


def test_backtracking_and_the_search_work_on_newtons_states():
    """Fig. 2.5's film (backtracking and the nucleation search on): the same cracks at the
    same loads with and without Newton, the energies within 1e-6."""
    scene, model = film({"load.steps": 40})
    t = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    runs = {}
    for method in ("altmin", "newton"):
        options = dataclasses.replace(scene.solver, newton=NewtonOptions(method=method))
        engine = Engine.from_options(model, options)
        records, states = engine.run(t)
        runs[method] = (records, states, engine.work)
    (r0, s0, w0), (r1, s1, w1) = runs["altmin"], runs["newton"]
    assert w0["backtracks"] >= 1 and w1["backtracks"] == w0["backtracks"]
    assert w1["trials_accepted"] == w0["trials_accepted"] >= 1
    assert w1["newton_steps"] > 0
    for a, b in zip(s0, s1):
        np.testing.assert_array_equal(a.alpha >= 0.5, b.alpha >= 0.5)
        assert b.total == pytest.approx(a.total, rel=1e-6)
    assert max(r.kkt_final for r in r1) <= 1e-6


def test_the_stability_check_works_on_newtons_states():
    """The stability check on Newton's states (Fig. 2.5's film): the same lowest curvatures
    of the reduced energy at the kept states as without Newton (infinite before the film
    has damaged nodes), and the same saddles left."""
    scene, model = film({"load.steps": 20, "solver.stability": True, "solver.backtrack": "none",
                         "solver.search": False})
    t = np.linspace(0.0, scene.load.t_max, scene.load.steps + 1)
    curvatures, saddles = {}, {}
    for method in ("altmin", "newton"):
        options = dataclasses.replace(scene.solver, newton=NewtonOptions(method=method))
        records, states = Engine.from_options(model, options).run(t)
        curvatures[method] = np.array([r.lowest_curvature for r in records[1:]])
        saddles[method] = sum(r.saddles_left for r in records)
    assert np.sum(np.isfinite(curvatures["newton"])) >= 5
    np.testing.assert_allclose(curvatures["newton"], curvatures["altmin"], rtol=1e-3)
    assert saddles["newton"] == saddles["altmin"]


def test_a_run_records_newton_work_and_kkt_residuals(tmp_path):
    scene = tmp_path / "indentation.toml"
    text = (CASES.joinpath("indentation.toml").read_text().replace("cells = [320, 320]", "cells = [48, 48]")
            .replace('[solver]\n', '[solver]\nnonlinear = "newton"\n'))
    scene.write_text(text)
    assert main(["run", str(scene), "--quiet", "--out", str(tmp_path / "out")]) == 0
    steps = json.loads((tmp_path / "out" / "summary.json").read_text())["steps"]
    for name in ("newton_steps", "newton_rejections", "linear_solves", "factorizations", "kkt_final"):
        assert len(steps[name]) == len(steps["t"])
    assert sum(steps["newton_steps"]) > 0
    assert max(steps["kkt_final"]) <= NewtonOptions().tol
    with h5py.File(tmp_path / "out" / "results.h5") as f:
        np.testing.assert_array_equal(f["steps/newton_steps"][()], steps["newton_steps"])
        assert np.all(f["steps/factorizations"][()] >= f["steps/linear_solves"][()])
        assert np.all(f["steps/linear_solves"][()] >= f["steps/u_solves"][()])
