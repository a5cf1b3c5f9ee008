"""``thinfilm info``: what a results file holds, in a few lines.

The scene, the versions, the parameters, the discretization, how far the run got and its last
energies are read the same way for every kind; the kind adds its own lines
(:meth:`thinfilm.kinds.ModelKind.info`: the engine's timings and solver work, or the exact
run's events).
"""

from __future__ import annotations

import math
from pathlib import Path

import h5py

from thinfilm import discretization, kinds
from thinfilm.results.reader import attrs_dict, finished_steps, open_results

__all__ = ["describe", "fmt", "seconds"]


def fmt(value):
    """A parameter value for one line: floats with 6 significant digits (also in lists), the
    rest as is."""
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, list):
        return "[" + ", ".join(fmt(v) for v in value) + "]"
    return str(value)


def seconds(s):
    """Wall time for people: ``0.42 s``, ``3 min 12 s``, ``2 h 05 min``."""
    if not math.isfinite(s):
        return "n/a"
    if s < 60:
        return f"{s:.3g} s"
    if s < 3600:
        return f"{int(s // 60)} min {s % 60:02.0f} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


def _adaptive_line(meshes, versions):
    """``mesh: adaptive, 7 versions, 1234 -> 5678 nodes; ...``: the meshes of a run refined as it went."""
    pass_nodes = meshes.pass_nodes
    line = (f"mesh: adaptive, {len(pass_nodes)} version{'s' if len(pass_nodes) != 1 else ''},"
            f" {pass_nodes[0]} -> {pass_nodes[-1]} nodes")
    if len(versions):
        last = int(versions[-1])
        line += (f"; the last finished step on version {last} ({pass_nodes[last]} nodes,"
                 f" {meshes.n_cells(last)} {meshes.cell_name})")
    return line


def describe(path):
    """The report of ``thinfilm info``: scene, versions, progress, last energies, the kind's lines.

    Parameters
    ----------
    path : str or Path
        A ``results.h5`` or its run directory.

    Returns
    -------
    str
        Several lines, no trailing newline. Energies are printed with 12 significant digits.

    Raises
    ------
    thinfilm.results.reader.ResultsError
    """
    with open_results(path) as f:
        path = Path(f.filename)
        attrs = attrs_dict(f)
        kind = attrs["kind"]
        params = attrs_dict(f["parameters"])
        n = finished_steps(f)
        planned = int(params.get("steps", n - 1)) + 1
        steps = {name: ds[:n] for name, ds in f["steps"].items() if isinstance(ds, h5py.Dataset)}
        lines = [f"results: {path} (kind = {kind}, format {attrs.get('format_version')})",
                 f"created: {attrs.get('created', 'unknown')}"]
        # thinfilm first, then its dependencies in the order the writer stores them.
        order = {"thinfilm_version": 0, "numpy_version": 1, "numba_version": 2, "h5py_version": 3}
        keys = sorted((key for key in attrs if key.endswith("_version") and key != "format_version"),
                      key=lambda key: (order.get(key, len(order)), key))
        versions = [f"{key[: -len('_version')]} {attrs[key]}" for key in keys]
        lines.append("versions: " + (", ".join(versions) if versions else "not recorded"))
        lines.append(f"scene: {attrs.get('scene_source', 'unknown')}")
        lines += ["    " + line if line else "" for line in str(attrs.get("scene", "")).strip("\n").splitlines()]
        if attrs.get("scene_overrides"):
            lines.append(f"overrides: {attrs['scene_overrides']}")
        lines.append("parameters: " + ", ".join(f"{k} = {fmt(v)}" for k, v in params.items()))
        if "material" in f:
            lines.append("material: " + ", ".join(f"{k} = {fmt(v)}" for k, v in attrs_dict(f["material"]).items()))
        nodes = discretization.read(f)
        if nodes is not None:
            lines.append(nodes.describe())
        meshes = discretization.StoredMeshes.of(f)
        if meshes is not None:
            lines.append(_adaptive_line(meshes, f["steps"]["mesh"][:n] if "mesh" in f["steps"] else []))

        t = steps["t"]
        t_max = params.get("t_max")
        state = "complete" if n >= planned else "stopped early or still running"
        span = f"t = {t[0]:.6g} .. {t[-1]:.6g}" if n else "none"
        lines.append(f"steps finished: {n} of {planned} ({span}; t_max = {fmt(t_max)}): {state}")
        if n:
            lines.append(f"last finished step: {n - 1}, t = {t[-1]:.12g}")
            lines.append(f"  elastic = {steps['elastic'][-1]:.12g}")
            lines.append(f"  surface = {steps['surface'][-1]:.12g}")
            lines.append(f"  total   = {steps['total'][-1]:.12g}")
        lines += kinds.get(kind).info(f, steps)
    return "\n".join(lines)
