"""The specimens a ``kind = "fem"`` scene can name (``[geometry] kind``): one module each, ending
in one :class:`~fem3d.specimens.specimen.Specimen` record called ``SPECIMEN``.

The built-in specimens are listed in :data:`BUILTIN` by module path and imported only when a
scene names them (or asks for every name). Adding one is one new module and one line in
:data:`BUILTIN`; a specimen defined outside the toolkit is made known with :func:`register`.
:mod:`~fem3d.specimens.gmsh_tools` is the gmsh plumbing the mesh functions share (sessions,
polygons, groups, size fields, reading meshes), :mod:`~fem3d.specimens.checks` their argument
checks.
"""

from __future__ import annotations

import importlib

from fem3d.specimens.specimen import Specimen

__all__ = ["BUILTIN", "register", "names", "get", "reference"]

#: Specimens that ship with the toolkit: ``geometry.kind`` -> module that defines ``SPECIMEN``.
BUILTIN = {
    "lpanel": "fem3d.specimens.lpanel",
    "three_point_bending": "fem3d.specimens.three_point_bending",
    "nooru_mohamed": "fem3d.specimens.nooru_mohamed",
    "brokenshire": "fem3d.specimens.brokenshire",
    "double_torsion": "fem3d.specimens.double_torsion",
    "file": "fem3d.specimens.file",
}

_registered: dict[str, Specimen] = {}


def register(specimen: Specimen) -> Specimen:
    """Make ``specimen`` known by its ``name`` (replacing a specimen of that name); returns it."""
    _registered[specimen.name] = specimen
    return specimen


def names() -> tuple[str, ...]:
    """The ``geometry.kind`` of every known specimen, built-in first."""
    return tuple(BUILTIN) + tuple(name for name in _registered if name not in BUILTIN)


def get(name: str) -> Specimen:
    """The specimen called ``name``.

    Raises
    ------
    KeyError
        If no specimen has that name.
    """
    if name in _registered:
        return _registered[name]
    if name not in BUILTIN:
        raise KeyError(f"unknown specimen {name!r} (known: {', '.join(names())})")
    specimen = importlib.import_module(BUILTIN[name]).SPECIMEN
    _registered[name] = specimen
    return specimen


def reference() -> str:
    """The ``[geometry]`` keys of the built-in specimens as a Markdown table, from their records
    (``docs/scenes.md`` holds it between ``<!-- geometry-keys -->`` markers; a test checks they
    agree).

    Returns
    -------
    str
        The table's lines, header first.
    """
    rows = ["| kind | key | default | allowed | meaning |", "|---|---|---|---|---|"]
    for name in BUILTIN:
        specimen = get(name)
        dims = " or ".join(f"{d}D" for d in specimen.dims)
        rows.append(f"| `\"{name}\"` ({dims}) | | | | {specimen.doc} |")
        for key in specimen.keys:
            allowed = key.allowed()
            allowed = allowed[len("must be "):] if allowed.startswith("must be ") else allowed
            if not set(specimen.dims) <= set(key.dims):
                allowed += " (" + " or ".join(f"{d}D" for d in key.dims) + " only)"
            rows.append(f"| | `{key.name}` | {_shown(key)} | {allowed} | {key.doc} |")
    return "\n".join(rows)


def _shown(key):
    """A key's default as the reference shows it."""
    if key.default is None:
        return "required" if key.file else "derived"
    if isinstance(key.default, str):
        return f'"{key.default}"'
    if isinstance(key.default, tuple):
        return "[" + ", ".join(f"{v:g}" for v in key.default) + "]"
    return f"{key.default:g}"
