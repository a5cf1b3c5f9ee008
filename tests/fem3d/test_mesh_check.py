"""The checks of a user's mesh (:mod:`fem3d.mesh_check`) on small meshes made by hand: each
bad mesh refused with its reason, each good one passed (and oriented)."""

import numpy as np
import pytest

from fem3d.mesh_check import check_cover, element_sizes, oriented_cells

#: The unit square as four triangles around its centre (node 4), counter-clockwise.
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]])
FAN = np.array([[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
#: Two tetrahedra sharing the face (1, 2, 3), on either side of it.
TETS_POINTS = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 1]])
TETS = np.array([[0, 1, 2, 3], [4, 1, 3, 2]])


def _check(points, cells):
    cells = oriented_cells(points, cells)
    check_cover(points, cells)
    return cells


def test_a_conforming_mesh_passes_and_is_oriented():
    flipped = FAN[:, [0, 2, 1]]  # every triangle clockwise: a valid mesh, oriented anew
    for cells in (FAN, flipped):
        out = _check(SQUARE, cells)
        e = SQUARE[out[:, 1:]] - SQUARE[out[:, :1]]
        assert np.all(np.linalg.det(e) > 0)
    out = _check(TETS_POINTS, TETS)
    assert np.all(np.linalg.det(TETS_POINTS[out[:, 1:]] - TETS_POINTS[out[:, :1]]) > 0)


def test_a_tangled_mesh_is_refused():
    # the centre node moved outside the square past the edge (1, 2): triangle (1, 2, 4)
    # turns over and overlaps its neighbours
    points = SQUARE.copy()
    points[4] = [1.3, 0.5]
    with pytest.raises(ValueError, match="both their cells on one side: the cells overlap"):
        _check(points, FAN)


def test_overlapping_tetrahedra_are_refused():
    points = TETS_POINTS.copy()
    points[4] = [0.1, 0.1, 0.1]  # the second tetrahedron now lies on the first one's side
    with pytest.raises(ValueError, match="the cells overlap"):
        _check(points, TETS)


def test_a_duplicated_or_stacked_cell_is_refused():
    duplicated = np.vstack([FAN, FAN[:1]])  # its interior edges now in three cells
    with pytest.raises(ValueError, match="three or more cells"):
        _check(SQUARE, duplicated)
    stacked = np.vstack([FAN, [[0, 1, 2]]])  # a triangle laid over two others
    with pytest.raises(ValueError, match="the cells overlap"):
        _check(SQUARE, stacked)


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_a_coordinate_that_is_not_finite_is_refused(value):
    points = SQUARE.copy()
    points[2, 1] = value
    with pytest.raises(ValueError, match="1 node\\(s\\) with a coordinate that is not a finite number"):
        _check(points, FAN)


def test_degenerate_cells_are_refused():
    collapsed = SQUARE.copy()
    collapsed[4] = [0.5, 0.0]  # on the edge (0, 1): triangle (0, 1, 4) has zero area
    with pytest.raises(ValueError, match="1 degenerate cell\\(s\\) of zero area"):
        _check(collapsed, FAN)
    nearly = SQUARE.copy()
    nearly[4] = [0.5, 1e-12]  # collinear to rounding
    with pytest.raises(ValueError, match="degenerate"):
        _check(nearly, FAN)
    repeated = FAN.copy()
    repeated[0] = [0, 0, 4]  # a repeated vertex
    with pytest.raises(ValueError, match="degenerate"):
        _check(SQUARE, repeated)
    flat = TETS_POINTS.copy()
    flat[3] = [0.3, 0.3, 0.0]  # the first tetrahedron flattened into the plane z = 0
    with pytest.raises(ValueError, match="zero volume"):
        _check(flat, TETS)


def test_element_sizes_are_the_longest_edges():
    assert np.allclose(element_sizes(SQUARE, FAN), 1.0)
    assert np.allclose(element_sizes(TETS_POINTS, TETS), [np.sqrt(2), np.sqrt(2)])
