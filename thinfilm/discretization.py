"""How a model's nodes are laid out, as the results file, the XDMF index and the plots see it.

A kind describes its discretization with one of two objects, written into ``results.h5`` and
read back from it alone:

* :class:`StructuredGrid`: the nodes of a uniform grid on an interval or a rectangle
  (the finite-difference film), stored in ``/grid``;
* :class:`SimplexMesh`: the vertices and cells of a mesh of segments, triangles or tetrahedra
  (P1 finite elements), stored in ``/mesh``.

A mesh refined during a run (adaptive refinement by nested bisection) is a :class:`SimplexMesh`
with a :class:`Refinement`: how it was made from the run's first mesh, pass by pass, each new
vertex the midpoint of an edge of the mesh before. :func:`prolong` carries a P1 field from an
earlier mesh of the run to a later one, and :class:`StoredMeshes` keeps every mesh of a run in
``/meshes`` of its results file (``docs/results.md#meshes-that-change-during-a-run``).

Nodal fields are flat arrays of ``n_nodes * components`` values, node by node (a vector field
``u`` of a 2D mesh is ``u_x, u_y`` of node 0, then of node 1...). Each description knows how
to write and read itself (:meth:`write`, :func:`read`), its XDMF topology and geometry
(:meth:`xdmf`) and the shape a field takes on it (:meth:`shaped`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

__all__ = ["StructuredGrid", "SimplexMesh", "Refinement", "StoredMeshes", "prolong", "read", "GROUPS"]


def _numbers(values):
    """Floats in XML text, exactly (``repr`` round-trips a float64)."""
    return " ".join(repr(float(v)) for v in values)


@dataclass(frozen=True, eq=False)
class StructuredGrid:
    """The nodes of a uniform grid: ``x`` (and ``y`` in 2D), x fastest in flat fields.

    Attributes
    ----------
    x : ndarray, shape (nx+1,)
    y : ndarray, shape (ny+1,) or None
        Node coordinates (the model's length unit); ``y`` is None in 1D.
    x_range, y_range : tuple of float
        The end points the nodes were made from (``y_range`` None in 1D): spacings are taken
        from them rather than from differences of rounded coordinates.
    """

    x: np.ndarray
    y: np.ndarray | None = None
    x_range: tuple | None = None
    y_range: tuple | None = None

    group = "grid"

    @property
    def dim(self):
        return 1 if self.y is None else 2

    @property
    def shape(self):
        """``(nx+1,)`` or ``(ny+1, nx+1)``: a flat scalar field reshaped to the grid."""
        return (len(self.x),) if self.y is None else (len(self.y), len(self.x))

    @property
    def n_nodes(self):
        return int(np.prod(self.shape))

    @property
    def spacing(self):
        """``(hx,)`` or ``(hx, hy)``."""
        nx = len(self.x) - 1
        x0, x1 = self.x_range if self.x_range else (self.x[0], self.x[-1])
        if self.y is None:
            return ((x1 - x0) / nx,)
        ny = len(self.y) - 1
        y0, y1 = self.y_range if self.y_range else (self.y[0], self.y[-1])
        return (x1 - x0) / nx, (y1 - y0) / ny

    @property
    def extent(self):
        """``(x0, x1)`` or ``(x0, x1, y0, y1)``: the nodes' span."""
        return (self.x[0], self.x[-1]) if self.y is None else (self.x[0], self.x[-1], self.y[0], self.y[-1])

    def shaped(self, values, components=1):
        """A flat nodal field on the grid: shape :attr:`shape` (times ``components``)."""
        return np.asarray(values).reshape(self.shape + ((components,) if components > 1 else ()))

    def describe(self):
        """One line for ``thinfilm info``."""
        nx = len(self.x) - 1
        cells = f"{nx}" if self.dim == 1 else f"{nx} x {len(self.y) - 1}"
        return f"grid: {self.dim}D, {cells} cells, {self.n_nodes} nodes"

    def write(self, f):
        """``/grid``: attrs dim, x0, x1, nx (and y0, y1, ny); datasets x (and y)."""
        g = f.create_group(self.group)
        x0, x1 = self.x_range if self.x_range else (float(self.x[0]), float(self.x[-1]))
        g.attrs.update({"dim": self.dim, "x0": x0, "x1": x1, "nx": len(self.x) - 1})
        g["x"] = np.asarray(self.x)
        if self.y is not None:
            y0, y1 = self.y_range if self.y_range else (float(self.y[0]), float(self.y[-1]))
            g.attrs.update({"y0": y0, "y1": y1, "ny": len(self.y) - 1})
            g["y"] = np.asarray(self.y)

    @classmethod
    def read(cls, g):
        attrs = dict(g.attrs)
        dim = int(attrs.get("dim", 2 if "y" in g else 1))
        x = g["x"][()]
        y = g["y"][()] if dim == 2 else None
        x_range = (float(attrs["x0"]), float(attrs["x1"])) if "x0" in attrs and "x1" in attrs else None
        y_range = (float(attrs["y0"]), float(attrs["y1"])) if dim == 2 and "y0" in attrs and "y1" in attrs else None
        return cls(x, y, x_range, y_range)

    def xdmf_dimensions(self):
        """Topology dimensions, origin and spacing of a one-layer ``3DCoRectMesh``, in XDMF's
        z, y, x order (see :mod:`thinfilm.xdmf` for why one layer of 3D rather than 2D).

        Returns
        -------
        dims : tuple of int
            ``(1, ny+1, nx+1)`` or ``(1, 1, nx+1)``.
        origin, spacing : tuple of float
            The z (and, in 1D, y) spacing is hx: any positive value would do for a single
            layer; hx keeps the cells' bounding boxes unskewed.
        """
        nx = len(self.x) - 1
        if self.dim == 1:
            (hx,) = self.spacing
            return (1, 1, nx + 1), (0.0, 0.0, float(self.x[0])), (hx, hx, hx)
        hx, hy = self.spacing
        return (1, len(self.y), nx + 1), (0.0, float(self.y[0]), float(self.x[0])), (hx, hy, hx)

    def xdmf(self, grid, reference):
        """Add the topology and geometry of one time step's ``<Grid>``; returns the field
        dimensions (the mesh's shape, slowest first) for scalar attributes."""
        dims, origin, spacing = self.xdmf_dimensions()
        ET.SubElement(grid, "Topology", TopologyType="3DCoRectMesh", Dimensions=" ".join(map(str, dims)))
        geometry = ET.SubElement(grid, "Geometry", GeometryType="ORIGIN_DXDYDZ")
        for name, values in (("Origin", origin), ("Spacing", spacing)):
            item = ET.SubElement(geometry, "DataItem", Name=name, Dimensions="3", NumberType="Float",
                                 Precision="8", Format="XML")
            item.text = _numbers(values)
        return dims


@dataclass(frozen=True, eq=False)
class Refinement:
    """How a mesh was made from the run's first mesh by nested refinement passes.

    Each pass appends its new vertices after the existing ones (existing vertices keep their
    numbers), each new vertex the midpoint of two vertices of lower numbers (an edge of the
    mesh before the pass, or one made by a bisection earlier in the pass).

    Attributes
    ----------
    parents : ndarray of int64, shape (n_nodes, 2)
        Vertex ``i`` made by a pass is the midpoint of vertices ``parents[i]``, both of lower
        numbers; rows of the first mesh's vertices are ``(-1, -1)``.
    pass_nodes : ndarray of int64, shape (passes + 1,)
        Number of vertices after each pass: ``pass_nodes[0]`` is the first mesh's,
        ``pass_nodes[-1] = n_nodes``.
    marked : tuple of ndarray of int64
        One array per pass: the cells marked at that pass (indices into the cells of the mesh
        before it).
    """

    parents: np.ndarray
    pass_nodes: np.ndarray
    marked: tuple = ()

    def __post_init__(self):
        parents = np.asarray(self.parents, dtype=np.int64).reshape(-1, 2)
        pass_nodes = np.atleast_1d(np.asarray(self.pass_nodes, dtype=np.int64))
        marked = tuple(np.asarray(m, dtype=np.int64).ravel() for m in self.marked)
        if pass_nodes.ndim != 1 or len(marked) != pass_nodes.size - 1:
            raise ValueError(f"a refinement of {len(marked)} passes needs {len(marked) + 1} entries in pass_nodes,"
                             f" not {pass_nodes.size}")
        if pass_nodes[-1] != parents.shape[0] or np.any(np.diff(pass_nodes) < 0):
            raise ValueError(f"pass_nodes {pass_nodes.tolist()} must be non-decreasing and end at the"
                             f" {parents.shape[0]} rows of parents")
        object.__setattr__(self, "parents", parents)
        object.__setattr__(self, "pass_nodes", pass_nodes)
        object.__setattr__(self, "marked", marked)

    @classmethod
    def initial(cls, n_nodes):
        """The refinement of a run's first mesh of ``n_nodes`` vertices: no pass yet."""
        return cls(np.full((int(n_nodes), 2), -1, dtype=np.int64), np.array([n_nodes], dtype=np.int64), ())

    @property
    def passes(self) -> int:
        """Refinement passes made; the mesh's version number (0: the run's first mesh)."""
        return len(self.marked)

    @property
    def n_nodes(self) -> int:
        return int(self.pass_nodes[-1])


def prolong(values, refinement, n_from, components=1):
    """A P1 nodal field on an earlier mesh of a refinement, carried to its last mesh.

    Each later vertex ``i``, in order, gets ``0.5 * (out[a] + out[b])`` with ``(a, b) =
    parents[i]``, per component: the same numbers as a loop over the vertices, computed over
    runs of vertices whose parents all precede the run (a pass's vertices can have parents made
    earlier in the same pass, when a bisection cuts an edge made by the one before). The run
    computes its prolongations with this function, so that a resumed run reproduces them bit
    for bit.

    Parameters
    ----------
    values : array_like, shape (n_from * components,)
        The field, flat (node by node).
    refinement : Refinement
    n_from : int
        Vertices of the mesh the field lives on: one of ``refinement.pass_nodes``.
    components : int, optional
        Values per node.

    Returns
    -------
    ndarray of float64, shape (refinement.n_nodes * components,)
        A new array; its first ``n_from * components`` values are ``values``.

    Raises
    ------
    ValueError
        If ``n_from`` is no mesh of the refinement, or ``values`` has not ``n_from * components``
        values.
    """
    values = np.asarray(values, dtype=np.float64).ravel()
    pass_nodes = refinement.pass_nodes
    found = np.flatnonzero(pass_nodes == n_from)
    if not found.size:
        raise ValueError(f"n_from = {n_from}: not a mesh of the refinement (its vertex counts:"
                         f" {pass_nodes.tolist()})")
    if values.size != n_from * components:
        raise ValueError(f"{values.size} values: a field of {components} per node on {n_from} vertices has"
                         f" {n_from * components}")
    out = np.empty(refinement.n_nodes * components, dtype=np.float64)
    out[: values.size] = values
    nodal = out.reshape(-1, components)
    parents = refinement.parents
    start, stop = n_from, refinement.n_nodes
    while start < stop:
        # the longest run of vertices whose parents all precede it: one vectorized sum
        late = np.flatnonzero(parents[start:stop].max(axis=1) >= start)
        end = start + int(late[0]) if late.size else stop
        a, b = parents[start:end, 0], parents[start:end, 1]
        nodal[start:end] = 0.5 * (nodal[a] + nodal[b])
        start = end
    return out


#: XDMF topology and cell name of each simplex dimension.
_SIMPLICES = {1: ("Polyline", "segments"), 2: ("Triangle", "triangles"), 3: ("Tetrahedron", "tetrahedra")}


def _simplex_topology(grid, dim, shape, path):
    """Add the ``<Topology>`` of cells of ``shape`` (n_cells, dim + 1), stored at ``path``
    (``file:/dataset``), to one time step's ``<Grid>``."""
    n_cells, per_cell = shape
    topology = ET.SubElement(grid, "Topology", TopologyType=_SIMPLICES[dim][0], NumberOfElements=str(n_cells),
                             **({"NodesPerElement": "2"} if dim == 1 else {}))
    item = ET.SubElement(topology, "DataItem", Dimensions=f"{n_cells} {per_cell}", NumberType="Int", Precision="8",
                         Format="HDF")
    item.text = path


@dataclass(frozen=True, eq=False)
class SimplexMesh:
    """The vertices and cells of a mesh of segments (1D), triangles (2D) or tetrahedra (3D).

    Attributes
    ----------
    points : ndarray, shape (n_nodes, dim)
        Vertex coordinates (the model's length unit).
    cells : ndarray of int, shape (n_cells, dim + 1)
        Vertex indices of each cell.
    refinement : Refinement or None
        How the mesh was made from the run's first mesh (a mesh refined during the run); None
        for a mesh that stays as it is.
    """

    points: np.ndarray
    cells: np.ndarray
    refinement: Refinement | None = None

    group = "mesh"

    @property
    def dim(self):
        return int(self.points.shape[1])

    @property
    def n_nodes(self):
        return int(self.points.shape[0])

    @property
    def shape(self):
        return (self.n_nodes,)

    @property
    def version(self) -> int:
        """The number of refinement passes that made this mesh (0: the run's first mesh, or a
        mesh without a refinement)."""
        return 0 if self.refinement is None else self.refinement.passes

    def shaped(self, values, components=1):
        """A flat nodal field: shape ``(n_nodes,)`` or ``(n_nodes, components)``."""
        return np.asarray(values).reshape((self.n_nodes, components) if components > 1 else (self.n_nodes,))

    def describe(self):
        """One line for ``thinfilm info``."""
        return f"mesh: {self.dim}D, {self.n_nodes} nodes, {len(self.cells)} {_SIMPLICES[self.dim][1]}"

    def write(self, f):
        """``/mesh``: attrs dim and cell_type; datasets ``points`` (padded with zero columns to
        at least two, so that every mesh has an XDMF geometry) and ``cells``."""
        g = f.create_group(self.group)
        g.attrs.update({"dim": self.dim, "cell_type": _SIMPLICES[self.dim][0].lower()})
        points = np.zeros((self.n_nodes, max(self.dim, 2)))
        points[:, : self.dim] = self.points
        g["points"] = points
        g["cells"] = np.asarray(self.cells, dtype=np.int64)

    @classmethod
    def read(cls, g):
        dim = int(g.attrs["dim"])
        return cls(g["points"][()][:, :dim], g["cells"][()])

    def xdmf(self, grid, reference):
        """Add the topology and geometry of one time step's ``<Grid>`` (read from ``/mesh`` of
        the HDF5 file ``reference``); returns the field dimensions for scalar attributes."""
        _simplex_topology(grid, self.dim, self.cells.shape, f"{reference}:/mesh/cells")
        columns = max(self.dim, 2)
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XY" if columns == 2 else "XYZ")
        item = ET.SubElement(geometry, "DataItem", Dimensions=f"{self.n_nodes} {columns}", NumberType="Float",
                             Precision="8", Format="HDF")
        item.text = f"{reference}:/mesh/points"
        return (self.n_nodes,)


class StoredMeshes:
    """Every mesh of a run whose mesh is refined as it goes, in ``/meshes`` of its results file.

    The meshes are nested: each version ``v`` (made by ``v`` refinement passes from the first
    mesh, which ``/mesh`` holds too) has the first ``pass_nodes[v]`` vertices of the last one,
    so the vertices are stored once, in the order they were made, with the passes that made
    them; the cells of each version a step was computed on are stored whole::

        /meshes            attrs dim, cell_type
        /meshes/points     (N, max(dim, 2)) every vertex ever made (zero columns to two)
        /meshes/parents    (N, 2) int64: the edge each vertex is the midpoint of ((-1, -1): the
                           first mesh's)
        /meshes/pass_nodes (passes + 1,) int64: vertices after each pass
        /meshes/marked     int64: the cells marked at every pass, one pass after the other,
        /meshes/marked_offsets (passes + 1,) int64: pass p's in marked[offsets[p]:offsets[p+1]]
        /meshes/cells_<v>  (n_cells, dim + 1) int64: the cells of version v

    The datasets only grow (versions are appended, never removed), so a step that adds a
    version appends to them and writes its cells, in the same commit as its fields.

    Parameters
    ----------
    group : h5py.Group
        ``/meshes`` of an open file (:meth:`create` makes it).
    """

    group_name = "meshes"

    def __init__(self, group):
        self.group = group
        self.dim = int(group.attrs["dim"])

    @classmethod
    def of(cls, f):
        """The stored meshes of an open results file, or None (a mesh that does not change, or a grid)."""
        return cls(f[cls.group_name]) if cls.group_name in f else None

    @classmethod
    def create(cls, f, mesh):
        """``/meshes`` of a new results file, holding the run's first mesh ``mesh`` (version 0;
        its cells are written with the first step computed on it)."""
        if mesh.version != 0:
            raise ValueError(f"the first mesh of a run is version 0, not {mesh.version}")
        g = f.create_group(cls.group_name)
        g.attrs.update({"dim": mesh.dim, "cell_type": _SIMPLICES[mesh.dim][0].lower()})
        columns = max(mesh.dim, 2)
        points = np.zeros((mesh.n_nodes, columns))
        points[:, : mesh.dim] = mesh.points
        g.create_dataset("points", data=points, maxshape=(None, columns), chunks=(4096, columns))
        g.create_dataset("parents", data=np.full((mesh.n_nodes, 2), -1, dtype=np.int64), maxshape=(None, 2),
                         chunks=(8192, 2), compression="gzip", shuffle=True)
        for name, values in (("pass_nodes", [mesh.n_nodes]), ("marked_offsets", [0])):
            g.create_dataset(name, data=np.array(values, dtype=np.int64), maxshape=(None,), chunks=(64,))
        g.create_dataset("marked", shape=(0,), maxshape=(None,), dtype=np.int64, chunks=(8192,),
                         compression="gzip", shuffle=True)
        return cls(g)

    @property
    def pass_nodes(self):
        """Vertices of each stored version, shape (versions,)."""
        return self.group["pass_nodes"][()]

    @property
    def versions(self) -> int:
        """Versions stored (0 to ``versions - 1``)."""
        return int(self.group["pass_nodes"].shape[0])

    def n_nodes(self, version):
        return int(self.group["pass_nodes"][version])

    @property
    def cell_name(self):
        """``"segments"``, ``"triangles"`` or ``"tetrahedra"``."""
        return _SIMPLICES[self.dim][1]

    def n_cells(self, version):
        """Cells of a version a step was computed on."""
        return int(self.group[f"cells_{int(version)}"].shape[0])

    def has_cells(self, version) -> bool:
        return f"cells_{int(version)}" in self.group

    def refinement(self, version=None):
        """The :class:`Refinement` of a stored version (default: the largest, the run's
        current mesh)."""
        g = self.group
        v = self.versions - 1 if version is None else int(version)
        if not 0 <= v < self.versions:
            raise ValueError(f"version {v}: the file stores versions 0 to {self.versions - 1}")
        pass_nodes = g["pass_nodes"][: v + 1]
        offsets = g["marked_offsets"][: v + 1]
        marked = g["marked"][: offsets[-1]]
        return Refinement(g["parents"][: pass_nodes[-1]], pass_nodes,
                          tuple(marked[offsets[p]:offsets[p + 1]] for p in range(v)))

    def mesh(self, version):
        """The mesh of a version a step was computed on: the first ``pass_nodes[version]`` vertices
        and ``cells_<version>``, with its refinement."""
        v = int(version)
        n = self.n_nodes(v)
        cells = self.group[f"cells_{v}"][()]
        return SimplexMesh(self.group["points"][:n, : self.dim], cells, self.refinement(v))

    def store(self, mesh):
        """Make ``mesh``'s version stored: append the passes the file does not hold yet, and its
        cells if they are not stored; returns its version.

        Raises
        ------
        ValueError
            If ``mesh`` has no refinement, or its refinement does not extend the stored passes.
        """
        refinement = mesh.refinement
        if refinement is None:
            raise ValueError("a mesh without a refinement cannot be stored among a run's refined meshes")
        if refinement.n_nodes != mesh.n_nodes:
            raise ValueError(f"the refinement has {refinement.n_nodes} vertices, the mesh {mesh.n_nodes}")
        g = self.group
        v, stored = refinement.passes, self.versions - 1
        old = self.pass_nodes
        common = min(v, stored)
        if not np.array_equal(refinement.pass_nodes[: common + 1], old[: common + 1]):
            raise ValueError(f"the mesh's refinement (vertices after each pass {refinement.pass_nodes.tolist()}) does"
                             f" not extend the stored one ({old.tolist()}): passes can only be appended")
        if v > stored:
            start, stop = int(old[-1]), mesh.n_nodes
            points = g["points"]
            points.resize((stop, points.shape[1]))
            points[start:stop, : self.dim] = mesh.points[start:stop]
            if points.shape[1] > self.dim:
                points[start:stop, self.dim:] = 0.0
            parents = g["parents"]
            parents.resize((stop, 2))
            parents[start:stop] = refinement.parents[start:stop]
            new = refinement.marked[stored:v]
            offsets, marked = g["marked_offsets"], g["marked"]
            end = int(offsets[-1])
            sizes = np.cumsum([m.size for m in new]) + end
            if sizes[-1] > end:
                marked.resize((int(sizes[-1]),))
                marked[end:] = np.concatenate(new)
            for name, values in (("pass_nodes", refinement.pass_nodes[stored + 1:]), ("marked_offsets", sizes)):
                ds = g[name]
                ds.resize((v + 1,))
                ds[stored + 1:] = values
        if not self.has_cells(v):
            cells = np.asarray(mesh.cells, dtype=np.int64)
            g.create_dataset(f"cells_{v}", data=cells, chunks=(min(len(cells), 16384) or 1, cells.shape[1]),
                             compression="gzip", shuffle=True)
        return v

    def xdmf(self, grid, reference, version):
        """Add the topology and geometry of version ``version`` to one time step's ``<Grid>``:
        ``/meshes/cells_<version>`` and, by hyperslab, the first ``pass_nodes[version]`` rows of
        ``/meshes/points``; returns the field dimensions for scalar attributes."""
        g = self.group
        n = self.n_nodes(version)
        cells = f"cells_{int(version)}"
        _simplex_topology(grid, self.dim, g[cells].shape, f"{reference}:/{self.group_name}/{cells}")
        rows, columns = g["points"].shape
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XY" if columns == 2 else "XYZ")
        slab = ET.SubElement(geometry, "DataItem", ItemType="HyperSlab", Type="HyperSlab",
                             Dimensions=f"{n} {columns}")
        selection = ET.SubElement(slab, "DataItem", Dimensions="3 2", NumberType="UInt", Format="XML")
        selection.text = f"0 0 1 1 {n} {columns}"
        source = ET.SubElement(slab, "DataItem", Dimensions=f"{rows} {columns}", NumberType="Float", Precision="8",
                               Format="HDF")
        source.text = f"{reference}:/{self.group_name}/points"
        return (n,)


#: The HDF5 group of each description, and the dataset that marks it as one.
GROUPS = {StructuredGrid.group: (StructuredGrid, "x"), SimplexMesh.group: (SimplexMesh, "points")}


def read(f):
    """The discretization stored in an open results file, or None (an exact 1D run has none:
    its ``/grid`` group holds the grid track of its evolution, not nodes)."""
    for name, (cls, marker) in GROUPS.items():
        if name in f and marker in f[name]:
            return cls.read(f[name])
    return None
