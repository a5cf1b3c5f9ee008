"""A corpus of bad finite-element input, each refused before anything is computed or
written: exit status 2, one stderr line naming the file and the problem, no traceback,
nothing made beside the scene, within seconds.

The meshes are written by hand in gmsh's format 2.2 (``$Nodes``: index and x y z;
``$Elements``: index, gmsh type, tags (physical, elementary), nodes): the unit square as four
triangles about its centre, with the lines "bottom" and "top" and the surface "plate".
"""

import time

import pytest

from thinfilm.cli import main

NODES = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5)]
TRIANGLES = [(1, 2, 5), (2, 3, 5), (3, 4, 5), (4, 1, 5)]
#: gmsh element types: 2-node line, 3-node triangle, 4-node quadrangle, 6-node triangle.
LINE, TRIANGLE, QUAD, TRIANGLE6 = 1, 2, 3, 9


def msh(nodes=NODES, cells=TRIANGLES, cell_type=TRIANGLE, bottom=((1, 2),), top=((3, 4),), extra_nodes=()):
    """A format-2.2 mesh text: the lines ``bottom`` and ``top`` (physical 1 and 2), ``cells``
    the surface "plate" (physical 3)."""
    nodes = list(nodes) + list(extra_nodes)
    out = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "3", '1 1 "bottom"', '1 2 "top"',
           '2 3 "plate"', "$EndPhysicalNames", "$Nodes", str(len(nodes))]
    out += [f"{i + 1} {p[0]} {p[1]} 0" for i, p in enumerate(nodes)]
    elements = ([(LINE, 1, line) for line in bottom] + [(LINE, 2, line) for line in top]
                + [(cell_type, 3, cell) for cell in cells])
    out += ["$EndNodes", "$Elements", str(len(elements))]
    out += [f"{i + 1} {t} 2 {phys} {phys} " + " ".join(map(str, nodes_)) for i, (t, phys, nodes_) in
            enumerate(elements)]
    out += ["$EndElements", ""]
    return "\n".join(out)


def grid_msh(n=8):
    """The unit square as ``n`` x ``n`` squares cut in two (element size sqrt(2)/n)."""
    def index(i, j):
        return j * (n + 1) + i + 1

    nodes = [(i / n, j / n) for j in range(n + 1) for i in range(n + 1)]
    cells = []
    for j in range(n):
        for i in range(n):
            cells += [(index(i, j), index(i + 1, j), index(i + 1, j + 1)),
                      (index(i, j), index(i + 1, j + 1), index(i, j + 1))]
    return msh(nodes, cells, bottom=[(index(i, 0), index(i + 1, 0)) for i in range(n)],
               top=[(index(i + 1, n), index(i, n)) for i in range(n)])


GOOD = grid_msh()
SCENE = """[model]
kind = "fem"
dim = 2
E = 1000.0
nu = 0.2
Gc = 0.01
eps = {eps}
thickness = 1.0
[geometry]
kind = "file"
file = "specimen.msh"
{mesh}
[load]
t_max = 0.01
steps = 2
fixed = ["bottom"]
[load.displacement.{group}]
y = 1.0
"""


def _refused(tmp_path, capsys, mesh_text, *, eps=0.1, mesh="", group="top", binary=None):
    scene = tmp_path / "specimen.toml"
    scene.write_text(SCENE.format(eps=eps, mesh=mesh, group=group))
    path = tmp_path / "specimen.msh"
    if binary is not None:
        path.write_bytes(binary)
    else:
        path.write_text(mesh_text)
    before = sorted(tmp_path.iterdir())
    start = time.perf_counter()
    status = main(["run", str(scene), "--quiet"])
    elapsed = time.perf_counter() - start
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert status == 2, captured.err
    assert len(lines) == 1 and "Traceback" not in captured.err, captured.err
    assert lines[0].startswith(f"thinfilm: error: {scene}: "), lines[0]
    assert sorted(tmp_path.iterdir()) == before
    assert elapsed < 10.0
    return lines[0]


BAD_MESHES = {
    "empty": ("", "geometry.file"),
    "garbage": ("this is not a mesh\n", "geometry.file"),
    "truncated": (msh()[: len(msh()) // 2], "geometry.file"),
    "node missing": (msh(cells=TRIANGLES[:3] + [(4, 1, 6)]), "geometry.file"),
    "nan coordinate": (msh(nodes=NODES[:2] + [(1.0, float("nan"))] + NODES[3:]), "not a finite number"),
    "line mesh": (msh(cells=()), "no triangles or tetrahedra"),
    "quads": (msh(cells=[(1, 2, 3, 4)], cell_type=QUAD), "only 3-node triangles"),
    "second order": (msh(cells=[(1, 2, 3, 6, 7, 8)], cell_type=TRIANGLE6,
                         extra_nodes=[(0.5, 0.0), (1.0, 0.5), (0.5, 0.5)]), "only 3-node triangles"),
    "collapsed": (msh(nodes=NODES[:4] + [(0.5, 0.0)]), "degenerate"),
    "repeated vertex": (msh(cells=[(1, 1, 5)] + TRIANGLES[1:]), "degenerate"),
    "tangled": (msh(nodes=NODES[:4] + [(1.3, 0.5)]), "overlap"),
}


@pytest.mark.parametrize("name", list(BAD_MESHES))
def test_a_bad_mesh_file_is_refused(tmp_path, capsys, name):
    text, detail = BAD_MESHES[name]
    line = _refused(tmp_path, capsys, text)
    assert "geometry.file" in line and "specimen.msh" in line and detail in line, line


def test_a_binary_file_is_refused(tmp_path, capsys):
    line = _refused(tmp_path, capsys, None, binary=bytes(range(256)) * 8)
    assert "geometry.file" in line


def test_a_group_the_mesh_lacks_is_refused(tmp_path, capsys):
    line = _refused(tmp_path, capsys, GOOD, group="left")
    assert "load.displacement.left" in line and "bottom" in line and "top" in line


@pytest.mark.parametrize("eps, mesh, detail", [
    (1e6, "", "model.eps = 1e+06"),                  # the band wider than the specimen
    (0.001, "", "model.eps = 0.001"),                # 700 times finer than the elements
    (0.1, "[mesh]\nh = 0.001", "mesh.h = 0.001"),   # declared 700 times finer than the file's
    (0.1, "[mesh]\nh = 50.0", "mesh.h = 50"),       # larger than the whole domain
])
def test_a_meaningless_regularization_is_refused(tmp_path, capsys, eps, mesh, detail):
    line = _refused(tmp_path, capsys, GOOD, eps=eps, mesh=mesh)
    assert detail in line, line


@pytest.mark.parametrize("case, h", [("lpanel", 1e-6), ("lpanel_3d", 1.0), ("brokenshire", 0.5)])
def test_a_size_that_cannot_fit_is_refused_before_meshing(tmp_path, capsys, case, h):
    from tests.helpers import CASES

    scene = tmp_path / f"{case}.toml"
    scene.write_text((CASES / f"{case}.toml").read_text())
    (tmp_path / "winkler_lpanel_series_a.csv").write_text((CASES / "winkler_lpanel_series_a.csv").read_text())
    before = sorted(tmp_path.iterdir())
    start = time.perf_counter()
    status = main(["run", str(scene), f"--set=mesh.h={h}", "--set=mesh.check_eps=false"])
    elapsed = time.perf_counter() - start
    captured = capsys.readouterr()
    line = captured.err.strip()
    assert status == 2 and "\n" not in line, captured.err
    assert line.startswith(f"thinfilm: error: {scene}: mesh.h = {h!r}: the run needs about") and "nodes" in line
    assert "use a larger h" in line
    assert sorted(tmp_path.iterdir()) == before and elapsed < 10.0


@pytest.mark.parametrize("name, dim, h, h_coarse", [
    ("lpanel", 2, 5.0, 25.0), ("lpanel", 3, 20.0, 50.0), ("three_point_bending", 2, 0.1, 0.5),
    ("nooru_mohamed", 2, 4.0, 20.0), ("brokenshire", 3, 20.0, 40.0), ("double_torsion", 3, 1.0, 2.0)])
def test_the_node_estimate_before_meshing_is_near_the_mesh(name, dim, h, h_coarse):
    # at these coarse sizes the graded transitions weigh most: within a factor 2.5 (at the
    # cases' own sizes within 25%, docs/scenes.md#sizes)
    from fem3d import specimens

    record = specimens.get(name)
    ratio = record.nodes_estimate(dim, h, h_coarse, {}) / record.make(dim, h, h_coarse, {}).n_nodes
    assert 0.4 < ratio < 1.5, ratio
