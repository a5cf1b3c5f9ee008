"""A mesh of one's own: a gmsh ``.msh`` file (``geometry.kind = "file"``).

Its physical groups of the mesh's dimension are regions, of one less boundaries, of lower
dimension points (:func:`fem3d.specimens.gmsh_tools.from_file`). The mesh is read as it is:
the scene's ``mesh.h`` and ``mesh.h_coarse`` do not change it. In 3D the crack front's width
for the energy release rate is the mesh's extent in z.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from fem3d.specimens.gmsh_tools import from_file
from fem3d.specimens.specimen import DIMS, MESH_FRONT, Groups, Specimen, path

__all__ = ["SPECIMEN", "read"]


def read(path):
    """The mesh of a ``.msh`` file (:func:`fem3d.specimens.gmsh_tools.from_file`, which checks
    it), read once while the file is unchanged: the scene reader judges it and measures its
    elements, the run then meshes nothing.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    fem3d.mesh.Mesh
        Shared between callers: do not modify its arrays.

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`~fem3d.specimens.gmsh_tools.from_file`.
    """
    path = Path(path).resolve()
    stat = path.stat()
    return _cached(str(path), stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=4)
def _cached(path, mtime_ns, size):
    # keyed on the file's modification time and size too: an edited file is read again
    return from_file(path)

SPECIMEN = Specimen(
    name="file", dims=DIMS, mesh=read, sized=False,
    doc="a gmsh `.msh` file (format 2.2 or 4): its physical groups of the mesh's dimension are regions, of one"
        " less boundaries, of lower dimension points",
    keys=(path("file", "the `.msh` file, relative to the scene file", argument="path"),),
    groups=Groups(), front=MESH_FRONT)
