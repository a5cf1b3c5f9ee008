"""The film's figures of a tiny indentation run: the contact circle on the snapshot panels,
tick labels that never meet, and a cracks figure that draws its last step whole."""

import numpy as np
import pytest

from tests.helpers import load_case
from thinfilm.plate.loads import contact_radius
from thinfilm.plate.plots import cracks_figure
from thinfilm.plate.results import PlateResults
from thinfilm.plots import image_figure, plt, snapshot_steps
from thinfilm.run import run


@pytest.fixture(scope="module")
def indentation(tmp_path_factory):
    out = tmp_path_factory.mktemp("indentation")
    scene = load_case("indentation", {"domain.cells": [24, 24], "load.steps": 4, "output.snapshots": [0.5, 0.75, 1.0]})
    run(scene, out)
    return out / "results.h5"


def snapshot_figure(res, field="alpha"):
    steps = snapshot_steps(res.t, res.parameters["snapshots"])
    values = np.array([res.field(field, k) for k in steps])
    return steps, image_figure(res, steps, field, values, "snapshots")


@pytest.mark.parametrize("field", ["alpha", "u"])
def test_snapshot_panels_draw_the_contact_circle_of_their_load(indentation, field):
    with PlateResults(indentation) as res:
        steps, fig = snapshot_figure(res, field)
        t = res.t[steps]
    panels = fig.axes[:len(steps)]
    for ax, tk in zip(panels, t):
        (circle,) = [line for line in ax.get_lines() if line.get_label() == "contact radius"]
        x, y = circle.get_data()
        assert np.allclose(np.hypot(x, y), contact_radius(0.3, tk))
        assert circle.get_linestyle() == "--"
    legend = panels[0].get_legend()
    assert [text.get_text() for text in legend.get_texts()] == ["contact radius"]
    plt.close(fig)


def test_snapshot_tick_labels_of_neighbouring_panels_do_not_meet(indentation):
    with PlateResults(indentation) as res:
        steps, fig = snapshot_figure(res)
    renderer = fig.canvas.get_renderer()
    # each panel's visible tick labels, 2 px around; a panel's own x and y labels may meet at
    # its corner (as on any axes), two panels' labels must not
    boxes = [(i, label.get_window_extent(renderer).padded(2.0))
             for i, ax in enumerate(fig.axes[:len(steps)])
             for label in ax.get_xticklabels() + ax.get_yticklabels() if label.get_visible() and label.get_text()]
    assert len({i for i, _ in boxes}) == len(steps) == 3  # one row: every panel labels its x axis
    overlaps = [(i, a, j, b) for n, (i, a) in enumerate(boxes) for j, b in boxes[n + 1:] if i != j and a.overlaps(b)]
    assert not overlaps
    plt.close(fig)


def test_cracks_figure_draws_the_last_step_inside_the_axes(indentation, tmp_path, monkeypatch):
    drawn = []
    monkeypatch.setattr(plt, "close", drawn.append)
    with PlateResults(indentation) as res:
        cracks_figure(res, tmp_path)
        t_last, x = res.t[-1], res.x
    (fig,) = drawn
    ax = fig.axes[0]
    low, high = ax.get_xlim()
    # the marker of the last step (a few points wide) lies inside the axes, not on its edge
    marker = ax.transData.inverted().transform([[0.0, 0.0], [6.0, 0.0]])
    half = abs(marker[1, 0] - marker[0, 0]) / 2
    assert low < 0.0
    assert t_last + half < high
    assert ax.get_ylim()[0] < x[0] and x[-1] < ax.get_ylim()[1]
    fig.clf()
