"""The worked example of a user's own specimen (``examples/own_mesh/``): its gmsh script makes
the mesh it ships, and its scene runs as a user runs it, the crack running from the notch's tip
straight across the plate."""

import runpy
import subprocess
import sys

import h5py
import numpy as np

from fem3d.specimens.gmsh_tools import from_file
from tests.helpers import ROOT

EXAMPLE = ROOT / "examples" / "own_mesh"


def test_the_script_makes_the_shipped_mesh(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(EXAMPLE / "notched_plate.py"), run_name="__main__")
    made, shipped = from_file(tmp_path / "notched_plate.msh"), from_file(EXAMPLE / "notched_plate.msh")
    assert np.array_equal(made.cells, shipped.cells)
    np.testing.assert_allclose(made.points, shipped.points, rtol=0, atol=1e-12)   # ASCII: 16 digits
    assert sorted(shipped.facet_groups) == ["bottom", "top"] and list(shipped.cell_groups) == ["plate"]


def test_the_scene_runs_and_cracks_from_the_notch(tmp_path):
    done = subprocess.run([sys.executable, "-m", "thinfilm", "run", str(EXAMPLE / "notched_plate.toml"), "--out",
                           str(tmp_path), "--quiet", "--set", "load.steps=10"], cwd=ROOT, capture_output=True,
                          text=True)
    assert done.returncode == 0, done.stderr
    with h5py.File(tmp_path / "results.h5") as f:
        points, alpha, force = f["mesh/points"][()], f["fields/alpha"][-1], f["steps/force"][()]
        assert f["parameters"].attrs["h"] < 0.06   # measured in the file: 0.05 mm in the band
    broken = points[alpha >= 0.9]
    # a straight crack along y = 5 mm from the notch's tip (x = 2 mm) to the far edge
    assert broken[:, 0].min() < 2.3 and broken[:, 0].max() > 9.9
    assert np.all(np.abs(broken[:, 1] - 5.0) < 0.4)
    assert force.max() > 50.0 and force[-1] < 0.01 * force.max()   # carried, then cut through
    for name in ("force_displacement.png", "alpha_snapshots.png", "results.xdmf"):
        assert (tmp_path / name).stat().st_size > 0
