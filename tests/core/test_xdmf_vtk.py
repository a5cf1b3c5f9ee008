"""``results.xdmf`` of a finite-element run read back by VTK's XDMF reader, the one ParaView
uses: the mesh, the times and each step's fields equal those of ``results.h5``. (The grids'
files are read back in ``tests/core/test_inspect.py``.)"""

import h5py
import numpy as np
import pytest

from thinfilm.run import run

from tests.helpers import load_case

xdmf2 = pytest.importorskip("vtkmodules.vtkIOXdmf2")
from vtkmodules.util.numpy_support import vtk_to_numpy  # noqa: E402
from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline  # noqa: E402


@pytest.mark.parametrize("case, overrides, cell_size", [
    ("lpanel", {"model.eps": 25.0, "mesh.h": 12.5, "mesh.h_coarse": 50.0, "load.t": [0.0, 0.3, 0.5]}, 3),
    ("lpanel_3d", {"model.eps": 80.0, "mesh.h": 40.0, "mesh.h_coarse": 80.0, "load.t_max": 0.5, "load.steps": 2},
     4),
])
def test_a_mesh_run_reads_back_in_vtk(tmp_path, case, overrides, cell_size):
    scene = load_case(case, {**overrides, "output.snapshots": [0.5]})
    out = run(scene, tmp_path)
    reader = xdmf2.vtkXdmfReader()
    reader.SetFileName(str(tmp_path / "results.xdmf"))
    reader.UpdateInformation()
    times = reader.GetOutputInformation(0).Get(vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    with h5py.File(out["results"]) as f:
        np.testing.assert_array_equal(times, f["steps/t"][()])
        points, cells = f["mesh/points"][()], f["mesh/cells"][()]
        dim = points.shape[1]
        for k in (0, len(times) - 1):
            reader.UpdateTimeStep(times[k])
            grid = reader.GetOutputDataObject(0)
            if grid.IsA("vtkMultiBlockDataSet"):  # a temporal collection: the step's block
                grid = grid.GetBlock(0)
            assert grid.GetNumberOfPoints() == points.shape[0] and grid.GetNumberOfCells() == cells.shape[0]
            read = np.array([grid.GetPoint(i) for i in range(grid.GetNumberOfPoints())])
            np.testing.assert_array_equal(read[:, :dim], points)
            first = grid.GetCell(0)
            assert first.GetNumberOfPoints() == cell_size
            assert [first.GetPointId(j) for j in range(cell_size)] == cells[0].tolist()
            alpha = vtk_to_numpy(grid.GetPointData().GetArray("alpha"))
            np.testing.assert_array_equal(alpha, f["fields/alpha"][k])
            u = vtk_to_numpy(grid.GetPointData().GetArray("u"))
            n = points.shape[0]
            np.testing.assert_array_equal(u[:, :dim], f["fields/u"][k][: n * dim].reshape(n, dim))
