"""Unilateral contact (:mod:`fem3d.split`, (4.10)-(4.12)): the densities and their frozen-switch
stiffness, the stress as the energy's gradient, the nonlinear u-solve against the closed form of
a damaged strip in uniaxial tension and compression, and alternate minimization with each split
on a small L-panel (the energy never rises; the switches are counted)."""

from __future__ import annotations

import numpy as np
import pytest

from fem3d import split as splits
from fem3d.damage import P1Damage
from fem3d.elasticity import Elasticity, lame_parameters
from fem3d.model import FemModel, Loads
from fem3d.scene import Loading
from tests.fem3d.meshes import small_mesh
from tests.fem3d.strip import EPS, GC, K_RES, E, H, L, NU, T, strip_mesh
from tests.helpers import load_case
from thinfilm.engine import Engine
from thinfilm.scene import SceneError
from thinfilm.solvers.linear import make_solver

SPLITS = ("none", "amor", "positive")


def random_strains(d, n=2000, seed=0):
    """Strains in Voigt order with tensor shear, of both signs of the trace."""
    return np.random.default_rng(seed).standard_normal((n, 3 if d == 2 else 6))


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("split", SPLITS)
def test_the_parts_add_up_and_the_frozen_switch_gives_the_density(d, split):
    lam, mu = lame_parameters(E, NU, "stress" if d == 2 else None)
    e = random_strains(d)
    plus, minus = splits.energy_parts(e, lam, mu, d, split)
    tr = e[:, :d].sum(axis=1)
    ee = (e[:, :d] ** 2).sum(axis=1) + 2 * (e[:, d:] ** 2).sum(axis=1)
    psi0 = 0.5 * lam * tr ** 2 + mu * ee
    np.testing.assert_allclose(plus + minus, psi0, rtol=1e-13)
    assert plus.min() >= 0.0 and minus.min() >= 0.0
    compressed = tr < 0
    assert compressed.any() and (~compressed).any()
    if split == "none":
        assert np.all(minus == 0.0)
    elif split == "positive":
        assert np.all(plus[compressed] == 0.0) and np.all(minus[~compressed] == 0.0)
    else:   # amor: the compressed volume change is intact, the rest degraded
        kappa = lam + 2 * mu / d
        np.testing.assert_allclose(minus, np.where(compressed, 0.5 * kappa * tr ** 2, 0.0), rtol=1e-13)
    # with the switch frozen at the strain's own, the effective Lame parameters give g psi+ + psi-
    g = np.random.default_rng(1).uniform(1e-3, 1.0, e.shape[0])
    lam_H, mu_H = splits.effective_lame(g, splits.tension(e, d), lam, mu, d, split)
    np.testing.assert_allclose(0.5 * lam_H * tr ** 2 + mu_H * ee, g * plus + minus, rtol=1e-12)
    # and with every point taken in tension, the whole density degraded
    lam_1, mu_1 = splits.effective_lame(g, None, lam, mu, d, split)
    np.testing.assert_allclose(0.5 * lam_1 * tr ** 2 + mu_1 * ee, g * psi0, rtol=1e-12)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("split", SPLITS)
def test_the_frozen_stiffness_at_the_own_switch_is_the_energy_gradient(dim, split):
    # K_H(u) u - (- K_fd u_d) on the free dofs is dP/du_f: central differences of the
    # elastic energy agree (the points where tr e = 0 have measure zero).
    mesh = small_mesh(dim)
    rng = np.random.default_rng(2)
    lo = mesh.points.min(axis=0)
    con = np.flatnonzero(mesh.points[:, 0] < lo[0] + 1e-9)
    constrained = np.sort(np.concatenate([con * dim + c for c in range(dim)]))
    el = Elasticity(mesh, E, NU, plane="stress", constrained=constrained, split=split)
    alpha = rng.uniform(0.0, 0.9, mesh.n_nodes)
    u = rng.standard_normal(el.n_dofs) * 1e-3
    tension = el.tension(u)
    assert tension.any() and (~tension).any()
    gradient = el.matrix(alpha, tension=tension) @ u[el.free] - el.rhs(alpha, u[el.constrained], tension=tension)
    v = np.zeros(el.n_dofs)
    v[el.free] = rng.standard_normal(el.free.size)
    s = 1e-7
    fd = (el.elastic_energy(u + s * v, alpha) - el.elastic_energy(u - s * v, alpha)) / (2 * s)
    assert fd == pytest.approx(gradient @ v[el.free], rel=1e-6)
    # the damage problem's nodal energy is the degraded part: P = sum c_i g_i + T sum |e| psi-
    g = (1 - alpha) ** 2 + el.k_res
    minus = el.energy_parts(u)[1]
    P = el.nodal_energy(u) @ g + el.thickness * el.measure @ minus
    # vertex quadrature: P uses the cell mean of g, the nodal form its nodal values: the same sum
    assert P == pytest.approx(el.elastic_energy(u, alpha), rel=1e-12)


def strip(split, alpha_value):
    """The plane-stress strip of tests/fem3d/test_model.py (pulled or pushed by u_x = t at
    x = L, lateral contraction free) with uniform damage and a contact split."""
    mesh = strip_mesh(40, 4)
    loading = Loading(t_max=1.0, steps=2, fixed=("pin",), displacement=(("left", 0, 0.0), ("right", 0, 1.0)))
    loads = Loads(mesh, loading, T)
    el = Elasticity(mesh, E, NU, plane="stress", thickness=T, k_res=K_RES, constrained=loads.constrained,
                    split=split)
    model = FemModel(mesh, el, P1Damage(mesh, GC, EPS, thickness=T), loads,
                     make_solver("direct", el.matrix(np.zeros(mesh.n_nodes))))
    return model, np.full(mesh.n_nodes, alpha_value)


def uniaxial_stress(split, g, e1):
    """The axial stress of a plane-stress bar, uniaxial stress, axial strain e1, degradation g:
    the lateral strain e2 minimizes the density (2D trace and deviator, kappa = lam* + mu)."""
    lam, mu = lame_parameters(E, NU, "stress")
    if e1 > 0 or split == "none":
        return g * E * e1           # tension (or no split): the whole density degraded
    if split == "positive":
        return E * e1               # compression: nothing degraded
    kappa = lam + mu                # amor in compression: g mu (e1 - e2)^2 / 2 + kappa (e1 + e2)^2 / 2
    e2 = e1 * (g * mu - kappa) / (g * mu + kappa)
    return g * mu * (e1 - e2) + kappa * (e1 + e2)


@pytest.mark.parametrize("split", SPLITS)
@pytest.mark.parametrize("t", [0.01, -0.01])
def test_damaged_strip_in_tension_and_compression_against_the_closed_form(split, t):
    model, alpha = strip(split, 0.5)
    g = 0.25 + K_RES
    u = model.solve_u(alpha, t, None, 1e-12)
    sigma = uniaxial_stress(split, g, t / L)
    force = model.forces(u, alpha, t)["right"]
    assert force == pytest.approx(sigma * H * T, rel=1e-9)
    assert model.energies(u, alpha, t)[0] == pytest.approx(0.5 * sigma * (t / L) * L * H * T, rel=1e-9)
    if split == "none":
        assert model.switches == []
    elif t > 0:
        assert model.switches == [0]   # started in tension, stays there: one solve
    else:
        # from the all-tension start every cell switches once, then the switch is settled
        assert model.switches == [model.mesh.n_cells, 0]
    # in compression (4.11) softens the shear only, (4.12) nothing: their strips are stiffer
    if t < 0 and split != "none":
        assert abs(force) > (g * E * abs(t) / L) * H * T


def small_lpanel(split):
    from fem3d.kind import build_mesh, build_model

    scene = load_case("lpanel", {"model.eps": 25.0, "mesh.h": 12.5, "mesh.h_coarse": 50.0, "model.split": split,
                                 "load.t": None, "load.t_max": 0.4, "load.steps": 8, "output": None})
    return build_model(scene, build_mesh(scene)), scene


@pytest.mark.parametrize("split", ["amor", "positive"])
def test_alternate_minimization_with_a_split_never_raises_the_energy(split):
    model, scene = small_lpanel(split)
    records, states = Engine.from_options(model, scene.solver).run(np.linspace(0.0, 0.4, 9))
    assert states[-1].alpha.max() > 0.9            # the panel cracked
    assert max(r.iterations for r in records) > 5
    for record in records:
        history = np.array(record.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * max(1.0, abs(history[0])))
    # the panel has compressed cells: the switch moved, and it settled in most u-solves
    switches = np.array(model.switches)
    assert switches.sum() > 0
    assert np.mean(switches == 0) > 0.3
    # the reaction is still the derivative of the minimized energy at fixed damage
    state = states[-1]
    t, dt = state.t, 1e-4 * state.t

    def elastic(ti):
        return model.energies(model.solve_u(state.alpha, ti, state.u * (ti / t), 1e-12), state.alpha, ti)[0]

    derivative = (elastic(t + dt) - elastic(t - dt)) / (2 * dt)
    u = model.solve_u(state.alpha, t, state.u, 1e-12)
    assert model.forces(u, state.alpha, t)["load"] == pytest.approx(derivative, rel=1e-6)


def test_a_split_with_a_constant_load_refuses_backtracking():
    with pytest.raises(SceneError, match=r"model.split = \"amor\": backtracking under a load with a constant part"):
        load_case("lpanel", {"model.split": "amor", "solver.backtrack": "standard",
                             "load.constant.force.load": {"x": 10.0}})
    with pytest.raises(SceneError, match=r"model.split = \"tension\": must be one of"):
        load_case("lpanel", {"model.split": "tension"})
