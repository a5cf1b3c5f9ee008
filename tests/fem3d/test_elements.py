"""The element registry (:mod:`fem3d.elements`): adding an element is one module and one line.

This module is itself an element: P1 displacements integrated by a 4-point (3D: 8-point)
rule, through the generic kernels of :mod:`fem3d.kernels` (no fast path). Registered under
the name ``"P1Q"`` (the registry's one line, here ``monkeypatch.setitem``), it runs through
the operator, the loads and :func:`fem3d.kind.build_model` unchanged and gives P1's matrix,
right-hand side, reactions and energies (the strain of a P1 field is constant in a cell, so
any rule gives P1's values). The generic kernels also meet the P1 fast path on P1's own
one-point rule.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fem3d import elements, kernels, scene as fem_scene
from fem3d.elasticity import Elasticity
from fem3d.elements.p1 import P1Space
from fem3d.elements.p2 import P2Space
from fem3d.elements.quadrature import collapsed_gauss
from fem3d.elements.space import Space
from tests.fem3d.meshes import boundary_nodes, node_dofs, small_mesh
from tests.fem3d.solves import solve
from tests.helpers import load_case

E, NU = 3.0, 0.3


class P1QSpace(Space):
    """P1 with the :func:`~fem3d.elements.quadrature.collapsed_gauss` rule of 2 points per
    direction (exact to degree 3)."""

    name = "P1Q"

    def __init__(self, mesh):
        super().__init__(mesh)
        self.points, self.cells, self.facet_groups = mesh.points, mesh.cells, mesh.facet_groups
        self.bary, self.weights = collapsed_gauss(self.dim, 2)

    def basis_values(self, bary):
        return np.asarray(bary, dtype=np.float64)

    def gradients_at(self, bary):
        return np.broadcast_to(self.grads[:, None], (self.n_cells, len(bary)) + self.grads.shape[1:])

    def facet_load(self, facets, area, name="facets"):
        d = self.dim
        return np.asarray(facets, dtype=np.int64), np.repeat(np.asarray(area)[:, None] / d, d, axis=1)


SPACE = P1QSpace


@pytest.fixture
def p1q(monkeypatch):
    """The element of this module, registered for the test."""
    monkeypatch.setitem(elements.ELEMENTS, "P1Q", __name__)
    return "P1Q"


def rel_diff(a, b):
    a = a.toarray() if hasattr(a, "toarray") else np.asarray(a)
    b = b.toarray() if hasattr(b, "toarray") else np.asarray(b)
    return float(np.abs(a - b).max() / np.abs(b).max())


def test_registry():
    assert list(elements.ELEMENTS) == ["P1", "P2"]
    assert fem_scene.ELEMENTS == tuple(elements.ELEMENTS)
    assert elements.space_class("P1") is P1Space and elements.space_class("P2") is P2Space
    mesh = small_mesh(2)
    for name in elements.ELEMENTS:
        space = elements.make_space(name, mesh)
        assert space.name == name and space.mesh is mesh
        assert space.basis_gradients.shape == (mesh.n_cells, space.n_q, space.cells.shape[1], 2)
        np.testing.assert_array_equal(space.points[: mesh.n_nodes], mesh.points)
    with pytest.raises(KeyError, match="no element 'Q2'"):
        elements.space_class("Q2")


@pytest.mark.parametrize("dim,split", [(2, "none"), (3, "none"), (2, "amor"), (3, "positive")])
def test_a_registered_element_gives_p1s_operator(p1q, dim, split):
    mesh = small_mesh(dim)
    rng = np.random.default_rng(2)
    space = elements.make_space(p1q, mesh)
    assert isinstance(space, P1QSpace) and space.point_shape == (mesh.n_cells, 4 if dim == 2 else 8)
    con = node_dofs(boundary_nodes(mesh), dim)
    T = 1.3 if dim == 2 else 1.0
    options = dict(thickness=T, k_res=1e-3, constrained=con, split=split,
                   modulus=np.where(np.arange(mesh.n_cells) % 5 == 0, 0.2, 1.0))
    el, p1 = Elasticity(mesh, E, NU, space=space, **options), Elasticity(mesh, E, NU, **options)
    alpha = rng.random(mesh.n_nodes)
    u = rng.standard_normal(el.n_dofs)
    f = rng.standard_normal(el.n_dofs)
    tension = el.tension(u)
    assert tension.shape == space.point_shape
    np.testing.assert_array_equal(tension, np.repeat(p1.tension(u)[:, None], space.n_q, axis=1))
    K = el.matrix(alpha, tension=tension)
    K1 = p1.matrix(alpha, tension=p1.tension(u))
    np.testing.assert_array_equal(K.indices, K1.indices)
    assert rel_diff(K, K1) < 1e-13
    assert (K - K.T).count_nonzero() == 0 or abs(K - K.T).max() == 0.0   # symmetric bit for bit
    assert rel_diff(el.rhs(alpha, u[con], f, tension=tension), p1.rhs(alpha, u[con], f, tension=p1.tension(u))) < 1e-13
    assert rel_diff(el.reactions(alpha, u, f), p1.reactions(alpha, u, f)) < 1e-13
    assert rel_diff(el.nodal_energy(u), p1.nodal_energy(u)) < 1e-13
    assert el.elastic_energy(u, alpha) == pytest.approx(p1.elastic_energy(u, alpha), rel=1e-13)
    assert rel_diff(el.strain_energy_density(u), p1.strain_energy_density(u)) < 1e-13
    np.testing.assert_allclose(el.strain(u), np.repeat(p1.strain(u)[:, None], space.n_q, axis=1), rtol=0,
                               atol=1e-14 * np.abs(p1.strain(u)).max())
    # a body force: the degree-7 rule of the load vector on the P1 basis, the same as P1's
    force = np.array([0.3, -0.2, 0.1][:dim])
    assert rel_diff(el.body_force(force), p1.body_force(force)) < 1e-13


@pytest.mark.parametrize("dim", [2, 3])
def test_a_registered_element_passes_the_patch_test(p1q, dim):
    mesh = small_mesh(dim, jitter=0.4)
    rng = np.random.default_rng(5)
    con = node_dofs(boundary_nodes(mesh), dim)
    space = elements.make_space(p1q, mesh)
    el = Elasticity(mesh, E, NU, constrained=con, space=space)
    G, u0 = rng.standard_normal((dim, dim)), rng.standard_normal(dim)
    u_lin = space.interpolate(lambda x: u0 + x @ G.T)
    u = solve(el, np.zeros(mesh.n_nodes), u_lin[con])
    assert np.abs(u - u_lin).max() < 1e-12 * np.abs(u_lin).max()


def test_a_registered_element_through_build_model(p1q):
    """:func:`fem3d.kind.build_model` takes the scene's element from the registry: the coarse
    L-panel with ``element = "P1Q"`` has P1's loads, matrix and description."""
    from fem3d.kind import build_mesh, build_model

    scene = load_case("lpanel", {"model.eps": 25.0, "mesh.h": 12.5, "mesh.h_coarse": 50.0})
    mesh = build_mesh(scene)
    p1 = build_model(scene, mesh)
    other = build_model(dataclasses.replace(scene, model=dataclasses.replace(scene.model, element=p1q)), mesh)
    assert isinstance(other.elasticity.space, P1QSpace) and isinstance(p1.elasticity.space, P1Space)
    np.testing.assert_array_equal(other.loads.constrained, p1.loads.constrained)
    np.testing.assert_array_equal(other.loads.unit_force, p1.loads.unit_force)
    alpha = np.linspace(0.0, 0.9, mesh.n_nodes)
    assert rel_diff(other.elasticity.matrix(alpha), p1.elasticity.matrix(alpha)) < 1e-13
    assert type(other.elasticity.space.description()) is type(p1.elasticity.space.description())


@pytest.mark.parametrize("dim", [2, 3])
def test_generic_kernels_meet_the_p1_fast_path(dim):
    """On P1's own one-point rule the generic kernels give the fast path's matrix and
    boundary products to rounding (the same sums in another order), its strain and energy
    density bit for bit."""
    mesh = small_mesh(dim)
    rng = np.random.default_rng(8)
    con = node_dofs(boundary_nodes(mesh)[::2], dim)
    el = Elasticity(mesh, E, NU, thickness=1.0, k_res=1e-3, constrained=con)
    space = el.space
    lam, mu = el.lame(rng.random(mesh.n_nodes))
    data = np.empty(el.nnz)
    args = (el.thickness, el._free_index, el._indptr, el._offsets, data)
    kernels.stiffness_values(space.basis_gradients, space.measure, space.weights, space.cells, lam[:, None],
                             mu[:, None], *args)
    assert rel_diff(data, el.matrix(None, lame=(lam, mu)).data) < 1e-14
    u = rng.standard_normal(el.n_dofs)
    generic, fast = np.zeros(con.size), np.zeros(con.size)
    cells = np.arange(mesh.n_cells)
    index = (el._con_index, np.arange(el.n_dofs), u, 1.0)
    kernels.boundary_product(space.basis_gradients, space.measure, space.weights, space.cells, cells, lam[:, None],
                             mu[:, None], el.thickness, *index, generic)
    kernels.p1_boundary_product(space.grads, space.measure, space.cells, cells, lam, mu, el.thickness, *index, fast)
    assert rel_diff(generic, fast) < 1e-13
    # the strain and the density: the same operations
    np.testing.assert_array_equal(kernels.point_strain(space.basis_gradients, space.cells, u)[:, 0],
                                  kernels.p1_strain(space.grads, space.cells, u))
    np.testing.assert_array_equal(kernels.energy_density(space.basis_gradients, space.cells, u, el.lam, el.mu)[:, 0],
                                  kernels.p1_energy_density(space.grads, space.cells, u, el.lam, el.mu))
