"""How a model's nodes are laid out, as the results file, the XDMF index and the plots see it.

A kind describes its discretization with one of two objects, written into ``results.h5`` and
read back from it alone:

* :class:`StructuredGrid`: the nodes of a uniform grid on an interval or a rectangle
  (the finite-difference film), stored in ``/grid``;
* :class:`SimplexMesh`: the vertices and cells of a mesh of segments, triangles or tetrahedra
  (P1 finite elements), stored in ``/mesh``.

Nodal fields are flat arrays of ``n_nodes * components`` values, node by node (a vector field
``u`` of a 2D mesh is ``u_x, u_y`` of node 0, then of node 1...). Each description knows how
to write and read itself (:meth:`write`, :func:`read`), its XDMF topology and geometry
(:meth:`xdmf`) and the shape a field takes on it (:meth:`shaped`).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

__all__ = ["StructuredGrid", "SimplexMesh", "read", "GROUPS"]


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


#: XDMF topology and cell name of each simplex dimension.
_SIMPLICES = {1: ("Polyline", "segments"), 2: ("Triangle", "triangles"), 3: ("Tetrahedron", "tetrahedra")}


@dataclass(frozen=True, eq=False)
class SimplexMesh:
    """The vertices and cells of a mesh of segments (1D), triangles (2D) or tetrahedra (3D).

    Attributes
    ----------
    points : ndarray, shape (n_nodes, dim)
        Vertex coordinates (the model's length unit).
    cells : ndarray of int, shape (n_cells, dim + 1)
        Vertex indices of each cell.
    """

    points: np.ndarray
    cells: np.ndarray

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
        topology_type = _SIMPLICES[self.dim][0]
        n_cells, per_cell = self.cells.shape
        topology = ET.SubElement(grid, "Topology", TopologyType=topology_type, NumberOfElements=str(n_cells),
                                 **({"NodesPerElement": "2"} if self.dim == 1 else {}))
        item = ET.SubElement(topology, "DataItem", Dimensions=f"{n_cells} {per_cell}", NumberType="Int",
                             Precision="8", Format="HDF")
        item.text = f"{reference}:/mesh/cells"
        columns = max(self.dim, 2)
        geometry = ET.SubElement(grid, "Geometry", GeometryType="XY" if columns == 2 else "XYZ")
        item = ET.SubElement(geometry, "DataItem", Dimensions=f"{self.n_nodes} {columns}", NumberType="Float",
                             Precision="8", Format="HDF")
        item.text = f"{reference}:/mesh/points"
        return (self.n_nodes,)


#: The HDF5 group of each description, and the dataset that marks it as one.
GROUPS = {StructuredGrid.group: (StructuredGrid, "x"), SimplexMesh.group: (SimplexMesh, "points")}


def read(f):
    """The discretization stored in an open results file, or None (an exact 1D run has none:
    its ``/grid`` group holds the grid track of its evolution, not nodes)."""
    for name, (cls, marker) in GROUPS.items():
        if name in f and marker in f[name]:
            return cls.read(f[name])
    return None
