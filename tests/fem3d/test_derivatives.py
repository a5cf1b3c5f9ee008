"""FemModel's EnergyDerivatives hook (fem3d/derivatives.py) against finite differences: P1 and
P2, plane stress and strain with a thickness, 3D, the splits."""

from __future__ import annotations

import numpy as np
import pytest

from fem3d.damage import P1Damage
from fem3d.elasticity import Elasticity
from fem3d.elements.p1 import P1Space
from fem3d.elements.p2 import P2Space
from fem3d.mesh import Mesh
from fem3d.model import FemModel, Loads
from fem3d.scene import Loading
from tests.derivatives_check import check_energy_derivatives, interior_damage
from tests.fem3d.meshes import small_mesh
from thinfilm.laws import CohesiveLaw
from thinfilm.solvers.linear import make_solver

E, NU, GC, EPS, K_RES = 3.0, 0.3, 1.2, 0.2, 1e-6


def model_on(dim, element="P1", plane="stress", thickness=1.0, split="none", at=1, modulus=False):
    """A jittered small mesh, its left side fixed, its right side pulled in x, a force in y on
    it; ``at = 0``: the cohesive law (linear softening, ft = 0.5)."""
    base = small_mesh(dim)
    x = base.points[:, 0]
    mesh = Mesh(base.points, base.cells, node_groups={"left": np.flatnonzero(np.isclose(x, x.min())),
                                                      "right": np.flatnonzero(np.isclose(x, x.max()))})
    space = (P1Space if element == "P1" else P2Space)(mesh)
    force = (0.0, 0.3) if dim == 2 else (0.0, 0.3, -0.2)
    loading = Loading(t_max=1.0, steps=2, fixed=("left",), displacement=(("right", 0, 1.0),),
                      force=(("right", force),))
    loads = Loads(mesh, loading, thickness, space=space)
    cell_modulus = np.random.default_rng(7).uniform(0.5, 2.0, mesh.n_cells) if modulus else None
    elasticity = Elasticity(mesh, E, NU, plane=plane, thickness=thickness, k_res=K_RES, constrained=loads.constrained,
                            modulus=cell_modulus, split=split, space=space,
                            law=CohesiveLaw(E, GC, 0.5, EPS) if at == 0 else None)
    damage = P1Damage(mesh, GC, EPS, at=at or 1, thickness=thickness, law=elasticity.law if at == 0 else None)
    solver = make_solver("direct", elasticity.matrix(np.zeros(mesh.n_nodes)))
    return FemModel(mesh, elasticity, damage, loads, solver)


def random_state(model, t, seed=0):
    rng = np.random.default_rng(seed)
    n_free = model.elasticity.free.size
    u = model.u_from_free(0.3 * rng.standard_normal(n_free), t)
    return u, interior_damage(rng, model.n_alpha)


@pytest.mark.parametrize("dim, element, plane, thickness, at", [
    (2, "P1", "stress", 0.3, 1),
    (2, "P1", "strain", 2.5, 2),
    (2, "P2", "stress", 0.3, 1),
    (2, "P2", "strain", 2.5, 1),
    (3, "P1", None, 1.0, 2),
    (3, "P2", None, 1.0, 1),
    (2, "P1", "stress", 0.3, 0),
    (3, "P1", None, 1.0, 0),
])
def test_gradient_and_hessian_blocks_match_finite_differences(dim, element, plane, thickness, at):
    model = model_on(dim, element, plane or "stress", thickness, at=at, modulus=True)
    t = 0.7
    u, alpha = random_state(model, t)
    if at == 0:   # the cohesive law: g rational, so smaller steps for the same fitted order
        check_energy_derivatives(model, u, alpha, t, steps=(2e-3, 1e-3, 5e-4), quadratic_alpha=False)
    else:
        check_energy_derivatives(model, u, alpha, t)


@pytest.mark.parametrize("split", ["amor", "positive"])
@pytest.mark.parametrize("dim, element", [(2, "P1"), (2, "P2"), (3, "P1")])
def test_splits_away_from_the_switch_surfaces(split, dim, element):
    # random strains: no point's trace is within the steps' reach of 0 (checked), so the
    # energy is the quadratic of the frozen switch along every difference
    model = model_on(dim, element, "strain", 1.5 if dim == 2 else 1.0, split=split)
    t = 0.5
    u, alpha = random_state(model, t, seed=1)
    el = model.elasticity
    trace = el.strain(u)[..., :dim].sum(axis=-1)
    assert np.abs(trace).min() > 1e-3
    assert el.tension(u).any() and (~el.tension(u)).any()
    check_energy_derivatives(model, u, alpha, t, steps=(1e-4, 5e-5, 2.5e-5), smallest=1e-6, exact=1e-6)


@pytest.mark.parametrize("dim, element, split", [(2, "P1", "none"), (2, "P2", "amor"), (3, "P1", "none")])
def test_blocks_are_the_u_matrix_and_the_damage_problem(dim, element, split):
    model = model_on(dim, element, "stress", 0.4 if dim == 2 else 1.0, split=split)
    t = 0.6
    u, alpha = random_state(model, t, seed=2)
    K_uu, K_ua, K_aa = model.hessian_blocks(u, alpha, t)
    el = model.elasticity
    tension = None if split == "none" else el.tension(u)
    assert (K_uu != el.matrix(alpha, tension=tension)).nnz == 0
    A, b = model.damage_problem(u, t)
    assert (K_aa != A).nnz == 0
    g_u, g_a = model.energy_gradient(u, alpha, t)
    np.testing.assert_array_equal(g_a, A @ alpha - b)
    # at the displacement solve_u returns, the u-gradient vanishes
    u_star = model.solve_u(alpha, t, None, None)
    g_star, _ = model.energy_gradient(u_star, alpha, t)
    assert np.linalg.norm(g_star) < 1e-8 * np.linalg.norm(g_u)
    # the blocks are fresh: a later solve does not change them
    K_copy = K_uu.copy()
    model.solve_u(np.zeros(model.n_alpha), t, None, None)
    assert (K_uu != K_copy).nnz == 0


def test_fixed_damage_nodes_are_decoupled():
    model = model_on(2, "P1", "stress", 0.5)
    fixed = np.array([0, 5, 9])
    model.damage = P1Damage(model.mesh, GC, EPS, at=1, thickness=0.5, fixed_nodes=fixed)
    u, alpha = random_state(model, 0.5, seed=3)
    _, K_ua, K_aa = model.hessian_blocks(u, alpha, 0.5)
    assert K_ua[:, fixed].nnz == 0 or np.all(K_ua[:, fixed].toarray() == 0)
    np.testing.assert_array_equal(K_aa[fixed][:, fixed].toarray(), np.eye(3))
