"""Scan files: the runs they generate, their names, and every bad input refused up front."""

import hashlib
import json
import subprocess
import sys
import tomllib

import pytest

from thinfilm.cli import main
from thinfilm.scan.plan import ScanError, load_plan, run_name
from thinfilm.scene import load_scene
from tests.helpers import CASES, ROOT

BASE = CASES / "fig2_18.toml"


def _plan(tmp_path, body, name="scan.toml"):
    path = tmp_path / name
    path.write_text(f'base = "{BASE}"\n' + body)
    return path


def test_product_and_zip_generate_every_combination_in_order(tmp_path):
    product = load_plan(_plan(tmp_path, '[vary]\n"model.lam" = [3.0, 4.0, 5.0]\n"model.toughness" = [0.1, 1.0]\n'))
    assert [tuple(r.values.values()) for r in product.runs] == [
        (3.0, 0.1), (3.0, 1.0), (4.0, 0.1), (4.0, 1.0), (5.0, 0.1), (5.0, 1.0)]
    zipped = load_plan(_plan(tmp_path, 'mode = "zip"\n[vary]\n"model.lam" = [3.0, 4.0]\n'
                                       '"model.toughness" = [0.1, 1.0]\n'))
    assert [tuple(r.values.values()) for r in zipped.runs] == [(3.0, 0.1), (4.0, 1.0)]
    assert [r.index for r in zipped.runs] == [0, 1]
    assert zipped.kind == "exact1d" and zipped.keys == ("model.lam", "model.toughness")


def test_bare_dotted_keys_are_the_quoted_ones(tmp_path):
    quoted = load_plan(_plan(tmp_path, '[vary]\n"model.lam" = [3.0, 4.0]\n[set]\n"load.steps" = 10\n', "a.toml"))
    bare = load_plan(_plan(tmp_path, '[vary]\nmodel.lam = [3.0, 4.0]\n[set]\nload.steps = 10\n', "b.toml"))
    assert [r.overrides for r in bare.runs] == [r.overrides for r in quoted.runs]
    assert [r.name for r in bare.runs] == [r.name for r in quoted.runs]


def test_set_and_repeat_add_fixed_keys_and_seeds(tmp_path):
    base = CASES / "cantilever_6e6.toml"
    path = tmp_path / "scan.toml"
    path.write_text(f'base = "{base}"\n[vary]\n"model.winkler" = [3e6, 6e6]\n[set]\n"load.steps" = 10\n'
                    '"model.toughness_noise" = 0.1\n"model.toughness_noise_length" = 0.02\n'
                    '[repeat]\nkey = "model.toughness_noise_seed"\ncount = 3\nfirst = 5\n'
                    '[collect]\nmetrics = ["cracks_at_t_max"]\n')
    plan = load_plan(path)
    assert len(plan.runs) == 6
    assert [r.values["model.toughness_noise_seed"] for r in plan.runs] == [5, 6, 7, 5, 6, 7]
    assert all(r.overrides["load.steps"] == 10 for r in plan.runs)
    assert plan.keys == ("model.winkler", "model.toughness_noise_seed") and plan.seed == "model.toughness_noise_seed"
    assert len({r.name for r in plan.runs}) == 6


def test_set_from_the_command_line_joins_every_run_and_names_it(tmp_path, capsys):
    path = _plan(tmp_path, '[vary]\n"model.lam" = [3.0, 4.0]\n[set]\n"load.steps" = 10\n')
    plain, more = load_plan(path), load_plan(path, {"load.steps": 12, "model.toughness": 0.5})
    assert [r.overrides for r in more.runs] == [{"load.steps": 12, "model.toughness": 0.5, "model.lam": v}
                                               for v in (3.0, 4.0)]
    assert [r.values for r in more.runs] == [r.values for r in plain.runs]
    assert not {r.name for r in more.runs} & {r.name for r in plain.runs}   # other runs, other directories
    with pytest.raises(ScanError, match="--set model.lam: the key is varied"):
        load_plan(path, {"model.lam": 5.0})
    # the command: a bad value is refused like [set]'s, before anything runs
    out = tmp_path / "out"
    assert main(["scan", str(path), "--set", "model.toughness=-1.0", "--out", str(out)]) == 2
    assert main(["scan", str(path), "--set", "model.toughness", "--out", str(out)]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert "model.toughness = -1.0" in lines[0] and "must be KEY=VALUE" in lines[1] and not out.exists()


def test_run_names_hash_the_parsed_base_and_the_overrides():
    overrides = {"model.lam": 4.0, "load.steps": 10}
    text = "[model]\nlam = 3.0 # the decay\n"
    blob = json.dumps({"base": {"model": {"lam": 3.0}}, "overrides": overrides}, sort_keys=True, separators=(",", ":"))
    assert run_name(text, overrides) == hashlib.sha256(blob.encode()).hexdigest()[:12]
    assert run_name(text, dict(reversed(overrides.items()))) == run_name(text, overrides)
    # comments and layout do not rename a run; a value does
    assert run_name("# a comment\n[model]\n  lam   = 3.0\n", overrides) == run_name(text, overrides)
    assert run_name("[model]\nlam = 3.5\n", overrides) != run_name(text, overrides)
    assert run_name(text, {**overrides, "model.lam": 4.5}) != run_name(text, overrides)
    # the same in another interpreter, whatever its hash seed
    code = ("from thinfilm.scan.plan import run_name; "
            "print(run_name('[model]\\nlam = 3.0 # the decay\\n', {'model.lam': 4.0, 'load.steps': 10}))")
    other = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT,
                           env={"PYTHONHASHSEED": "12345", "PATH": ""}).stdout.strip()
    assert other == run_name(text, overrides)


@pytest.mark.parametrize("body, key, phrase", [
    ('[vary]\n"model.lam" = [3.0, -4.0]\n', "model.lam", "run 1 (model.lam = -4.0)"),
    ('[vary]\n"model.lamb" = [3.0]\n', "model.lamb", "unknown key"),
    ('mode = "zip"\n[vary]\n"model.lam" = [3.0, 4.0]\n"model.toughness" = [0.1]\n', "vary", "one length"),
    ('mode = "grid"\n[vary]\n"model.lam" = [3.0]\n', "mode", '"product", "zip"'),
    ('[vary]\n"model.lam" = 3.0\n', "vary.model.lam", "non-empty list"),
    ('[vary]\n', "vary", "at least one key"),
    ('[vary]\n"model.lam" = [3.0, 3.0]\n', "vary", "repeats run 0"),
    ('[vary]\n"model.lam" = [3.0]\n[set]\n"model.lam" = 2.0\n', "set.model.lam", "also varied"),
    ('[vary]\n"model.lam" = [3.0]\n[collect]\nmetrics = ["peak_force"]\n', "collect.metrics",
     "not recorded by exact1d runs"),
    ('[vary]\n"model.lam" = [3.0]\n[collect]\nmetrics = ["spacing"]\n', "collect.metrics", "unknown metric"),
    ('[vary]\n"model.lam" = [3.0]\n[repeat]\nkey = "model.lam"\ncount = 2\n', "repeat.key", "also in"),
    ('workers = 2\n[vary]\n"model.lam" = [3.0]\n', "workers", "unknown key"),
])
def test_a_bad_scan_is_refused_in_one_line_naming_file_and_key(tmp_path, body, key, phrase):
    path = _plan(tmp_path, body)
    with pytest.raises(ScanError) as err:
        load_plan(path)
    message = str(err.value)
    assert message.startswith(str(path)) and key in message and phrase in message and "\n" not in message


def test_the_command_refuses_a_bad_run_with_status_2_and_starts_nothing(tmp_path, capsys):
    path = _plan(tmp_path, '[vary]\n"model.lam" = [3.0, 4.0, -1.0]\n')
    out = tmp_path / "out"
    assert main(["scan", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"thinfilm: error: {path}: run 2 (model.lam = -1.0): {BASE}: model.lam")
    assert "\n" not in err and not out.exists()


def test_the_command_refuses_a_run_that_cannot_fit_and_starts_nothing(tmp_path, capsys):
    path = _plan(tmp_path, '[vary]\n"grid.cells" = [200, 1000000000]\n')
    out = tmp_path / "out"
    assert main(["scan", str(path), "--out", str(out), "--no-time-limit"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"thinfilm: error: {path}: run 1 (grid.cells = 1000000000): {BASE}: grid.cells ="
                          " 1000000000: the run needs about")
    assert "available on this machine" in err and "\n" not in err and not out.exists()


def test_the_command_refuses_bad_options_with_status_2(tmp_path, capsys):
    path = _plan(tmp_path, '[vary]\n"model.lam" = [3.0]\n')
    assert main(["scan", str(path), "--workers", "0"]) == 2
    assert main(["scan", str(path), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"]) == 2
    assert main(["scan", str(path), "--resume", "--force"]) == 2
    assert main(["scan"]) == 2
    assert main(["scan", "--collect", str(tmp_path)]) == 2      # not a scan directory
    assert main(["scan", str(tmp_path / "missing.toml")]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 6 and all(line.startswith("thinfilm: error: ") for line in lines)
    assert "not a scan directory" in lines[4] and "no such file" in lines[5]


@pytest.mark.parametrize("path", sorted((CASES / "scans").glob("*.toml")), ids=lambda p: p.name)
def test_every_scan_case_and_its_base_scene_is_valid(path):
    if "base" in tomllib.loads(path.read_text()):
        plan = load_plan(path)                 # every run's scene validated
        assert len(plan.runs) >= 2 and plan.base.parent in (CASES, CASES / "scans")
    else:
        load_scene(path)                       # a base scene


def test_a_zip_scan_is_drawn_as_one_series_in_the_file_order(tmp_path):
    """Keys that vary together are one parameter: scan.png draws each metric against the run's
    place in the scan file, one series without a legend (grouping by the other keys made one
    legend entry per run, each as long as all its keys, covering the panels)."""
    import matplotlib.pyplot as plt

    from thinfilm.scan.table import draw

    plan = {"base": "base.toml", "mode": "zip", "keys": ["geometry.width", "mesh.h"], "seed": None,
            "metrics": ["peak_force"]}
    rows = [{"run": f"r{k}", "geometry.width": w, "mesh.h": h, "peak_force": str(f), "status": status}
            for k, (w, h, f, status) in enumerate([(0.5, 0.1, 3.0, "done"), (0.5, 0.2, 2.0, "done"),
                                                   (0.3, 0.1, 5.0, "failed"), (0.3, 0.2, 1.0, "done")])]
    drawn = []
    original = plt.Figure.savefig

    def keep(fig, *args, **kwargs):
        drawn.append(fig)
        return original(fig, *args, **kwargs)

    plt.Figure.savefig = keep
    try:
        path = draw(tmp_path, plan, rows)
    finally:
        plt.Figure.savefig = original
    assert path.exists()
    ax = drawn[0].axes[0]
    (line,) = ax.get_lines()
    assert list(line.get_xdata()) == [1, 2, 4] and list(line.get_ydata()) == [3.0, 2.0, 1.0]
    assert ax.get_legend() is None
    assert "run, in the scan file's order" in drawn[0].axes[-1].get_xlabel()
