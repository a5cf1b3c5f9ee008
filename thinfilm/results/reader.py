"""Reading a ``results.h5`` back: validation, finished steps, the nodal fields.

:mod:`thinfilm.results.writer` writes the files; this module reads them for the commands that
work from a file alone (``thinfilm plot``, ``thinfilm info``, the XDMF index of
:mod:`thinfilm.xdmf`), for the run's own summary and for a resumed run. Everything here copes
with files of runs that stopped early: only the **finished steps** (:func:`finished_steps`)
are read; rows beyond them are an unfinished write and are ignored.

A run whose mesh was refined as it went stores each step's fields on that step's mesh
(:class:`thinfilm.discretization.StoredMeshes`): :meth:`Results.discretization_at` gives it, and
:meth:`Results.nodal` and :meth:`Results.field` the step's values on it.

A path that is not a thinfilm results file raises :class:`ResultsError`, whose message is
one line for the user (the command line prints it and exits with status 2).
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from thinfilm import discretization, kinds
from thinfilm.results.journal import RolledBack, journal_path

#: The ``format`` attribute of every results file, and the newest layout this version writes.
FORMAT = "thinfilm-results"
FORMAT_VERSION = 1


class ResultsError(ValueError):
    """A path that is not a readable thinfilm results file; the message is one line."""


def _scalar(value):
    """An HDF5 attribute value as a plain Python object (numpy scalars -> int/float/str,
    arrays -> lists), ready for JSON and for printing."""
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value.item() if isinstance(value, np.generic) else value


def attrs_dict(node):
    """The attributes of an HDF5 group or dataset as a dict of plain Python values."""
    return {key: _scalar(value) for key, value in node.attrs.items()}


def resolve_results(path):
    """The ``results.h5`` that ``path`` names: the file itself, or ``DIR/results.h5``.

    Raises
    ------
    ResultsError
        If nothing readable is there.
    """
    path = Path(path)
    if path.is_dir():
        candidate = path / "results.h5"
        if not candidate.is_file():
            raise ResultsError(f"{path}: a directory without results.h5 (give the results file or its run directory)")
        return candidate
    if not path.exists():
        raise ResultsError(f"{path}: no such file")
    if not path.is_file():
        raise ResultsError(f"{path}: not a regular file")
    return path


def open_results(path):
    """Open a thinfilm ``results.h5`` for reading, after checking that it is one.

    It is read as it stood at its writer's last commit (:func:`open_committed`): a killed
    run's file up to its last finished step, a running one's up to the steps committed so far.

    Parameters
    ----------
    path : str or Path
        The file, or the run directory holding ``results.h5``.

    Returns
    -------
    h5py.File
        Open read-only; the caller closes it.

    Raises
    ------
    ResultsError
        Missing file, not HDF5, not written by thinfilm, a newer format, or an unknown kind.
    """
    path = resolve_results(path)
    if not h5py.is_hdf5(path):
        raise ResultsError(f"{path}: not an HDF5 file (expected the results.h5 of a thinfilm run)")
    try:
        f = open_committed(path)
    except OSError as err:
        raise ResultsError(f"{path}: cannot be opened: {' '.join(str(err).split())}") from None
    try:
        fmt = _scalar(f.attrs.get("format", None))
        if fmt != FORMAT:
            found = "no 'format' attribute" if fmt is None else f"format = {fmt!r}"
            raise ResultsError(f"{path}: not a thinfilm results file ({found}, expected {FORMAT!r})")
        version = _scalar(f.attrs.get("format_version", 0))
        if not isinstance(version, int) or version > FORMAT_VERSION:
            raise ResultsError(f"{path}: format_version = {version!r} is newer than this thinfilm reads"
                               f" ({FORMAT_VERSION}); upgrade thinfilm")
        kind = _scalar(f.attrs.get("kind", None))
        if kind not in kinds.names():
            raise ResultsError(f"{path}: kind = {kind!r} is not one of {', '.join(kinds.names())}")
        required = ("steps/t", "parameters") + tuple(kinds.get(kind).required_datasets)
        for name in required:
            if name not in f:
                raise ResultsError(f"{path}: incomplete {kind} results: /{name} is missing")
    except BaseException:
        f.close()
        raise
    return f


def open_committed(path):
    """An HDF5 file as it stood at its writer's last commit, read-only, the file untouched.

    A results file written step by step has a rollback journal beside it while a step is
    being written, or after its writer was killed in the middle of one
    (:mod:`thinfilm.results.journal`); it is then read as the journal restores it, up to its
    last finished step. A file locked by a running writer is opened without the lock (what
    it has committed so far; a step being written meanwhile may make the read fail).

    Parameters
    ----------
    path : str or Path

    Returns
    -------
    h5py.File
        Open read-only; the caller closes it.

    Raises
    ------
    OSError
        HDF5 cannot open it.
    """
    path = Path(path)
    if journal_path(path).exists():
        view = RolledBack(path)
        try:
            f = h5py.File(view, "r")
        except BaseException:
            view.close()
            raise
        f._thinfilm_view = view  # h5py holds no reference: the view must live as long as the file
        return f
    try:
        return h5py.File(path, "r")
    except OSError as err:
        if "lock" not in str(err).lower():
            raise
        return h5py.File(path, "r", locking=False)  # held by a running job: what it has committed


def finished_steps(f):
    """Number of finished steps ``n`` of an open results file.

    A run appends each step to every dataset of ``/steps`` and ``/fields`` in turn and
    flushes, so a run killed mid-way can leave datasets of lengths ``k`` and ``k + 1``.

    Parameters
    ----------
    f : h5py.File

    Returns
    -------
    int
        The shortest length among the per-step datasets (``/steps/*`` and ``/fields/*``
        except the fields stored once): rows ``0 .. n-1`` are complete in every dataset.
    """
    lengths = [ds.shape[0] for ds in f["steps"].values() if isinstance(ds, h5py.Dataset) and ds.ndim >= 1]
    if "fields" in f:
        lengths += [ds.shape[0] for ds in f["fields"].values()
                    if isinstance(ds, h5py.Dataset) and ds.attrs.get("per_step", ds.ndim == 2)]
    return min(lengths) if lengths else 0


class Results:
    """A results file of a run driven by the engine, opened for reading, cut to its finished steps.

    Reads the discretization, the parameters and the per-step records at once; nodal fields
    are read one step at a time (:meth:`nodal`, :meth:`field`), so a large run is never
    loaded whole.

    Parameters
    ----------
    path : str or Path
        The file or its run directory.

    Attributes
    ----------
    path : Path
    kind : str
        The model kind that wrote it.
    n : int
        Finished steps (see :func:`finished_steps`).
    discretization : StructuredGrid or SimplexMesh
        The nodes (:mod:`thinfilm.discretization`); of a refined mesh, the run's first mesh (each
        step's: :meth:`discretization_at`).
    adaptive : bool
        The mesh was refined during the run (``/meshes``).
    meshes : thinfilm.discretization.StoredMeshes or None
        The run's meshes, if it refined them.
    steps : dict of ndarray, each shape (n,)
        ``/steps/*`` cut to the finished steps.
    parameters, attrs : dict
        Attributes of ``/parameters`` and of the root.
    """

    def __init__(self, path):
        self.file = open_results(path)
        self.path = Path(self.file.filename)
        f = self.file
        try:
            self.attrs = attrs_dict(f)
            self.kind = self.attrs["kind"]
            self.parameters = attrs_dict(f["parameters"])
            self.discretization = discretization.read(f)
            if self.discretization is None or "fields" not in f:
                raise ResultsError(f"{self.path}: kind = {self.kind!r} has no nodal fields to read")
            self.n = finished_steps(f)
            self.steps = {name: ds[: self.n] for name, ds in f["steps"].items()}
            self.meshes = discretization.StoredMeshes.of(f)
            self.adaptive = self.meshes is not None
            self._versions = {}
            if self.adaptive:
                first = self.meshes.n_nodes(0)
                if "mesh" not in self.steps or first != self.discretization.n_nodes:
                    raise ResultsError(f"{self.path}: incomplete results of a refined mesh: /steps/mesh"
                                       f" {'found' if 'mesh' in self.steps else 'missing'}, /meshes begins with"
                                       f" {first} nodes, /mesh has {self.discretization.n_nodes}")
            else:
                n_values = f["fields/alpha"].shape[1]
                if n_values != self.discretization.n_nodes:
                    raise ResultsError(f"{self.path}: /fields/alpha has {n_values} nodes per step, the"
                                       f" {self.discretization.group} has {self.discretization.n_nodes}")
        except KeyError as err:
            f.close()
            raise ResultsError(f"{self.path}: incomplete {self.attrs.get('kind', '')} results: {err}") from None
        except BaseException:
            f.close()
            raise

    @property
    def n_planned(self):
        """Steps of the complete run, ``parameters.steps + 1`` (step 0 is t = 0)."""
        return int(self.parameters.get("steps", self.n - 1)) + 1

    @property
    def t(self):
        """Loads of the finished steps, shape (n,)."""
        return self.steps["t"]

    @property
    def t_max(self):
        """Final load of the complete run (the last finished one if not recorded)."""
        return float(self.parameters.get("t_max", self.t[-1] if self.n else 0.0))

    def components(self, name):
        """Values per node of field ``name`` (1 for a scalar)."""
        return int(self.file[f"fields/{name}"].attrs.get("components", 1))

    def mesh_version(self, k):
        """The version of the mesh finished step ``k`` was computed on (the number of refinement
        passes that made it; always 0 for a mesh that is not refined)."""
        self._check_step(k)
        return int(self.steps["mesh"][k]) if self.adaptive else 0

    def discretization_at(self, k):
        """The discretization finished step ``k`` was computed on: its refined mesh (with its
        :class:`~thinfilm.discretization.Refinement`), read once per version; for a
        discretization that does not change, :attr:`discretization`."""
        version = self.mesh_version(k)
        if not self.adaptive:
            return self.discretization
        if version not in self._versions:
            self._versions[version] = self.meshes.mesh(version)
        return self._versions[version]

    def _check_step(self, k):
        if not 0 <= k < self.n:
            raise IndexError(f"step {k} is not among the {self.n} finished steps")

    def nodal(self, name, k=None):
        """Field ``name`` of finished step ``k`` as stored, flat (a field stored once: ``k`` None);
        on a refined mesh, the ``n_nodes * components`` values of the step's own mesh."""
        ds = self.file[f"fields/{name}"]
        if k is None:
            return ds[()]
        self._check_step(k)
        if self.adaptive and ds.attrs.get("per_step", ds.ndim == 2):
            return ds[k, : self.meshes.n_nodes(self.mesh_version(k)) * self.components(name)]
        return ds[k]

    def field(self, name, k=None):
        """Field ``name`` of finished step ``k`` shaped on its discretization (a grid's
        ``(ny+1, nx+1)``; a mesh's ``(n_nodes,)`` or ``(n_nodes, components)``; on a refined mesh,
        the step's: :meth:`discretization_at`). A field stored with more values (a P2
        displacement, its edge midpoints' after its nodes') gives its nodes' values."""
        components = self.components(name)
        values = self.nodal(name, k)
        d = self.discretization if k is None else self.discretization_at(k)
        return d.shaped(values[: d.n_nodes * components], components)

    def close(self):
        self.file.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
