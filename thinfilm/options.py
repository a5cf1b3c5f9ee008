"""Options declared once: each with its default, units, allowed values and meaning.

The numerical options of the toolkit (the engine's, the linear solver's) are frozen
dataclasses whose fields are declared with :func:`option`. The declaration is the single
source of truth:

* the dataclass checks every value when it is made (:func:`validate`, called from
  ``__post_init__``), so an option object can never hold a value outside its range, whoever
  made it (a scene, a test, a benchmark);
* a scene's ``[solver]`` table is read straight into these objects
  (:func:`thinfilm.scene.read_options`), the scene key of each field derived from its
  declaration (:func:`scene_keys`);
* the scene reference in ``docs/scenes.md`` lists them from the same declaration
  (:func:`reference_rows`; a test checks that the page and the code agree).

This module depends on nothing else of the toolkit.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OptionError", "Rule", "option", "validate", "scene_keys", "reference_rows", "real_in_range",
           "index_array"]


class OptionError(ValueError):
    """An option value outside its declared range.

    Attributes
    ----------
    name : str
        The field's name.
    value : object
        The value given.
    allowed : str
        What is allowed, as a phrase (``"must be a positive number"``).
    """

    def __init__(self, name, value, allowed):
        super().__init__(f"{name} = {value!r}: {allowed}")
        self.name, self.value, self.allowed = name, value, allowed


@dataclass(frozen=True)
class Rule:
    """What one option allows.

    Attributes
    ----------
    type : {"number", "integer", "boolean", "choice"}
        A finite real number, an integer, true/false, or one of ``choices``.
    minimum, maximum : float, optional
        Bounds of a number or integer.
    exclusive : bool
        The minimum is excluded (``> minimum``) rather than included.
    choices : tuple, optional
        The allowed values of a choice (strings, or integers such as the direction +-1).
    phrase : str, optional
        The allowed values in words, when the bounds alone would say it badly.
    words : tuple of str, optional
        Strings allowed besides the numbers of an integer or number rule (e.g. ``"auto"``).
    """

    type: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive: bool = False
    choices: tuple = ()
    phrase: str | None = None
    words: tuple = ()

    def allowed(self):
        """The allowed values as a phrase, in the words of the scene errors."""
        if self.phrase:
            return self.phrase
        if self.type == "boolean":
            return "must be true or false"
        if self.type == "choice":
            return "must be one of " + ", ".join(f'"{c}"' if isinstance(c, str) else str(c) for c in self.choices)
        if self.minimum is not None and self.maximum is not None:
            return f"must be in [{_g(self.minimum)}, {_g(self.maximum)}]"
        if self.type == "integer":
            return "must be an integer" + ("" if self.minimum is None else f" >= {_g(self.minimum)}")
        if self.minimum is None:
            return "must be a finite number"
        if self.exclusive:
            return "must be a positive number" if self.minimum == 0 else f"must be > {_g(self.minimum)}"
        return f"must be >= {_g(self.minimum)}"

    def accepts_type(self, value):
        """Whether ``value`` has this rule's type (TOML bools are not numbers)."""
        if self.type == "boolean":
            return isinstance(value, bool)
        if isinstance(value, bool):
            return False
        if isinstance(value, str) and self.words:
            return True
        if self.type == "integer" or (self.type == "choice" and all(isinstance(c, int) for c in self.choices)):
            return isinstance(value, int)
        if self.type == "choice":
            return isinstance(value, str)
        return isinstance(value, (int, float)) and math.isfinite(value)

    def type_phrase(self):
        """The phrase for a value of the wrong type."""
        if self.words:
            return self.allowed()
        if self.type == "integer":
            return "must be an integer"
        if self.type == "number":
            return "must be a finite number"
        return self.allowed()

    def accepts(self, value):
        """Whether ``value`` is allowed (type and range)."""
        if not self.accepts_type(value):
            return False
        if isinstance(value, str) and self.words:
            return value in self.words
        if self.type == "choice":
            return value in self.choices
        if self.type == "boolean":
            return True
        if self.minimum is not None:
            if self.exclusive and not value > self.minimum:
                return False
            if not self.exclusive and not value >= self.minimum:
                return False
        return self.maximum is None or value <= self.maximum


def _g(x):
    return f"{x:g}" if isinstance(x, float) else str(x)


def option(default, doc, *, rule, units="", scene=None):
    """Declare an option field.

    Parameters
    ----------
    default : object
        The default value (checked against ``rule`` when the class is first used).
    doc : str
        One sentence: what it does.
    rule : Rule
        What is allowed.
    units : str, optional
        Its units ("" for none).
    scene : str or None, optional
        Its scene key; default derived by :func:`scene_keys`.
    """
    return dataclasses.field(default=default, metadata={"doc": doc, "rule": rule, "units": units, "scene": scene})


def validate(obj):
    """Check every declared field of the dataclass ``obj``.

    Raises
    ------
    OptionError
        Naming the first field whose value is not allowed.
    """
    for f in dataclasses.fields(obj):
        rule = f.metadata.get("rule")
        if rule is None:
            continue
        value = getattr(obj, f.name)
        if not rule.accepts(value):
            raise OptionError(f.name, value, rule.allowed() if rule.accepts_type(value) else rule.type_phrase())


def scene_keys(cls, prefix="", head=None) -> dict[str, dataclasses.Field]:
    """The scene keys of the options of ``cls``: ``{key: field}``.

    A field's key is ``prefix`` for the field named ``head`` (the switch of a group, e.g.
    ``[solver] backtrack = "standard"``), ``prefix_<name>`` for the others, or the bare
    name without a prefix; an explicit ``scene=`` in the declaration wins.
    """
    keys = {}
    for f in dataclasses.fields(cls):
        if "rule" not in f.metadata:
            continue
        key = f.metadata.get("scene")
        if key is None:
            key = prefix if (f.name == head and prefix) else (f"{prefix}_{f.name}" if prefix else f.name)
        keys[key] = f
    return keys


def reference_rows(cls, prefix="", head=None) -> list[tuple[str, str, str, str, str]]:
    """Rows ``(key, default, allowed, units, meaning)`` of the scene reference for ``cls``."""
    rows = []
    for key, f in scene_keys(cls, prefix, head).items():
        rule, default = f.metadata["rule"], f.default
        if isinstance(default, bool):
            shown = "true" if default else "false"
        elif isinstance(default, str):
            shown = f'"{default}"'
        else:
            shown = _g(default)
        allowed = rule.allowed()
        allowed = allowed[len("must be "):] if allowed.startswith("must be ") else allowed
        rows.append((key, shown, allowed, f.metadata["units"], f.metadata["doc"]))
    return rows


def real_in_range(name, value, low, high, low_open=False, high_open=True):
    """``float(value)``, checked finite and in the interval from ``low`` to ``high`` (open or
    closed at each end): the argument check of the models' operator constructors.

    Raises
    ------
    TypeError
        If ``value`` is not a real number.
    ValueError
        Naming ``name``, the value and the interval, if it is outside.
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} = {value!r} must be a real number") from None
    ok = math.isfinite(v) and (v > low if low_open else v >= low) and (v < high if high_open else v <= high)
    if not ok:
        raise ValueError(f"{name} = {value!r} outside the allowed range "
                         f"{'(' if low_open else '['}{low}, {high}{')' if high_open else ']'}")
    return v


def index_array(name, value, size) -> np.ndarray:
    """``value`` as a strictly increasing int64 array of indices in ``[0, size)``.

    Raises
    ------
    ValueError
        Naming ``name``, if ``value`` is not a 1D integer array, has an entry outside
        ``[0, size)``, or is not sorted without repeats.
    """
    a = np.asarray(value)
    if a.ndim != 1 or not (a.size == 0 or np.issubdtype(a.dtype, np.integer)):
        raise ValueError(f"{name} must be a 1D array of integers, got shape {a.shape} and dtype {a.dtype}")
    a = a.astype(np.int64)
    if a.size and (a[0] < 0 or a[-1] >= size):
        raise ValueError(f"{name} has entries outside [0, {size}): min {a.min()}, max {a.max()}")
    if np.any(np.diff(a) <= 0):
        raise ValueError(f"{name} must be sorted without repeats")
    return a
