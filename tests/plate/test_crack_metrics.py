"""Crack metrics of drawn damage fields: lengths against exact values, counts of cracks,
fragments, branch points, rings and radial cracks (thinfilm.plate.crack_metrics)."""

import math

import numpy as np
import pytest
from scipy import ndimage

from thinfilm.plate.crack_metrics import energy_length, measure, measured_steps
from thinfilm.plate.cracks import count_fragments, radial_cracks, ring_radii
from thinfilm.plate.model import crack_profile
from thinfilm.plate.skeleton import junctions, length, thin

OCTAGON = 16.0 * (math.sqrt(2.0) - 1.0)  # 8-chain length of a circle over its radius


def _grid(cells):
    x = np.linspace(-0.5, 0.5, cells + 1)
    return x, *np.meshgrid(x, x)


def _line_distance(X, Y, point, degrees):
    a = math.radians(degrees)
    return np.abs(-math.sin(a) * (X - point[0]) + math.cos(a) * (Y - point[1]))


def _chord(point, degrees, half=0.5):
    """Length of the line through ``point`` at ``degrees`` inside the square (-half, half)^2."""
    d = np.array([math.cos(math.radians(degrees)), math.sin(math.radians(degrees))])
    low, high = -np.inf, np.inf
    for p, v in zip(point, d):
        if abs(v) > 1e-15:
            s = sorted(((-half - p) / v, (half - p) / v))
            low, high = max(low, s[0]), min(high, s[1])
    return high - low


def _segment_distance(X, Y, p, q):
    d = np.subtract(q, p)
    s = np.clip(((X - p[0]) * d[0] + (Y - p[1]) * d[1]) / (d @ d), 0.0, 1.0)
    return np.hypot(X - p[0] - s * d[0], Y - p[1] - s * d[1])


# -- lengths: 400 cells, the optimal AT1 profile at eta = 10 h (its broken core, |d| <= 0.10 eta,
# is two to three nodes wide, as in the evolutions) ----------------------------------------------
CELLS, ETA_H = 400, 10
H = 1.0 / CELLS
ETA = ETA_H * H
# Sampling the profile on the grid: the kink of alpha at the crack's centre loses up to
# h / eta of the gradient term's integral when it falls midway between node lines, i.e. a
# relative h / (4 c_1 eta) = 3 h / (8 eta) of the length; on a node line the sums exceed the
# integrals by (h / eta)^2 / 32. These bound the energy's length, from below and above.
ENERGY_LOW, ENERGY_HIGH = -3.0 / (8.0 * ETA_H), 1.0 / (32.0 * ETA_H**2)


@pytest.mark.parametrize("degrees", [0.0, 22.5, 45.0, 63.0])
def test_both_lengths_of_a_straight_band(degrees):
    x, X, Y = _grid(CELLS)
    # Off the nodes; the band leaves the square through its edges more than its half-width
    # 2 eta away from the corners, where the edges would cut its profile unevenly.
    point = (0.1 + 0.3 * H, -0.17 * H)
    exact = _chord(point, degrees)
    alpha = crack_profile(_line_distance(X, Y, point, degrees), ETA, 1)
    relative = energy_length(alpha, H, H, ETA, 1) / exact - 1.0
    assert ENERGY_LOW <= relative <= ENERGY_HIGH, relative
    # The skeleton is a digital straight line: (cos + (sqrt 2 - 1) sin) of the angle to the
    # nearer grid axis times its length (8.2 % more at 22.5 degrees), to within a node at
    # each end.
    theta = math.radians(min(degrees % 90.0, 90.0 - degrees % 90.0))
    chain = exact * (math.cos(theta) + (math.sqrt(2.0) - 1.0) * math.sin(theta))
    assert abs(length(thin(alpha >= 0.9), H, H) - chain) <= 2 * math.sqrt(2.0) * H


def test_both_lengths_of_a_circle():
    x, X, Y = _grid(CELLS)
    radius, centre = 0.3, (0.37 * H, -0.21 * H)
    alpha = crack_profile(np.abs(np.hypot(X - centre[0], Y - centre[1]) - radius), ETA, 1)
    exact = 2.0 * math.pi * radius
    # The profile is even in the distance, so the circle's energy is exactly its length (the
    # curvature's first-order terms cancel); the grid's error is that of a straight band.
    relative = energy_length(alpha, H, H, ETA, 1) / exact - 1.0
    assert ENERGY_LOW <= relative <= ENERGY_HIGH, relative
    # A convex 8-chain is as long as the octagon of its supporting lines along the axes and
    # diagonals; the skeleton's nodes lie within h of the circle, so the octagon's radius too.
    skeleton = thin(alpha >= 0.9)
    assert abs(length(skeleton, H, H) - OCTAGON * radius) <= OCTAGON * H
    assert not junctions(skeleton).any()


def test_skeleton_keeps_the_topology_and_is_one_node_wide():
    x, X, Y = _grid(200)
    ring = np.abs(np.hypot(X, Y) - 0.3) <= 0.012
    bar = _line_distance(X, Y, (0.0, 0.0), 30.0) <= 0.015
    for mask, holes in ((ring, 1), (bar & (np.abs(X) < 0.4), 0)):
        lines = thin(mask)
        assert (lines <= mask).all()
        assert ndimage.label(lines, structure=np.ones((3, 3)))[1] == 1
        assert ndimage.label(~lines)[1] == holes + 1
        assert not junctions(lines).any()  # no node with three neighbours: no staircase


# -- counts: 200 cells, AT1 bands with a broken core two cells wide at eta = 2 h ------------------
COUNT_CELLS = 200
COUNT_H = 1.0 / COUNT_CELLS
COUNT_ETA, CORE = 2 * COUNT_H, 2 * COUNT_H


def _drawn(distance):
    return crack_profile(np.maximum(distance - CORE / 2, 0.0), COUNT_ETA, 1)


def _measure(alpha, **kwargs):
    x = np.linspace(-0.5, 0.5, COUNT_CELLS + 1)
    return measure(alpha, x, x, COUNT_ETA, 1, **kwargs)


def test_six_parallel_bands_are_six_cracks_and_seven_fragments():
    # Close enough that along y = 0 their profiles merge when the cores widen; each its own crack.
    x, X, Y = _grid(COUNT_CELLS)
    centres = -0.375 + 0.15 * np.arange(6) + 0.0013
    m = _measure(_drawn(np.min([np.abs(X - c) for c in centres], axis=0)))
    assert (m.cracks, m.fragments, m.intact_fragments, m.branch_points) == (6, 7, 7, [])
    assert m.length_skeleton == pytest.approx(6.0, abs=6 * 2 * COUNT_H)


def test_crossing_bands_are_one_crack_four_fragments_and_a_branch_point():
    x, X, Y = _grid(COUNT_CELLS)
    cross = (0.0123, -0.0311)
    m = _measure(_drawn(np.minimum(np.abs(X - cross[0]), np.abs(Y - cross[1]))))
    assert (m.cracks, m.fragments) == (1, 4)
    ((bx, by, arms),) = m.branch_points
    assert arms == 4 and math.hypot(bx - cross[0], by - cross[1]) <= 2 * COUNT_H
    assert m.length_skeleton == pytest.approx(2.0, abs=4 * COUNT_H)


def test_a_ring_is_found_at_its_radius_within_a_grid_spacing():
    x, X, Y = _grid(COUNT_CELLS)
    radius = 0.2718
    alpha = _drawn(np.abs(np.hypot(X, Y) - radius))
    (found,) = ring_radii(alpha, x, x)
    assert abs(found - radius) <= COUNT_H
    m = _measure(alpha, t=0.5, indenter_radius=0.3)
    assert (m.cracks, m.fragments, m.radial_total, m.branch_points) == (1, 2, 0, [])
    assert m.contact_radius == pytest.approx(0.3 * math.sqrt(0.5 * 1.5))
    assert m.rings == [found]


@pytest.mark.parametrize("k", [3, 6, 8])
def test_a_ring_with_k_radial_cracks(k):
    x, X, Y = _grid(COUNT_CELLS)
    radius = 0.2718
    angles = np.radians(10.0 + 360.0 / k * np.arange(k))
    rays = [_segment_distance(X, Y, (radius * math.cos(a), radius * math.sin(a)),
                              ((radius + 0.15) * math.cos(a), (radius + 0.15) * math.sin(a))) for a in angles]
    alpha = _drawn(np.minimum(np.abs(np.hypot(X, Y) - radius), np.min(rays, axis=0)))
    m = _measure(alpha, t=1.0, indenter_radius=0.3)
    assert m.radial_total == k
    assert [count for _, _, count in m.radial_cracks] == [0, k]
    assert (m.cracks, m.fragments) == (1, 2)  # the radial cracks end in the film: no new piece
    assert len(m.branch_points) == k and all(arms == 3 for _, _, arms in m.branch_points)


def test_radial_cracks_between_two_rings_cut_the_annulus():
    x, X, Y = _grid(COUNT_CELLS)
    inner, outer, k = 0.15, 0.3, 5
    r = np.hypot(X, Y)
    angles = np.radians(25.0 + 360.0 / k * np.arange(k))
    bridges = [_segment_distance(X, Y, (inner * math.cos(a), inner * math.sin(a)),
                                 (outer * math.cos(a), outer * math.sin(a))) for a in angles]
    alpha = _drawn(np.minimum(np.minimum(np.abs(r - inner), np.abs(r - outer)), np.min(bridges, axis=0)))
    rings = ring_radii(alpha, x, x)
    assert rings == pytest.approx([inner, outer], abs=COUNT_H)
    assert [count for _, _, count in radial_cracks(alpha, x, x, rings)] == [0, k, 0]
    m = _measure(alpha)
    assert (m.cracks, m.fragments, len(m.branch_points)) == (1, k + 2, 2 * k)


def test_a_pocket_of_damaged_film_is_a_fragment_but_not_an_intact_one():
    x, X, Y = _grid(COUNT_CELLS)
    alpha = _drawn(np.maximum(np.abs(Y) - 0.02, 0.0))
    alpha[(np.abs(X) <= 0.01) & (np.abs(Y) <= 0.005)] = 0.85
    assert count_fragments(alpha) == (3, 2)


def test_every_step_of_a_small_run_is_measured_and_snapshots_of_a_large_one():
    t = np.linspace(0.0, 1.0, 21)
    assert list(measured_steps(10_000, t)) == list(range(21))
    assert list(measured_steps(10**6, t)) == [0, 5, 10, 15, 20]
    assert list(measured_steps(10**6, t, snapshots=[0.3, 0.52])) == [6, 10, 20]
