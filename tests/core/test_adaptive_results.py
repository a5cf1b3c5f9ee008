"""Results of runs whose mesh is refined as they go (``docs/results.md#meshes-that-change-during-a-run``):
nested meshes made by hand (``tests/adaptive_meshes.py``) written through the results writer
step by step; every step read back on its own mesh, by the reader, the resumed run's history,
VTK's XDMF reader (the one ParaView uses), the figures and ``thinfilm info``; a backtrack, a
trim and a kill in the middle of a step that adds a mesh."""

import os
import subprocess
import sys
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.adaptive_meshes import (OBSERVABLES, bisect, extends, linear, open_writer, scene, square_meshes,
                                   step_values, tetrahedra_meshes, write_run)
from tests.helpers import ROOT
from thinfilm.cli import main
from thinfilm.discretization import Refinement, SimplexMesh, prolong
from thinfilm.results.reader import Results, finished_steps, open_committed
from thinfilm.results.writer import ResultsWriter, ResumeError

#: The versions of the steps of the 2D run: version 2 is never a step's (stored with 3).
VERSIONS = [0, 0, 1, 1, 3, 3]


@pytest.fixture
def square_run(tmp_path):
    """A 2D run of six steps on versions :data:`VERSIONS`: its path, meshes and fields."""
    meshes = square_meshes()
    path = tmp_path / "results.h5"
    writer = open_writer(path, meshes)
    written = write_run(writer, meshes, VERSIONS)
    writer.close()
    return path, meshes, written


# --- prolongation ---------------------------------------------------------------------------------
@pytest.mark.parametrize("make", [square_meshes, tetrahedra_meshes])
@pytest.mark.parametrize("components", [1, 2])
def test_prolongation_is_exact_on_linear_fields(make, components):
    meshes = make()
    last = meshes[-1]
    for mesh in meshes:
        coarse = linear(mesh.points, components)
        fine = prolong(coarse, last.refinement, mesh.n_nodes, components)
        np.testing.assert_allclose(fine, linear(last.points, components), rtol=0, atol=1e-14)
        np.testing.assert_array_equal(fine[: coarse.size], coarse)


def test_prolongation_is_the_sequential_loop_bit_for_bit():
    meshes = square_meshes()
    refinement = meshes[-1].refinement
    rng = np.random.default_rng(7)
    for components in (1, 3):
        for mesh in meshes[:-1]:
            values = rng.standard_normal(mesh.n_nodes * components) * np.exp(rng.uniform(-20, 20, mesh.n_nodes
                                                                                         * components))
            # subnormal values, where 0.5 * a + 0.5 * b is not 0.5 * (a + b)
            values[::3] = rng.integers(1, 4, values[::3].size) * 5e-324
            expected = np.empty(refinement.n_nodes * components)
            expected[: values.size] = values
            for i in range(mesh.n_nodes, refinement.n_nodes):
                a, b = refinement.parents[i]
                for c in range(components):
                    expected[i * components + c] = 0.5 * (expected[a * components + c] + expected[b * components + c])
            got = prolong(values, refinement, mesh.n_nodes, components)
            assert got.dtype == np.float64 and got is not values
            np.testing.assert_array_equal(got, expected)


def test_prolongation_refuses_a_mesh_not_in_the_refinement():
    refinement = square_meshes()[-1].refinement
    assert refinement.passes == 3 and refinement.pass_nodes.tolist() == [4, 5, 7, 9]
    with pytest.raises(ValueError, match="n_from = 6: not a mesh of the refinement"):
        prolong(np.zeros(6), refinement, 6)
    with pytest.raises(ValueError, match="5 values"):
        prolong(np.zeros(5), refinement, 7)


def test_a_refinement_is_checked_when_made():
    first = Refinement.initial(4)
    assert first.passes == 0 and first.n_nodes == 4 and first.parents.tolist() == [[-1, -1]] * 4
    with pytest.raises(ValueError, match="a refinement of 1 passes needs 2 entries in pass_nodes"):
        Refinement(np.full((5, 2), -1), [5], (np.array([0]),))
    with pytest.raises(ValueError, match="must be non-decreasing and end at the 5 rows of parents"):
        Refinement(np.full((5, 2), -1), [4, 6], (np.array([0]),))
    assert SimplexMesh(np.zeros((4, 2)), np.zeros((1, 3), dtype=int)).version == 0


def test_the_hand_made_meshes_are_nested_and_conforming():
    for meshes in (square_meshes(), tetrahedra_meshes()):
        for coarse, fine in zip(meshes, meshes[1:]):
            assert extends(fine.refinement, coarse.refinement) and not extends(coarse.refinement, fine.refinement)
            np.testing.assert_array_equal(fine.points[: coarse.n_nodes], coarse.points)
        last = meshes[-1]
        # conforming: every interior facet in exactly two cells, the total measure kept
        d = last.dim
        measure = [abs(np.linalg.det(m.points[m.cells[:, 1:]] - m.points[m.cells[:, :1]])) for m in meshes]
        for m in measure[1:]:
            assert m.sum() == pytest.approx(measure[0].sum(), rel=1e-14)
        facets = np.sort(np.concatenate([np.delete(last.cells, j, axis=1) for j in range(d + 1)]), axis=1)
        _, counts = np.unique(facets, axis=0, return_counts=True)
        assert set(counts.tolist()) <= {1, 2}


# --- the file, written and read back --------------------------------------------------------------
def test_each_step_reads_back_on_its_own_mesh(square_run):
    path, meshes, written = square_run
    with h5py.File(path, "r") as f:
        assert f["steps/mesh"][()].tolist() == VERSIONS
        assert f["meshes/pass_nodes"][()].tolist() == [4, 5, 7, 9]
        assert sorted(name for name in f["meshes"] if name.startswith("cells_")) == ["cells_0", "cells_1", "cells_3"]
        np.testing.assert_array_equal(f["mesh/points"][()], meshes[0].points)     # /mesh: the first mesh
        np.testing.assert_array_equal(f["mesh/cells"][()], meshes[0].cells)
        np.testing.assert_array_equal(f["meshes/points"][()], meshes[-1].points)
        np.testing.assert_array_equal(f["meshes/parents"][()], meshes[-1].refinement.parents)
        assert f["meshes/marked"][()].tolist() == [0, 1, 0, 1, 4, 5]
        assert f["meshes/marked_offsets"][()].tolist() == [0, 2, 4, 6]
        assert f["fields/alpha"].shape == (6, 9) and f["fields/u"].shape == (6, 18)
        assert f["fields/alpha"].maxshape == (None, None)
        assert np.isnan(f["fields/alpha"][0, 4:]).all() and np.isnan(f["fields/u"][2, 10:]).all()
    with Results(path) as res:
        assert res.adaptive and res.n == 6
        assert res.discretization.n_nodes == 4 and res.discretization.refinement is None
        for k, (version, (u, alpha)) in enumerate(zip(VERSIONS, written)):
            mesh = meshes[version]
            assert res.mesh_version(k) == version
            d = res.discretization_at(k)
            np.testing.assert_array_equal(d.points, mesh.points)
            np.testing.assert_array_equal(d.cells, mesh.cells)
            assert extends(d.refinement, mesh.refinement) and extends(mesh.refinement, d.refinement)
            assert d.refinement.passes == version
            np.testing.assert_array_equal(res.nodal("alpha", k), alpha)
            np.testing.assert_array_equal(res.nodal("u", k), u)
            np.testing.assert_array_equal(res.field("u", k), u.reshape(-1, 2))
            np.testing.assert_array_equal(res.field("alpha", k), alpha)
        assert res.discretization_at(4) is res.discretization_at(5)   # read once per version


def test_a_resumed_run_gets_every_state_on_the_current_mesh(square_run):
    path, meshes, written = square_run
    writer = open_writer(path, meshes, resume=True)
    try:
        refinement = writer.stored_refinement()
        assert extends(refinement, meshes[3].refinement) and extends(meshes[3].refinement, refinement)
        assert [m.tolist() for m in refinement.marked] == [[0, 1], [0, 1], [4, 5]]
        states = writer.history(all_alpha=True)
    finally:
        writer.close()
    assert len(states) == 6 and all(s.alpha.size == 9 for s in states)
    for state, version, (u, alpha) in zip(states, VERSIONS, written):
        n = meshes[version].n_nodes
        np.testing.assert_array_equal(state.alpha, prolong(alpha, refinement, n))
        np.testing.assert_array_equal(state.alpha[:n], alpha)
    np.testing.assert_array_equal(states[-1].u, written[-1][0])
    assert all(s.u is None for s in states[:-1])
    # from a step on version 1 the displacement is carried to version 3 too
    states = _history_after(path, meshes, [0, 1])
    n = meshes[1].n_nodes
    u = step_values(meshes[1], 1)[0]
    np.testing.assert_array_equal(states[-1].u, prolong(u, meshes[3].refinement, n, components=2))
    assert states[-1].u.size == 18


def _history_after(path, meshes, versions):
    """A backtrack to step ``len(versions) - 1`` rewritten on its version: the history then."""
    writer = open_writer(path, meshes, resume=True)
    try:
        write_run(writer, meshes, versions[-1:], start=len(versions) - 1)
        return writer.history(all_alpha=False)
    finally:
        writer.close()


def test_a_backtrack_truncates_the_steps_and_keeps_the_meshes(square_run):
    path, meshes, written = square_run
    writer = open_writer(path, meshes, resume=True)
    again = write_run(writer, meshes, [3], start=2)      # back to step 2, now on the current mesh
    with Results(path) as res:                            # what is committed
        assert res.n == 3 and res.steps["mesh"].tolist() == [0, 0, 3]
        np.testing.assert_array_equal(res.nodal("alpha", 1), written[1][1])
        np.testing.assert_array_equal(res.nodal("alpha", 2), again[0][1])
    later = write_run(writer, meshes, [3, 3], start=3)
    writer.close()
    with h5py.File(path, "r") as f:
        assert all(ds.shape[0] == 5 for ds in f["steps"].values())
        assert f["meshes/pass_nodes"].shape == (4,) and "cells_1" in f["meshes"]
    with Results(path) as res:
        assert res.steps["mesh"].tolist() == [0, 0, 3, 3, 3]
        for k, (u, alpha) in zip((3, 4), later):
            np.testing.assert_array_equal(res.nodal("u", k), u)
            np.testing.assert_array_equal(res.nodal("alpha", k), alpha)
    # the current mesh is the largest stored, even when the last step is on an earlier one
    states = _history_after(path, meshes, [0, 1])
    assert [s.alpha.size if s.alpha is not None else None for s in states] == [None, 9]


def test_trim_cuts_the_versions_of_unfinished_steps(square_run):
    path, meshes, _ = square_run
    writer = open_writer(path, meshes, resume=True)
    try:
        for name in ("steps/mesh", "fields/alpha", "fields/u"):   # a write cut after these
            ds = writer.file[name]
            ds.resize(7, axis=0)
        assert finished_steps(writer.file) == 6
        assert writer.trim() == 6
        assert writer.file["steps/mesh"].shape == (6,) and writer.file["fields/u"].shape == (6, 18)
    finally:
        writer.close()


def test_a_mesh_whose_refinement_does_not_extend_the_stored_one_is_refused(square_run, tmp_path):
    path, meshes, _ = square_run
    other = bisect(meshes[1], [(2, 3)])                   # another second pass
    writer = open_writer(path, meshes, resume=True)
    try:
        u, alpha = step_values(other, 6)
        from thinfilm.engine.records import State, StepRecord

        with pytest.raises(ValueError, match="does not extend the stored one"):
            writer.write_step(StepRecord(6, 0.6), State(0.6, u, alpha, 0.0, 0.0), {"force": 0.0,
                                                                                    "displacement": 0.6}, mesh=other)
        with pytest.raises(ValueError, match="alpha has 4 values, its mesh"):
            writer.write_step(StepRecord(6, 0.6), State(0.6, np.zeros(18), np.zeros(4), 0.0, 0.0),
                              {"force": 0.0, "displacement": 0.6}, mesh=meshes[3])
    finally:
        writer.journaled.failed = True                    # the refused steps are not committed
        writer.close()
    with Results(path) as res:
        assert res.n == 6
    # the file's kind of mesh is the scene's
    with pytest.raises(ResumeError, match="was written on a mesh refined during the run"):
        from fem3d.kind import KIND

        fem = scene(2)
        ResultsWriter(path, fem, KIND.parameters(fem), SimplexMesh(meshes[0].points, meshes[0].cells),
                      components={"u": 2}, observables=OBSERVABLES, resume=True)


def test_a_mesh_that_is_not_refined_is_written_as_before(tmp_path):
    from fem3d.kind import KIND

    mesh = square_meshes()[0]
    fixed = SimplexMesh(mesh.points, mesh.cells)
    fem = scene(2)
    path = tmp_path / "results.h5"
    writer = ResultsWriter(path, fem, KIND.parameters(fem), fixed, components={"u": 2}, observables=OBSERVABLES)
    write_run(writer, [fixed], [0, 0])
    assert writer.stored_refinement() is None
    writer.close()
    with h5py.File(path, "r") as f:
        assert "meshes" not in f and "mesh" not in f["steps"]
        assert f["fields/alpha"].maxshape == (None, 4) and f["fields/u"].chunks == (1, 8)
    with Results(path) as res:
        assert not res.adaptive and res.mesh_version(1) == 0 and res.discretization_at(1) is res.discretization
        assert res.discretization_at(1).refinement is None


# --- a kill in the middle of a step that adds a mesh ----------------------------------------------
_KILLED = """
import shutil, sys
from tests.adaptive_meshes import open_writer, square_meshes, write_run
from thinfilm.results import journal
path, kill = sys.argv[1], int(sys.argv[2])
meshes = square_meshes()
writer = open_writer(path, meshes)
write_run(writer, meshes, [0, 0, 1])
shutil.copyfile(path, path + ".committed")
before = journal.io_events()
journal.kill_at_event(before + kill if kill else 0)
write_run(writer, meshes, [3], start=3)            # adds versions 2 and 3
print(journal.io_events() - before)
writer.close()
"""


def _killed(path, kill):
    return subprocess.run([sys.executable, "-c", _KILLED, str(path), str(kill)], cwd=ROOT, capture_output=True,
                          text=True, env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)


def test_a_kill_in_a_step_that_adds_a_mesh_returns_to_the_step_before(tmp_path):
    from thinfilm.results.journal import journal_path, recover

    done = _killed(tmp_path / "whole.h5", 0)
    assert done.returncode == 0, done.stderr
    events = int(done.stdout.split()[-1])
    assert events > 3
    meshes = square_meshes()
    for kill in sorted({1, events // 3, 2 * events // 3, events - 1}):
        path = tmp_path / f"killed_{kill}.h5"
        killed = _killed(path, kill)
        assert killed.returncode == -9, (kill, killed.stderr)
        committed = Path(str(path) + ".committed").read_bytes()
        with open_committed(path) as f:                   # read through the journal
            assert finished_steps(f) == 3 and f["meshes/pass_nodes"][()].tolist() == [4, 5]
            assert "cells_3" not in f["meshes"]
        if journal_path(path).exists():
            assert recover(path)
        assert path.read_bytes() == committed, kill
    # the last one resumed: the step that adds the mesh written again
    writer = open_writer(path, meshes, resume=True)
    u, alpha = write_run(writer, meshes, [3], start=3)[0]
    writer.close()
    with Results(path) as res:
        assert res.n == 4 and res.mesh_version(3) == 3
        np.testing.assert_array_equal(res.nodal("alpha", 3), alpha)
        np.testing.assert_array_equal(res.discretization_at(3).cells, meshes[3].cells)


# --- ParaView, the figures, thinfilm info ---------------------------------------------------------
@pytest.mark.parametrize("make, versions", [(square_meshes, VERSIONS), (tetrahedra_meshes, [0, 1, 2, 2])])
def test_the_xdmf_gives_each_step_its_mesh_in_vtk(tmp_path, make, versions):
    vtk_xdmf = pytest.importorskip("vtkmodules.vtkIOXdmf2")
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline

    from thinfilm.xdmf import write_xdmf

    meshes = make()
    path = tmp_path / "results.h5"
    writer = open_writer(path, meshes)
    written = write_run(writer, meshes, versions)
    writer.close()
    xdmf = write_xdmf(path)
    reader = vtk_xdmf.vtkXdmfReader()
    reader.SetFileName(str(xdmf))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    np.testing.assert_array_equal(times, [0.1 * k for k in range(len(versions))])
    dim = meshes[0].dim
    for k, (version, (u, alpha)) in enumerate(zip(versions, written)):
        mesh = meshes[version]
        reader.UpdateTimeStep(times[k])
        grid = reader.GetOutputDataObject(0)
        if grid.IsA("vtkMultiBlockDataSet"):
            grid = grid.GetBlock(0)
        assert grid.GetNumberOfPoints() == mesh.n_nodes and grid.GetNumberOfCells() == len(mesh.cells), k
        read = np.array([grid.GetPoint(i) for i in range(grid.GetNumberOfPoints())])
        np.testing.assert_array_equal(read[:, :dim], mesh.points)
        cells = np.array([[grid.GetCell(c).GetPointId(j) for j in range(dim + 1)] for c in range(len(mesh.cells))])
        np.testing.assert_array_equal(cells, mesh.cells)
        np.testing.assert_array_equal(vtk_to_numpy(grid.GetPointData().GetArray("alpha")), alpha)
        np.testing.assert_array_equal(vtk_to_numpy(grid.GetPointData().GetArray("u"))[:, :dim], u.reshape(-1, dim))


def test_plot_and_info_of_a_refined_2d_run(square_run, tmp_path, capsys):
    path, _, _ = square_run
    out = tmp_path / "figures"
    assert main(["plot", str(path), "--out", str(out), "--animate", "--t", "0.1", "0.3", "0.5"]) == 0
    for name in ("alpha_snapshots.png", "alpha.png", "alpha.gif", "energy.png", "results.xdmf"):
        assert (out / name).stat().st_size > 0, name
    capsys.readouterr()
    assert main(["info", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "mesh: 2D, 4 nodes, 2 triangles" in lines
    assert ("mesh: adaptive, 4 versions, 4 -> 9 nodes; the last finished step on version 3 (9 nodes, 8 triangles)"
            in lines)


def test_the_figures_of_a_refined_3d_run_draw_its_last_mesh(tmp_path):
    from fem3d.plots import slice_polygons
    from thinfilm.plots import plot_run

    meshes = tetrahedra_meshes()
    path = tmp_path / "results.h5"
    writer = open_writer(path, meshes)
    write_run(writer, meshes, [0, 1, 2])
    writer.close()
    paths = plot_run(path, tmp_path / "figures")
    assert {"crack_surface.png", "alpha_slices.png"} <= {p.name for p in paths}
    with Results(path) as res:                 # the slices of the last step cut its own tetrahedra
        d = res.discretization_at(2)
        polygons, _ = slice_polygons(d.points, d.cells, res.field("alpha", 2), 2, 0.5)
        assert len(d.cells) == 6 and len(polygons) > 2
