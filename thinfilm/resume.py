"""Resuming a run: what may differ between the scene a results file was written from and the
scene that continues it (``thinfilm run SCENE --resume``; ``docs/results.md#stopping-and-resuming``).

The two scenes are compared as parsed, not as text: each is read by TOML with its ``--set``
overrides applied (:func:`scene_keys`), and compared key by key, so comments, key order,
formatting, ``10`` against ``10.0``, and whether a key comes from the file or from ``--set``
do not matter. A key that differs is refused, naming it with its old and new values, unless

* it is ``load.t_max``, ``load.steps`` or a solid's ``load.t`` and the new scene's loads
  begin with the old scene's, double for double (:func:`thinfilm.steps.load_steps`): the run
  is **extended**. For equal steps that is the same spacing ``t_max / steps`` (as exact
  decimals) with more steps; for a list of loads, the old list followed by more;
* it lies in ``[output]``, which only the figures read;
* or the two scenes validate to the same model all the same (a default written out, a key
  of a table left empty).

The files the scene reads (a solid's mesh, a film's field file or coarse run: the kind's
:meth:`thinfilm.run.EvolutionKind.inputs`) are compared by their SHA-256, stored with the
results (root attribute ``inputs``, :func:`input_digests`): a resume whose files changed or
are missing is refused, naming the file and the scene key (:func:`check_inputs`).

Everything is checked on the file's attributes before the file is opened for writing (and
before anything is computed), so a refused resume leaves the results as they were.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import tomllib
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import numpy as np

from thinfilm.scene import SceneError, apply_overrides, parse_scene, show
from thinfilm.steps import load_steps

__all__ = ["ResumeError", "Continuation", "check_resume", "scene_keys", "scene_changes", "EXTENSION_KEYS",
           "INPUTS_ATTRIBUTE", "input_digests", "check_inputs"]

#: The keys that set the loads: they may change when the new loads extend the old ones.
EXTENSION_KEYS = ("load.t_max", "load.steps", "load.t")
#: What a resumed run may change, for the messages.
RULE = ("a resumed run may only extend the loads (load.t_max and load.steps in proportion, or more loads"
        " after a load.t list) and change [output] and solver.threads")
#: Fields of the validated scenes left out of their comparison: where the scene came from,
#: its loads (checked on the loads themselves), what only the figures read, and the threads
#: (which never change a result: thinfilm.threads).
_UNCOMPARED = {"text", "source", "overrides", "snapshots", "reference", "load.t_max", "load.steps",
               "load.values", "solver.threads"}
_ABSENT = object()
#: The root attribute of a results file that holds the digests of the scene's input files.
INPUTS_ATTRIBUTE = "inputs"


class ResumeError(RuntimeError):
    """A results file that cannot be continued; the message is one line for the user."""


@dataclass(frozen=True)
class Continuation:
    """What a resumed run continues, once :func:`check_resume` has accepted the scene.

    Attributes
    ----------
    planned_before, planned : int
        Steps of the stored scene and of the new one, step 0 included (``steps + 1``).
    changed : tuple of str
        The keys that differ and were accepted (the loads', ``[output]``'s, equivalent spellings).
    t_max_before, steps_before : float, int
        The stored scene's ``load.t_max`` and ``load.steps``.
    """

    planned_before: int
    planned: int
    changed: tuple = ()
    t_max_before: float = 0.0
    steps_before: int = 0

    @property
    def extended(self):
        """Whether the new scene has more steps than the stored one."""
        return self.planned > self.planned_before


def scene_keys(text, overrides=None):
    """A scene as TOML reads it, with its overrides applied, flat: ``{"model.lam": 10.0, ...}``.

    Parameters
    ----------
    text : str
        The scene's TOML text.
    overrides : dict or str or None
        Dotted keys set over the file's (:func:`thinfilm.scene.apply_overrides`), or their JSON
        (as :attr:`scene.overrides` and the results' ``scene_overrides`` hold them).

    Returns
    -------
    dict
        Dotted key -> value of every leaf (a value that is not a table; an empty table counts
        as absent).

    Raises
    ------
    tomllib.TOMLDecodeError, SceneError
    """
    if isinstance(overrides, str):
        overrides = json.loads(overrides)
    data = apply_overrides(tomllib.loads(text), overrides)
    out = {}

    def walk(node, prefix):
        for key, value in node.items():
            if isinstance(value, dict):
                walk(value, f"{prefix}{key}.")
            else:
                out[f"{prefix}{key}"] = value

    walk(data, "")
    return out


def _equal(a, b):
    """Values equal as a scene means them: numbers by value (``10 == 10.0``), booleans only
    to booleans, lists and tables element by element."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


def scene_changes(old, new):
    """The keys whose values differ between two :func:`scene_keys` dicts, in the order the new
    scene has them (then those only the old one has).

    Returns
    -------
    list of (key, old value, new value)
        A missing key's value is :data:`_ABSENT` (shown as "not given").
    """
    keys = list(new) + [k for k in old if k not in new]
    return [(k, old.get(k, _ABSENT), new.get(k, _ABSENT)) for k in keys
            if k not in old or k not in new or not _equal(old[k], new[k])]


def _show(value):
    return "not given" if value is _ABSENT else show(value)


def describe(changes):
    """``"model.toughness (0.05 -> 0.06), model.k_res (not given -> 1e-05)"``."""
    return ", ".join(f"{key} ({_show(old)} -> {_show(new)})" for key, old, new in changes)


def _first_difference(a, b, path=""):
    """The dotted path of the first field where two validated scenes differ (None if none),
    leaving out :data:`_UNCOMPARED`."""
    if path in _UNCOMPARED:
        return None
    if dataclasses.is_dataclass(a) and dataclasses.is_dataclass(b):
        if type(a) is not type(b):
            return path or "model.kind"
        for f in dataclasses.fields(a):
            sub = f"{path}.{f.name}" if path else f.name
            found = _first_difference(getattr(a, f.name), getattr(b, f.name), sub)
            if found is not None:
                return found
        return None
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        same = np.shape(a) == np.shape(b) and np.array_equal(a, b)
        return None if same else path
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        if len(a) != len(b):
            return path
        for x, y in zip(a, b):
            if _first_difference(x, y, path) is not None:
                return path
        return None
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            return path
        return next((path for k in a if _first_difference(a[k], b[k], path) is not None), None)
    return None if (type(a) is type(b) or {type(a), type(b)} <= {int, float}) and a == b else path


def _refuse(path, details):
    return ResumeError(f"{path} was written by a different scene: {details}; {RULE} (run with --force to start"
                       " over)")


def _loads_message(old, new, t_old, t_new):
    """Why the new loads do not extend the old ones, naming the load keys."""
    if getattr(old.load, "values", None) is not None or getattr(new.load, "values", None) is not None:
        keys = "load.t"
    else:
        keys = (f"load.t_max ({show(old.load.t_max)} -> {show(new.load.t_max)}), load.steps ({old.load.steps}"
                f" -> {new.load.steps})")
    if t_new.size < t_old.size and np.array_equal(t_new, t_old[: t_new.size]):
        return f"{keys}: fewer loads than the run was written with ({t_old.size - 1} steps to t = {t_old[-1]:g})"
    k = int(np.flatnonzero(t_new[: t_old.size] != t_old[: t_new.size])[0])
    text = f"{keys}: the loads computed would change (step {k}: t = {float(t_old[k])!r} -> {float(t_new[k])!r})"
    if getattr(old.load, "values", None) is None and getattr(new.load, "values", None) is None:
        steps = Fraction(repr(new.load.t_max)) / (Fraction(repr(old.load.t_max)) / old.load.steps)
        if steps.denominator == 1 and steps >= old.load.steps:
            text += f", load.steps = {steps.numerator} keeps the spacing"
    return text


def check_resume(path, attrs, scene):
    """Check that ``scene`` may continue the results file ``path``, whose root attributes are
    ``attrs``; see the module docstring for the rules.

    Parameters
    ----------
    path : str or Path
        The results file (for messages).
    attrs : dict
        Its root attributes: ``kind``, ``scene`` (the text), ``scene_overrides`` (JSON or absent).
    scene : object
        The validated scene of the resumed run.

    Returns
    -------
    Continuation

    Raises
    ------
    ResumeError
        Naming every refused key with its old and new values, in one line.
    """
    stored_text = attrs.get("scene", "")
    stored_overrides = attrs.get("scene_overrides") or None
    overrides = json.loads(stored_overrides) if stored_overrides else None
    try:
        old_keys = scene_keys(stored_text, overrides)
    except (tomllib.TOMLDecodeError, SceneError) as err:
        raise ResumeError(f"{path}: its stored scene cannot be read ({' '.join(str(err).split())}); it cannot be"
                          " resumed (run with --force to start over)") from None
    changes = scene_changes(old_keys, scene_keys(scene.text, scene.overrides))
    loads = [c for c in changes if c[0] in EXTENSION_KEYS]
    output = [c for c in changes if c[0].split(".")[0] == "output"]
    others = [c for c in changes if c not in loads and c not in output and c[0] != "solver.threads"]
    if attrs.get("kind", scene.kind) != scene.kind:
        raise _refuse(path, describe(others) or f'model.kind ("{attrs.get("kind")}" -> "{scene.kind}")')
    try:
        # read with the new scene's source: files it names resolve as they do for the new one
        old = parse_scene(stored_text, scene.source, overrides)
    except SceneError as err:
        raise _refuse(path, (describe(others) + "; " if others else "")
                      + f"the stored scene is not valid any more ({err.detail})") from None
    field = _first_difference(old, scene)
    if field is not None:
        # keys that differ in the text but spell the same model (a default written out) are
        # accepted: only a difference in the validated scenes refuses
        raise _refuse(path, describe(others) or f"{field} (the scenes' keys agree but what they read differs)")
    t_old, t_new = load_steps(old.load), load_steps(scene.load)
    if t_new.size < t_old.size or not np.array_equal(t_new[: t_old.size], t_old):
        raise _refuse(path, _loads_message(old, scene, t_old, t_new))
    return Continuation(planned_before=int(t_old.size), planned=int(t_new.size),
                        changed=tuple(c[0] for c in changes), t_max_before=float(old.load.t_max),
                        steps_before=int(old.load.steps))


def _sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def input_digests(inputs):
    """The SHA-256 of each input file of a scene.

    Parameters
    ----------
    inputs : dict
        ``{scene key: Path}`` (:meth:`thinfilm.run.EvolutionKind.inputs`).

    Returns
    -------
    dict
        ``{scene key: {"path": str, "sha256": hex digest or None}}``, in the keys' order; None
        for a file that does not exist (any more).
    """
    return {key: {"path": str(path), "sha256": _sha256(path) if Path(path).is_file() else None}
            for key, path in inputs.items()}


def check_inputs(path, stored, digests):
    """Refuse a resume whose input files differ from those the results were computed from.

    Parameters
    ----------
    path : str or Path
        The results file (for messages).
    stored : str or None
        Its root attribute ``inputs`` (JSON of :func:`input_digests`), None in a file written
        before the digests were stored: then nothing is compared (the resumed run adds them).
    digests : dict
        :func:`input_digests` of the resumed scene.

    Raises
    ------
    ResumeError
        Naming the scene key and the file, in one line.
    """
    for key, new in digests.items():
        if new["sha256"] is None:
            raise ResumeError(f"{path} cannot be resumed: {key} = {new['path']} is missing (the run read it;"
                              " restore it, or run with --force to start over)")
    if stored is None:
        return
    old = json.loads(stored) if isinstance(stored, str) else stored
    for key, new in digests.items():
        before = old.get(key)
        if before is not None and before.get("sha256") != new["sha256"]:
            moved = "" if before.get("path") == new["path"] else f" (was {before.get('path')})"
            raise ResumeError(f"{path} was computed from another {key}: {new['path']}{moved} has changed since"
                              f" (SHA-256 {before.get('sha256', '')[:12]}... -> {new['sha256'][:12]}...); a resumed"
                              " run must read the same input files (run with --force to start over)")
