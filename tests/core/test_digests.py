"""The input files of a scene (a solid's mesh, a film's field file) are stored with the
results by their SHA-256: a resume whose files changed or are missing is refused in one line
naming the file and the scene key, before the results file is opened for writing (its bytes
stay as they were); a file written before the digests were stored resumes and gets them."""

import hashlib
import json

import gmsh
import h5py
import numpy as np
import pytest

from thinfilm.cli import main
from thinfilm.results.journal import journal_path

from tests.helpers import CASES


def write_rectangle(path, width=2.0, size=0.25):
    """A ``width`` x 1 rectangle meshed with triangles by gmsh, facet groups ``bottom`` (y = 0)
    and ``load`` (y = 1); another ``size`` gives another node count."""
    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("Mesh.MeshSizeMax", size)
        gmsh.model.add("rectangle")
        gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, width, 1.0)
        gmsh.model.occ.synchronize()

        def edges(y):
            return [t for _, t in gmsh.model.getEntitiesInBoundingBox(-1e-6, y - 1e-6, -1e-6, width + 1e-6,
                                                                       y + 1e-6, 1e-6, 1)]

        gmsh.model.addPhysicalGroup(2, [t for _, t in gmsh.model.getEntities(2)], name="solid")
        gmsh.model.addPhysicalGroup(1, edges(0.0), name="bottom")
        gmsh.model.addPhysicalGroup(1, edges(1.0), name="load")
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


def _solid(mesh):
    """The L-panel's case on a mesh file: its loads on the rectangle's groups, three steps."""
    return ["run", str(CASES / "lpanel.toml"), "--quiet", "--set", 'geometry.kind="file"',
            "--set", f"geometry.file={json.dumps(str(mesh))}", "--set", "model.undamaged=[]",
            "--set", "model.eps=0.5", "--set", "mesh.h=0.25", "--set", "load.t=[0.0, 0.0001, 0.0002]",
            "--set", "output.snapshots=[0.0001]"]


def _bytes(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def solid_run(tmp_path_factory):
    """A finished run on a mesh file: (its command, the mesh, the run directory)."""
    tmp = tmp_path_factory.mktemp("solid")
    mesh = tmp / "rectangle.msh"
    write_rectangle(mesh)
    args = _solid(mesh) + ["--out", str(tmp / "out")]
    assert main(args) == 0
    return args, mesh, tmp / "out"


def test_the_mesh_s_digest_is_stored(solid_run):
    _, mesh, out = solid_run
    with h5py.File(out / "results.h5", "r") as f:
        inputs = json.loads(f.attrs["inputs"])
    assert inputs == {"geometry.file": {"path": str(mesh), "sha256": _bytes(mesh)}}


@pytest.mark.parametrize("change", ["geometry", "nodes"])
def test_a_resume_on_a_changed_mesh_is_refused_naming_it(solid_run, tmp_path, capsys, change):
    """The same node count with another geometry (which used to append steps of another
    specimen), or another node count (which used to crash after changing results.h5): refused,
    exit status 2, one line naming geometry.file and the mesh, results.h5 untouched."""
    args, mesh, out = solid_run
    moved = tmp_path / "out"
    moved.mkdir()
    (moved / "results.h5").write_bytes((out / "results.h5").read_bytes())
    before = _bytes(moved / "results.h5")
    original = mesh.read_bytes()
    try:
        if change == "geometry":
            write_rectangle(mesh, width=2.5, size=0.3125)  # the same divisions: the same node count
        else:
            write_rectangle(mesh, size=0.2)
        assert mesh.read_bytes() != original
        status = main(args[:-1] + [str(moved), "--resume"])
    finally:
        mesh.write_bytes(original)
    err = capsys.readouterr().err.strip()
    assert status == 2
    assert "\n" not in err and "geometry.file" in err and str(mesh) in err and "Traceback" not in err, err
    assert "--force" in err
    assert _bytes(moved / "results.h5") == before and not journal_path(moved / "results.h5").exists()


def test_a_file_without_digests_resumes_and_gets_them(solid_run, tmp_path):
    args, mesh, out = solid_run
    moved = tmp_path / "out"
    moved.mkdir()
    (moved / "results.h5").write_bytes((out / "results.h5").read_bytes())
    with h5py.File(moved / "results.h5", "r+") as f:
        del f.attrs["inputs"]
    assert main(args[:-1] + [str(moved), "--resume"]) == 0
    with h5py.File(moved / "results.h5", "r") as f:
        assert json.loads(f.attrs["inputs"])["geometry.file"]["sha256"] == _bytes(mesh)


def test_a_resume_on_a_changed_field_file_is_refused(tmp_path, capsys):
    """A film under a ``"field"`` load: its file's digest is stored; another field is refused,
    naming load.file; the same file resumes."""
    field = tmp_path / "w.npz"
    x = np.linspace(-0.25, 0.25, 81)
    np.savez(field, w=x ** 2)
    args = ["run", str(CASES / "fig2_5.toml"), "--quiet", "--out", str(tmp_path / "out"),
            "--set", "domain.cells=80", "--set", "model.eta_dx=4", "--set", "load.steps=4",
            "--set", "solver.search=false", "--set", 'load.kind="field"', "--set",
            f"load.file={json.dumps(str(field))}"]
    assert main(args) == 0
    with h5py.File(tmp_path / "out" / "results.h5", "r") as f:
        assert json.loads(f.attrs["inputs"])["load.file"]["sha256"] == _bytes(field)
    assert main(args + ["--resume"]) == 0
    capsys.readouterr()
    before = _bytes(tmp_path / "out" / "results.h5")
    np.savez(field, w=2 * x ** 2)
    assert main(args + ["--resume"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "load.file" in err and str(field) in err, err
    assert _bytes(tmp_path / "out" / "results.h5") == before
