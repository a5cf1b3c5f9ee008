"""The loads of a run's steps (thinfilm.steps): the decimals the scene writes, and the same
loads for the same spacing, which extended runs rely on."""

import numpy as np
import pytest

from thinfilm.steps import equal_steps, load_steps


@pytest.mark.parametrize("t_max, steps, exact", [
    (3.0, 100, lambda k: 3 * k / 100),   # int / int: the double nearest to the exact load
    (1.6, 160, lambda k: k / 100),
    (0.3, 3, lambda k: k / 10),
    (0.4, 80, lambda k: k / 200),
    (7.0, 70, lambda k: k / 10),
    (2.0, 60, lambda k: k / 30),
])
def test_each_load_is_the_double_nearest_to_t_max_k_over_steps(t_max, steps, exact):
    t = equal_steps(t_max, steps)
    assert t.tolist() == [exact(k) for k in range(steps + 1)]
    assert t[0] == 0.0 and t[-1] == t_max


def test_loads_print_as_the_scene_writes_them():
    t = equal_steps(3.0, 100)
    assert repr(float(t[11])) == "0.33" and max(len(repr(float(v))) for v in t) <= 4
    # what np.linspace gave: k * (3 / 100)
    assert repr(float(np.linspace(0.0, 3.0, 101)[11])) == "0.32999999999999996"


@pytest.mark.parametrize("short, long", [((2.0, 60), (4.0, 120)), ((0.3, 3), (0.9, 9)), ((1.6, 160), (2.4, 240)),
                                         ((0.7, 7), (2.1, 21))])
def test_the_same_spacing_gives_the_same_loads(short, long):
    a, b = equal_steps(*short), equal_steps(*long)
    np.testing.assert_array_equal(b[: a.size], a)


@pytest.mark.parametrize("t_max", [1 / 3, 0.1234567891234, 1e-3, 12.5])
def test_the_last_load_is_t_max(t_max):
    t = equal_steps(t_max, 7)
    assert t[-1] == t_max and np.all(np.diff(t) > 0)


def test_an_explicit_list_is_kept():
    class Load:
        values, t_max, steps = (0.0, 0.1, 0.25), 0.25, 2

    assert load_steps(Load()).tolist() == [0.0, 0.1, 0.25]
