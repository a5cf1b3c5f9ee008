"""``thinfilm plot`` and ``thinfilm info`` from a results file alone, and the XDMF index.

Two small plate runs are made once per module through the command line: a 1D film like
``cases/fig2_5.toml`` (200 cells, 20 steps; backtracking, no nucleation search, to stay fast)
and a 40 x 8 strip.
"""

import json
import re
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.plots import snapshot_steps

from tests.helpers import CASES

#: The runs inspected: case files with overrides (``thinfilm run CASE --set KEY=VALUE``).
#: A 1D film (Fig. 2.5's, coarser, without the search), a 2D strip (Fig. 2.7's strip at
#: lam = 10, small), and the exact 0.5 film of Fig. 2.15 (fewer steps and cells).
FILM_1D = ("fig2_5", {"domain.cells": 200, "load.steps": 20, "solver.search": False})
STRIP_2D = ("fig2_7", {"model.lam": 10.0, "model.eta_dx": 2, "domain.x": [-0.25, 0.25], "domain.y": [-0.05, 0.05],
                       "domain.cells": [40, 8], "load.t_max": 3.0, "load.steps": 20, "solver.backtrack": "none",
                       "solver.acceleration": "none"})
EXACT = ("fig2_15", {"load.steps": 30, "grid.cells": 200})


PNG = b"\x89PNG\r\n\x1a\n"
FIGURES = ("energy.png", "cracks.png", "alpha.png", "alpha_snapshots.png", "u_snapshots.png", "iterations.png")


def _run(root, name, case):
    stem, overrides = case
    out = root / name
    settings = [f"--set={key}={json.dumps(value)}" for key, value in overrides.items()]
    assert main(["run", str(CASES / f"{stem}.toml"), "--out", str(out), "--quiet"] + settings) == 0
    return out / "results.h5"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    return {"1d": _run(root, "film", FILM_1D), "2d": _run(root, "strip", STRIP_2D)}


@pytest.fixture(scope="module")
def truncated(runs, tmp_path_factory):
    """The strip's file as a run killed during step 7 leaves it: /steps/t and the fields
    already hold row 7, the other step records do not (io.py writes them in turn)."""
    path = tmp_path_factory.mktemp("killed") / "results.h5"
    shutil.copy(runs["2d"], path)
    with h5py.File(path, "r+") as f:
        for name, ds in f["steps"].items():
            ds.resize((8 if name == "t" else 7,))
        for ds in f["fields"].values():
            ds.resize((8, ds.shape[1]))
    return path


def _is_png(path):
    return path.is_file() and path.stat().st_size > 1000 and path.read_bytes()[:8] == PNG


def _last(path):
    with h5py.File(path) as f:
        n = min(len(ds) for ds in f["steps"].values())
        return n, {name: f["steps"][name][n - 1] for name in ("t", "elastic", "surface", "total")}


def _info(capsys, path):
    capsys.readouterr()
    assert main(["info", str(path)]) == 0
    captured = capsys.readouterr()
    assert captured.err == ""
    return captured.out


def _printed(out, name):
    return float(re.search(rf"^\s*{name}\s*=\s*(\S+)$", out, re.M).group(1))


# -- plot --------------------------------------------------------------------------------
def test_run_leaves_every_figure_and_the_xdmf(runs):
    for results in runs.values():
        for name in FIGURES:
            assert _is_png(results.parent / name), name
        assert (results.parent / "results.xdmf").is_file()


def test_plot_truncated_run_at_chosen_loads_with_animation(truncated, tmp_path, capsys):
    # A run killed during step 7 (7 finished steps, t <= 0.9): every figure is drawn from
    # what is there; a load past the last finished step shows that step.
    out = tmp_path / "figures"
    assert main(["plot", str(truncated.parent), "--t", "0.3", "0.9", "3", "--out", str(out), "--animate"]) == 0
    assert capsys.readouterr().out.startswith("wrote ")
    for name in FIGURES:
        assert _is_png(out / name), name
    gif = out / "alpha.gif"
    assert gif.read_bytes()[:6] == b"GIF89a"
    from PIL import Image

    with Image.open(gif) as image:
        assert image.n_frames == 7  # the finished steps, not the 8 rows of /steps/t

    # The index written elsewhere finds the fields by a relative path, for the 7 steps.
    root = ET.parse(out / "results.xdmf").getroot()
    assert len(root.findall(".//Grid[@GridType='Uniform']")) == 7
    source = root.find(".//DataItem[@Format='HDF']").text
    assert (out / source.split(":")[0]).resolve() == truncated.resolve()

    text = _info(capsys, truncated)
    assert "steps finished: 7 of 21" in text and "stopped early" in text
    n, last = _last(truncated)
    assert n == 7 and _printed(text, "total") == pytest.approx(last["total"], rel=1e-11)


def test_snapshot_and_frame_selection():
    t = np.linspace(0.0, 3.0, 21)
    assert list(snapshot_steps(t)) == [0, 5, 10, 15, 20]  # 5 loads, evenly spread
    assert list(snapshot_steps(t[:3])) == [0, 1, 2]  # fewer finished steps than snapshots
    assert list(snapshot_steps(t, [1.5, 1.52, 0.0, 99.0])) == [0, 10, 20]  # nearest, once, sorted
    frames = snapshot_steps(np.linspace(0.0, 1.0, 250), count=100)  # alpha.gif of a long run
    assert len(frames) == 100 and frames[0] == 0 and frames[-1] == 249


# -- info --------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", ["1d", "2d"])
def test_info_reports_scene_progress_energies_and_timings(runs, dim, capsys):
    results = runs[dim]
    out = _info(capsys, results)
    n, last = _last(results)
    assert n == 21 and "steps finished: 21 of 21" in out and "complete" in out
    for name in ("elastic", "surface", "total"):
        assert _printed(out, name) == pytest.approx(last[name], rel=1e-11), name
    assert re.search(r"last finished step: 20, t = 3$", out, re.M)
    stem, overrides = FILM_1D if dim == "1d" else STRIP_2D
    assert all(line.strip() in out for line in (CASES / f"{stem}.toml").read_text().strip().splitlines())
    assert f"overrides: {json.dumps(overrides, sort_keys=True)}" in out
    assert re.search(r"^versions: thinfilm \S+, numpy \S+, numba \S+, h5py \S+$", out, re.M)
    with h5py.File(results) as f:
        iterations = int(f["steps/iterations"][()].sum())
        u_solves = int(f["steps/u_solves"][()].sum())
    assert f"iterations    {iterations} alternate-minimization" in out
    assert f"({u_solves} solves," in out
    for label in ("wall time", "u-solves", "alpha-solves"):
        assert re.search(rf"^  {label}\s+[0-9.]+ s", out, re.M), label


def test_a_2d_run_measures_its_cracks_in_summary_info_and_figures(runs, capsys):
    from thinfilm.plate.crack_metrics import measure_step

    results = runs["2d"]
    for name in ("crack_metrics.png", "crack_pattern.png"):
        assert _is_png(results.parent / name), name
    summary = json.loads((results.parent / "summary.json").read_text())
    measured = summary["crack_metrics"]["measured"]
    assert [m["step"] for m in measured] == list(range(21))  # a small run: every step
    with h5py.File(results) as f:
        last = measure_step(f, 20)
        crack_length = f["steps/surface"][()] / f["parameters"].attrs["toughness"]
    assert measured[-1] == last.as_json()
    assert summary["steps"]["crack_length"] == pytest.approx(crack_length, rel=1e-14)
    assert [m["length_energy"] for m in measured] == pytest.approx(crack_length, rel=1e-12, abs=1e-14)
    text = _info(capsys, results)
    assert f"cracks at the last finished step (alpha >= 0.9): {last.describe()}" in text
    assert re.search(r"^  centre line y = 0: \d+ crossing\(s\) \(local maxima", text, re.M)


def test_exact1d_plot_and_info(tmp_path, capsys):
    results = _run(tmp_path, "exact", EXACT)
    out = tmp_path / "again"
    assert main(["plot", str(results), "--out", str(out)]) == 0
    assert _is_png(out / "energy.png") and _is_png(out / "cracks.png")
    text = _info(capsys, results)
    n, last = _last(results)
    assert "steps finished: 31 of 31" in text and "t = 0.68156753: 1 crack(s)" in text
    assert _printed(text, "total") == pytest.approx(last["total"], rel=1e-11)


# -- XDMF --------------------------------------------------------------------------------
@pytest.mark.parametrize("dim", ["1d", "2d"])
def test_xdmf_references_the_datasets(runs, dim):
    results = runs[dim]
    xdmf = results.with_suffix(".xdmf")
    root = ET.parse(xdmf).getroot()  # well-formed, or this raises
    assert root.tag == "Xdmf" and root.get("Version") == "3.0"
    collection = root.find("Domain/Grid")
    assert collection.get("GridType") == "Collection" and collection.get("CollectionType") == "Temporal"
    grids = collection.findall("Grid")
    with h5py.File(results) as f:
        t = f["steps/t"][()]
        nx = len(f["grid/x"]) - 1
        ny = len(f["grid/y"]) - 1 if dim == "2d" else 0
        x0 = f["grid/x"][0]
        assert len(grids) == len(t) == 21
        for k, grid in enumerate(grids):
            assert float(grid.find("Time").get("Value")) == t[k]
            topology = grid.find("Topology")
            assert topology.get("TopologyType") == "3DCoRectMesh"
            dims = [int(v) for v in topology.get("Dimensions").split()]
            assert dims == [1, ny + 1, nx + 1]
            origin, spacing = (np.array(item.text.split(), float) for item in grid.findall("Geometry/DataItem"))
            assert origin[2] == x0 and spacing[2] == pytest.approx(0.5 / nx, rel=1e-14)
            if dim == "2d":
                assert origin[1] == -0.05 and spacing[1] == pytest.approx(0.1 / ny, rel=1e-14)
            names = []
            for attribute in grid.findall("Attribute"):
                names.append(attribute.get("Name"))
                assert attribute.get("Center") == "Node"
                slab = attribute.find("DataItem")
                assert slab.get("ItemType") == "HyperSlab"
                selection, source = slab.findall("DataItem")
                start, stride, count = np.array(selection.text.split(), int).reshape(3, 2)
                file_name, dataset = source.text.strip().split(":")
                assert (xdmf.parent / file_name).resolve() == results.resolve()
                ds = f[dataset]
                assert dataset == f"/fields/{attribute.get('Name')}"
                assert [int(v) for v in source.get("Dimensions").split()] == list(ds.shape)
                assert [int(v) for v in slab.get("Dimensions").split()] == dims  # the row, shaped as the mesh
                assert list(start) == [k, 0] and list(stride) == [1, 1]
                assert np.all(start + (count - 1) * stride < ds.shape)
                assert np.prod(count) == np.prod(dims)  # one value per node
                if k in (0, len(grids) - 1):  # the slab is the step's field, x fastest
                    values = ds[start[0]: start[0] + count[0], : count[1]]
                    np.testing.assert_array_equal(values.reshape(dims)[0], ds[k].reshape(ny + 1, nx + 1))
            assert names == ["alpha", "u"]


@pytest.mark.parametrize("dim", ["1d", "2d"])
def test_xdmf_reads_back_in_vtk(runs, dim):
    # ParaView's "XDMF Reader" is VTK's vtkXdmfReader. Skipped unless the vtk package is
    # installed (it is not a dependency of thinfilm).
    xdmf2 = pytest.importorskip("vtkmodules.vtkIOXdmf2")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

    results = runs[dim]
    reader = xdmf2.vtkXdmfReader()
    reader.SetFileName(str(results.with_suffix(".xdmf")))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    with h5py.File(results) as f:
        np.testing.assert_array_equal(times, f["steps/t"][()])
        x = f["grid/x"][()]
        y = f["grid/y"][()] if dim == "2d" else np.zeros(1)
        for k in (0, len(times) // 2, len(times) - 1):
            reader.UpdateTimeStep(times[k])
            image = reader.GetOutputDataObject(0)
            assert image.GetDimensions() == (len(x), len(y), 1)
            for name in ("alpha", "u"):
                np.testing.assert_array_equal(vtk_to_numpy(image.GetPointData().GetArray(name)), f[f"fields/{name}"][k])
    points = np.array([image.GetPoint(i) for i in range(image.GetNumberOfPoints())])
    X, Y = np.meshgrid(x, y)  # x fastest, as the fields are stored
    np.testing.assert_allclose(points, np.column_stack([X.ravel(), Y.ravel(), np.zeros(X.size)]), atol=1e-12)


# -- bad input ---------------------------------------------------------------------------
@pytest.mark.parametrize("command", ["plot", "info"])
@pytest.mark.parametrize("case", ["missing", "text", "foreign_hdf5", "empty_dir"])
def test_bad_paths_exit_2_with_one_line(tmp_path, capsys, command, case):
    path = tmp_path / "results.h5"
    if case == "text":
        path.write_text("not hdf5\n")
    elif case == "foreign_hdf5":
        with h5py.File(path, "w") as f:
            f["x"] = np.arange(3)
    elif case == "empty_dir":
        path = tmp_path
    assert main([command, str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("thinfilm: error: ") and str(path) in lines[0]
    assert not list(Path(tmp_path).glob("*.png"))
