"""The energy release rate of an evolution from its steps, against closed forms."""

import numpy as np
import pytest

from fem3d.release import energy_release_rate
from tests.helpers import load_case


def compliance_evolution(t, Gc=None):
    """A synthetic evolution with B = c(A) t^2, c(A) = 1 / (2 (1 + A)): G = t^2 / (2 (1 + A)^2).
    With ``Gc``, the crack grows so that G = Gc (t = (1 + A) sqrt(2 Gc)); else A = 2 (t - 1)
    (then G = t^2 / (2 (2 t - 1)^2) varies along the path)."""
    A = t / np.sqrt(2.0 * Gc) - 1.0 if Gc else 2.0 * (t - 1.0)
    A = np.maximum(A, 0.0)
    return A, t ** 2 / (2.0 * (1.0 + A))


@pytest.mark.parametrize("Gc", [0.5, 2.0])
def test_an_evolution_that_keeps_the_energy_balance_releases_gc(Gc):
    t = np.linspace(0.0, 3.0 * np.sqrt(2.0 * Gc), 61)
    A, B = compliance_evolution(t, Gc)
    thickness = 4.0
    G, a = energy_release_rate(t, B, Gc * A, Gc, thickness, a0=0.1)
    np.testing.assert_allclose(a, A / thickness + 0.1)
    growing = np.flatnonzero(np.diff(A) > 0) + 1
    assert np.isnan(G[: growing[0]]).all() and np.isfinite(G[growing[1:]]).all()   # stationary: NaN
    np.testing.assert_allclose(G[growing[1:]], Gc, rtol=2e-3)                      # G > 0: the sign fixed


def test_finite_differences_converge_at_second_order():
    def error(n):
        t = np.linspace(1.0, 2.0, n + 1)
        A, B = compliance_evolution(t)
        G, _ = energy_release_rate(t, B, A, 1.0, 1.0)
        mid_t, mid_A = 0.5 * (t[1:] + t[:-1]), 0.5 * (A[1:] + A[:-1])
        exact = mid_t ** 2 / (2.0 * (1.0 + mid_A) ** 2)
        return np.max(np.abs(G[1:] - exact))

    errors = [error(n) for n in (20, 40, 80, 160)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))     # 1.89, 1.94, 1.97: towards 2
    assert errors[-1] < 2e-5 and np.all(np.diff(orders) > 0) and abs(orders[-1] - 2.0) < 0.05


def test_growth_below_da_min_is_merged_into_one_interval():
    t = np.array([0.0, 1.0, 1.05, 1.1, 1.15, 1.2])                # A = 0, 0, 0.1, 0.2, 0.3, 0.4
    A, B = compliance_evolution(t)
    G, _ = energy_release_rate(t, B, A, 1.0, 1.0, da_min=0.25)
    assert np.isnan(G[:4]).all() and np.isfinite(G[4:]).all()     # A - A_j >= 0.25 from step 4 on
    # step 4's G over steps 1 .. 4 (A = 0 .. 0.3), step 5's over steps 2 .. 5 (A = 0.1 .. 0.4)
    for k, j in ((4, 1), (5, 2)):
        difference = (B[j] / t[j] + B[k] / t[k]) * (t[k] - t[j]) - (B[k] - B[j])
        assert G[k] == pytest.approx(difference / (A[k] - A[j]), rel=1e-12)


def test_the_crack_front_of_each_geometry():
    # a = S / (Gc width) + a0: the slab's thickness in 2D; in 3D the geometry's own depth and
    # starter notch (its function's defaults unless the scene sets them); no G without a front
    from fem3d.kind import crack_front

    assert crack_front(load_case("lpanel")) == (100.0, 0.0)
    assert crack_front(load_case("lpanel_3d")) == (100.0, 0.0)
    assert crack_front(load_case("double_torsion")) == (3.0, 7.0)
    assert crack_front(load_case("double_torsion", {"geometry.thickness": 2.5, "geometry.notch": 10.0})) == (2.5, 10.0)
    assert crack_front(load_case("brokenshire")) == ("none", 0.0)


def test_no_difference_across_a_jump_and_none_once_cut_through():
    # a jump of A by 1.5 at step 2, slow growth of 0.1 a step after it, then the specimen cut
    # through (B collapses) while the broken band keeps widening
    t = np.array([0.0, 1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6])
    A = np.array([0.0, 0.0, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0])
    B = t ** 2 / (2.0 * (1.0 + A))
    B[6:] = 1e-6
    G_old, _ = energy_release_rate(t, B, A, 1.0, 1.0, da_min=0.25)
    G, _ = energy_release_rate(t, B, A, 1.0, 1.0, da_min=0.25, jump=1.0, carried=0.01)
    assert np.isfinite(G[2]) and G[2] == G_old[2]            # the jump's own step: as before
    assert np.isfinite(G_old[3]) and np.isnan(G[3])           # 0.1 after the jump: not across it
    assert np.isnan(G[4]) and G[5] == pytest.approx(G_old[5])  # steps 2 .. 5: 0.3 >= da_min
    assert np.isfinite(G_old[6:]).all() and np.isnan(G[6:]).all()   # cut through: no G


def test_no_difference_across_a_refinement():
    # an adaptive run's steps on meshes 0, 0, 1, 1, 1: G only between steps on the same mesh
    t = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    a_len = np.array([1.0, 1.2, 1.4, 1.6, 1.8])
    B = 3.0 * t ** 2 / a_len
    S = 2.0 * a_len
    fixed, _ = energy_release_rate(t, B, S, 2.0, 1.0)
    adaptive, _ = energy_release_rate(t, B, S, 2.0, 1.0, meshes=[0, 0, 1, 1, 1])
    assert np.isfinite(fixed[1:]).all()
    np.testing.assert_array_equal(adaptive[[1, 3, 4]], fixed[[1, 3, 4]])
    assert np.isnan(adaptive[2]) and np.isnan(adaptive[0])


def test_difference_across_a_refinement_from_the_previous_step_on_the_new_mesh():
    # A refinement at step 2 softens the specimen (bulk energy 0.9 of the coarse one at the
    # same crack). Given step 1's energies on step 2's mesh, step 2's G is the difference a
    # run on the fine mesh throughout would give over steps 1-2; without them, NaN.
    t = np.array([0.5, 1.0, 1.5, 2.0, 2.5])
    a_len = np.array([1.0, 1.2, 1.4, 1.6, 1.8])
    factor = np.array([1.0, 1.0, 0.9, 0.9, 0.9])
    B = factor * 3.0 * t ** 2 / a_len
    S = 2.0 * a_len
    fine, _ = energy_release_rate(t, 0.9 * 3.0 * t ** 2 / a_len, S, 2.0, 1.0)
    elastic_previous = np.full(5, np.nan)
    surface_previous = np.full(5, np.nan)
    elastic_previous[2], surface_previous[2] = 0.9 * 3.0 * t[1] ** 2 / a_len[1], S[1]
    G, _ = energy_release_rate(t, B, S, 2.0, 1.0, meshes=[0, 0, 1, 1, 1],
                               previous=(elastic_previous, surface_previous))
    np.testing.assert_allclose(G[2:], fine[2:], rtol=1e-14)
    across, _ = energy_release_rate(t, B, S, 2.0, 1.0)     # the coarse energy differenced with the fine
    assert abs(across[2] - fine[2]) > 0.1 * fine[2]
    G_none, _ = energy_release_rate(t, B, S, 2.0, 1.0, meshes=[0, 0, 1, 1, 1])
    assert np.isnan(G_none[2])
    # a step that grew less than da_min over the refined step: NaN, not a difference further back
    G_short, _ = energy_release_rate(t, B, S, 2.0, 1.0, da_min=0.3, meshes=[0, 0, 1, 1, 1],
                                     previous=(elastic_previous, surface_previous))
    assert np.isnan(G_short[2])
