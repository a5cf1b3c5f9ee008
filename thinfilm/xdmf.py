"""An XDMF index of a plate ``results.h5``, so that ParaView (or VisIt) opens the fields.

``results.xdmf`` is light XML only: an XDMF 3 temporal collection with one grid per finished
step (its ``Time`` the load t), each a uniform structured mesh with the node attributes
``alpha`` and ``u`` (and ``toughness`` for an imperfect film). The attributes point into
``/fields/alpha`` and ``/fields/u`` of the HDF5 file by hyperslab (row k of the
``(n_steps, n_nodes)`` dataset; ``/fields/toughness`` whole), so nothing is copied;
the HDF5 path is relative to the XDMF file, so the run directory can be moved whole.

The mesh is a ``3DCoRectMesh`` of one layer in every case:

* 2D run: ``Dimensions = "1 ny+1 nx+1"``, origin ``(0, y0, x0)``, spacing ``(hx, hy, hx)``;
* 1D run: ``Dimensions = "1 1 nx+1"``, origin ``(0, 0, x0)``: a single row of nodes along x.

XDMF lists dimensions, origin and spacing slowest first (z, y, x), and so does VTK's Xdmf3
reader (``vtkXdmf3DataSet::CopyShape`` fills VTK's axes 2, 1, 0 from entries 0, 1, 2). A
``2DCoRectMesh`` would therefore come out in ParaView as a plane of constant x, with the
film's x along VTK's y; the one-layer 3D mesh puts the film in the x-y plane with x along x.
Nodes run x fastest, which is the flattening of :mod:`thinfilm.plate.grid`, so each field row is
used as stored.

Open ``results.xdmf`` in ParaView with the **"XDMF Reader"** (VTK's ``vtkXdmfReader``); the
time slider then steps through the load. With VTK 9.7's reader, every step's ``alpha`` and
``u``, its load and the node coordinates come back exactly (``tests/test_inspect.py``, when
the ``vtk`` package is installed). ParaView's "Xdmf3 Reader S/T" are not recommended for this
file: ``vtkXdmf3DataSet::XdmfToVTKAttributes`` sizes an attribute's array from its dimensions
*before* reading it, and a HyperSlab item has none until it is read, so those readers are
expected to give empty arrays (found by reading their source; not run here).

The file describes the steps finished when it was written: a run that goes on, or
backtracks, needs it rewritten (``thinfilm plot`` and the end of ``thinfilm run`` do that).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

from thinfilm.results import PlateResults, ResultsError

#: Node attributes written for every step, from ``/fields/<name>``.
FIELDS = ("alpha", "u")


def _numbers(values):
    """Floats in XML text, exactly (``repr`` round-trips a float64)."""
    return " ".join(repr(float(v)) for v in values)


def _reference(h5_path, xdmf_path):
    """The HDF5 file as seen from the XDMF file: relative if possible, else absolute."""
    h5_path, xdmf_path = Path(h5_path).resolve(), Path(xdmf_path).resolve()
    try:
        return Path(os.path.relpath(h5_path, xdmf_path.parent)).as_posix()
    except ValueError:  # another drive (Windows): no relative path exists
        return h5_path.as_posix()


def mesh_description(res):
    """Topology dimensions, origin and spacing of the one-layer ``3DCoRectMesh``.

    Parameters
    ----------
    res : thinfilm.results.PlateResults

    Returns
    -------
    dims : tuple of int, length 3
        ``(1, ny+1, nx+1)`` or ``(1, 1, nx+1)``: nodes along z, y, x.
    origin, spacing : tuple of float, length 3
        In the same z, y, x order. The z (and, in 1D, y) spacing is hx: any positive value
        would do for a single layer; hx keeps the cells' bounding boxes unskewed.
    """
    x = res.x
    nx = len(x) - 1
    g = res.grid_attrs
    # hx from the end points, as thinfilm.plate.grid builds the nodes, not from a difference of
    # two rounded coordinates.
    hx = (float(g["x1"]) - float(g["x0"])) / nx if "x1" in g and "x0" in g else float(x[1] - x[0])
    if res.dim == 1:
        return (1, 1, nx + 1), (0.0, 0.0, float(x[0])), (hx, hx, hx)
    y = res.y
    ny = len(y) - 1
    hy = (float(g["y1"]) - float(g["y0"])) / ny if "y1" in g and "y0" in g else float(y[1] - y[0])
    return (1, ny + 1, nx + 1), (0.0, float(y[0]), float(x[0])), (hx, hy, hx)


def build_xdmf(res, reference):
    """The XDMF document of a plate run.

    Parameters
    ----------
    res : thinfilm.results.PlateResults
        The open results; one grid per finished step ``0 .. res.n - 1``.
    reference : str
        The HDF5 file's name as the XDMF reader should open it (relative to the XDMF file).

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``<Xdmf>`` root.
    """
    dims, origin, spacing = mesh_description(res)
    f = res.file
    root = ET.Element("Xdmf", Version="3.0")
    domain = ET.SubElement(root, "Domain")
    ET.SubElement(domain, "Information", Name="thinfilm",
                  Value=f"{res.n} of {res.n_planned} steps of {res.attrs.get('scene_source', '?')};"
                        f" fields {', '.join(FIELDS)} by hyperslab from {reference}")
    collection = ET.SubElement(domain, "Grid", Name="evolution", GridType="Collection", CollectionType="Temporal")
    datasets = {name: f[f"fields/{name}"] for name in FIELDS}
    toughness = f["fields"].get("toughness")
    for k in range(res.n):
        grid = ET.SubElement(collection, "Grid", Name=f"step {k}", GridType="Uniform")
        ET.SubElement(grid, "Time", Value=repr(float(res.t[k])))
        ET.SubElement(grid, "Topology", TopologyType="3DCoRectMesh", Dimensions=" ".join(map(str, dims)))
        geometry = ET.SubElement(grid, "Geometry", GeometryType="ORIGIN_DXDYDZ")
        for name, values in (("Origin", origin), ("Spacing", spacing)):
            item = ET.SubElement(geometry, "DataItem", Name=name, Dimensions="3", NumberType="Float",
                                 Precision="8", Format="XML")
            item.text = _numbers(values)
        for name, ds in datasets.items():
            rows, n_nodes = ds.shape
            attribute = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar", Center="Node")
            # A hyperslab is (start, stride, count) per dimension of the source: one row of
            # n_nodes values, x fastest. Its own Dimensions give that row the mesh's shape
            # (z, y, x): the legacy Xdmf2 reader reads structured attributes by sub-extent
            # and needs them; the Xdmf3 reader takes the count and finds one value per node.
            slab = ET.SubElement(attribute, "DataItem", ItemType="HyperSlab", Type="HyperSlab",
                                 Dimensions=" ".join(map(str, dims)))
            selection = ET.SubElement(slab, "DataItem", Dimensions="3 2", NumberType="UInt", Format="XML")
            selection.text = f"{k} 0 1 1 1 {n_nodes}"
            source = ET.SubElement(slab, "DataItem", Dimensions=f"{rows} {n_nodes}", NumberType="Float",
                                   Precision=str(ds.dtype.itemsize), Format="HDF")
            source.text = f"{reference}:/fields/{name}"
        if toughness is not None:  # an imperfect film: the same field at every step
            attribute = ET.SubElement(grid, "Attribute", Name="toughness", AttributeType="Scalar", Center="Node")
            item = ET.SubElement(attribute, "DataItem", Dimensions=" ".join(map(str, dims)), NumberType="Float",
                                 Precision=str(toughness.dtype.itemsize), Format="HDF")
            item.text = f"{reference}:/fields/toughness"
    return root


def write_xdmf(results_path, out=None):
    """Write the XDMF index of a plate ``results.h5`` (see the module docstring).

    Parameters
    ----------
    results_path : str or Path
        The plate ``results.h5`` (or its run directory).
    out : str or Path, optional
        The XDMF file, or a directory to write ``<stem>.xdmf`` into; default: beside the
        HDF5 file, ``results.xdmf``.

    Returns
    -------
    Path
        The file written (under a temporary name first, then renamed).

    Raises
    ------
    thinfilm.results.ResultsError
        Not a plate results file, or no finished step.
    """
    with PlateResults(results_path) as res:
        h5 = res.path
        if res.n == 0:
            raise ResultsError(f"{h5}: no finished step to index")
        if out is None:
            out = h5.with_suffix(".xdmf")
        out = Path(out)
        if out.is_dir():
            out = out / h5.with_suffix(".xdmf").name
        root = build_xdmf(res, _reference(h5, out))
    ET.indent(root)
    partial = out.with_name(f".{out.name}.partial")
    ET.ElementTree(root).write(partial, encoding="utf-8", xml_declaration=True)
    os.replace(partial, out)
    return out
