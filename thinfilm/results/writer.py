"""Writing ``results.h5`` step by step, and ``summary.json``.

Everything a plot, a summary, a resumed run or a later comparison needs is read back from
these files, never from live objects (:mod:`thinfilm.results.reader`). The layout of a run
driven by the engine, whatever its kind::

    /                  attrs: format = "thinfilm-results", format_version, kind, scene (the
                       TOML text), scene_source, scene_overrides (JSON, if any), thinfilm_version,
                       numpy_version, numba_version, h5py_version, created (UTC, ISO 8601);
                       extended (JSON, if a resumed run extended the loads: thinfilm.resume);
                       threads (JSON: the setting, the cores, OpenBLAS's and Numba's pool;
                       thinfilm.threads); inputs (JSON: the SHA-256 of each file the scene
                       reads, by scene key: thinfilm.resume.input_digests)
    /parameters        attrs: the kind's parameters (t_max and steps always)
    /<group>           attrs only, one group per table of the kind's choosing (e.g. /material)
    /grid or /mesh     the discretization (thinfilm.discretization)
    /steps/<name>      (n,) one value per finished step: the StepRecord's t, elastic, surface,
                       total, iterations, u_solves, u_solves_skipped, backtracks, trials,
                       trials_accepted, time_u, time_alpha, time_total (seconds),
                       lowest_curvature, saddles_left, u_rescalable; then the kind's observables,
                       and threads (of MKL, OpenMP and Numba during the step; 0: not recorded)
    /fields/u          (n, n_nodes * components) displacement of each finished step
    /fields/alpha      (n, n_nodes) damage of each finished step
    /fields/<name>     a field stored once (e.g. the toughness of an imperfect film), with
                       attr per_step = False

A run whose mesh is refined as it goes (a discretization with a refinement,
thinfilm.discretization.Refinement) has ``/mesh`` as its first mesh and, besides::

    /meshes            every mesh of the run (thinfilm.discretization.StoredMeshes): points
                       (N, max(dim, 2)) and parents (N, 2) of every vertex ever made, in order;
                       pass_nodes (passes + 1,), marked and marked_offsets (the refinement
                       passes); cells_<v> for each version v a step was computed on
    /steps/mesh        (n,) int64: the version of each step's mesh
    /fields/u          (n, width), maxshape (None, None): row k holds its version's
                       n_nodes * components values first, NaN after them (width: the largest
                       version's so far)
    /fields/alpha      (n, width), the same

``docs/results.md`` describes it for users. A backtrack to step k truncates every per-step
dataset to k steps before step k is rewritten, so the file always holds the current evolution
up to its last finished step; the stored meshes stay (the mesh never coarsens).

The file is made whole under a temporary name and renamed into place, then written step by
step through a rollback journal (:mod:`thinfilm.results.journal`): each finished step is
flushed and committed, and a process killed at any instant leaves a file that reads (and
resumes) as it stood at the last commit, so a kill costs at most the step in flight
(``docs/results.md#stopping-and-resuming``).
"""

from __future__ import annotations

import json
import os
from datetime import datetime, timezone
from pathlib import Path

import h5py
import numba
import numpy as np

from thinfilm import __version__
from thinfilm.discretization import Refinement, SimplexMesh, StoredMeshes, prolong
from thinfilm.results.journal import JournaledFile, JournalError, journal_path
from thinfilm.results.reader import FORMAT, FORMAT_VERSION, attrs_dict, finished_steps, open_committed
from thinfilm.resume import INPUTS_ATTRIBUTE, ResumeError, check_inputs, check_resume
from thinfilm.threads import threads_summary

__all__ = ["ResumeError", "ResultsWriter", "check_stored_inputs", "STEP_FIELDS", "INTEGER_STEP_FIELDS",
           "SUMMARY_STEP_FIELDS",
           "root_attributes", "write_json", "write_summary"]

#: Per-step records of an engine run, in /steps (names of thinfilm.engine.records.StepRecord).
STEP_FIELDS = ("t", "elastic", "surface", "total", "iterations", "u_solves", "u_solves_skipped",
               "backtracks", "trials", "trials_accepted", "time_u", "time_alpha", "time_total",
               "lowest_curvature", "saddles_left", "u_rescalable", "kkt", "stopped_by_energy",
               "newton_steps", "newton_attempts", "newton_failures", "newton_rejections", "inertia_corrections",
               "linear_solves", "factorizations", "kkt_final", "time_newton", "refinements",
               "elastic_previous", "surface_previous", "damage_newton_iterations")
#: The integer ones among them (and the kinds' observables that count).
INTEGER_STEP_FIELDS = ("iterations", "u_solves", "u_solves_skipped", "backtracks", "trials", "trials_accepted",
                       "saddles_left", "u_rescalable", "stopped_by_energy", "threads", "newton_steps",
                       "newton_attempts", "newton_failures", "newton_rejections", "inertia_corrections",
                       "linear_solves", "factorizations", "mesh", "refinements", "nodes", "cells",
                       "damage_newton_iterations")
#: The per-step lists of summary.json (those a file written before they existed lacks are left out).
SUMMARY_STEP_FIELDS = ("t", "elastic", "surface", "total", "iterations", "newton_steps", "newton_rejections",
                       "linear_solves", "factorizations", "kkt_final")


def root_attributes(scene):
    """The root attributes of every results file: format, kind, the scene, versions, date."""
    attrs = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "kind": scene.kind, "scene": scene.text,
        "scene_source": scene.source,
    }
    if getattr(scene, "overrides", None):
        attrs["scene_overrides"] = scene.overrides
    attrs.update({
        "thinfilm_version": __version__, "numpy_version": np.__version__, "numba_version": numba.__version__,
        "h5py_version": h5py.__version__, "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    })
    return attrs


def _atomic_path(path):
    return path.with_name(f".{path.name}.partial")


def write_json(path, content, indent=1):
    """Write ``content`` as JSON under a temporary name, then rename it: never half a file."""
    path = Path(path)
    partial = _atomic_path(path)
    partial.write_text(json.dumps(content, indent=indent) + "\n", encoding="utf-8")
    os.replace(partial, path)
    return path


def check_stored_inputs(path, digests):
    """Refuse to resume ``path`` if the scene's input files differ from those stored in it
    (:func:`thinfilm.resume.check_inputs`); read-only, on the file as of its last commit.

    Parameters
    ----------
    path : Path
        The results file.
    digests : dict
        :func:`thinfilm.resume.input_digests` of the resumed scene.

    Raises
    ------
    ResumeError
    """
    if not digests:
        return
    try:
        f = open_committed(path)
    except OSError as err:
        raise ResumeError(f"{path} cannot be read back to resume it ({' '.join(str(err).split())}); run with"
                          " --force to start over") from None
    with f:
        check_inputs(path, attrs_dict(f).get(INPUTS_ATTRIBUTE), digests)


class ResultsWriter:
    """``results.h5`` of a run driven by the engine, written and committed step by step.

    Parameters
    ----------
    path : Path
    scene : object
        The validated scene (its ``kind``, ``text``, ``source``, ``overrides`` are stored).
    parameters : dict
        Attributes of ``/parameters``.
    discretization : StructuredGrid or SimplexMesh
        Written to ``/grid`` or ``/mesh``. A mesh with a refinement (the run's first mesh, version
        0: :class:`thinfilm.discretization.Refinement`) makes a file whose steps may be computed on
        refined meshes (:meth:`write_step` with ``mesh``): ``/meshes``, ``/steps/mesh``, and
        field rows of each step's own length (the module docstring).
    components : dict, optional
        Values per node of ``u`` and ``alpha`` (default 1 each; 2 or 3 for a vector ``u``).
    sizes : dict, optional
        Values per step of a field that holds more than ``n_nodes * components`` (a P2
        displacement: its first ``n_nodes * components`` values are those of the nodes, what
        the plots and XDMF read; the rest those of the edge midpoints); default
        ``n_nodes * components``. Not for a refined mesh, whose steps hold ``n_nodes *
        components`` values of their own mesh.
    observables : sequence of str, optional
        Names of the kind's own per-step values (e.g. a reaction force), stored in
        ``/steps/<name>`` beside the engine's records.
    constant : dict, optional
        Fields stored once, ``{name: ndarray of shape (n_nodes,)}``; on resume they are
        checked against the stored ones (an imperfect film's toughness, which another numpy
        could draw differently from the same seed).
    groups : dict, optional
        ``{group name: attributes}``, written as attribute-only groups (e.g. ``material``).
    resume : bool
        Continue an existing file written by the same scene, or by one that the scene extends
        (:func:`thinfilm.resume.check_resume`), from the same input files
        (:func:`thinfilm.resume.check_inputs`), on as many nodes; all checked on the file as
        it stood at its last commit before it is opened for writing, so a refused scene leaves
        it as it was. The root's scene attributes and ``/parameters`` then take the new
        scene's, and an extension is recorded in the root attribute ``extended``. A file of a
        refined mesh is resumed with the run's first mesh (``/mesh``) as ``discretization``, and
        the run goes on on its current mesh (:meth:`stored_refinement`, :meth:`history`).
    inputs : dict, optional
        The SHA-256 of the files the scene reads (:func:`thinfilm.resume.input_digests`),
        stored in the root attribute ``inputs`` (JSON).

    Attributes
    ----------
    continuation : thinfilm.resume.Continuation or None
        What a resumed run continues (None for a new file).
    adaptive : bool
        The file stores a mesh refined during the run (``/meshes``).
    """

    def __init__(self, path, scene, parameters, discretization, *, components=None, observables=(),
                 constant=None, groups=None, resume=False, sizes=None, inputs=None):
        self.path = Path(path)
        self.file = None
        self.observables = tuple(observables)
        self.step_fields = STEP_FIELDS + self.observables
        constant = constant or {}
        self.continuation = None
        self.inputs = dict(inputs or {})
        self.adaptive = getattr(discretization, "refinement", None) is not None
        if self.adaptive:
            for name, size in (sizes or {}).items():
                if size != discretization.n_nodes * (components or {}).get(name, 1):
                    raise ValueError(f"sizes[{name!r}] = {size}: a step on a refined mesh holds n_nodes * components"
                                     " values of its own mesh")
        if resume:
            # every check on the file as it stood at its last commit, read-only: a refused
            # resume leaves the file (and a killed writer's journal) as they were
            try:
                f = open_committed(self.path)
            except OSError as err:
                raise ResumeError(f"{self.path} cannot be read back to resume it ({' '.join(str(err).split())});"
                                  " run with --force to start over") from None
            with f:
                self.continuation = check_resume(self.path, attrs_dict(f), scene)
                check_inputs(self.path, attrs_dict(f).get(INPUTS_ATTRIBUTE), self.inputs)
                if (StoredMeshes.group_name in f) != self.adaptive:
                    written, scene_mesh = ("a mesh refined during the run", "one that is not") if not self.adaptive \
                        else ("a mesh that is not refined", "one refined during the run")
                    raise ResumeError(f"{self.path} was written on {written}, the scene has {scene_mesh}; it cannot"
                                      " be resumed (run with --force to start over)")
                if self.adaptive:  # the run's first mesh
                    stored = f["mesh/points"].shape[0]
                else:
                    stored = f["fields/alpha"].shape[1] if "fields/alpha" in f else None
                if stored is not None and stored != (sizes or {}).get("alpha", discretization.n_nodes):
                    raise ResumeError(f"{self.path} was written on {stored} nodes, the scene has"
                                      f" {discretization.n_nodes}; it cannot be resumed (run with --force to start"
                                      " over)")
                for name, values in constant.items():
                    if not np.array_equal(f["fields"][name][()], values):
                        raise ResumeError(f"{self.path}: this installation computes another {name} field than"
                                          " the stored one (numpy's random generator changed?); it cannot be"
                                          " resumed (run with --force)")
            self._open()  # rolls back a step a killed writer left half written
            try:
                self._continue_with(scene, parameters)
                n = self.trim()  # a step whose write was cut short is not finished
                for name in self.step_fields:
                    if name not in self.file["steps"]:   # written before the record existed
                        self._create_step_dataset(self.file["steps"], name, n)
                self._commit()
            except BaseException:
                self.journaled.failed = True  # not committed: the next opening undoes it all
                self.close()
                raise
            return
        # made whole under a temporary name, then renamed: never a file that cannot be read
        partial = _atomic_path(self.path)
        with h5py.File(partial, "w") as f:
            f.attrs.update(root_attributes(scene))
            if self.inputs:
                f.attrs[INPUTS_ATTRIBUTE] = json.dumps(self.inputs)
            f.create_group("parameters").attrs.update(parameters)
            for name, attrs in (groups or {}).items():
                f.create_group(name).attrs.update(attrs)
            discretization.write(f)
            if self.adaptive:
                StoredMeshes.create(f, discretization)
            steps = f.create_group("steps")
            for name in self.step_fields + (("mesh",) if self.adaptive else ()):
                self._create_step_dataset(steps, name, 0)
            fields = f.create_group("fields")
            n_nodes = discretization.n_nodes
            for name in ("u", "alpha"):
                c = (components or {}).get(name, 1)
                n = (sizes or {}).get(name, n_nodes * c)
                if self.adaptive:
                    # rows widen as the mesh is refined: chunks of at least 2^14 values, so that a
                    # first mesh much coarser than the last does not split a row into many chunks
                    ds = fields.create_dataset(name, shape=(0, n), maxshape=(None, None), dtype=np.float64,
                                               chunks=(1, min(max(n, 1 << 14), 1 << 20)), fillvalue=np.nan)
                else:
                    ds = fields.create_dataset(name, shape=(0, n), maxshape=(None, n), dtype=np.float64,
                                               chunks=(1, min(n, 1 << 20)))
                if c > 1:
                    ds.attrs["components"] = c
            for name, values in constant.items():
                ds = fields.create_dataset(name, data=np.asarray(values, dtype=np.float64))
                ds.attrs["per_step"] = False
        # a journal left by an earlier run of this directory belongs to the file replaced
        journal_path(self.path).unlink(missing_ok=True)
        os.replace(partial, self.path)
        self._open()

    def _open(self):
        """Open the file for writing through its rollback journal."""
        try:
            self.journaled = JournaledFile(self.path)
        except JournalError as err:
            raise ResumeError(f"{err}; it cannot be resumed now") from None
        try:
            self.file = h5py.File(self.journaled, "r+")
        except BaseException:
            self.journaled.close()
            raise

    def _commit(self):
        """Flush and commit: what the file holds now is what a kill from here on returns to."""
        self.file.flush()
        self.journaled.commit()

    def _continue_with(self, scene, parameters):
        """The resumed file takes the new scene: its text, source and overrides at the root,
        its parameters in ``/parameters`` (the same model, perhaps more steps and other
        snapshots), and an extension is appended to the root's ``extended`` (JSON list of
        ``{"after_step", "t_max", "steps", "date"}``: where the run stood and what it was
        planned to before)."""
        f, c = self.file, self.continuation
        if c.extended:
            history = json.loads(f.attrs.get("extended", "[]"))
            history.append({"after_step": finished_steps(f) - 1, "t_max": c.t_max_before, "steps": c.steps_before,
                            "date": datetime.now(timezone.utc).isoformat(timespec="seconds")})
            f.attrs["extended"] = json.dumps(history)
        f.attrs["scene"], f.attrs["scene_source"] = scene.text, scene.source
        if self.inputs:  # a file written before the digests were stored gets them
            f.attrs[INPUTS_ATTRIBUTE] = json.dumps(self.inputs)
        if getattr(scene, "overrides", None):
            f.attrs["scene_overrides"] = scene.overrides
        elif "scene_overrides" in f.attrs:
            del f.attrs["scene_overrides"]
        group = f["parameters"]
        for key in list(group.attrs):
            del group.attrs[key]
        group.attrs.update(parameters)

    @staticmethod
    def _create_step_dataset(steps, name, n):
        """``/steps/<name>`` with ``n`` rows (0 for integers, NaN for floats: not recorded)."""
        integer = name in INTEGER_STEP_FIELDS
        ds = steps.create_dataset(name, shape=(n,), maxshape=(None,), dtype=np.int64 if integer else np.float64,
                                  chunks=(256,))
        if n:
            ds[:] = 0 if integer else np.nan

    def write_step(self, record, state, observed=None, mesh=None):
        """Store step ``record.index`` (truncating any later steps) and commit.

        The fields are written before the step's records, so a step counts as finished
        (``/steps/t`` has it) only once its fields are stored.

        Parameters
        ----------
        record : thinfilm.engine.records.StepRecord
        state : thinfilm.engine.records.State
        observed : dict, optional
            The kind's observables at this state, ``{name: float}``.
        mesh : SimplexMesh, optional
            The mesh the step was computed on, with its refinement (a file of a refined mesh):
            a version not stored yet is stored with the step, in the same commit
            (:meth:`thinfilm.discretization.StoredMeshes.store`). Default: the largest stored
            version. Ignored for a mesh that is not refined.

        Raises
        ------
        ValueError
            A field whose length is not that of the step's mesh, or a refinement that does not
            extend the stored one.
        """
        k = record.index
        f = self.file
        if not self.adaptive:
            if mesh is not None and getattr(mesh, "refinement", None) is not None:
                raise ValueError(f"{self.path} stores a mesh that is not refined: a step on a refined mesh cannot be"
                                 " written into it")
            for name, values in (("u", state.u), ("alpha", state.alpha)):
                ds = f["fields"][name]
                ds.resize((k + 1, ds.shape[1]))
                ds[k] = values
        else:
            version = self._store_mesh(mesh)
            n_nodes = StoredMeshes.of(f).n_nodes(version)
            for name, values in (("u", state.u), ("alpha", state.alpha)):
                ds = f["fields"][name]
                values = np.asarray(values, dtype=np.float64).ravel()
                size = n_nodes * int(ds.attrs.get("components", 1))
                if values.size != size:
                    raise ValueError(f"step {k}: {name} has {values.size} values, its mesh (version {version},"
                                     f" {n_nodes} nodes) {size}")
                width = max(ds.shape[1], size)
                ds.resize((k + 1, width))
                row = np.full(width, np.nan)  # the whole row: no value of an earlier write stays behind
                row[:size] = values
                ds[k] = row
            ds = f["steps"]["mesh"]
            ds.resize((k + 1,))
            ds[k] = version
        for name in self.step_fields:
            ds = f["steps"][name]
            ds.resize((k + 1,))
            ds[k] = observed[name] if name in self.observables else getattr(record, name)
        self._commit()

    def _store_mesh(self, mesh):
        """The version of a step's mesh, stored if it is not yet (a file of a refined mesh)."""
        meshes = StoredMeshes.of(self.file)
        if mesh is not None:
            return meshes.store(mesh)
        version = meshes.versions - 1
        if not meshes.has_cells(version):
            if version:
                raise ValueError(f"{self.path}: version {version} of the mesh has no cells stored; give the step's"
                                 " mesh")
            meshes.store(self._first_mesh())
        return version

    def _first_mesh(self):
        """The run's first mesh as the file stores it (``/mesh``), version 0."""
        first = SimplexMesh.read(self.file["mesh"])
        return SimplexMesh(first.points, first.cells, Refinement.initial(first.n_nodes))

    def write_attribute(self, name, value):
        """Set the root attribute ``name`` (a run's circumstances, such as its threads)."""
        self.file.attrs[name] = value
        self._commit()

    def trim(self):
        """Cut every per-step dataset to the finished steps (after a write was interrupted);
        returns their number."""
        f = self.file
        n = finished_steps(f)
        for name in f["steps"]:
            f["steps"][name].resize((n,))
        for name in ("u", "alpha"):
            ds = f["fields"][name]
            ds.resize((n, ds.shape[1]))
        self._commit()
        return n

    def history(self, all_alpha=True):
        """The finished steps, as states to resume the evolution from.

        Parameters
        ----------
        all_alpha : bool
            Read the damage of every finished step (backtracking may return to any of
            them); otherwise only the last one's, the others' left as None.

        Returns
        -------
        list of thinfilm.engine.records.State
            One per finished step; the last one carries ``u``. On a refined mesh every field is
            carried to the largest stored version (the run's current mesh,
            :meth:`stored_refinement`) by :func:`thinfilm.discretization.prolong`.
        """
        from thinfilm.engine.records import State

        f = self.file
        n = finished_steps(f)
        t, elastic, surface = (f["steps"][name][:n] for name in ("t", "elastic", "surface"))
        rescalable = f["steps"]["u_rescalable"][:n] if "u_rescalable" in f["steps"] else np.zeros(n)
        refinement = self.stored_refinement()
        versions = f["steps"]["mesh"][:n] if refinement is not None else None

        def read(name, k):
            if refinement is None:
                return f["fields"][name][k]
            ds = f["fields"][name]
            components = int(ds.attrs.get("components", 1))
            n_from = int(refinement.pass_nodes[versions[k]])
            return prolong(ds[k, : n_from * components], refinement, n_from, components)

        states = []
        for k in range(n):
            last = k == n - 1
            alpha = read("alpha", k) if (all_alpha or last) else None
            u = read("u", k) if last else None
            # energies from a coarser version than the run's current mesh are stale
            # (State.stale), as the uninterrupted run holds them
            stale = refinement is not None and int(refinement.pass_nodes[versions[k]]) < int(refinement.pass_nodes[-1])
            states.append(State(float(t[k]), u, alpha, float(elastic[k]), float(surface[k]),
                                u_rescalable=bool(last and rescalable[k]), stale=stale))
        return states

    def stored_refinement(self):
        """The :class:`~thinfilm.discretization.Refinement` of the largest stored version of a
        refined mesh (the run's current mesh, on which a resumed run rebuilds its model: the
        mesh never coarsens, and a backtrack keeps the versions stored); None for a mesh that
        is not refined."""
        meshes = StoredMeshes.of(self.file)
        return None if meshes is None else meshes.refinement()

    def close(self):
        """Close the file (HDF5 writes what it still holds) and commit it; if that fails (a
        write failed before), the journal stays and the next opening returns the file to its
        last finished step."""
        if self.file is None:
            return
        try:
            self.file.close()
            self.journaled.commit()
        finally:
            self.file = None
            self.journaled.close()


def write_summary(path, scene, results, extra=None):
    """``summary.json`` of a run driven by the engine.

    ``{"kind": ..., "scene": <scene file>, "parameters": {...}, <the kind's own entries>,
    "threads": {...} (:func:`thinfilm.threads.threads_summary`), "steps": {"t": [...], "elastic": [...], ...}}``
    with the per-step lists :data:`SUMMARY_STEP_FIELDS` (``kkt_final``: the scaled KKT residual
    each step ended at, :attr:`thinfilm.engine.records.StepRecord.kkt_final`; NaN is written as
    ``NaN``).

    Parameters
    ----------
    path : Path
    scene : object
        The validated scene.
    results : thinfilm.results.reader.Results
        The run's open results (finished steps).
    extra : dict, optional
        The kind's own entries (the film's crack events, for example); its ``"steps"`` entry,
        if any, adds per-step lists to ``"steps"`` (a solid's force and crack length).
    """
    extra = dict(extra or {})
    steps = {name: results.steps[name].tolist() for name in SUMMARY_STEP_FIELDS if name in results.steps}
    steps.update(extra.pop("steps", {}))
    content = {"kind": scene.kind, "scene": scene.source, "parameters": results.parameters, **extra}
    threads = threads_summary(results.attrs.get("threads"), results.steps.get("threads"))
    if threads is not None:
        content["threads"] = threads
    content["steps"] = steps
    return write_json(path, content)
