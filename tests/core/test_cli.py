"""The command line and scene validation: good runs write their files, bad input exits 2."""

import json
import subprocess
import sys

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.scene import SceneError, parse_scene

GOOD = """
[model]
kind = "exact1d"
length = 0.5
lam = 10.0
toughness = 0.05
[load]
t_max = 3.0
steps = 30
[grid]
cells = 200
"""


def _write(tmp_path, text, name="scene.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_run_writes_results_summary_and_figures(tmp_path, capsys):
    scene = _write(tmp_path, GOOD)
    assert main(["run", str(scene), "--quiet"]) == 0
    out = tmp_path / "scene"
    assert sorted(p.name for p in out.iterdir()) == ["cracks.png", "energy.png", "results.h5", "summary.json"]
    assert capsys.readouterr().err == ""  # --quiet: no progress bar

    summary = json.loads((out / "summary.json").read_text())
    assert [len(e["cracks"]) for e in summary["events"]] == [1, 3]
    assert summary["events"][0]["t"] == pytest.approx(0.6815675, abs=1e-6)
    assert set(summary["events"][0]) == {"t", "cracks"}
    assert summary["events_grid"][1]["cracks"] == pytest.approx([-0.125, 0.0, 0.125], abs=1e-12)

    with h5py.File(out / "results.h5") as f:
        assert f.attrs["scene"] == GOOD
        assert f.attrs["kind"] == "exact1d" and f.attrs["thinfilm_version"]
        t = f["steps/t"][()]
        assert t.shape == (31,) and t[0] == 0.0 and t[-1] == 3.0
        total = f["steps/total"][()]
        assert np.allclose(total, f["steps/elastic"][()] + f["steps/surface"][()], rtol=1e-15)
        count = f["steps/crack_count"][()]
        assert list(np.unique(count)) == [0, 1, 3]
        assert np.all(np.diff(count) >= 0)
        assert f["steps/cracks"].shape == (31, 3)
        # The state energy follows its branch t^2/2 coefficient + n G/a at every step.
        branch = f["events/branch_coefficient"][()]
        index = np.searchsorted([0, 1, 3], count)
        assert np.allclose(total, 0.5 * t**2 * branch[index] + count * 0.05, rtol=1e-13)
        assert "grid" in f and f["grid/events/t"].shape == (2,)


def test_out_option_and_module_entry_point(tmp_path):
    scene = _write(tmp_path, GOOD)
    result = subprocess.run([sys.executable, "-m", "thinfilm", "run", str(scene), "--out", str(tmp_path / "elsewhere")],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "elsewhere" / "summary.json").exists()
    assert "t = 0.68156753" in result.stdout


BAD = [
    # (scene text or None for a missing file, fragment of the one-line message)
    (None, "no such file"),
    ("[model\nkind = 1", "TOML syntax error"),
    (GOOD.replace("lam = 10.0", "lamda = 10.0"), "model.lamda: unknown key; did you mean 'lam'?"),
    (GOOD.replace("[grid]", "[grids]"), ": grids: unknown key; did you mean 'grid'?"),
    (GOOD.replace('kind = "exact1d"', 'kind = "plate2d"'), 'model.kind = "plate2d": must be one of'),
    (GOOD.replace("length = 0.5", 'length = "long"'), 'model.length = "long": must be a finite number'),
    (GOOD.replace("steps = 30", "steps = 30.5"), "load.steps = 30.5: must be an integer"),
    (GOOD.replace("steps = 30", "steps = true"), "load.steps = true: must be an integer"),
    (GOOD.replace("length = 0.5", "length = -0.5"), "model.length = -0.5: must be a positive number"),
    (GOOD.replace("lam = 10.0", "lam = 0.0"), "model.lam = 0.0: must be a positive number"),
    (GOOD.replace("toughness = 0.05", "toughness = -1"), "model.toughness = -1: must be a positive number"),
    (GOOD.replace("t_max = 3.0", "t_max = 0"), "load.t_max = 0: must be a positive number"),
    (GOOD.replace("t_max = 3.0", "t_max = nan"), "load.t_max = nan: must be a finite number"),
    (GOOD.replace("cells = 200", "cells = 1"), "grid.cells = 1: must be an integer >= 2"),
    (GOOD.replace("steps = 30", "steps = 1"), "load.steps = 1: must be an integer >= 2"),
    (GOOD.replace("lam = 10.0", "lam = 10.0\nwinkler = 4e4"), "give exactly one of model.lam and model.winkler (both are given)"),
    (GOOD.replace("lam = 10.0", ""), "give exactly one of model.lam and model.winkler (neither is given)"),
    (GOOD.replace("toughness = 0.05", ""), "model.toughness: missing (required)"),
    (GOOD.replace("[load]\nt_max = 3.0\nsteps = 30", ""), "load: missing table [load] (required)"),
]


@pytest.mark.parametrize("text, message", BAD)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys, text, message):
    scene = tmp_path / "bad.toml" if text is None else _write(tmp_path, text, "bad.toml")
    before = sorted(tmp_path.iterdir())
    assert main(["run", str(scene)]) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert str(scene) in lines[0] and message in lines[0], lines[0]
    assert "Traceback" not in err
    assert sorted(tmp_path.iterdir()) == before  # no output written


def test_syntax_error_names_the_line(tmp_path, capsys):
    scene = _write(tmp_path, GOOD.replace("cells = 200", "cells = = 200"))
    assert main(["run", str(scene)]) == 2
    assert "line 11" in capsys.readouterr().err


def test_bad_input_from_the_console_script_exits_2(tmp_path):
    result = subprocess.run([sys.executable, "-m", "thinfilm", "run", str(tmp_path / "missing.toml")],
                            capture_output=True, text=True)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "no such file" in result.stderr


def test_winkler_is_an_alternative_to_lam():
    scene = parse_scene(GOOD.replace("lam = 10.0", "winkler = 4e4"))
    assert scene.model.lam == pytest.approx(10.0, rel=1e-15)
    assert scene.model.winkler == pytest.approx(4e4, rel=1e-15)


def test_scene_is_frozen():
    scene = parse_scene(GOOD)
    with pytest.raises(AttributeError):
        scene.model.lam = 3.0
    with pytest.raises(SceneError):
        parse_scene(GOOD.replace("cells = 200", "cells = 0"))


from tests.helpers import CASES  # noqa: E402


@pytest.mark.parametrize("name, counts, first_t", [
    ("fig2_15", [1, 3], 0.68156753),
    ("fig2_16", [1, 2, 3], 0.67140084),
    ("fig2_18", [9, 19], 5.36067809),
])
def test_cases_regression(tmp_path, name, counts, first_t):
    assert main(["run", str(CASES / f"{name}.toml"), "--out", str(tmp_path), "--quiet"]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [len(e["cracks"]) for e in summary["events"]] == counts
    assert summary["events"][0]["t"] == pytest.approx(first_t, abs=1e-8)
