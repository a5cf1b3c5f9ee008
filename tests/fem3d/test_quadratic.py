"""P2 displacements (:mod:`fem3d.elements.p2`, :mod:`fem3d.kernels`, :mod:`fem3d.elasticity`):
quadrature rules, the node set and its groups, kernels
against their NumPy references, the energy in the damage variables, patch tests (linear and
quadratic fields), third-order L2 convergence to a manufactured solution, bending against P1
and the beam, and a scene with ``element = "P2"`` run, indexed and resumed bit for bit.
"""

from __future__ import annotations

import itertools
import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
import scipy.sparse.linalg as spla

from fem3d import kernels
from fem3d.elasticity import Elasticity
from fem3d.elements.p2 import FACET_SHARES, LOCAL_EDGES, STIFFNESS_RULES, P2Space, basis_values
from fem3d.elements.quadrature import collapsed_gauss
from fem3d.mesh import Mesh
from fem3d.model import Loads
from fem3d.scene import Loading
from tests.fem3d.checks import force_and_moment
from tests.fem3d.manufactured import PH2, PH3, W2, W3, body_force, exact_fields
from tests.fem3d.meshes import tet_mesh, tri_mesh
from tests.helpers import CASES, ROOT, load_case
from thinfilm.scene import SceneError, parse_scene

E, NU = 3.0, 0.3
MODELS = [(2, "stress"), (2, "strain"), (3, None)]
MODEL_IDS = ["plane-stress", "plane-strain", "3d"]


def small_mesh(dim, jitter=0.3):
    return tri_mesh(5, 4, 1.2, 0.9, jitter=jitter) if dim == 2 else tet_mesh((3, 2, 2), (1.0, 0.8, 0.7), jitter=jitter)


def p2_boundary_nodes(space):
    """P2 nodes on the faces of the mesh's bounding box."""
    p = space.points
    lo, hi = p.min(axis=0), p.max(axis=0)
    tol = 1e-12 * float(np.ptp(p, axis=0).max())
    return np.flatnonzero(np.any((p < lo + tol) | (p > hi - tol), axis=1))


def dofs_of(nodes, dim):
    return np.sort((np.asarray(nodes)[:, None] * dim + np.arange(dim)).ravel())


def boundary_facets(mesh, where):
    """The boundary facets (vertex arrays, shape (k, d)) whose vertices all satisfy ``where(points)``."""
    d = mesh.dim
    faces = np.sort(np.concatenate([np.delete(mesh.cells, k, axis=1) for k in range(d + 1)]), axis=1)
    unique, counts = np.unique(faces, axis=0, return_counts=True)
    outer = unique[counts == 1]
    return outer[np.all(where(mesh.points)[outer], axis=1)]


def solve(el, alpha, u_d, f=None):
    u_f = spla.spsolve(el.matrix(alpha).tocsc(), el.rhs(alpha, u_d, f))
    return el.expand(u_f, u_d)


def rel_diff(A, B):
    A = A.toarray() if hasattr(A, "toarray") else np.asarray(A)
    B = B.toarray() if hasattr(B, "toarray") else np.asarray(B)
    return float(np.abs(A - B).max() / np.abs(B).max())


# --- quadrature, basis, node set ---------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_quadrature_rules_are_exact_to_their_degree(dim):
    def exact(p):   # Int over the reference simplex of x^p, over its measure 1/d!
        return math.prod(math.factorial(k) for k in p) / math.factorial(sum(p) + dim) * math.factorial(dim)

    rules = [(STIFFNESS_RULES[dim], 2)] + [(collapsed_gauss(dim, n), 2 * n - 1) for n in (2, 4)]
    for (bary, w), degree in rules:
        assert w.sum() == pytest.approx(1.0, abs=1e-15) and np.all(w > 0)
        np.testing.assert_allclose(bary.sum(axis=1), 1.0, atol=1e-15)
        for p in itertools.product(range(degree + 1), repeat=dim):
            if sum(p) <= degree:
                assert w @ np.prod(bary[:, 1:] ** np.array(p), axis=1) == pytest.approx(exact(p), abs=1e-15)
    # the P2 basis: a partition of unity, nodal (1 at its own node, 0 at the others)
    nodes = np.vstack([np.eye(dim + 1), 0.5 * (np.eye(dim + 1)[LOCAL_EDGES[dim][:, 0]]
                                                + np.eye(dim + 1)[LOCAL_EDGES[dim][:, 1]])])
    np.testing.assert_allclose(basis_values(nodes, dim), np.eye(nodes.shape[0]), atol=1e-15)
    bary, w = collapsed_gauss(dim, 3)
    np.testing.assert_allclose(basis_values(bary, dim).sum(axis=1), 1.0, atol=1e-14)
    # the consistent facet loads are the integrals of the facet's basis (a facet is a (d-1)-simplex)
    if dim == 3:
        fb, fw = collapsed_gauss(2, 2)
        np.testing.assert_allclose(fw @ basis_values(fb, 2), FACET_SHARES[3], atol=1e-15)
    else:
        s, ws = np.polynomial.legendre.leggauss(3)
        s, ws = (s + 1) / 2, ws / 2
        np.testing.assert_allclose(ws @ np.column_stack([(1 - s) * (1 - 2 * s), s * (2 * s - 1), 4 * s * (1 - s)]),
                                   FACET_SHARES[2], atol=1e-15)


@pytest.mark.parametrize("dim", [2, 3])
def test_node_set_and_groups(dim):
    mesh = small_mesh(dim)
    bottom = boundary_facets(mesh, lambda p: p[:, 1] == 0.0)
    corner = np.array([int(np.argmin(mesh.points.sum(axis=1)))])
    left = np.flatnonzero(mesh.points[mesh.cells].mean(axis=1)[:, 0] < 0.3)
    mesh = Mesh(mesh.points, mesh.cells, cell_groups={"left": left}, facet_groups={"bottom": bottom},
                node_groups={"corner": corner})
    space = P2Space(mesh)
    n_edges = {2: 3 * 5 * 4 + 5 + 4, 3: None}[dim]   # 2D: n_x n_y (3 per rectangle) + n_x + n_y
    if n_edges is not None:
        assert space.n_edges == n_edges
    # vertices first, in the mesh's numbering; each edge once; each cell's midpoints in the local order
    np.testing.assert_array_equal(space.points[: mesh.n_nodes], mesh.points)
    assert np.unique(space.edges, axis=0).shape[0] == space.n_edges and np.all(space.edges[:, 0] < space.edges[:, 1])
    local = LOCAL_EDGES[dim]
    mids = 0.5 * (mesh.points[mesh.cells[:, local[:, 0]]] + mesh.points[mesh.cells[:, local[:, 1]]])
    np.testing.assert_array_equal(space.points[space.cells[:, dim + 1:]], mids)
    assert np.bincount(space.cells[:, dim + 1:].ravel(), minlength=space.n_nodes)[mesh.n_nodes:].min() >= 1
    # groups: a boundary's nodes are its vertices and its facets' edge midpoints, all on it
    nodes = space.nodes_of("bottom")
    assert np.all(space.points[nodes, 1] == 0.0)
    on_bottom = np.flatnonzero(np.abs(space.points[:, 1]) < 1e-14)
    np.testing.assert_array_equal(nodes, on_bottom)
    facets = space.facet_groups["bottom"]
    assert facets.shape == (bottom.shape[0], 3 if dim == 2 else 6)
    np.testing.assert_array_equal(space.nodes_of("corner"), corner)
    np.testing.assert_array_equal(space.nodes_of("left"), np.unique(space.cells[mesh.cell_groups["left"]]))
    with pytest.raises(KeyError, match="no group"):
        space.nodes_of("top")
    with pytest.raises(ValueError, match="no edge"):
        space.facet_nodes(np.array([[0, space.n_vertices - 1, 1][:dim]]))


# --- kernels and the operator --------------------------------------------------------------------

@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_kernels_against_references(dim, plane):
    """Stiffness (per-point Lame parameters), right-hand side, reactions, basis gradients and
    strains against their NumPy/scipy references, with some nodes fully constrained and some
    in one component only."""
    mesh = small_mesh(dim)
    rng = np.random.default_rng(1)
    space = P2Space(mesh)
    bnd = p2_boundary_nodes(space)
    part = rng.choice(np.setdiff1d(np.arange(space.n_nodes), bnd), size=4, replace=False)
    con = np.union1d(dofs_of(bnd[::2], dim), part * dim + 1)
    T = 1.7 if dim == 2 else 1.0
    el = Elasticity(mesh, E, NU, plane=plane or "stress", thickness=T, k_res=1e-3, constrained=con, space=space)
    bary, w = space.bary, space.weights
    # the basis gradients against the chain rule on central differences in the barycentric
    # coordinates (exact for the quadratic basis)
    step = 0.5 * np.eye(dim + 1)
    dphi = np.stack([(basis_values(bary + step[k], dim) - basis_values(bary - step[k], dim)) / 1.0
                     for k in range(dim + 1)], axis=2)   # (n_q, nl, d + 1)
    np.testing.assert_allclose(space.basis_gradients, np.einsum("qlk,ekc->eqlc", dphi, el.grads), rtol=0,
                               atol=1e-12)
    lam, mu = rng.random((2, mesh.n_cells, space.n_q)) + 0.1
    K_full = kernels.stiffness_reference(space.basis_gradients, el.measure, w, space.cells, lam, mu, T)
    K = el.matrix(None, lame=(lam, mu))
    free = el.free
    assert K.shape == (free.size, free.size) and K.has_sorted_indices and K.nnz == el.nnz
    assert rel_diff(K, K_full[free][:, free]) < 1e-14
    assert (K - K.T).count_nonzero() == 0 or abs(K - K.T).max() == 0.0   # symmetric bit for bit
    # the pattern holds exactly the couplings of the free dofs
    r_indptr, r_indices = kernels.free_pattern_reference(*kernels.node_graph_reference(space.cells, space.n_nodes),
                                                         free, dim)
    np.testing.assert_array_equal(K.indptr, r_indptr)
    np.testing.assert_array_equal(K.indices, r_indices)
    # right-hand side and reactions: blocks of the full matrix
    u = rng.standard_normal(el.n_dofs)
    f = rng.standard_normal(el.n_dofs)
    u_d = u[con]
    rhs = el.rhs(None, u_d, f, lame=(lam, mu))
    assert rel_diff(rhs, f[free] - K_full[free][:, con] @ u_d) < 1e-13
    assert rel_diff(el.reactions(None, u, f, lame=(lam, mu)), K_full[con] @ u - f[con]) < 1e-13
    np.testing.assert_allclose(el.strain(u), kernels.point_strain_reference(space.basis_gradients, space.cells, u),
                               rtol=0, atol=1e-12 * np.abs(el.strain(u)).max())
    np.testing.assert_allclose(kernels.energy_density(space.basis_gradients, space.cells, u, el.lam, el.mu),
                               kernels.energy_density_reference(space.basis_gradients, space.cells, u, el.lam, el.mu),
                               rtol=1e-12)
    # the default Lame parameters: gbar_e times the cell's modulus, the same at every point
    alpha = rng.random(mesh.n_nodes)
    gbar = el.degradation(alpha)
    lam_q, mu_q = el.lame(alpha)
    np.testing.assert_array_equal(lam_q, np.repeat((gbar * el.lam)[:, None], space.n_q, axis=1))
    np.testing.assert_array_equal(el.matrix(alpha).data, el.matrix(None, lame=(lam_q, mu_q)).data)


@pytest.mark.parametrize("dim,split", [(2, "none"), (3, "none"), (2, "amor"), (3, "positive")])
def test_energy_in_the_damage_variables(dim, split):
    """``P(u, alpha) = 1/2 u.K(alpha).u`` (exact quadrature, no split) and
    ``P = sum_i c_i g(alpha_i) + T sum_e Int_e psi_minus`` on the vertices (any split); the
    cell density's mean is the point densities' weighted sum."""
    mesh = small_mesh(dim)
    rng = np.random.default_rng(4)
    modulus = np.where(mesh.points[mesh.cells].mean(axis=1)[:, 0] < 0.4, 0.1, 1.0)
    T = 0.6 if dim == 2 else 1.0
    el = Elasticity(mesh, E, NU, thickness=T, k_res=1e-3, modulus=modulus, split=split, space=P2Space(mesh))
    u = rng.standard_normal(el.n_dofs)
    alpha = rng.random(mesh.n_nodes)
    P = el.elastic_energy(u, alpha)
    c = el.nodal_energy(u)
    assert c.shape == (mesh.n_nodes,)
    g = (1.0 - alpha) ** 2 + el.k_res
    minus = T * np.dot(el.measure, el.cell_mean(el.energy_parts(u)[1]))
    assert P == pytest.approx(c @ g + minus, rel=1e-12)
    if split == "none":
        K_full = kernels.stiffness_reference(el.space.basis_gradients, el.measure, el.space.weights, el.space.cells,
                                             *el.lame(alpha), T)
        assert P == pytest.approx(0.5 * u @ (K_full @ u), rel=1e-12)
        # the quadrature is exact: a finer rule gives the same cell energies
        bary, w = collapsed_gauss(dim, 3)
        strain = kernels.point_strain(np.ascontiguousarray(el.space.gradients_at(bary)), el.space.cells, u)
        tr = strain[..., :dim].sum(axis=-1)
        ee = (strain[..., :dim] ** 2).sum(axis=-1) + 2 * (strain[..., dim:] ** 2).sum(axis=-1)
        psi = (0.5 * el.lam * tr ** 2 + el.mu * ee) @ w * modulus
        np.testing.assert_allclose(el.strain_energy_density(u), psi, rtol=1e-12)
    else:
        # the switch at each point; the frozen stiffness at u's own switch gives u's energy
        tension = el.tension(u)
        assert tension.shape == (mesh.n_cells, el.space.n_q) and tension.any() and not tension.all()
        K_full = kernels.stiffness_reference(el.space.basis_gradients, el.measure, el.space.weights, el.space.cells,
                                             *el.lame(alpha, tension), T)
        assert 0.5 * u @ (K_full @ u) == pytest.approx(P, rel=1e-12)


def test_validation():
    mesh = small_mesh(2)
    space = P2Space(mesh)
    with pytest.raises(ValueError, match="sorted"):
        Elasticity(mesh, E, NU, constrained=[5, 1], space=space)
    with pytest.raises(ValueError, match="outside"):
        Elasticity(mesh, E, NU, constrained=[2 * space.n_nodes], space=space)
    with pytest.raises(ValueError, match="space"):
        Elasticity(mesh, E, NU, space=P2Space(small_mesh(2)))
    el = Elasticity(mesh, E, NU, space=space)
    with pytest.raises(ValueError, match="alpha"):
        el.matrix(np.zeros(space.n_nodes))
    with pytest.raises(ValueError, match="lame"):
        el.matrix(None, lame=(np.zeros(mesh.n_cells), np.zeros(mesh.n_cells)))
    with pytest.raises(ValueError, match="not both"):
        el.matrix(np.zeros(mesh.n_nodes), lame=el.lame(np.zeros(mesh.n_nodes)))


# --- patch tests ---------------------------------------------------------------------------------

@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_patch(dim, plane):
    """On a jittered mesh, with the exact values on the boundary's P2 nodes: a linear field
    (no load) and a quadratic field (with its constant body force) are reproduced at every
    node; the reactions balance the body force in force and moment."""
    mesh = small_mesh(dim, jitter=0.4)
    rng = np.random.default_rng(3)
    space = P2Space(mesh)
    con = dofs_of(p2_boundary_nodes(space), dim)
    el = Elasticity(mesh, E, NU, plane=plane or "stress", constrained=con, space=space)
    alpha = np.zeros(mesh.n_nodes)
    G, u0 = rng.standard_normal((dim, dim)), rng.standard_normal(dim)
    u_lin = space.interpolate(lambda x: u0 + x @ G.T)
    u = solve(el, alpha, u_lin[con])
    assert np.abs(u - u_lin).max() < 1e-12 * np.abs(u_lin).max()
    # u_a = 1/2 x.Q_a.x (Q_a symmetric): grad div u and lap u are constant, and so is f
    Q = rng.standard_normal((dim, dim, dim))
    Q = 0.5 * (Q + np.swapaxes(Q, 1, 2))
    grad_div = np.einsum("kik->i", Q)   # d/dx_i (du_k/dx_k) = Q[k, k, i]
    lap = np.einsum("kii->k", Q)
    g = 1.0 + el.k_res   # the sound material's stiffness factor
    force = -g * ((el.lam + el.mu) * grad_div + el.mu * lap)
    u_quad = space.interpolate(lambda x: 0.5 * np.einsum("na,kab,nb->nk", x, Q, x))
    f = el.body_force(force)
    u = solve(el, alpha, u_quad[con], f)
    assert np.abs(u - u_quad).max() < 1e-11 * np.abs(u_quad).max()
    r = el.reactions(alpha, u, f)
    F, M = force_and_moment(space.points, dim, con, r)
    Fb, Mb = force_and_moment(space.points, dim, np.arange(el.n_dofs), f)
    scale = np.abs(r).max()
    assert np.abs(F + Fb).max() < 1e-11 * scale
    assert np.abs(M + Mb).max() < 1e-11 * scale * np.abs(space.points).max()


@pytest.mark.parametrize("dim", [2, 3])
def test_traction_load_gives_the_uniform_stress_state(dim):
    """A bar pulled by a uniform traction ``s`` on its right end (the consistent P2 facet load
    of :class:`fem3d.model.Loads`), held in x on the left end: the exact uniaxial stress
    ``s`` (P2 holds the linear field), the load summing to ``s`` times the end's area."""
    lx, ly, lz, s, T = 2.0, 0.5, 0.4, 0.01, 3.0
    if dim == 2:
        mesh = tri_mesh(6, 3, lx, ly, jitter=0.3)
        area, nu = ly * T, NU
    else:
        mesh, T = tet_mesh((4, 2, 2), (lx, ly, lz), jitter=0.3), 1.0
        area, nu = ly * lz, NU
    corner = int(np.flatnonzero(np.all(mesh.points == 0.0, axis=1))[0])
    groups = {"left": boundary_facets(mesh, lambda p: p[:, 0] == 0.0),
              "right": boundary_facets(mesh, lambda p: p[:, 0] == lx)}
    nodes = {"corner": np.array([corner])}
    if dim == 3:
        nodes["top"] = np.flatnonzero(np.all(mesh.points == [0.0, ly, 0.0], axis=1))
    mesh = Mesh(mesh.points, mesh.cells, facet_groups=groups, node_groups=nodes)
    space = P2Space(mesh)
    displacement = [("left", 0, 0.0), ("corner", 1, 0.0)] + ([("corner", 2, 0.0), ("top", 2, 0.0)] if dim == 3 else [])
    loading = Loading(t_max=1.0, steps=1, displacement=tuple(displacement),
                      traction=(("right", (s,) + (0.0,) * (dim - 1)),))
    loads = Loads(mesh, loading, T, space=space)
    assert loads.unit_force.shape == (space.n_nodes * dim,)
    assert loads.unit_force[0::dim].sum() == pytest.approx(s * area, rel=1e-13)
    if dim == 3:   # the 6-node facet load: nothing at the vertices
        assert np.all(loads.unit_force[: mesh.n_nodes * dim] == 0.0)
    # the left face's P2 nodes are held in x (its midpoints too)
    assert np.isin(dofs_of(space.nodes_of("left"), dim)[0::dim], loads.constrained).all()
    el = Elasticity(mesh, E, nu, thickness=T, k_res=0.0, constrained=loads.constrained, space=space)
    u = solve(el, np.zeros(mesh.n_nodes), loads.values_at(1.0), loads.force_at(1.0))
    stress = el.stress(u)
    np.testing.assert_allclose(stress[..., 0], s, rtol=1e-10)
    assert np.abs(stress[..., 1:]).max() < 1e-10 * s
    ux = u[0::dim]
    np.testing.assert_allclose(ux, s / E * space.points[:, 0], atol=1e-12 * s / E * lx)


# --- convergence and bending ---------------------------------------------------------------------

def manufactured_l2_error(mesh, plane):
    d = mesh.dim
    W, PH = (W2, PH2) if d == 2 else (W3, PH3)
    space = P2Space(mesh)
    con = dofs_of(p2_boundary_nodes(space), d)
    el = Elasticity(mesh, E, NU, plane=plane or "stress", k_res=0.0, constrained=con, space=space)
    f = el.body_force(lambda x: body_force(x, W, PH, el.lam, el.mu), n=4)
    u_exact = space.interpolate(lambda x: exact_fields(x, W, PH)[0])
    u = solve(el, np.zeros(mesh.n_nodes), u_exact[con], f)
    bary, w = collapsed_gauss(d, 4)
    x = space.points_at(bary)
    diff = space.evaluate(u, bary) - exact_fields(x.reshape(-1, d), W, PH)[0].reshape(x.shape)
    return math.sqrt(np.einsum("e,p,epc->", el.measure, w, diff ** 2))


@pytest.mark.parametrize("dim,plane,ns", [(2, "stress", [4, 8, 16]), (3, None, [2, 4, 8])], ids=["2d", "3d"])
def test_manufactured_convergence_of_order_3(dim, plane, ns):
    """Smooth ``u``, its body force integrated exactly to degree 7, the P2 interpolant of ``u``
    on the boundary: the L2 error falls as ``h^3`` (fitted on three meshes)."""
    meshes = [tri_mesh(n, n) for n in ns] if dim == 2 else [tet_mesh(n) for n in ns]
    errors = np.array([manufactured_l2_error(m, plane) for m in meshes])
    order = float(np.polyfit(np.log(1.0 / np.array(ns)), np.log(errors), 1)[0])
    assert 2.8 < order < 3.3, (order, errors)


def cantilever_compliance(n, element):
    """Tip deflection over tip force of a cantilever ``10 x 1 x 1`` (nu = 0) clamped at
    x = 0 and loaded by a uniform shear traction on its end x = 10, on ``10 n x n x n`` Kuhn
    boxes: the mean deflection of the end face."""
    L = 10.0
    mesh = tet_mesh((10 * n, n, n), (L, 1.0, 1.0))
    mesh = Mesh(mesh.points, mesh.cells, facet_groups={"clamp": boundary_facets(mesh, lambda p: p[:, 0] == 0.0),
                                                       "tip": boundary_facets(mesh, lambda p: p[:, 0] == L)})
    space = P2Space(mesh) if element == "P2" else None
    loading = Loading(t_max=1.0, steps=1, fixed=("clamp",), traction=(("tip", (0.0, 0.0, -1.0)),))
    loads = Loads(mesh, loading, 1.0, space=space)
    options = dict(k_res=0.0, constrained=loads.constrained)
    el = (Elasticity(mesh, 1.0, 0.0, space=space, **options) if element == "P2"
          else Elasticity(mesh, 1.0, 0.0, **options))
    f = loads.force_at(1.0)
    u = solve(el, np.zeros(mesh.n_nodes), loads.values_at(1.0), f)
    # the work of the unit tip load: the compliance
    return float(f @ u)


def test_p2_bends_where_p1_locks():
    """P1 tetrahedra are too stiff in bending. The Timoshenko beam's compliance is
    ``4 L^3/(E h^4) + L / (kappa G A) = 4024`` (L = 10, h = 1, E = 1, nu = 0, kappa = 5/6).
    Measured: P1 0.244, 0.550, 0.824 of it on 10n x n x n boxes (n = 1, 2, 4); P2 0.99845,
    0.99986 (n = 1, 2; 0.99997, 0.999994 at n = 3, 4)."""
    beam = 4.0 * 10.0 ** 3 + 10.0 / (5.0 / 6.0 * 0.5)
    p1 = [cantilever_compliance(n, "P1") / beam for n in (1, 2, 4)]
    p2 = [cantilever_compliance(n, "P2") / beam for n in (1, 2)]
    assert p1[0] < p1[1] < p1[2] < 1.0 and p1[0] < 0.3 and p1[2] > 0.8, p1
    assert p1[1] < p2[0] < p2[1] < 1.0, p2
    assert abs(p2[0] - 1.0) < 3e-3 and abs(p2[1] - 1.0) < 3e-4, p2


# --- the scene option and a run ----------------------------------------------------------------

SCENE_OVERRIDES = {"model.eps": 25.0, "mesh.h": 12.5, "mesh.h_coarse": 50.0, "model.element": "P2",
                   "load.t": [0.0, 0.1, 0.2, 0.3, 0.4], "output.snapshots": [0.4]}


def test_scene_key():
    scene = load_case("lpanel", {"model.element": "P2"})
    assert scene.model.element == "P2"
    assert load_case("lpanel").model.element == "P1"
    with pytest.raises(SceneError, match=r'model.element = "Q2": must be one of "P1", "P2"'):
        load_case("lpanel", {"model.element": "Q2"})
    with pytest.raises(SceneError, match=r"model.element"):
        parse_scene((CASES / "lpanel.toml").read_text().replace('kind = "fem"', 'kind = "fem"\nelement = 2'))


# Resumed runs are compared bit for bit, so both runs are made in a process of their own on one
# thread (a threaded PARDISO need not sum in the same order twice; tests/core/test_resume.py).
_ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

# The whole run, then a copy cut after step 2 (what a killed run leaves: every per-step dataset
# at 2 rows), resumed.
_RUNS = """
import json, shutil, sys
from pathlib import Path
import h5py
from tests.helpers import load_case
from thinfilm.run import run

out = Path(sys.argv[1])
scene = load_case("lpanel", json.loads(sys.argv[2]))
run(scene, out / "whole")
(out / "cut").mkdir()
shutil.copy(out / "whole" / "results.h5", out / "cut" / "results.h5")
with h5py.File(out / "cut" / "results.h5", "r+") as f:
    for name in f["steps"]:
        f["steps"][name].resize((2,))
    for name in ("u", "alpha"):
        f["fields"][name].resize((2, f["fields"][name].shape[1]))
run(scene, out / "cut", resume=True)
"""


def test_a_p2_run_through_the_toolkit_resumes_bit_for_bit(tmp_path):
    """The coarse L-panel with P2 displacements, elastic then cracking, through
    :func:`thinfilm.run.run`: results with the P2 layout, the figures, XDMF of the vertex
    values; cut after step 2 and resumed through the crack's nucleation, the same bits as the
    whole run; softer than P1 on the same mesh."""
    import json

    done = subprocess.run([sys.executable, "-c", _RUNS, str(tmp_path), json.dumps(SCENE_OVERRIDES)],
                          env=dict(os.environ, PYTHONPATH=str(ROOT), **_ONE_THREAD), capture_output=True, text=True,
                          timeout=300, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    whole = tmp_path / "whole"
    with h5py.File(whole / "results.h5") as f:
        n_vertices, n_edges = f["mesh/points"].shape[0], f["mesh/edges"].shape[0]
        assert f["mesh"].attrs["element"] == "P2" and f["parameters"].attrs["element"] == "P2"
        assert f["fields/u"].shape == (5, 2 * (n_vertices + n_edges)) and f["fields/alpha"].shape == (5, n_vertices)
        force, alpha = f["steps/force"][()], f["fields/alpha"][()]
    assert force[1] > 0 and alpha[1].max() == 0.0   # elastic at t = 0.1, cracked at 0.3
    assert alpha[-1].max() > 0.9 and force[3] < 0.5 * force[2]
    for name in ("force_displacement.png", "crack_length.png", "energy.png", "alpha_snapshots.png"):
        assert (whole / name).stat().st_size > 0, name
    root = ET.parse(whole / "results.xdmf").getroot()
    slab = root.find(".//Attribute[@Name='u']/DataItem")
    assert slab.get("Dimensions") == f"{n_vertices} 2"
    assert slab[0].text.split()[-1] == str(2 * n_vertices)
    with h5py.File(whole / "results.h5") as a, h5py.File(tmp_path / "cut" / "results.h5") as b:
        for name in ("fields/u", "fields/alpha", "steps/t", "steps/total", "steps/force"):
            np.testing.assert_array_equal(a[name][()], b[name][()], err_msg=name)
    # P1 on the same mesh: stiffer
    from fem3d.kind import build_mesh, build_model

    p1 = load_case("lpanel", {**SCENE_OVERRIDES, "model.element": "P1"})
    model = build_model(p1, build_mesh(p1))
    u = model.solve_u(np.zeros(n_vertices), 0.1, None, None)
    assert model.forces(u, np.zeros(n_vertices), 0.1)["load"] > 1.02 * force[1]
