"""The specimen registry of :mod:`fem3d.specimens`: every record is consistent with its mesh
function and the scene reference, and a specimen defined here, registered by one line, runs a
scene end to end."""

from __future__ import annotations

import inspect
import json
import re

import numpy as np
import pytest

from fem3d import specimens
from fem3d.mesh import Mesh
from fem3d.specimens.checks import check_positive, check_sizes
from fem3d.specimens.gmsh_tools import box_field, physical, polygon, read_model, session
from fem3d.specimens.specimen import Groups, Specimen, number
from tests.helpers import ROOT
from thinfilm.scene import SceneError, parse_scene

# --- a specimen of one's own: a rectangle with a slit from its left side ------------------------

WIDTH = 4.0
NOTCH = 1.0


def notched_rectangle(h, h_coarse, width=WIDTH, notch=NOTCH) -> Mesh:
    """A ``width`` x 2 rectangle, a slit ``notch`` long and 0.1 wide from the middle of its left
    side; boundaries ``"bottom"`` (y = 0) and ``"top"`` (y = 2), refined along the ligament."""
    h, h_coarse, _ = check_sizes(h, h_coarse, 1.0)
    width, notch = check_positive("width", width), check_positive("notch", notch)
    outline = [(0.0, 0.0), (width, 0.0), (width, 2.0), (0.0, 2.0), (0.0, 1.05), (notch, 1.05), (notch, 0.95),
               (0.0, 0.95)]
    with session("notched_rectangle") as gmsh:
        polygon(gmsh.model.geo, outline)
        gmsh.model.geo.synchronize()
        z = (0.0, 0.0)
        physical(gmsh, 1, "bottom", (0.0, width), (0.0, 0.0), z, 1e-9)
        physical(gmsh, 1, "top", (0.0, width), (2.0, 2.0), z, 1e-9)
        box_field(gmsh, h, h_coarse, (notch, width, 0.5, 1.5), z, 1.0, 1.0)
        gmsh.model.mesh.generate(2)
        return read_model(gmsh, "notched_rectangle")


SPECIMEN = Specimen(name="notched_rectangle", dims=(2,), mesh=notched_rectangle,
                    keys=(number("width", WIDTH, "the rectangle's width"), number("notch", NOTCH, "the slit's length")),
                    groups=Groups(facets=("bottom", "top")), doc="a rectangle with a slit")

specimens.register(SPECIMEN)   # the one line that makes it known

SCENE = """\
[model]
kind = "fem"
dim = 2
E = 1.0
nu = 0.3
Gc = 1.0
eps = 0.4
[geometry]
kind = "notched_rectangle"
width = 3.0
[mesh]
h = 0.2
h_coarse = 0.5
[load]
t = [0.0, 0.5, 1.0]
fixed = ["bottom"]
[load.displacement.top]
y = 1.0
"""


def test_a_registered_specimen_runs_a_scene(tmp_path):
    from thinfilm.run import run

    scene = parse_scene(SCENE, source="x.toml")
    assert scene.geometry.kind == "notched_rectangle" and dict(scene.geometry.options) == {"width": 3.0}
    out = run(scene, tmp_path)
    summary = json.loads(out["summary"].read_text())
    assert (tmp_path / "results.h5").is_file()
    force = summary["steps"]["force"]
    assert len(force) == 3 and force[0] == 0.0 and force[1] > 0.0


def test_a_registered_specimen_is_checked_like_the_others():
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE.replace("width = 3.0", "width = -3.0"), source="x.toml")
    assert "geometry.width = -3.0: must be a positive number" in str(err.value)
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE.replace("width = 3.0", "depth = 3.0"), source="x.toml")
    assert 'geometry.depth = 3.0: is not a key of geometry.kind = "notched_rectangle" (its keys: width, notch)' in str(
        err.value)
    with pytest.raises(SceneError) as err:
        parse_scene(SCENE.replace("dim = 2", "dim = 3"), source="x.toml")
    assert 'geometry.kind = "notched_rectangle": is a 2D geometry' in str(err.value)


# --- every record ------------------------------------------------------------------------------

@pytest.mark.parametrize("name", specimens.names())
def test_every_record_is_consistent(name):
    record = specimens.get(name)
    assert record.name == name and specimens.get(name) is record
    assert record.dims and set(record.dims) <= {2, 3}
    names = [key.name for key in record.keys]
    arguments = [key.argument for key in record.keys]
    assert len(set(names)) == len(names) and len(set(arguments)) == len(arguments)
    for key in record.keys:
        assert set(key.dims) & set(record.dims), key.name
        assert key.doc, key.name
        if key.default is None:    # a file (required), or a value the function derives
            assert key.file or "default" in key.doc, key.name
        else:
            assert key.accepts(key.default), key.name
    # the mesh function accepts exactly the declared keys, with the record's defaults
    parameters = inspect.signature(record.mesh).parameters
    fixed = ({"h", "h_coarse"} if record.sized else set()) | ({"dim"} if record.takes_dim else set())
    assert fixed <= set(parameters)
    assert set(arguments) <= set(parameters), set(arguments) - set(parameters)
    undeclared = set(parameters) - set(arguments) - fixed
    # besides the declared keys only keyword-only tuning (the grading) that no scene sets
    assert all(parameters[p].kind == inspect.Parameter.KEYWORD_ONLY for p in undeclared), undeclared
    for key in record.keys:
        p = parameters[key.argument]
        if not key.file:
            assert p.default == key.default, key.name
    for part in (record.front.width, record.front.start):
        if part is not None:
            assert part in names
    groups = record.groups.cells + record.groups.facets + record.groups.nodes
    assert len(set(groups)) == len(groups)


SMALL = {"lpanel": [(2, 20.0, 50.0, {}), (3, 25.0, 50.0, {})], "three_point_bending": [(2, 0.2, 0.25, {})],
         "nooru_mohamed": [(2, 5.0, 10.0, {}), (2, 5.0, 10.0, {"symmetry": "half_turn"})],
         "brokenshire": [(3, 12.5, 25.0, {})],
         "double_torsion": [(3, 1.5, 1.5, {"crack": 20.0, "buffer": 1.0})]}


@pytest.mark.parametrize("name", list(SMALL))
def test_every_built_in_mesh_has_its_declared_groups(name):
    record = specimens.get(name)
    for dim, h, h_coarse, options in SMALL[name]:
        mesh = record.make(dim, h, h_coarse, options)
        assert mesh.dim == dim
        assert sorted(mesh.cell_groups) == sorted(record.groups.cells)
        assert sorted(mesh.facet_groups) == sorted(record.groups.facets)
        assert sorted(mesh.node_groups) == sorted(record.groups.nodes)


def test_the_crack_fronts():
    # 2D: the slab's thickness; 3D: the record's keys, their defaults, or the mesh's extent
    get = specimens.get
    assert get("lpanel").crack_front(2, 100.0, ()) == (100.0, 0.0)
    assert get("lpanel").crack_front(3, 1.0, ()) == (100.0, 0.0)
    assert get("lpanel").crack_front(3, 1.0, (("thickness", 40.0),)) == (40.0, 0.0)
    assert get("double_torsion").crack_front(3, 1.0, (("notch", 10.0),)) == (3.0, 10.0)
    assert get("brokenshire").crack_front(3, 1.0, ()) == ("none", 0.0)
    assert get("file").crack_front(3, 1.0, (("path", "x.msh"),)) == ("mesh", 0.0)
    assert get("file").crack_front(2, 5.0, (("path", "x.msh"),)) == (5.0, 0.0)


def test_unknown_specimens_are_refused():
    with pytest.raises(KeyError, match="unknown specimen 'beam'"):
        specimens.get("beam")


def test_the_scene_reference_lists_every_key():
    text = (ROOT / "docs" / "scenes.md").read_text(encoding="utf-8")
    m = re.search(r"<!-- geometry-keys -->\n(.*?)\n<!-- /geometry-keys -->", text, re.S)
    assert m is not None, "docs/scenes.md has no <!-- geometry-keys --> table"
    assert m.group(1).strip() == specimens.reference().strip(), (
        "docs/scenes.md's [geometry] table differs from the specimens' records; paste the output of"
        " python -c 'from fem3d.specimens import reference; print(reference())'")


def test_a_mesh_file_is_read_as_it_is(tmp_path):
    # kind = "file": the .msh named relative to the scene, read as written whatever the declared sizes
    import gmsh

    from fem3d.kind import build_mesh, crack_front
    from thinfilm.scene import load_scene

    gmsh.initialize(readConfigFiles=False, interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("square")
        gmsh.model.occ.addRectangle(0.0, 0.0, 0.0, 1.0, 1.0)
        gmsh.model.occ.synchronize()
        gmsh.model.addPhysicalGroup(2, [1], name="solid")
        gmsh.model.addPhysicalGroup(1, [1], name="bottom")
        gmsh.model.addPhysicalGroup(1, [3], name="top")
        gmsh.option.setNumber("Mesh.MeshSizeMax", 0.5)
        gmsh.model.mesh.generate(2)
        gmsh.write(str(tmp_path / "square.msh"))
    finally:
        gmsh.finalize()
    text = SCENE.replace('kind = "notched_rectangle"\nwidth = 3.0', 'kind = "file"\nfile = "square.msh"')
    (tmp_path / "scene.toml").write_text(text)
    scene = load_scene(tmp_path / "scene.toml")
    assert scene.geometry.file == str(tmp_path / "square.msh")
    a = build_mesh(scene)
    # (a declared h must agree with the file's measured one within a factor 2: tests/fem3d/test_bad_input.py)
    b = build_mesh(load_scene(tmp_path / "scene.toml", overrides={"mesh.h": 0.15, "mesh.h_coarse": 0.3}))
    assert np.array_equal(a.points, b.points) and np.array_equal(a.cells, b.cells)
    assert list(a.cell_groups) == ["solid"] and sorted(a.facet_groups) == ["bottom", "top"]
    assert crack_front(scene) == (1.0, 0.0)
    with pytest.raises(SceneError) as err:
        build_mesh(load_scene(tmp_path / "scene.toml", overrides={"model.dim": 3}))
    assert "geometry.file = " in str(err.value) and "a 2D mesh, but model.dim = 3" in str(err.value)
    with pytest.raises(SceneError) as err:
        load_scene(tmp_path / "scene.toml", overrides={"geometry.file": "nothing.msh"})
    assert 'geometry.file = "nothing.msh": must be the path of a file; there is no such file' in str(err.value)
