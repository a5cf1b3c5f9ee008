"""P1 elasticity (:mod:`fem3d.elasticity`, :mod:`fem3d.kernels`, :mod:`fem3d.elements.p1`): kernels against their NumPy
references and against scikit-fem, the patch test, convergence to a manufactured solution,
plane stress against plane strain, reactions as the derivative of the energy.

Meshes are built by :mod:`tests.fem3d.meshes`: structured triangulations with diagonals
alternating from row to row (every interior node has six triangles) and Kuhn
tetrahedralizations (six tetrahedra per cube around its main diagonal), optionally with the
interior nodes jittered.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.sparse.linalg as spla
import skfem
from skfem.helpers import ddot, div, sym_grad
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTet, RefTri

from fem3d import kernels
from fem3d.elasticity import Elasticity, lame_parameters
from fem3d.mesh import Mesh
from tests.fem3d.checks import fitted_order, force_and_moment, rel_diff
from tests.fem3d.manufactured import PH2, PH3, W2, W3, body_force, exact_fields
from tests.fem3d.meshes import boundary_nodes, node_dofs, small_mesh, tet_mesh, to_skfem, tri_mesh
from tests.fem3d.solves import solve

E, NU = 3.0, 0.3
MODELS = [(2, "stress"), (2, "strain"), (3, None)]
MODEL_IDS = ["plane-stress", "plane-strain", "3d"]


# --- meshes ------------------------------------------------------------------------------------

def elasticity(dim, plane, mesh=None, **kw):
    mesh = small_mesh(dim) if mesh is None else mesh
    return Elasticity(mesh, E, NU, plane=plane or "stress", **kw)


def smooth_alpha(mesh, amplitude=0.9):
    """A damage bump in [0, amplitude] across the mesh."""
    x = (mesh.points - mesh.points.min(axis=0)) / np.ptp(mesh.points, axis=0)
    return amplitude * np.exp(-8.0 * ((x[:, 0] - 0.5) ** 2 + 0.3 * (x[:, 1] - 0.4) ** 2))


# --- scikit-fem references ----------------------------------------------------------------------

def skfem_stiffness(mesh, lam, mu, coef, thickness=1.0):
    """The full stiffness matrix with a P0 coefficient, by scikit-fem."""
    m = to_skfem(mesh)
    p1, p0 = (skfem.ElementTriP1(), skfem.ElementTriP0()) if mesh.dim == 2 else (skfem.ElementTetP1(),
                                                                                  skfem.ElementTetP0())
    basis = skfem.Basis(m, skfem.ElementVector(p1))
    assert np.array_equal(basis.nodal_dofs, np.arange(basis.N).reshape(-1, mesh.dim).T)  # node * d + a
    g = basis.with_element(p0).interpolate(coef)

    @skfem.BilinearForm
    def form(u, v, w):
        return w["g"] * (lam * div(u) * div(v) + 2.0 * mu * ddot(sym_grad(u), sym_grad(v)))

    return thickness * skfem.asm(form, basis, g=g).tocsr()


# --- kernels -------------------------------------------------------------------------------------

@pytest.mark.parametrize("dim", [2, 3])
def test_geometry_and_node_graph_against_references(dim):
    mesh = small_mesh(dim)
    grads, measure = kernels.cell_geometry(mesh.points, mesh.cells)
    g_ref, m_ref = kernels.cell_geometry_reference(mesh.points, mesh.cells)
    assert rel_diff(grads, g_ref) < 1e-13 and rel_diff(measure, m_ref) < 1e-14
    assert measure.sum() == pytest.approx(float(np.prod(np.ptp(mesh.points, axis=0))), rel=1e-14)
    # gradients of the barycentric coordinates: sum to 0, and grad lambda_k . (x_l - x_0) = delta_kl - delta_k0
    assert np.abs(grads.sum(axis=1)).max() < 1e-12 * np.abs(grads).max()
    edges = mesh.points[mesh.cells[:, 1:]] - mesh.points[mesh.cells[:, :1]]
    np.testing.assert_allclose(np.einsum("ekc,elc->ekl", grads[:, 1:], edges), np.broadcast_to(np.eye(dim), (mesh.n_cells, dim, dim)),
                               atol=1e-13)
    indptr, indices = kernels.node_graph(mesh.cells, mesh.n_nodes)
    r_indptr, r_indices = kernels.node_graph_reference(mesh.cells, mesh.n_nodes)
    np.testing.assert_array_equal(indptr, r_indptr)
    np.testing.assert_array_equal(indices, r_indices)


@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_kernels_against_references(dim, plane):
    """Every kernel against its NumPy/scipy reference, with some nodes fully constrained and
    some constrained in one component only (rows and columns of partly free nodes)."""
    mesh = small_mesh(dim)
    rng = np.random.default_rng(1)
    bnd = boundary_nodes(mesh)
    part = rng.choice(np.setdiff1d(np.arange(mesh.n_nodes), bnd), size=3, replace=False)
    con = np.union1d(node_dofs(bnd[::2], dim), part * dim + 1)
    el = elasticity(dim, plane, mesh, thickness=1.7 if dim == 2 else 1.0, k_res=1e-3, constrained=con)
    T = el.thickness
    alpha = rng.random(mesh.n_nodes)
    u = rng.standard_normal(el.n_dofs)
    gbar = el.degradation(alpha)
    np.testing.assert_allclose(gbar, kernels.cell_degradation_reference(alpha, mesh.cells, el.k_res), rtol=1e-15)

    K_full = kernels.stiffness_reference(el.space.basis_gradients, el.measure, el.space.weights, mesh.cells,
                                         gbar * el.lam, gbar * el.mu, T)
    free = el.free
    K = el.matrix(alpha)
    assert K.shape == (free.size, free.size) and K.has_sorted_indices and K.nnz == el.nnz
    assert rel_diff(K, K_full[free][:, free]) < 1e-14
    # the pattern holds exactly the couplings of the free dofs (no missing or spurious entries)
    indptr, indices, _ = kernels.free_pattern(*kernels.node_graph(mesh.cells, mesh.n_nodes), el._free_index, dim,
                                              free.size)
    r_indptr, r_indices = kernels.free_pattern_reference(*kernels.node_graph_reference(mesh.cells, mesh.n_nodes),
                                                         free, dim)
    for a, b in ((indptr, r_indptr), (indices, r_indices), (K.indptr, r_indptr), (K.indices, r_indices)):
        np.testing.assert_array_equal(a, b)

    u_d = rng.standard_normal(con.size)
    f = rng.standard_normal(el.n_dofs)
    np.testing.assert_allclose(el.rhs(alpha, u_d, f), f[free] - K_full[free][:, con] @ u_d, rtol=1e-12,
                               atol=1e-13 * np.abs(f).max())
    r = el.reactions(alpha, u, f)
    np.testing.assert_allclose(r, (K_full @ u - f)[con], rtol=1e-12, atol=1e-13 * np.abs(K_full @ u).max())
    assert rel_diff(el.reactions(alpha, u), (K_full @ u)[con]) < 1e-13

    psi = el.strain_energy_density(u)
    basis = el.space.basis_gradients
    np.testing.assert_allclose(psi, kernels.energy_density_reference(basis, mesh.cells, u, el.lam, el.mu)[:, 0],
                               rtol=1e-13)
    np.testing.assert_allclose(el.strain(u), kernels.point_strain_reference(basis, mesh.cells, u)[:, 0], rtol=1e-13,
                               atol=1e-14 * np.abs(el.strain(u)).max())
    c = el.nodal_energy(u)
    np.testing.assert_allclose(c, kernels.nodal_energy_reference(psi, el.measure, mesh.cells, T, mesh.n_nodes),
                               rtol=1e-13)
    # the energy three ways: cells, nodes (P = sum_i c_i g(alpha_i)), quadratic form
    g = (1.0 - alpha) ** 2 + el.k_res
    P = el.elastic_energy(u, alpha)
    assert P == pytest.approx(c @ g, rel=1e-13)
    assert P == pytest.approx(0.5 * u @ (K_full @ u), rel=1e-12)
    # stress: sigma = C e in Voigt, and psi = 1/2 sigma . e (engineering shears)
    s, e = el.stress(u), el.strain(u)
    e_eng = e.copy()
    e_eng[:, dim:] *= 2.0
    np.testing.assert_allclose(s, e_eng @ kernels.elasticity_matrix_voigt(el.lam, el.mu, dim), rtol=1e-12,
                               atol=1e-13 * np.abs(s).max())
    np.testing.assert_allclose(0.5 * np.einsum("ei,ei->e", s, e_eng), psi, rtol=1e-12)


@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
@pytest.mark.parametrize("damaged", [False, True], ids=["sound", "damaged"])
def test_matrix_against_skfem(dim, plane, damaged):
    """``K_ff`` equals scikit-fem's assembly with ``lam``, ``mu`` (plane stress: ``lam*``) and
    the cell degradation as a P0 coefficient, restricted to the free dofs."""
    mesh = small_mesh(dim)
    con = node_dofs(boundary_nodes(mesh)[::3], dim)
    T = 2.5 if dim == 2 else 1.0
    el = elasticity(dim, plane, mesh, thickness=T, constrained=con)
    alpha = smooth_alpha(mesh) if damaged else np.zeros(mesh.n_nodes)
    lam3, mu = lame_parameters(E, NU)
    lam = 2.0 * lam3 * mu / (lam3 + 2.0 * mu) if plane == "stress" else lam3
    assert (el.lam, el.mu) == pytest.approx((lam, mu), rel=1e-15)
    gbar = ((1.0 - alpha) ** 2 + el.k_res)[mesh.cells].mean(axis=1)
    K_ref = skfem_stiffness(mesh, lam, mu, gbar, T)
    assert rel_diff(el.matrix(alpha), K_ref[el.free][:, el.free]) < 1e-12
    K = el.matrix(alpha)
    assert abs(K - K.T).max() == 0.0
    assert spla.eigsh(K, k=1, sigma=0, which="LM", return_eigenvectors=False)[0] > 0


def test_matrix_is_rewritten_in_place():
    el = elasticity(2, "stress", constrained=node_dofs(boundary_nodes(small_mesh(2)), 2))
    K0 = el.matrix(np.zeros(el.mesh.n_nodes))
    data0 = K0.data.copy()
    K1 = el.matrix(np.full(el.mesh.n_nodes, 0.5))
    assert K1 is K0
    assert rel_diff(K1.data, data0 * (0.25 + el.k_res) / (1.0 + el.k_res)) < 1e-14
    lame = (np.full(el.mesh.n_cells, 2.0 * el.lam), np.full(el.mesh.n_cells, 2.0 * el.mu))
    assert rel_diff(el.matrix(None, lame=lame).data, 2 * data0 / (1 + el.k_res)) < 1e-14


@pytest.mark.parametrize("dim", [2, 3])
def test_rigid_modes(dim):
    """``K`` (no constraint, any damage) annihilates the rigid-body modes; the columns are
    of order 1 and independent; with constraints they are the free rows."""
    mesh = small_mesh(dim)
    el = elasticity(dim, "stress", mesh)
    B = el.rigid_modes()
    assert B.shape == (el.n_dofs, 3 if dim == 2 else 6)
    assert 0.3 < np.abs(B).max() <= 1.0
    assert np.linalg.matrix_rank(B) == B.shape[1]
    K = el.matrix(smooth_alpha(mesh))
    assert np.abs(K @ B).max() < 1e-13 * abs(K).max()
    con = node_dofs(boundary_nodes(mesh)[:4], dim)
    el_c = elasticity(dim, "stress", mesh, constrained=con)
    np.testing.assert_array_equal(el_c.rigid_modes(), B[el_c.free])


def test_expand_and_validation():
    mesh = small_mesh(2)
    con = np.array([0, 1, 5])
    el = elasticity(2, "stress", mesh, constrained=con)
    u_f = np.arange(el.free.size, dtype=float)
    u = el.expand(u_f, [7.0, 8.0, 9.0])
    np.testing.assert_array_equal(u[con], [7.0, 8.0, 9.0])
    np.testing.assert_array_equal(u[el.free], u_f)
    with pytest.raises(ValueError, match="sorted"):
        elasticity(2, "stress", mesh, constrained=[5, 1])
    with pytest.raises(ValueError, match="outside"):
        elasticity(2, "stress", mesh, constrained=[0, 2 * mesh.n_nodes])
    with pytest.raises(ValueError, match="nu"):
        Elasticity(mesh, E, 0.5)
    with pytest.raises(ValueError, match="plane"):
        Elasticity(mesh, E, NU, plane="axisymmetric")
    with pytest.raises(ValueError, match="thickness"):
        Elasticity(small_mesh(3), E, NU, thickness=2.0)
    with pytest.raises(ValueError, match="no cell"):
        Elasticity(Mesh(np.vstack([mesh.points, [[5.0, 5.0]]]), mesh.cells), E, NU)
    with pytest.raises(ValueError, match="shape"):
        el.matrix(np.zeros(3))


# --- patch test and equilibrium ------------------------------------------------------------------

@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_patch(dim, plane):
    """A linear displacement imposed on the boundary nodes of a jittered mesh is reproduced
    at the interior nodes; the reactions balance in force and moment (also with damage)."""
    mesh = small_mesh(dim, jitter=0.4)
    rng = np.random.default_rng(3)
    G, u0 = rng.standard_normal((dim, dim)), rng.standard_normal(dim)
    u_lin = (u0 + mesh.points @ G.T).ravel()
    con = node_dofs(boundary_nodes(mesh), dim)
    el = elasticity(dim, plane, mesh, constrained=con)
    alpha = np.zeros(mesh.n_nodes)
    u = solve(el, alpha, u_lin[con])
    assert np.abs(u - u_lin).max() < 1e-12 * np.abs(u_lin).max()
    for alpha in (np.zeros(mesh.n_nodes), smooth_alpha(mesh)):
        u = solve(el, alpha, u_lin[con])
        r = el.reactions(alpha, u)
        F, M = force_and_moment(mesh.points, dim, con, r)
        scale = np.abs(r).max()
        assert np.abs(F).max() < 1e-12 * scale
        assert np.abs(M).max() < 1e-12 * scale * np.abs(mesh.points).max()
        # the free rows of K u vanish: the reactions are all of K u
        assert np.abs(el.matrix(alpha) @ u[el.free] - el.rhs(alpha, u[con])).max() < 1e-12 * scale


@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_uniaxial_stiffness(dim, plane):
    """Uniaxial stress in a bar: left end held in x only (plus the rigid modes), right end
    pulled by ``delta`` in x, lateral faces free. The reaction is ``E' A delta / length`` with
    ``E' = E`` (plane stress, 3D) and ``E / (1 - nu^2)`` (plane strain: ``e_zz = 0``), times
    ``g(0) = 1 + k_res``."""
    lx, ly, lz, delta, T = 2.0, 0.5, 0.4, 1e-3, 3.0
    if dim == 2:
        mesh = tri_mesh(8, 3, lx, ly, jitter=0.3)
        area = ly * T
        fix = [0 * 2 + 1]  # node 0 = (0, 0): no motion in y
    else:
        mesh, T = tet_mesh((6, 2, 2), (lx, ly, lz), jitter=0.3), 1.0
        area = ly * lz
        corner = int(np.flatnonzero(np.all(mesh.points == 0.0, axis=1))[0])
        top = int(np.flatnonzero(np.all(mesh.points == [0.0, ly, 0.0], axis=1))[0])
        fix = [corner * 3 + 1, corner * 3 + 2, top * 3 + 2]  # translations y, z; rotation about x
    left = np.flatnonzero(mesh.points[:, 0] == 0.0)
    right = np.flatnonzero(mesh.points[:, 0] == lx)
    con = np.unique(np.concatenate([left * dim, right * dim, fix]))
    el = Elasticity(mesh, E, NU, plane=plane or "stress", thickness=T, constrained=con)
    u_d = np.where(np.isin(con, right * dim), delta, 0.0)
    alpha = np.zeros(mesh.n_nodes)
    u = solve(el, alpha, u_d)
    reaction = el.reactions(alpha, u)[np.isin(con, right * dim)].sum()
    E_eff = E / (1.0 - NU**2) if plane == "strain" else E
    # g(0) = 1 + k_res: the sound material's modulus is E (1 + k_res)
    assert reaction == pytest.approx((1.0 + el.k_res) * E_eff * area * delta / lx, rel=1e-12)
    # the strain is uniform (P1 holds the exact linear field)
    e = el.strain(u)
    np.testing.assert_allclose(e[:, 0], delta / lx, rtol=1e-11)


@pytest.mark.parametrize("dim", [2, 3])
def test_a_softer_region_in_series_adds_its_compliance(dim):
    """A buffer-like region (modulus r E, the same nu = 0) over the left half of a bar pulled by
    ``delta``: uniform uniaxial stress, exact in P1, ``F = E A delta / (L/2 / r + L/2)``, the
    strain ``r`` times larger on the soft side, and the energy ``F delta / 2``."""
    lx, ly, lz, delta, r = 2.0, 0.5, 0.4, 1e-3, 1e-2
    mesh = tri_mesh(8, 3, lx, ly) if dim == 2 else tet_mesh((4, 2, 2), (lx, ly, lz))
    area = ly if dim == 2 else ly * lz
    left = np.flatnonzero(mesh.points[:, 0] == 0.0)
    right = np.flatnonzero(mesh.points[:, 0] == lx)
    origin = int(np.flatnonzero(np.all(mesh.points == 0.0, axis=1))[0])
    fix = [origin * dim + a for a in range(1, dim)]
    if dim == 3:
        top = int(np.flatnonzero(np.all(mesh.points == [0.0, ly, 0.0], axis=1))[0])
        fix.append(top * 3 + 2)
    con = np.unique(np.concatenate([left * dim, right * dim, fix]))
    soft = mesh.points[mesh.cells].mean(axis=1)[:, 0] < lx / 2
    el = Elasticity(mesh, E, 0.0, k_res=0.0, constrained=con, modulus=np.where(soft, r, 1.0))
    u_d = np.where(np.isin(con, right * dim), delta, 0.0)
    alpha = np.zeros(mesh.n_nodes)
    u = solve(el, alpha, u_d)
    force = el.reactions(alpha, u)[np.isin(con, right * dim)].sum()
    assert force == pytest.approx(E * area * delta / (lx / 2 / r + lx / 2), rel=1e-10)
    e = el.strain(u)[:, 0]
    np.testing.assert_allclose(e[soft], force / (area * E * r), rtol=1e-9)
    np.testing.assert_allclose(e[~soft], force / (area * E), rtol=1e-9)
    np.testing.assert_allclose(el.stress(u)[:, 0], force / area, rtol=1e-9)
    assert el.elastic_energy(u, alpha) == pytest.approx(force * delta / 2, rel=1e-10)
    assert el.nodal_energy(u).sum() == pytest.approx(force * delta / 2, rel=1e-10)


@pytest.mark.parametrize("dim,plane", [(2, "stress"), (3, None)], ids=["2d", "3d"])
def test_reaction_is_energy_derivative(dim, plane):
    """With a damaged field, the left end clamped and the right end moved by ``t v``:
    ``dP/dt`` (central difference of the elastic energy at the solutions) equals
    ``v . reactions`` on the right end."""
    if dim == 2:
        mesh, T = tri_mesh(10, 5, 2.0, 1.0, jitter=0.3), 0.7
    else:
        mesh, T = tet_mesh((5, 3, 3), (2.0, 1.0, 1.0), jitter=0.3), 1.0
    left = np.flatnonzero(mesh.points[:, 0] == 0.0)
    right = np.flatnonzero(mesh.points[:, 0] == 2.0)
    con = node_dofs(np.union1d(left, right), dim)
    el = Elasticity(mesh, E, NU, plane=plane or "stress", thickness=T, k_res=1e-4, constrained=con)
    alpha = smooth_alpha(mesh, 0.95)
    direction = np.array([1.0, 0.4, -0.3][:dim])
    v = np.zeros(el.n_dofs)
    v.reshape(-1, dim)[right] = direction
    v_d = v[con]

    def energy(t):
        return el.elastic_energy(solve(el, alpha, t * v_d), alpha)

    t, dt = 0.02, 1e-4
    dP = (energy(t + dt) - energy(t - dt)) / (2 * dt)
    u = solve(el, alpha, t * v_d)
    assert dP == pytest.approx(v_d @ el.reactions(alpha, u), rel=1e-8)


# --- convergence to a manufactured solution ------------------------------------------------------

def quadrature_points(mesh, order=4):
    """Physical quadrature points (n_cells, q, d), weights (n_cells, q) and barycentric
    coordinates (q, d + 1) of a rule exact to ``order`` (scikit-fem's tables)."""
    X, w = get_quadrature(RefTri if mesh.dim == 2 else RefTet, order)
    bary = np.vstack([1.0 - X.sum(axis=0), X]).T
    x = np.einsum("qk,ekc->eqc", bary, mesh.points[mesh.cells])
    edges = mesh.points[mesh.cells[:, 1:]] - mesh.points[mesh.cells[:, :1]]
    jac = np.abs(np.linalg.det(edges))
    return x, jac[:, None] * w[None], bary


def manufactured_errors(mesh, plane):
    d = mesh.dim
    W, PH = (W2, PH2) if d == 2 else (W3, PH3)
    bnd = boundary_nodes(mesh)
    con = node_dofs(bnd, d)
    el = Elasticity(mesh, E, NU, plane=plane or "stress", constrained=con)
    x, wq, bary = quadrature_points(mesh)
    f_q = body_force(x.reshape(-1, d), W, PH, el.lam, el.mu).reshape(x.shape)
    f_cell = np.einsum("eq,qk,eqa->eka", wq, bary, f_q)  # (n_cells, d + 1, d): Int f phi_k
    f = np.zeros((mesh.n_nodes, d))
    np.add.at(f, mesh.cells, f_cell)
    u_exact_nodes, _, _ = exact_fields(mesh.points, W, PH)
    u = solve(el, np.zeros(mesh.n_nodes), u_exact_nodes.ravel()[con], f.ravel())
    # errors at the quadrature points
    u_ex, grad_ex, _ = exact_fields(x.reshape(-1, d), W, PH)
    u_h = np.einsum("qk,eka->eqa", bary, u.reshape(-1, d)[mesh.cells]).reshape(-1, d)
    l2 = math.sqrt(np.sum(wq.ravel() * np.sum((u_ex - u_h) ** 2, axis=1)))
    grad_h = np.einsum("eka,ekb->eab", u.reshape(-1, d)[mesh.cells], el.grads)
    de = grad_ex.reshape(x.shape[0], -1, d, d) - grad_h[:, None]
    de = 0.5 * (de + np.swapaxes(de, 2, 3))
    density = el.lam * np.einsum("eqaa->eq", de) ** 2 + 2.0 * el.mu * np.einsum("eqab,eqab->eq", de, de)
    energy = math.sqrt(np.sum(wq * density))
    return l2, energy


@pytest.mark.parametrize("dim,plane", MODELS, ids=MODEL_IDS)
def test_manufactured_convergence(dim, plane):
    """Smooth ``u``, its body force integrated with an order-4 rule, Dirichlet data on the
    whole boundary: L2 error of order 2, energy-norm error of order 1 (within 0.15)."""
    if dim == 2:
        ns = [8, 16, 32, 64]
        meshes = [tri_mesh(n, n) for n in ns]
    else:
        ns = [4, 8, 12, 16]
        meshes = [tet_mesh(n) for n in ns]
    errors = np.array([manufactured_errors(m, plane) for m in meshes])
    h = 1.0 / np.array(ns)
    p_l2, p_energy = fitted_order(h, errors[:, 0]), fitted_order(h, errors[:, 1])
    assert abs(p_l2 - 2.0) < 0.15, (p_l2, errors)
    assert abs(p_energy - 1.0) < 0.15, (p_energy, errors)
