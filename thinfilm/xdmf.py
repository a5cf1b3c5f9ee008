"""An XDMF index of a ``results.h5``, so that ParaView (or VisIt) opens the fields.

``results.xdmf`` is light XML only: an XDMF 3 temporal collection with one grid per finished
step (its ``Time`` the load t), each with the node attributes ``alpha`` and ``u`` (and every
field stored once, such as the toughness of an imperfect film). The attributes point into
``/fields/alpha`` and ``/fields/u`` of the HDF5 file by hyperslab (row k of the
``(n_steps, n_values)`` dataset; a field stored once whole), so nothing is copied; the HDF5
path is relative to the XDMF file, so the run directory can be moved whole. A vector field
(``components`` > 1, e.g. the displacement of a finite-element solid) is a ``Vector``
attribute of shape ``(n_nodes, components)``.

The topology and geometry come from the run's discretization
(:meth:`thinfilm.discretization.StructuredGrid.xdmf`, :meth:`~thinfilm.discretization.SimplexMesh.xdmf`).
A mesh of triangles or tetrahedra points into ``/mesh/cells`` and ``/mesh/points``; a mesh
refined during the run gives each step the mesh it was computed on
(:meth:`thinfilm.discretization.StoredMeshes.xdmf`): its topology ``/meshes/cells_<v>``, its
geometry the first n rows of ``/meshes/points`` (a hyperslab), its attributes the first
``n * components`` values of the step's row. A structured grid is a ``3DCoRectMesh`` of one layer in every case:

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
``u``, its load and the node coordinates come back exactly (``tests/core/test_inspect.py``, when
the ``vtk`` package is installed). ParaView's "Xdmf3 Reader S/T" are not recommended for this
file: ``vtkXdmf3DataSet::XdmfToVTKAttributes`` sizes an attribute's array from its dimensions
*before* reading it, and a HyperSlab item has none until it is read, so those readers are
expected to give empty arrays (found by reading their source; not run here).

The file describes the steps finished when it was written: a run that goes on, or
backtracks, needs it rewritten (``thinfilm plot`` and the end of ``thinfilm run`` do that).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from pathlib import Path

from thinfilm.results.reader import Results, ResultsError

#: Node attributes written for every step, from ``/fields/<name>``.
FIELDS = ("alpha", "u")


def _reference(h5_path, xdmf_path):
    """The HDF5 file as seen from the XDMF file: relative if possible, else absolute."""
    h5_path, xdmf_path = Path(h5_path).resolve(), Path(xdmf_path).resolve()
    try:
        return Path(os.path.relpath(h5_path, xdmf_path.parent)).as_posix()
    except ValueError:  # another drive (Windows): no relative path exists
        return h5_path.as_posix()


def _field_dims(dims, components):
    """The Dimensions of an attribute of ``components`` values per node on a mesh of ``dims``."""
    return " ".join(map(str, dims + ((components,) if components > 1 else ())))


def build_xdmf(res, reference):
    """The XDMF document of a run.

    Parameters
    ----------
    res : thinfilm.results.reader.Results
        The open results; one grid per finished step ``0 .. res.n - 1``.
    reference : str
        The HDF5 file's name as the XDMF reader should open it (relative to the XDMF file).

    Returns
    -------
    xml.etree.ElementTree.Element
        The ``<Xdmf>`` root.
    """
    f = res.file
    root = ET.Element("Xdmf", Version="3.0")
    domain = ET.SubElement(root, "Domain")
    ET.SubElement(domain, "Information", Name="thinfilm",
                  Value=f"{res.n} of {res.n_planned} steps of {res.attrs.get('scene_source', '?')};"
                        f" fields {', '.join(FIELDS)} by hyperslab from {reference}")
    collection = ET.SubElement(domain, "Grid", Name="evolution", GridType="Collection", CollectionType="Temporal")
    datasets = {name: f[f"fields/{name}"] for name in FIELDS}
    constant = {name: ds for name, ds in f["fields"].items() if name not in FIELDS}
    for k in range(res.n):
        grid = ET.SubElement(collection, "Grid", Name=f"step {k}", GridType="Uniform")
        ET.SubElement(grid, "Time", Value=repr(float(res.t[k])))
        if res.adaptive:
            dims = res.meshes.xdmf(grid, reference, res.mesh_version(k))
        else:
            dims = res.discretization.xdmf(grid, reference)
        for name, ds in datasets.items():
            rows, n_values = ds.shape
            components = res.components(name)
            attribute = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar" if components == 1
                                      else "Vector", Center="Node")
            # A hyperslab is (start, stride, count) per dimension of the source: one row of
            # n_values values, x fastest. Its own Dimensions give that row the mesh's shape
            # (z, y, x for a grid): the legacy Xdmf2 reader reads structured attributes by
            # sub-extent and needs them; the Xdmf3 reader takes the count and finds one value
            # per node.
            slab = ET.SubElement(attribute, "DataItem", ItemType="HyperSlab", Type="HyperSlab",
                                 Dimensions=_field_dims(dims, components))
            selection = ET.SubElement(slab, "DataItem", Dimensions="3 2", NumberType="UInt", Format="XML")
            # the nodes' values: a P2 displacement's row goes on with its edge midpoints'
            selection.text = f"{k} 0 1 1 1 {math.prod(dims) * components}"
            source = ET.SubElement(slab, "DataItem", Dimensions=f"{rows} {n_values}", NumberType="Float",
                                   Precision=str(ds.dtype.itemsize), Format="HDF")
            source.text = f"{reference}:/fields/{name}"
        for name, ds in constant.items():  # a field stored once: the same at every step (of its mesh)
            if ds.shape[0] != math.prod(dims):
                continue
            attribute = ET.SubElement(grid, "Attribute", Name=name, AttributeType="Scalar", Center="Node")
            item = ET.SubElement(attribute, "DataItem", Dimensions=_field_dims(dims, 1), NumberType="Float",
                                 Precision=str(ds.dtype.itemsize), Format="HDF")
            item.text = f"{reference}:/fields/{name}"
    return root


def write_xdmf(results_path, out=None):
    """Write the XDMF index of a ``results.h5`` (see the module docstring).

    Parameters
    ----------
    results_path : str or Path
        The ``results.h5`` of a run driven by the engine (or its run directory).
    out : str or Path, optional
        The XDMF file, or a directory to write ``<stem>.xdmf`` into; default: beside the
        HDF5 file, ``results.xdmf``.

    Returns
    -------
    Path
        The file written (under a temporary name first, then renamed).

    Raises
    ------
    thinfilm.results.reader.ResultsError
        Not such a results file, or no finished step.
    """
    with Results(results_path) as res:
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
