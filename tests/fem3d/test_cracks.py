"""Reading a crack off a damage field: its tip, chord and initial direction."""

import math

import numpy as np
import pytest

from fem3d.cracks import crack_tip, initial_direction, trace_angles, twist


def curved_crack(start_deg=30.0, bend_deg=-20.0, kink=40.0, length=120.0, width=1.5, h=0.5):
    """Nodes of a grid, broken (alpha = 1) within ``width`` of a polyline leaving (0, 0) to the
    upper left at ``start_deg`` above the horizontal and turning by ``bend_deg`` after ``kink``."""
    x, y = np.meshgrid(np.arange(-140.0, 10.0, h), np.arange(-10.0, 80.0, h))
    points = np.column_stack([x.ravel(), y.ravel()])
    a1 = math.radians(180.0 - start_deg)
    knee = kink * np.array([math.cos(a1), math.sin(a1)])
    a2 = math.radians(180.0 - start_deg - bend_deg)
    end = knee + (length - kink) * np.array([math.cos(a2), math.sin(a2)])

    def distance(p, a, b):
        s = np.clip(((p - a) @ (b - a)) / ((b - a) @ (b - a)), 0.0, 1.0)
        return np.linalg.norm(p - (a + s[:, None] * (b - a)), axis=1)

    near = np.minimum(distance(points, np.zeros(2), knee), distance(points, knee, end)) <= width
    return points, near.astype(float), end


def test_initial_direction_reads_the_start_and_the_tip_the_chord():
    points, alpha, end = curved_crack()
    assert 180.0 - initial_direction(points, alpha, (0.0, 0.0), 25.0) == pytest.approx(30.0, abs=0.5)
    tip, length, angle = crack_tip(points, alpha, (0.0, 0.0))
    chord = math.degrees(math.atan2(end[1], -end[0]))        # the tip's direction above the horizontal
    assert length == pytest.approx(np.linalg.norm(end), abs=2.0)
    assert 180.0 - angle == pytest.approx(chord, abs=1.0) and chord < 20.0        # the chord is flatter
    assert math.isnan(initial_direction(points, np.zeros(len(points)), (0.0, 0.0), 25.0))


def twisted_crack(top=45.0, bottom=85.0, h=2.0, width=1.5):
    """Nodes of a 3D grid, broken within ``width`` (in plan) of a surface whose trace on the
    plane z is the line through (200, 0) at ``top + (bottom - top)(1 - z/50)`` degrees from +x:
    a crack twisting from ``top`` at z = 50 to ``bottom`` at z = 0, as under the Brokenshire
    test's notch."""
    x, y, z = np.meshgrid(np.arange(120.0, 280.0 + h / 2, h), np.arange(-50.0, 50.0 + h / 2, h),
                          np.arange(0.0, 50.0 + h / 2, h), indexing="ij")
    points = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    angle = np.radians(top + (bottom - top) * (1.0 - points[:, 2] / 50.0))
    distance = np.abs(-(points[:, 0] - 200.0) * np.sin(angle) + points[:, 1] * np.cos(angle))
    return points, (distance <= width).astype(float)


def test_trace_angles_follow_a_twisted_surface():
    points, alpha = twisted_crack()
    levels = [50.0, 40.0, 30.0, 20.0, 10.0, 0.0]
    rows = trace_angles(points, alpha, levels, width=2.0)
    for level, angle, count, flatness in rows:
        assert angle == pytest.approx(45.0 + 40.0 * (1.0 - level / 50.0), abs=1.5), level
        assert count > 50 and flatness < 0.1
    unwrapped, total = twist([row[1] for row in rows])
    assert total == pytest.approx(40.0, abs=2.0) and np.all(np.diff(unwrapped) > 0.0)
    # A planar crack does not twist; an empty section gives NaN and is skipped.
    points, alpha = twisted_crack(top=60.0, bottom=60.0)
    rows = trace_angles(points, alpha, levels + [80.0], width=2.0)
    assert math.isnan(rows[-1][1]) and rows[-1][2] == 0
    assert twist([row[1] for row in rows])[1] == pytest.approx(0.0, abs=1.0)


def test_twist_unwraps_across_the_axis():
    # 170 -> 5 -> 20 degrees (modulo 180) is a turn of +30, not -150.
    unwrapped, total = twist([170.0, 5.0, math.nan, 20.0])
    assert np.allclose(unwrapped, [170.0, 185.0, 200.0]) and total == pytest.approx(30.0)
    assert math.isnan(twist([10.0])[1])

