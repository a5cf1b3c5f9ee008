"""What a newcomer sees in the figures: default snapshots that skip the sound start, a colour
scale that fits a one-signed deflection, markers not cut by the frame."""

import numpy as np

from thinfilm.plots import U_CMAP, U_HALF_CMAPS, colour_range, plt, snapshot_steps, unclip_markers


def test_default_snapshots_start_at_the_first_step_worth_a_panel():
    t = np.linspace(0.0, 1.0, 21)
    assert list(snapshot_steps(t)) == [0, 5, 10, 15, 20]               # as before when asked from 0
    assert list(snapshot_steps(t, first=12)) == [12, 14, 16, 18, 20]   # from the first damaged step
    assert list(snapshot_steps(t[:3], first=1)) == [1, 2]
    assert list(snapshot_steps(t, [0.0, 0.5], first=12)) == [0, 10]     # asked-for loads win


def test_a_one_signed_deflection_gets_half_the_diverging_scale():
    assert colour_range("u", np.array([[-2.0, -0.5, 0.0]])) == (-2.0, 0.0, U_HALF_CMAPS[0])
    assert colour_range("u", np.array([[0.0, 3.0]])) == (0.0, 3.0, U_HALF_CMAPS[1])
    assert colour_range("u", np.array([[-1.0, 3.0]])) == (-3.0, 3.0, U_CMAP)
    # a ripple of the other sign below 2 % of the extreme: still one-signed (the indented film)
    assert colour_range("u", np.array([[-0.3, 0.0006]])) == (-0.3, 0.0, U_HALF_CMAPS[0])
    assert colour_range("u", np.array([[-0.3, 0.01]])) == (-0.3, 0.3, U_CMAP)
    assert colour_range("u", np.zeros((2, 3))) == (-1.0, 1.0, U_CMAP)
    # the halves are the diverging map's own colours: white at 0 in both
    white = plt.get_cmap(U_CMAP)(0.5)
    np.testing.assert_allclose(U_HALF_CMAPS[0](1.0), white, atol=0.01)
    np.testing.assert_allclose(U_HALF_CMAPS[1](0.0), white, atol=0.01)


def test_markers_inside_the_limits_are_not_clipped():
    fig, ax = plt.subplots()
    inside, = ax.plot([0.0, 1.0], [0.0, 1.0], "o")
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.0)
    beyond, = ax.plot([0.0, 2.0], [0.0, 0.5], "o")    # runs past the limits: stays clipped
    plain, = ax.plot([0.0, 1.0], [0.5, 0.5])          # no marker: left alone
    unclip_markers(fig)
    assert not inside.get_clip_on() and beyond.get_clip_on() and plain.get_clip_on()
    plt.close(fig)
