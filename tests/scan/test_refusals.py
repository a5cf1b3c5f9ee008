"""Scan input refused before anything is written: a base that is a mesh, a malformed or
silent ``--scheduler`` address, a scan larger than the run limit. Each exits with status 2
and one stderr line naming the scan file, no traceback, nothing made next to it."""

import socket
import time

import pytest

from thinfilm.cli import main
from thinfilm.scan.execute import CONNECT_TIMEOUT
from thinfilm.scan.plan import MAX_RUNS

from tests.helpers import CASES


def _refused(tmp_path, capsys, text, extra=()):
    """Write ``scan.toml`` beside a copy of the 1D cantilever scene, run ``thinfilm scan`` on it
    and check the refusal; returns its line and the seconds it took."""
    (tmp_path / "base.toml").write_text((CASES / "scans" / "cantilever_film_1d.toml").read_text())
    scan = tmp_path / "scan.toml"
    scan.write_text(text)
    before = sorted(tmp_path.iterdir())
    start = time.perf_counter()
    status = main(["scan", str(scan), "--quiet", *extra])
    elapsed = time.perf_counter() - start
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert status == 2, captured.err
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"thinfilm: error: {scan}: "), lines[0]
    assert "Traceback" not in captured.err
    assert sorted(tmp_path.iterdir()) == before
    return lines[0], elapsed


SMALL = 'base = "base.toml"\n[vary]\n"model.winkler" = [3e6, 6e6]\n'


def test_a_mesh_as_base_scene_is_refused(tmp_path, capsys):
    (tmp_path / "panel.msh").write_text("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n")
    line, _ = _refused(tmp_path, capsys, 'base = "panel.msh"\n[vary]\n"model.E" = [1.0, 2.0]\n')
    assert 'base = "panel.msh": is a gmsh mesh, not a scene' in line


def test_a_base_that_is_not_a_scene_is_refused(tmp_path, capsys):
    (tmp_path / "notes.toml").write_text("this is not toml\n")
    line, _ = _refused(tmp_path, capsys, 'base = "notes.toml"\n[vary]\n"model.E" = [1.0, 2.0]\n')
    assert 'base = "notes.toml": not a valid scene' in line and "TOML syntax error" in line


@pytest.mark.parametrize("address, detail", [
    ("tcp://[bad", "not a scheduler address"),
    ("tcp://host", "missing port number"),
    ("foo://host:8786", "with a scheme of tcp"),
    ("tcp://host:0", "a port in 1-65535"),
])
def test_a_malformed_scheduler_address_is_refused(tmp_path, capsys, address, detail):
    line, elapsed = _refused(tmp_path, capsys, SMALL, ["--scheduler", address])
    assert f"--scheduler {address}: " in line and detail in line
    assert elapsed < 2.0


def test_a_scheduler_that_does_not_answer_is_refused_after_the_timeout(tmp_path, capsys):
    with socket.socket() as s:  # a port nothing listens on: bound, then released
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    line, elapsed = _refused(tmp_path, capsys, SMALL, ["--scheduler", f"tcp://127.0.0.1:{port}"])
    assert f"no Dask scheduler answered within {CONNECT_TIMEOUT:g} s" in line
    assert elapsed < CONNECT_TIMEOUT + 5.0


def test_a_scan_above_the_run_limit_is_refused_before_validation(tmp_path, capsys):
    values = ", ".join(str(3e6 * (1 + k)) for k in range(4000))
    text = f'base = "base.toml"\n[vary]\n"model.winkler" = [{values}]\n"model.toughness" = [{values}]\n'
    line, elapsed = _refused(tmp_path, capsys, text)
    assert f"vary: makes 16000000 runs (4000 x 4000): more than the limit of {MAX_RUNS}" in line
    assert "--max-runs" in line
    assert elapsed < 5.0


def test_the_run_limit_is_lifted_by_max_runs(tmp_path, capsys):
    # 3 runs against a limit of 2: refused; --max-runs 3 lets validation go on (and the
    # run 2 mistake below is then found instead)
    text = 'base = "base.toml"\n[vary]\n"model.winkler" = [3e6, 6e6, -1.0]\n'
    line, _ = _refused(tmp_path, capsys, text, ["--max-runs", "2"])
    assert "makes 3 runs (3): more than the limit of 2" in line
    line, _ = _refused(tmp_path, capsys, text, ["--max-runs", "3"])
    assert "run 2 (model.winkler = -1.0)" in line
