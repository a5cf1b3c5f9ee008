"""A mesh of one's own: a gmsh ``.msh`` file (``geometry.kind = "file"``).

Its physical groups of the mesh's dimension are regions, of one less boundaries, of lower
dimension points (:func:`fem3d.specimens.gmsh_tools.from_file`). The mesh is read as it is:
the scene's ``mesh.h`` and ``mesh.h_coarse`` do not change it. In 3D the crack front's width
for the energy release rate is the mesh's extent in z.
"""

from __future__ import annotations

from fem3d.specimens.gmsh_tools import from_file
from fem3d.specimens.specimen import DIMS, MESH_FRONT, Groups, Specimen, path

__all__ = ["SPECIMEN"]

SPECIMEN = Specimen(
    name="file", dims=DIMS, mesh=from_file, sized=False,
    doc="a gmsh `.msh` file (format 2.2 or 4): its physical groups of the mesh's dimension are regions, of one"
        " less boundaries, of lower dimension points",
    keys=(path("file", "the `.msh` file, relative to the scene file", argument="path"),),
    groups=Groups(), front=MESH_FRONT)
