"""The evolution engine on the 1D film under pure bending, against the exact evolution."""

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from onedim.evolution import evolve
from onedim.partition import partition_energy
from thinfilm.engine import AltMinOptions, BacktrackOptions, Engine, EvolutionError, SearchOptions
from thinfilm.plate.grid import Grid
from thinfilm.solvers.linear import LinearSolverError
from thinfilm.plate.model import PlateModel
from thinfilm.plate.cracks import crack_positions


class SuperLU:
    """Smallest linear solver of the protocol: factorize at each update."""

    def update(self, K):
        self.lu = sla.splu(K.tocsc())

    def solve(self, f, x0=None, rtol=None):
        return self.lu.solve(f), {}


def film(length=0.5, cells=400, lam=10.0, toughness=0.05, eta_dx=10, at=1, k_res=1e-6):
    grid = Grid.line(-length / 2, length / 2, cells)
    w1 = -0.5 * grid.x**2
    eta = eta_dx * length / cells
    model = PlateModel(grid, 0.0, 4 * lam**4, k_res, eta, toughness, at, lambda t: t * w1, True, SuperLU())
    return grid, model


def events_of(grid, states):
    out, last = [], 0
    for s in states:
        cracks = crack_positions(grid.x, s.alpha)
        if len(cracks) != last:
            out.append((s.t, cracks))
            last = len(cracks)
    return out


def test_irreversibility_and_monotone_energy():
    grid, model = film()
    engine = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard"))
    records, states = engine.run(np.linspace(0.0, 3.0, 61))
    for before, after in zip(states[:-1], states[1:]):
        assert np.all(after.alpha >= before.alpha)  # exact, not within a tolerance
    assert np.all((states[-1].alpha >= 0) & (states[-1].alpha <= 1))
    for r in records:
        history = np.array(r.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * max(1.0, abs(history[0])))
    assert states[-1].alpha.max() > 0.99  # it did crack


def test_over_relaxation_keeps_energy_monotone_bounds_and_evolution():
    t = np.linspace(0.0, 2.0, 41)
    grid, model = film()
    plain = Engine(model, AltMinOptions(tol=1e-4))
    _, plain_states = plain.run(t)
    grid, model = film()
    engine = Engine(model, AltMinOptions(tol=1e-4, acceleration="overrelax", omega=4.0))
    records, states = engine.run(t)
    for r in records:
        history = np.array(r.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * max(1.0, abs(history[0])))
    for before, after in zip(states[:-1], states[1:]):
        assert np.all(after.alpha >= before.alpha) and np.all(after.alpha <= 1.0)
    # The same evolution, with fewer iterations where alpha moves (each step needs one to
    # confirm it is stationary).
    events, plain_events = events_of(grid, states), events_of(grid, plain_states)
    assert [e[0] for e in events] == [e[0] for e in plain_events]
    for (_, x), (_, x_plain) in zip(events, plain_events):
        np.testing.assert_allclose(x, x_plain, atol=2 * grid.hx)
    assert abs(states[-1].total - plain_states[-1].total) < 5e-3 * plain_states[-1].total
    assert engine.work["iterations"] <= plain.work["iterations"]


def test_elastic_steps_skip_the_u_solve():
    grid, model = film()
    engine = Engine(model, AltMinOptions(tol=1e-4))
    records, states = engine.run(np.linspace(0.0, 0.5, 11))
    assert all(s.alpha.max() < 0.5 for s in states)
    assert sum(r.u_solves for r in records) <= 2  # the first step solves; later ones scale it
    assert sum(r.u_solves_skipped for r in records) >= 9
    fresh = sla.spsolve(model.plate.matrix(states[-1].alpha).tocsc(), model.plate.rhs(model.load(0.5)))
    assert np.allclose(states[-1].u, fresh, rtol=1e-6, atol=1e-12 * np.abs(fresh).max())


def test_backtracking_brings_nucleation_back_to_the_exact_load():
    # Plain alternate minimization cracks late (it waits for the elastic state to become
    # unstable); Alg. 3.1 backtracking moves the crack back to where it lowers the energy.
    t = np.linspace(0.0, 2.0, 41)
    grid, model = film()
    plain = Engine(model, AltMinOptions(tol=1e-4)).run(t)[1]
    grid, model = film()
    back_records, back = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard")).run(t)
    t_plain = events_of(grid, plain)[0][0]
    t_back = events_of(grid, back)[0][0]
    t_exact = evolve(0.5, 10.0, 0.05, cells=1000, t_max=2.0)[0].t
    assert t_back < t_plain
    assert sum(r.backtracks for r in back_records) >= 1  # recorded on the restarted step
    assert abs(t_back - t_exact) <= t[1] - t[0] + 1e-12


def test_deep_backtracking_runs_and_is_not_worse():
    t = np.linspace(0.0, 2.0, 41)
    grid, model = film()
    standard = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard")).run(t)[1]
    grid, model = film()
    deep = Engine(model, AltMinOptions(tol=1e-4),
                  BacktrackOptions(kind="deep", interval=1, direction=1)).run(t)[1]
    assert deep[-1].total <= standard[-1].total * (1 + 1e-3)
    assert events_of(grid, deep)[0][0] <= events_of(grid, standard)[0][0] + 1e-12


def test_backtracking_refused_for_loads_not_proportional():
    grid, model = film()
    model.proportional = False
    with pytest.raises(ValueError, match="proportional"):
        Engine(model, backtrack=BacktrackOptions(kind="standard"))


def test_non_convergence_names_step_and_keeps_done_steps():
    grid, model = film()
    done = []
    engine = Engine(model, AltMinOptions(tol=1e-12, max_iter=2))
    with pytest.raises(EvolutionError, match=r"step \d+ \(t = [0-9.]+\).*did not converge in 2 iterations"):
        engine.run(np.linspace(0.0, 3.0, 31), on_step=lambda r, s: done.append(r.index))
    assert done and done == list(range(len(done)))


class FailsAtSolve:
    """A linear solver that fails at its n-th solve, like a diverging CG."""

    def __init__(self, n):
        self.inner, self.left = SuperLU(), n

    def update(self, K):
        self.inner.update(K)

    def solve(self, f, x0=None, rtol=None):
        self.left -= 1
        if self.left < 0:
            raise LinearSolverError("did not reach rtol = 1.0e-06", residual=3e-2, iterations=500, kind="amg")
        return self.inner.solve(f, x0, rtol)


def test_a_failed_u_solve_names_the_step_and_keeps_the_finished_ones():
    grid, model = film()
    model.linear_solver = FailsAtSolve(3)
    done = []
    engine = Engine(model, AltMinOptions(), BacktrackOptions(kind="standard"))
    with pytest.raises(EvolutionError, match=r"step \d+ \(t = [0-9.]+\), alternate-minimization iteration \d+:"
                                             r" u-solve failed: .*relative residual 3.000e-02"):
        engine.run(np.linspace(0.0, 3.0, 31), on_step=lambda r, s: done.append(r.index))
    assert done and done == list(range(len(done)))


def test_fig2_5_with_search_matches_the_exact_evolution():
    # l0 = 0.5, lam = 10, G/a = 0.05, eta = 10 dx, t in [0, 3] with 100 steps: one crack at 0
    # at t = 0.6816, three at 0 and +-0.125 at t = 1.620; each nucleation within one load
    # step and the total energy within 1% of the exact one after each event.
    t = np.linspace(0.0, 3.0, 101)
    grid, model = film(cells=800)
    engine = Engine(model, AltMinOptions(tol=1e-4), BacktrackOptions(kind="standard"),
                    SearchOptions(enabled=True))  # delta: 1e-3 G/a
    records, states = engine.run(t)
    found = events_of(grid, states)
    exact = evolve(0.5, 10.0, 0.05, cells=1000, t_max=3.0)
    assert [len(c) for _, c in found] == [len(e.cracks) for e in exact]
    for (t_found, cracks), event in zip(found, exact):
        assert abs(t_found - event.t) <= t[1] - t[0] + 1e-12
        assert np.max(np.abs(cracks - np.array(event.cracks))) < 4 * grid.hx
    evolution_states = [s for s in states if s.t >= found[0][0]]
    for s in evolution_states:
        cracks = [e for e in exact if e.t <= s.t]
        cracks = cracks[-1].cracks if cracks else ()
        exact_total = partition_energy(cracks, -0.25, 0.25, 10.0, 0.05, s.t)[2]
        if any(abs(s.t - e.t) < t[1] - t[0] for e in exact):
            continue  # the step that straddles an event compares two different branches
        assert s.total == pytest.approx(exact_total, rel=0.01)
    assert sum(r.trials for r in records) > 0
