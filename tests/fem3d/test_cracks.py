"""Reading a crack off a damage field: its tip, chord and initial direction."""

import math

import numpy as np
import pytest

from fem3d.cracks import crack_tip, initial_direction


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
