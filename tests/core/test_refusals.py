"""Bad input the command line refuses in one line, exit status 2, nothing written: sizes that
cannot fit the machine, derived parameters that are not finite, keys misnamed in messages,
a comparison without an exact counterpart, snapshot loads beyond the run.

Each case runs a case file with ``--set`` overrides from a scene copied into a temporary
folder (so the default output directory would be made there), through :func:`thinfilm.cli.main`.
The memory estimates of :mod:`thinfilm.resources` are checked against what moderate runs
allocate (``tracemalloc``) at the end.
"""

import json
import sys
import time
import tomllib
import tracemalloc

from pathlib import Path

import numpy as np
import pytest

import thinfilm.exact1d.kind  # noqa: F401  (imported here, not inside a timed refusal)
import thinfilm.plate.kind  # noqa: F401
from thinfilm import resources
from thinfilm.cli import main
from thinfilm.scene import SceneError, load_scene

from tests.helpers import CASES

#: A 1D film, a 2D film (indenter), the exact 1D film.
FILM_1D, FILM_2D, EXACT = "fig2_5", "indentation", "fig2_15"


def _refused(tmp_path, capsys, case, overrides, *, command="run", extra=(), text=None):
    """Run ``thinfilm COMMAND`` on a copy of ``cases/CASE.toml`` with ``--set`` overrides and
    check the refusal: exit status 2, one stderr line naming the scene file, no traceback,
    nothing printed on stdout, nothing made in the scene's folder. Returns the line."""
    scene = tmp_path / f"{case}.toml"
    scene.write_text(text if text is not None else (CASES / f"{case}.toml").read_text())
    before = sorted(tmp_path.iterdir())
    settings = [f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]
    start = time.perf_counter()
    status = main([command, str(scene), *settings, *extra])
    elapsed = time.perf_counter() - start
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert status == 2, captured.err
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"thinfilm: error: {scene}: "), lines[0]
    assert "Traceback" not in captured.err and captured.out == ""
    assert sorted(tmp_path.iterdir()) == before  # no output directory, no file
    assert elapsed < 2.0, elapsed
    return lines[0]


# -- sizes that cannot fit -----------------------------------------------------------------
SIZES = [
    (FILM_2D, {"domain.cells": [1000000, 1000000]}, "domain.cells = [1000000, 1000000]"),
    (FILM_1D, {"domain.cells": 1000000000}, "domain.cells = 1000000000"),
    (EXACT, {"grid.cells": 1000000000}, "grid.cells = 1000000000"),
    (EXACT, {"load.steps": 1000000000}, "load.steps = 1000000000"),
    (EXACT, {"load.steps": 10000000000}, "load.steps = 10000000000"),
    (FILM_1D, {"load.steps": 10000000000}, "load.steps = 10000000000"),
    (FILM_2D, {"load.steps": 10000000000}, "load.steps = 10000000000"),
]


@pytest.mark.parametrize("case, overrides, named", SIZES)
def test_sizes_that_cannot_fit_the_memory_are_refused_at_once(tmp_path, capsys, case, overrides, named):
    tracemalloc.start()
    try:
        line = _refused(tmp_path, capsys, case, overrides)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert named in line, line
    assert "of memory" in line and "available on this machine" in line, line
    assert peak < 50e6  # refused from the scene: nothing of the run's size was allocated


def test_the_memory_limit_cannot_be_lifted(tmp_path, capsys):
    line = _refused(tmp_path, capsys, EXACT, {"grid.cells": 1000000000}, extra=("--no-time-limit",))
    assert "grid.cells = 1000000000" in line and "of memory" in line


def test_a_long_exact_run_is_refused_unless_the_time_limit_is_lifted(tmp_path, capsys):
    line = _refused(tmp_path, capsys, EXACT, {"grid.cells": 1000000})
    assert "grid.cells = 1000000: the run takes at least about 11" in line and "h (" in line
    assert "time limit of 1 h" in line and "--no-time-limit" in line
    scene = load_scene(CASES / f"{EXACT}.toml", {"grid.cells": 1000000})
    resources.check(scene, time_limit=None)  # what --no-time-limit does: no error


def test_the_blame_goes_to_the_key_that_does_not_fit(tmp_path):
    # the grid alone fits, the steps' fields on it do not: the steps are named
    limit = 1e9
    scene = load_scene(CASES / f"{FILM_1D}.toml", {"domain.cells": 100000, "load.steps": 1000})
    with pytest.raises(SceneError, match=r"load\.steps = 1000: the run needs about [\d.]+ GB of memory"):
        resources.check(scene, memory=limit)
    scene = load_scene(CASES / f"{FILM_1D}.toml", {"domain.cells": 10000000, "load.steps": 2})
    with pytest.raises(SceneError, match=r"domain\.cells = 10000000: "):
        resources.check(scene, memory=limit)
    resources.check(load_scene(CASES / f"{FILM_1D}.toml"), memory=limit)  # the case itself fits


def test_every_case_file_fits_16_gb_and_the_time_limit():
    # (the largest: indentation_full, 1500^2 nodes, measured at 5.7 GB; 6.4 GB in double precision)
    for path in sorted(CASES.glob("*.toml")):
        data = tomllib.loads(path.read_text())
        if data["model"]["kind"] != "fem":  # (their kind is left unimported here: gmsh)
            coarse = {"solver.coarse": None} if "coarse" in data.get("solver", {}) else {}
            resources.check(load_scene(path, coarse), memory=16e9)


# -- derived parameters, and messages that name the key written ------------------------------
def test_lam_whose_winkler_overflows_is_refused(tmp_path, capsys):
    line = _refused(tmp_path, capsys, FILM_1D, {"model.lam": 1e300})
    assert "model.lam = 1e+300: must be in [8.6e-78, 8.2e+76], so that winkler = 4 lam^4" in line
    line = _refused(tmp_path, capsys, EXACT, {"model.lam": 1e300})
    assert "model.lam = 1e+300" in line


def test_material_whose_groups_overflow_is_refused(tmp_path, capsys):
    line = _refused(tmp_path, capsys, "ito_indentation", {"material.bond_stiffness": 1e300, "material.L": 1e10})
    assert ": material: E = 9.98e+10, h = 1e-07, bond_stiffness = 1e+300, L = 1e+10: (2.13) gives winkler = inf;" in line
    line = _refused(tmp_path, capsys, "ito_indentation", {"material.K_IC": 1e200})
    assert "material.K_IC = 1e+200: gives Gc = K_IC^2 / E = inf" in line


@pytest.mark.parametrize("key, value, named", [
    ("model.eta", 100.0, "model.eta = 100.0: must be a positive length up to the domain's size 0.5"),
    ("model.eta_dx", 2000, "model.eta_dx = 2000: gives eta = eta_dx * dx = 1.25"),
])
def test_eta_beyond_the_domain_names_the_key_written(tmp_path, capsys, key, value, named):
    text = (CASES / f"{FILM_1D}.toml").read_text()
    if key == "model.eta":  # (an override cannot remove eta_dx from the command line)
        text = text.replace("eta_dx = 10", f"eta = {value!r}  #")
    line = _refused(tmp_path, capsys, FILM_1D, {} if key == "model.eta" else {key: value}, text=text)
    assert named in line and "toughness_noise_length" not in line


FIELD = {"load.kind": "field", "load.t_max": 1.0, "solver.backtrack": "none"}


def test_a_field_file_of_the_wrong_type_is_named_once(tmp_path, capsys):
    (tmp_path / "w.txt").write_text("0\n")
    line = _refused(tmp_path, capsys, FILM_1D, {**FIELD, "load.file": "w.txt"})
    assert line.endswith('load.file = "w.txt": must end in .npz, .h5 or .hdf5'), line
    assert line.count("load.file") == 1 and "SceneError" not in line


def test_a_field_file_without_the_array_names_load_name(tmp_path, capsys):
    np.savez(tmp_path / "w.npz", v=np.zeros(801))
    line = _refused(tmp_path, capsys, FILM_1D, {**FIELD, "load.file": "w.npz"})
    assert line.endswith('load.name = "w": no array of that name in w.npz (it has: v)'), line
    (tmp_path / "text.npz").write_text("0\n")
    line = _refused(tmp_path, capsys, FILM_1D, {**FIELD, "load.file": "text.npz"})
    assert line.endswith('load.file = "text.npz": cannot be read: not an .npz archive (numpy.savez writes them)')


# -- commands ------------------------------------------------------------------------------
def test_compare_refuses_a_load_other_than_bending(tmp_path, capsys):
    line = _refused(tmp_path, capsys, FILM_2D, {}, command="compare")
    assert 'load.kind = "indenter": compare draws the run against the exact 1D evolution' in line
    assert 'it needs load.kind = "bending"' in line


def _film_results(path):
    """``results.h5`` of a 1D film of 40 cells to t_max = 1 in 2 steps, written as a run writes
    it (its fields are zeros: only the loads matter here)."""
    from thinfilm.engine.records import State, StepRecord
    from thinfilm.plate.kind import KIND, build_grid
    from thinfilm.results.writer import ResultsWriter

    scene = load_scene(CASES / f"{FILM_1D}.toml", {"domain.cells": 40, "load.steps": 2, "load.t_max": 1.0})
    grid = build_grid(scene.domain)
    writer = ResultsWriter(path, scene, KIND.parameters(scene), grid.description())
    for k, t in enumerate((0.0, 0.5, 1.0)):
        zero = np.zeros(grid.n_nodes)
        writer.write_step(StepRecord(k, t, 0.0, 0.0, 0.0), State(t, zero, zero, 0.0, 0.0))
    writer.close()
    return path


def test_plot_refuses_loads_beyond_the_run(tmp_path, capsys):
    results = _film_results(tmp_path / "results.h5")
    out = tmp_path / "figures"
    assert main(["plot", str(results), "--t", "0.5", "5", "--out", str(out)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and captured.out == "" and "Traceback" not in captured.err
    assert lines[0] == (f"thinfilm: error: {results}: snapshot loads (--t) 5: must be in [0, 1], the run's"
                        " loads (t_max = 1)")
    assert not out.exists()


# -- the estimates against what the code allocates ------------------------------------------
def _traced(function):
    """``function()``'s result and the peak of what it allocated (bytes)."""
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        tracemalloc.reset_peak()
        out = function()
        return out, tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()


def test_plate_bytes_per_node_and_per_step_are_what_a_run_allocates(monkeypatch):
    # pypardiso looks for MKL by walking the whole of sys.prefix at every solver it makes
    # (seconds); tell it where the library is when it lies in sys.prefix/lib
    mkl = sorted(Path(sys.prefix, "lib").glob("libmkl_rt.so*"))
    if mkl:
        monkeypatch.setenv("PYPARDISO_MKL_RT", str(mkl[0]))
    from thinfilm.engine.evolution import Engine
    from thinfilm.plate import resources as plate
    from thinfilm.plate.kind import KIND
    from thinfilm.run import load_steps

    def evolve(scene):
        setup = KIND.setup(scene)
        return setup.model.n_alpha, Engine.from_options(setup.model, scene.solver).run(load_steps(scene.load))

    overrides = {"load.t_max": 0.01, "load.steps": 2, "output.snapshots": [0.01], "solver.search": False,
                 "solver.linear": "direct"}
    evolve(load_scene(CASES / f"{FILM_2D}.toml", {**overrides, "domain.cells": [8, 8]}))  # compiled, imported
    scene = load_scene(CASES / f"{FILM_2D}.toml", {**overrides, "domain.cells": [100, 100]})
    (nodes, (records, states)), peak = _traced(lambda: evolve(scene))
    # The model, its solver's arrays and the engine's working fields (PARDISO's factors are
    # not Python's: docs/scenes.md#sizes measures them with the process's memory).
    assert 0.8 < peak / (nodes * plate.NODE_BYTES[2, "direct"]) < 1.1, peak / nodes
    # Every step's u and alpha are kept until the evolution ends: FIELD_BYTES per node.
    assert len(states) == 3
    assert all(s.u.nbytes + s.alpha.nbytes == plate.FIELD_BYTES * nodes for s in states)


def test_exact1d_bytes_per_cell_and_per_step_are_what_a_run_allocates():
    from thinfilm.exact1d import resources as exact
    from thinfilm.exact1d.evolution import run_exact1d

    run_exact1d(load_scene(CASES / f"{EXACT}.toml", {"grid.cells": 20, "load.steps": 2}))  # compiled
    cells = load_scene(CASES / f"{EXACT}.toml", {"grid.cells": 1000, "load.steps": 2})
    _, peak = _traced(lambda: run_exact1d(cells))
    assert 0.8 < peak / (1000 * exact.CELL_BYTES) < 1.1, peak / 1000
    few, many = (load_scene(CASES / f"{EXACT}.toml", {"grid.cells": 20, "load.steps": n}) for n in (50, 250))
    per_step = (_traced(lambda: run_exact1d(many))[1] - _traced(lambda: run_exact1d(few))[1]) / 200
    # (what Python allocates; the process holds a third more: thinfilm/exact1d/resources.py)
    assert 0.65 < per_step / exact.STEP_BYTES < 0.85, per_step
