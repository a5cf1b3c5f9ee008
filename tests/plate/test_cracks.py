"""Reading cracks off a damage field: the branch points of drawn crack patterns."""

import math

import numpy as np
import pytest

from thinfilm.plate.cracks import branch_points, branch_spacing
from thinfilm.plate.model import crack_profile

# A grid of 0.5e-3 on (-0.06, 0.06)^2 and drawn AT1 cracks (eta = 2e-3) with a broken core
# 4 cells wide, as the evolutions at eta = 10 dx give.
X_NODES = np.linspace(-0.06, 0.06, 241)
ETA, CORE = 2e-3, 1e-3
RADIUS = 1.5 * ETA


def _distance_to_segment(X, Y, p, q):
    d = np.subtract(q, p)
    s = np.clip(((X - p[0]) * d[0] + (Y - p[1]) * d[1]) / (d @ d), 0.0, 1.0)
    return np.hypot(X - p[0] - s * d[0], Y - p[1] - s * d[1])


def _drawn(segments):
    X, Y = np.meshgrid(X_NODES, X_NODES)
    distance = np.min([_distance_to_segment(X, Y, p, q) for p, q in segments], axis=0)
    return crack_profile(np.maximum(distance - CORE / 2, 0.0), ETA, 1)


def _ray(origin, degrees, length=0.05):
    a = math.radians(degrees)
    return origin, (origin[0] + length * math.cos(a), origin[1] + length * math.sin(a))


def _two_junctions(spacing):
    """Two Y junctions at (+-spacing/2, 0.004), joined by a straight crack, each with two
    further cracks at +-60 degrees to it."""
    a, b = (-spacing / 2, 0.004), (spacing / 2, 0.004)
    return [(a, b), _ray(a, 120), _ray(a, 240), _ray(b, 60), _ray(b, -60)]


@pytest.mark.parametrize("spacing", [0.006, 0.012, 0.02, 0.035])
def test_two_branch_points_at_their_drawn_places(spacing):
    found = branch_points(_drawn(_two_junctions(spacing)), X_NODES, X_NODES, RADIUS)
    assert len(found) == 2
    (x1, y1, arms1), (x2, y2, arms2) = sorted(found)
    assert (arms1, arms2) == (3, 3)
    # The cluster of a junction is about RADIUS across along its arms; its mean is within
    # two cells of the junction.
    assert (x1, x2) == pytest.approx((-spacing / 2, spacing / 2), abs=1e-3)
    assert (y1, y2) == pytest.approx((0.004, 0.004), abs=1e-3)
    assert branch_spacing(found) == pytest.approx(spacing, abs=2e-3)


def test_junctions_closer_than_twice_the_radius_read_as_a_cross():
    found = branch_points(_drawn(_two_junctions(0.004)), X_NODES, X_NODES, RADIUS)
    assert len(found) == 1
    assert branch_spacing(found) == 0.0
    assert found[0][2] == 4
    assert found[0][:2] == pytest.approx((0.0, 0.004), abs=1e-3)


def test_star_and_cross_have_one_branch_point_with_their_arms():
    centre = (0.007, -0.003)
    star = [_ray(centre, a) for a in (10, 130, 250)]
    cross = [_ray(centre, a) for a in (0, 90, 180, 270)]
    for segments, n_arms in ((star, 3), (cross, 4)):
        (found,) = branch_points(_drawn(segments), X_NODES, X_NODES, RADIUS)
        assert found == pytest.approx((*centre, n_arms), abs=1e-3)


def test_single_and_bent_cracks_have_no_branch_point():
    straight = [((-0.05, -0.01), (0.05, 0.02))]
    bent = [((-0.05, 0.0), (0.0, 0.0)), ((0.0, 0.0), (0.04, 0.03))]   # a kink of 37 degrees
    for segments in (straight, bent):
        assert branch_points(_drawn(segments), X_NODES, X_NODES, RADIUS) == []


def test_within_limits_the_nodes_looked_at():
    alpha = _drawn(_two_junctions(0.02))
    X, _ = np.meshgrid(X_NODES, X_NODES)
    (found,) = branch_points(alpha, X_NODES, X_NODES, RADIUS, within=X > 0)
    assert found[:2] == pytest.approx((0.01, 0.004), abs=1e-3)
