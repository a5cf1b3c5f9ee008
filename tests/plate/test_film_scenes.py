"""The thin-film scenes of dissertation section 2.5 on coarse grids: the coated cantilever and
the spherical indenter. Each test checks one number that the full-resolution case also shows
(docs/cases.md)."""


import numpy as np
import pytest

from thinfilm.plate.cracks import arms
from thinfilm.engine import AltMinOptions, Engine, StepRecord
from thinfilm.plate.results import PlateResults
from thinfilm.plate.kind import build_grid, make_model
from thinfilm.run import run
from thinfilm.scene import load_scene, parse_scene
from thinfilm.plate.loads import contact_radius

from tests.helpers import CASES  # noqa: E402


def variant(name, **lines):
    """The case file ``name`` with whole ``key = value`` lines replaced (each must exist)."""
    text = (CASES / name).read_text()
    for key, value in lines.items():
        old = [line for line in text.splitlines() if line.split("=")[0].strip() == key]
        assert len(old) == 1, f"{name}: no single line for {key}"
        text = text.replace(old[0], f"{key} = {value}")
    return parse_scene(text, source=name)


def crack_spacing(cracks):
    return np.diff(np.sort(cracks))


def test_cantilever_crack_spacing_scales_with_the_decay_length(tmp_path):
    # The full 400 x 40 cases give an array of equidistant cracks with spacing * lam = 2.9
    # (winkler = 6e6: 0.0825 * 35.0; winkler = 1.2e7 at eta = 2.5 dx: 0.070 * 41.6). A narrow
    # strip of the same length (crack spacing and load do not depend on the width) reproduces it.
    scene = variant("cantilever_6e6.toml", y="[-0.0125, 0.0125]", cells="[400, 10]", t_max="1.4", steps="140",
                    snapshots="[1.4]")
    run(scene, tmp_path)
    with PlateResults(tmp_path / "results.h5") as r:
        cracks = r.cracks()[-1]
        lam = (r.parameters["winkler"] / 4.0) ** 0.25
    assert len(cracks) >= 3
    spacing = crack_spacing(cracks)
    assert np.all(np.abs(spacing * lam - 2.9) < 0.25), (cracks, spacing * lam)
    assert cracks[0] < spacing[0]  # the array starts at the clamped end


def test_indenter_first_ring_crack_is_at_the_contact_edge(tmp_path):
    # The first crack is a ring at the contact radius r_c(t) = R sqrt(t (2 - t)) of the load
    # at which it forms, the same along the axes and the diagonal (no grid imprint).
    scene = variant("indentation.toml", cells="[160, 160]", eta="0.01", t_max="0.4", steps="8",
                    snapshots="[0.2, 0.4]")
    run(scene, tmp_path)
    with PlateResults(tmp_path / "results.h5") as r:
        assert list(r.parameters["snapshots"]) == [0.2, 0.4]
        counts = [len(c) for c in r.cracks()]
        first = next(k for k, n in enumerate(counts) if n > 0)
        t, x, y = r.t[first], r.x, r.y
        alpha = r.field("alpha", first)
    assert counts[first] == 2  # a ring cuts y = 0 twice
    rc = contact_radius(0.3, t)
    dx = x[1] - x[0]
    j0 = len(y) // 2
    on_x = x[np.argmax(np.where(x > 0, alpha[j0], 0.0))]
    diag = np.diag(alpha)
    on_diag = np.sqrt(2.0) * x[np.argmax(np.where(x > 0, diag, 0.0))]
    assert abs(on_x - rc) <= 2 * dx and abs(on_diag - rc) <= 2 * np.sqrt(2.0) * dx, (t, rc, on_x, on_diag)


def test_ito_film_in_physical_units_is_the_indentation_scene():
    # (2.13) with Table 2.1 (G~ = 0.0531) and the chosen L and bond stiffness give back the
    # non-dimensional scene of Fig. 2.12: G/a = 1, winkler = 4e6.
    ito = load_scene(CASES / "ito_indentation.toml")
    plain = load_scene(CASES / "indentation.toml")
    assert ito.material.G_tilde == pytest.approx(0.05306, rel=1e-3)
    assert ito.model.toughness == pytest.approx(plain.model.toughness, rel=1e-4)
    assert ito.model.winkler == pytest.approx(plain.model.winkler, rel=1e-4)
    assert (ito.domain, ito.load, ito.model.eta, ito.model.nu) == (plain.domain, plain.load, plain.model.eta, plain.model.nu)


def test_indenter_crossing_cracks_meet_at_right_angles(tmp_path):
    # Fig. 2.13: under the small indenter two cracks cross at the centre; on a circle about
    # the crossing the four arms are 90 degrees apart (whatever their orientation).
    scene = variant("indentation_crossing.toml", cells="[100, 100]", t_max="0.24", steps="12",
                    snapshots="[0.24]")
    run(scene, tmp_path)
    with PlateResults(tmp_path / "results.h5") as r:
        alpha, x, y = r.field("alpha", r.n - 1), r.x, r.y
    directions = np.sort(arms(alpha, x, y, radius=0.02))
    assert len(directions) == 4, directions
    gaps = np.diff(np.r_[directions, directions[0] + 360.0])
    assert np.all(np.abs(gaps - 90.0) < 10.0), directions


def test_small_indenter_breaks_the_film_first_at_the_centre_of_contact(tmp_path):
    # Fig. 2.14's scenes (stiff bond, G/a = 0.7): the film first breaks where it is bent
    # both ways, at the centre of the contact, then as a cross of two cracks. The cracks stay
    # within r < 0.03 up to t = 0.06, so the domain is cropped further for the test.
    scene = variant("indentation_branching_G07.toml", x="[-0.1, 0.1]", y="[-0.1, 0.1]", cells="[80, 80]",
                    t_max="0.06", steps="12", snapshots="[0.06]")
    run(scene, tmp_path)
    with PlateResults(tmp_path / "results.h5") as r:
        peaks = [r.field("alpha", k).max() for k in range(r.n)]
        first = next(k for k, p in enumerate(peaks) if p > 0.5)
        alpha = r.field("alpha", first)
        x, y = r.x, r.y
        last = r.field("alpha", r.n - 1)
    j, i = np.unravel_index(np.argmax(alpha), alpha.shape)
    assert np.hypot(x[i], y[j]) <= 2 * (x[1] - x[0])
    directions = np.sort(arms(last, x, y, radius=0.012))
    assert len(directions) == 4, directions


def test_tail_extrapolation_shortens_the_settling_of_a_ring():
    # The ring step of the indenter from alpha = 0 on 100^2 (eta = 2 dx): after the ring forms,
    # alternate minimization settles its band linearly (the change of alpha shrinks by a few
    # percent per iteration). Summing that tail as a geometric series (omega_tail = 8) must
    # save at least 30% of the iterations (measured 58 -> 33) and end at the same ring with
    # an energy no higher than plain settling's.
    scene = variant("indentation.toml", cells="[100, 100]", eta="0.016")
    grid = build_grid(scene.domain)
    model = make_model(scene, grid)
    zero = np.zeros(model.n_alpha)
    runs = {}
    for tail in (1.0, 8.0):
        engine = Engine(model, AltMinOptions(tol=1e-4, acceleration="overrelax", omega=4.0, omega_tail=tail))
        record = StepRecord(6, 0.3)
        state = engine.alternate_minimization(0.3, zero, zero, None, record, 6)
        history = np.array(record.energy_history)
        assert np.all(np.diff(history) <= 1e-12 * history[0])  # only accepted extrapolations
        runs[tail] = record.iterations, state
    (n_plain, plain), (n_tail, tail) = runs[1.0], runs[8.0]
    assert n_tail <= 0.7 * n_plain, (n_tail, n_plain)
    assert tail.total <= plain.total + 1e-9 * plain.total
    assert np.max(np.abs(tail.alpha - plain.alpha)) < 0.05
