"""Scene files: TOML text -> validated, frozen dataclasses, by the model kind they name.

A scene names its model (``[model] kind``); the kind's own module reads the rest
(:mod:`thinfilm.kinds`: ``"exact1d"`` in :mod:`thinfilm.exact1d.scene`, ``"plate"`` in
:mod:`thinfilm.plate.scene`). What every kind shares is here:

* :class:`SceneError`, whose message is one line naming the file, the key path, the value
  and what is allowed (the command line prints it and exits with status 2), and
  :class:`Table`, the typed getters that raise it: unknown keys (with the closest valid key
  suggested), wrong types, values out of range;
* :func:`read_solver`: the ``[solver]`` table, read straight into the engine's option
  objects (:mod:`thinfilm.engine.options`, where every option is declared once) and the
  choice of linear solver; :func:`read_snapshots`: ``[output] snapshots``;
* :func:`parse_scene` and :func:`load_scene`, with ``overrides``: dotted keys set on the
  file's tables before validation (``{"model.winkler": 3e6, "domain.cells": [200, 200]}``),
  as tests, studies and parameter scans use case files.

Everything is checked before anything is computed or written.
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

from thinfilm import kinds
from thinfilm.engine.options import SCENE_GROUPS, EngineOptions
from thinfilm.options import OptionError, Rule, option, reference_rows, scene_keys, validate
from thinfilm.solvers.linear import KINDS as LINEAR_KINDS
from thinfilm.solvers.linear import PRECISIONS

__all__ = ["SceneError", "Table", "show", "SolverSettings", "read_solver", "read_snapshots", "parse_scene", "load_scene",
           "apply_overrides", "read_text"]


class SceneError(ValueError):
    """A scene file that cannot be run; the message is one line for the user.

    Parameters
    ----------
    source : str
        The scene file (or ``"<string>"``).
    key : str or None
        Dotted key path, e.g. ``"model.lam"``; None for file-level problems.
    message : str
        What is wrong and what is allowed.
    """

    def __init__(self, source, key, message):
        self.source = str(source)
        self.key = key
        self.detail = message
        if key is None:
            text = f"{self.source}: {message}"
        elif message.startswith("= "):  # "model.lam = -1.0: must be ..."
            text = f"{self.source}: {key} {message}"
        else:
            text = f"{self.source}: {key}: {message}"
        super().__init__(text)


def show(value):
    """A TOML value as a scene error shows it: strings quoted, booleans lower case, short lists."""
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        if len(value) <= 6 and all(not isinstance(v, (list, dict)) for v in value):
            return "[" + ", ".join(show(v) for v in value) + "]"
        return "an array"
    return repr(value)


class Table:
    """One TOML table being read: typed getters that raise :class:`SceneError`.

    Parameters
    ----------
    source : str
        The scene file (for messages).
    name : str
        The table's dotted name (``"model"``, ``"solver"``); ``"scene"`` for the top level.
    data : dict
        The table as TOML read it.
    allowed : sequence of str
        Its valid keys: any other is refused, with the closest valid key suggested.
    """

    def __init__(self, source, name, data, allowed):
        self.source, self.name = source, name
        if not isinstance(data, dict):
            raise SceneError(source, name, f"= {show(data)}: must be a table [{name}]")
        self.data = data
        for key in data:
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.5)
                hint = f"; did you mean '{close[0]}'?" if close else ""
                valid = ", ".join(allowed)
                raise SceneError(source, self.path(key), f"unknown key{hint} (valid keys in [{name}]: {valid})")

    def path(self, key):
        return key if self.name == "scene" else f"{self.name}.{key}"

    def has(self, key):
        return key in self.data

    def fail(self, key, value, allowed):
        """Refuse ``key``'s ``value``, saying what is ``allowed``.

        Raises
        ------
        SceneError
            Always: ``<key> = <value>: <allowed>``.
        """
        raise SceneError(self.source, self.path(key), f"= {show(value)}: {allowed}")

    def required(self, key):
        """The value of ``key``, which must be given (:class:`SceneError` otherwise)."""
        if key not in self.data:
            raise SceneError(self.source, self.path(key), "missing (required)")
        return self.data[key]

    def number(self, key, *, minimum=None, exclusive=True, default=None):
        """A finite real number (TOML float or integer), optionally bounded below."""
        if default is not None and key not in self.data:
            return float(default)
        value = self.required(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(key, value, "must be a finite number")
        if minimum is not None:
            if exclusive and not value > minimum:
                self.fail(key, value, "must be a positive number" if minimum == 0 else f"must be > {minimum}")
            if not exclusive and not value >= minimum:
                self.fail(key, value, f"must be >= {minimum}")
        return float(value)

    def integer(self, key, *, minimum=None, default=None):
        """An integer, optionally bounded below (inclusive)."""
        if default is not None and key not in self.data:
            return int(default)
        value = self.required(key)
        if isinstance(value, bool) or not isinstance(value, int):
            self.fail(key, value, "must be an integer")
        if minimum is not None and value < minimum:
            self.fail(key, value, f"must be an integer >= {minimum}")
        return int(value)

    def boolean(self, key, *, default):
        """A TOML boolean."""
        if key not in self.data:
            return default
        value = self.data[key]
        if not isinstance(value, bool):
            self.fail(key, value, "must be true or false")
        return value

    def file(self, key, allowed):
        """The file that the string ``key`` names, relative to the scene file's folder (an
        absolute path, or any path of a scene given as a string, as it is). ``allowed``: the
        error's phrase for a value that is not a non-empty string. Whether the file exists
        and what it holds are the caller's checks."""
        raw = self.data.get(key)
        if not isinstance(raw, str) or not raw:
            self.fail(key, raw if raw is not None else "missing", allowed)
        path = Path(raw)
        if not path.is_absolute() and self.source != "<string>":
            path = Path(self.source).parent / path
        return path

    def interval(self, key, *, required=True):
        """A pair ``[a, b]`` of finite numbers with ``a < b``; None if absent and optional."""
        if key not in self.data and not required:
            return None
        value = self.required(key)
        ok = (isinstance(value, list) and len(value) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok or not value[0] < value[1]:
            self.fail(key, value, "must be an interval [a, b] of two finite numbers with a < b")
        return float(value[0]), float(value[1])

    def choice(self, key, choices, *, default=None):
        """A string among ``choices``."""
        if default is not None and key not in self.data:
            return default
        value = self.required(key)
        if not isinstance(value, str) or value not in choices:
            self.fail(key, value, "must be one of " + ", ".join(f'"{c}"' for c in choices))
        return value


@dataclass(frozen=True)
class SolverSettings(EngineOptions):
    """The ``[solver]`` table: the engine's options and the u-problem's linear solver.

    Attributes
    ----------
    altmin, backtrack, search, stability
        The engine's option groups (:class:`thinfilm.engine.options.EngineOptions`).
    linear : {"auto", "direct", "amg"}
        The linear solver of the u-problem (:func:`thinfilm.solvers.linear.make_solver`).
    precision : {"auto", "double", "single"}
        Precision of the direct solver's factorization (:class:`thinfilm.solvers.linear.DirectSolver`).
    threads : "auto" or int
        Threads of MKL, OpenMP and Numba (:mod:`thinfilm.threads`); never changes a result.
    """

    linear: str = option("auto", "u-problem solver: sparse direct, AMG-preconditioned CG, or chosen by size",
                         rule=Rule("choice", choices=LINEAR_KINDS))
    precision: str = option("auto", "precision of the direct solver's factorization: single (PARDISO) refines each solve"
                            " by CG to the tolerance alternate minimization asks; auto = single from 10^6 unknowns",
                            rule=Rule("choice", choices=PRECISIONS))
    threads: object = option("auto", "threads of MKL (PARDISO), OpenMP and Numba: the cores other processes leave"
                             " idle, measured at each step, or a fixed number (docs/speed.md#threads); `--threads`"
                             " overrides it", rule=Rule("integer", minimum=1, words=("auto",),
                                                        phrase='must be "auto" or an integer >= 1'))

    def __post_init__(self):
        validate(self)


def solver_keys():
    """Every ``[solver]`` key with its group and field: ``{key: (group or None, field)}``."""
    out = {}
    for group, cls, prefix, head in SCENE_GROUPS:
        for key, f in scene_keys(cls, prefix, head).items():
            out[key] = (group, f)
    for key, f in scene_keys(SolverSettings).items():  # its own: the groups are not options
        out[key] = (None, f)
    return out


def _option_value(table, key, f):
    """The value of option ``key`` as its field holds it (numbers as floats), type-checked."""
    rule = f.metadata["rule"]
    value = table.data[key]
    if not rule.accepts_type(value):
        table.fail(key, value, rule.type_phrase())
    return float(value) if rule.type == "number" else value


def read_solver(source, data, *, proportional, load="the load", extra=()):
    """Read a ``[solver]`` table into :class:`SolverSettings`.

    Parameters
    ----------
    source : str
        The scene file.
    data : dict
        The table (``{}`` if the scene has none: every default).
    proportional : bool
        Whether the scene's load is proportional to t (backtracking needs it).
    load : str
        The load, as the message refusing backtracking names it (``'load.kind = "indenter"'``).
    extra : sequence of str
        Keys of the kind's own (e.g. the film's ``coarse``), allowed here and read by it.

    Returns
    -------
    SolverSettings, Table
        The settings, and the table for the kind's own keys.

    Raises
    ------
    SceneError
        Naming ``solver.<key>`` of the first value not allowed.
    """
    keys = solver_keys()
    table = Table(source, "solver", data, tuple(keys) + tuple(extra))
    groups = {group: {} for group, *_ in SCENE_GROUPS}
    own = {}
    by_field = {}
    for key, (group, f) in keys.items():
        by_field[(group, f.name)] = key
        if table.has(key):
            (own if group is None else groups[group])[f.name] = _option_value(table, key, f)
    parts = {}
    for group, cls, *_ in SCENE_GROUPS:
        try:
            parts[group] = cls(**groups[group])
        except OptionError as err:
            table.fail(by_field[(group, err.name)], err.value, err.allowed)
    try:
        settings = SolverSettings(**parts, **own)
    except OptionError as err:
        table.fail(by_field[(None, err.name)], err.value, err.allowed)
    if settings.backtrack.kind != "none" and not proportional:
        table.fail("backtrack", settings.backtrack.kind, f"backtracking needs a load proportional to t; {load}"
                    ' is not (use "none")')
    return settings, table


def read_snapshots(source, data, t_max):
    """``[output] snapshots``: the loads at which a run draws its fields (in [0, t_max]), or None."""
    output = Table(source, "output", data, ("snapshots",))
    if not output.has("snapshots"):
        return None
    value = output.data["snapshots"]
    ok = (isinstance(value, list) and 1 <= len(value) <= 12
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and 0 <= v <= t_max
                  for v in value))
    if not ok:
        output.fail("snapshots", value, f"must be a list of 1 to 12 loads in [0, load.t_max = {t_max:g}]")
    return tuple(float(v) for v in value)


def require_tables(source, data, required, optional=()):
    """Check the top-level tables: the ``required`` ones present, no other than ``optional``."""
    top = Table(source, "scene", data, tuple(required) + tuple(optional))
    for name in required:
        if not top.has(name):
            raise SceneError(source, name, f"missing table [{name}] (required)")
    return top


def apply_overrides(data, overrides, source="<string>"):
    """Set dotted keys on a scene's parsed TOML, in place: ``{"model.winkler": 3e6}``.

    Tables named on the way are made if missing; a key whose parent is a value, not a table,
    is refused. The value None removes the key (TOML has no null): ``{"model.eta_dx": None,
    "model.eta": 0.005}`` trades one for the other. The result is validated like any scene
    afterwards.

    Raises
    ------
    SceneError
    """
    for dotted, value in (overrides or {}).items():
        parts = str(dotted).split(".")
        node = data
        for depth, part in enumerate(parts[:-1]):
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise SceneError(source, ".".join(parts[: depth + 1]), "is a value, not a table: cannot override"
                                 f" {dotted}")
        if value is None:
            node.pop(parts[-1], None)
        else:
            node[parts[-1]] = value
    return data


def parse_scene(text, source="<string>", overrides=None):
    """Validate scene text.

    Parameters
    ----------
    text : str
        TOML text of the scene.
    source : str, optional
        Name used in error messages (and to find files the scene names relative to itself).
    overrides : dict, optional
        Dotted keys to set before validation (:func:`apply_overrides`).

    Returns
    -------
    object
        The kind's frozen, validated scene: a dataclass with at least ``kind``, ``text``,
        ``source``, ``overrides`` (the overrides as JSON, or None), ``load`` (``t_max``,
        ``steps``, ``proportional``), and for kinds the engine runs ``solver``
        (:class:`SolverSettings`) and ``snapshots``.

    Raises
    ------
    SceneError
        On any problem, with a one-line message.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(source, None, f"TOML syntax error: {err}") from None
    apply_overrides(data, overrides, source)
    names = kinds.names()
    model = data.get("model")
    if not isinstance(model, dict):
        raise SceneError(source, "model", "missing table [model] (required), with kind = " +
                         " or ".join(f'"{k}"' for k in names))
    kind = Table(source, "model", {"kind": model.get("kind")} if "kind" in model else {}, ("kind",))
    kind = kind.choice("kind", names)
    scene = kinds.get(kind).parse(str(source), data, text)
    if overrides:
        scene = dataclasses.replace(scene, overrides=json.dumps(dict(overrides), sort_keys=True))
    return scene


def load_scene(path, overrides=None):
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        The TOML scene file.
    overrides : dict, optional
        Dotted keys to set before validation (:func:`apply_overrides`).

    Returns
    -------
    object
        The kind's frozen, validated scene.

    Raises
    ------
    SceneError
        If the file cannot be read or is not a valid scene.
    """
    path = Path(path)
    return parse_scene(read_text(path), source=str(path), overrides=overrides)


def read_text(path, what="scene file", error=SceneError):
    """The UTF-8 text of an input file, or ``error`` (a :class:`SceneError`) in one line."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error(path, None, "no such file") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as err:
        raise error(path, None, f"cannot read the {what} ({err.__class__.__name__})") from None


def solver_reference():
    """The ``[solver]`` keys as a Markdown table, from their declarations (``docs/scenes.md``
    holds this table between ``<!-- solver-options -->`` markers; a test checks they agree).

    Returns
    -------
    str
        The table's lines, header first.
    """
    rows = ["| key | default | allowed | units | meaning |", "|---|---|---|---|---|"]
    for group, cls, prefix, head in SCENE_GROUPS:
        rows += [f"| `{k}` | {d} | {a} | {u} | {m} |" for k, d, a, u, m in reference_rows(cls, prefix, head)]
    rows += [f"| `{k}` | {d} | {a} | {u} | {m} |" for k, d, a, u, m in reference_rows(SolverSettings)]
    return "\n".join(rows)
