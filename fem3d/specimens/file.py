"""A mesh of one's own: a gmsh ``.msh`` file (``geometry.kind = "file"``).

Its physical groups of the mesh's dimension are regions, of one less boundaries, of lower
dimension points (:func:`fem3d.specimens.gmsh_tools.from_file`). The mesh is read as it is:
the scene's ``mesh.h`` and ``mesh.h_coarse`` do not change it. In 3D the crack front's width
for the energy release rate is the mesh's extent in z.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import tempfile
from functools import lru_cache
from pathlib import Path

from fem3d.specimens.gmsh_tools import from_file
from fem3d.specimens.specimen import DIMS, MESH_FRONT, Groups, Specimen, path

__all__ = ["SPECIMEN", "read", "read_isolated"]


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
    return read_isolated(path)


#: What the reading process runs: :func:`from_file`, its mesh or its error pickled to a file.
_CHILD = """
import pickle, sys
from fem3d.specimens.gmsh_tools import from_file
try:
    result = from_file(sys.argv[1])
except (OSError, ValueError) as error:
    result = ValueError(str(error))
with open(sys.argv[2], "wb") as f:
    pickle.dump(result, f)
"""


def read_isolated(path):
    """:func:`from_file` in a process of its own: gmsh's reader can crash on a malformed file
    (a cell naming a node the file lacks ends in a segmentation fault inside gmsh), which
    must be a refusal, not the end of the run's process. A subprocess rather than
    ``multiprocessing``: a scan's Dask workers may not start children of their own.

    Raises
    ------
    FileNotFoundError, ValueError
        As :func:`from_file`; ValueError also if the reading process died.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no file {str(path)!r}")
    root = str(Path(__file__).resolve().parents[2])   # the folder that holds the fem3d package
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [root, os.environ.get("PYTHONPATH")])))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "mesh.pickle"
        done = subprocess.run([sys.executable, "-c", _CHILD, str(path), str(out)], env=env, capture_output=True,
                              text=True)
        if done.returncode != 0 or not out.is_file():
            why = f"signal {-done.returncode}" if done.returncode < 0 else f"exit status {done.returncode}"
            last = (done.stderr.strip().splitlines() or [""])[-1]
            raise ValueError(f"gmsh could not read it ({why}{': ' + last if last else ''}): not a valid .msh file")
        with open(out, "rb") as f:
            result = pickle.load(f)
    if isinstance(result, Exception):
        raise result
    return result

SPECIMEN = Specimen(
    name="file", dims=DIMS, mesh=read, sized=False,
    doc="a gmsh `.msh` file (format 2.2 or 4): its physical groups of the mesh's dimension are regions, of one"
        " less boundaries, of lower dimension points",
    keys=(path("file", "the `.msh` file, relative to the scene file", argument="path"),),
    groups=Groups(), front=MESH_FRONT)
