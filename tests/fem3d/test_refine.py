"""Conforming longest-edge bisection (fem3d.refine): conformity, measures, groups, midpoints,
locality, determinism and the quality the bisection keeps, in 2D and 3D."""

from __future__ import annotations

import numpy as np
import pytest

from fem3d.mesh import Mesh
from fem3d.refine import LOCAL_EDGES, cell_sizes, refine
from tests.fem3d.checks import boundary_facets, check_common, facet_measures, signed_measures
from tests.fem3d.meshes import small_mesh, tet_mesh, tri_mesh


def grouped(mesh):
    """``mesh`` with a boundary group on each of two sides, a region and a point group."""
    p = mesh.points
    lo, hi = p.min(axis=0), p.max(axis=0)
    facets = np.array(sorted(boundary_facets(mesh)))
    on = {name: facets[np.all(np.isclose(p[facets][:, :, 0], value), axis=1)]
          for name, value in (("left", lo[0]), ("right", hi[0]))}
    centroids = p[mesh.cells].mean(axis=1)
    region = np.flatnonzero(centroids[:, 1] < 0.5 * (lo[1] + hi[1]))
    return Mesh(p, mesh.cells, cell_groups={"low": region}, facet_groups=on, node_groups={"corner": np.array([0])})


def facet_counts(mesh):
    """How many cells hold each facet (1 on the boundary, 2 inside: at most 2 if conforming)."""
    k = mesh.dim + 1
    faces = np.sort(np.concatenate([np.delete(mesh.cells, i, axis=1) for i in range(k)]), axis=1)
    return np.unique(faces, axis=0, return_counts=True)


def boundary_measure(mesh):
    faces, counts = facet_counts(mesh)
    return facet_measures(mesh, faces[counts == 1]).sum()


def min_angles(mesh):
    """Smallest interior angle of each triangle (radians)."""
    p = mesh.points[mesh.cells]
    out = np.full(mesh.n_cells, np.inf)
    for i in range(3):
        a, b = p[:, (i + 1) % 3] - p[:, i], p[:, (i + 2) % 3] - p[:, i]
        cos = np.sum(a * b, axis=1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
        out = np.minimum(out, np.arccos(np.clip(cos, -1.0, 1.0)))
    return out


def tet_quality(mesh):
    """``6 sqrt(2) V / l_max^3`` of each tetrahedron: 1 for a regular one, 0 for a flat one."""
    return 6.0 * np.sqrt(2.0) * signed_measures(mesh) / cell_sizes(mesh.points, mesh.cells) ** 3


def passes(mesh, n, pick, seed=0):
    """``n`` passes, each refining the cells ``pick(mesh, rng)`` selects."""
    rng = np.random.default_rng(seed)
    history = []
    for _ in range(n):
        refined = refine(mesh, pick(mesh, rng))
        history.append((mesh, refined))
        mesh = refined.mesh
    return mesh, history


def random_cells(mesh, rng):
    return rng.choice(mesh.n_cells, size=max(1, mesh.n_cells // 7), replace=False)


def near_point(mesh, rng):
    """The cells within two sizes of a corner of the box: a graded refinement."""
    centroids = mesh.points[mesh.cells].mean(axis=1)
    lo = mesh.points.min(axis=0)
    return np.flatnonzero(np.linalg.norm(centroids - lo, axis=1) < 2.0 * cell_sizes(mesh.points, mesh.cells))


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("pick", [random_cells, near_point])
def test_conforming_with_groups_kept(dim, pick):
    first = grouped(small_mesh(dim))
    mesh, history = passes(first, 5, pick)
    check_common(mesh)   # oriented, every node used, every facet group on the boundary
    _, counts = facet_counts(mesh)
    assert counts.max() == 2   # no facet in three cells: no overlap; hanging nodes would add boundary:
    assert boundary_measure(mesh) == pytest.approx(boundary_measure(first), rel=1e-12)
    assert signed_measures(mesh).sum() == pytest.approx(signed_measures(first).sum(), rel=1e-12)
    for name, facets in first.facet_groups.items():
        assert facet_measures(mesh, mesh.facet_groups[name]).sum() == pytest.approx(
            facet_measures(first, facets).sum(), rel=1e-12)
    assert signed_measures(mesh)[mesh.cell_groups["low"]].sum() == pytest.approx(
        signed_measures(first)[first.cell_groups["low"]].sum(), rel=1e-12)
    assert np.array_equal(mesh.node_groups["corner"], first.node_groups["corner"])
    np.testing.assert_array_equal(mesh.points[: first.n_nodes], first.points)   # old vertices keep their numbers


@pytest.mark.parametrize("dim", [2, 3])
def test_midpoints_parents_and_marked_cells(dim):
    mesh = grouped(small_mesh(dim))
    rng = np.random.default_rng(3)
    for _ in range(4):
        marked = random_cells(mesh, rng)
        refined = refine(mesh, marked)
        new = refined.mesh
        n_old = mesh.n_nodes
        assert refined.parents.shape == (new.n_nodes - n_old, 2)
        own = np.arange(n_old, new.n_nodes)
        assert np.all(refined.parents.max(axis=1) < own)   # every parent is older
        np.testing.assert_array_equal(new.points[own], 0.5 * (new.points[refined.parents[:, 0]]
                                                              + new.points[refined.parents[:, 1]]))
        # every marked cell was cut; each child lies in its parent (same measure in total)
        children = np.bincount(refined.cell_parent, minlength=mesh.n_cells)
        assert np.all(children[marked] >= 2)
        np.testing.assert_allclose(np.bincount(refined.cell_parent, weights=signed_measures(new)),
                                   signed_measures(mesh), rtol=1e-12)
        # the longest edge of a marked cell is split: its midpoint is a vertex
        mesh = new


def test_local_and_deterministic():
    mesh = tri_mesh(40, 40, jitter=0.3)
    one = refine(mesh, [800])
    # longest-edge propagation reaches a few cells only
    assert one.mesh.n_cells - mesh.n_cells < 12
    again = refine(mesh, [800])
    np.testing.assert_array_equal(one.mesh.cells, again.mesh.cells)
    np.testing.assert_array_equal(one.mesh.points, again.mesh.points)
    assert refine(mesh, []).mesh.n_cells == mesh.n_cells


def test_angles_2d_bounded_by_half_the_first():
    """Longest-edge bisection of triangles keeps every angle above half the smallest angle of
    the first mesh (Rosenberg and Stenger)."""
    first = tri_mesh(8, 8, jitter=0.4, seed=2)
    mesh, _ = passes(first, 10, random_cells)
    assert mesh.n_cells > 4 * first.n_cells
    assert min_angles(mesh).min() >= 0.5 * min_angles(first).min()


def test_tetrahedra_quality_kept():
    """3D longest-edge bisection has no proven bound; on a graded refinement to 1/64 of the
    first size the worst tetrahedron stays within a factor 4 of the first mesh's worst
    (docs/adaptivity.md#refinement: it falls from 0.134 to 0.106 here)."""
    first = tet_mesh((4, 4, 4), jitter=0.3, seed=1)
    mesh, _ = passes(first, 18, near_point)
    assert cell_sizes(mesh.points, mesh.cells).min() < cell_sizes(first.points, first.cells).min() / 16
    q0, q = tet_quality(first).min(), tet_quality(mesh).min()
    assert q >= 0.25 * q0


def test_refuses_bad_marks():
    mesh = small_mesh(2)
    with pytest.raises(IndexError):
        refine(mesh, [mesh.n_cells])
    mask = np.zeros(mesh.n_cells, dtype=bool)
    mask[[0, 3]] = True
    assert refine(mesh, mask).mesh.n_cells == refine(mesh, [0, 3]).mesh.n_cells
    assert LOCAL_EDGES[3].shape == (6, 2)
