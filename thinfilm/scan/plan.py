"""Scan files: TOML text -> the list of runs of a parameter scan, every scene validated.

A scan file names a base scene and the scene keys to vary::

    base = "../cantilever_6e6.toml"   # relative to the scan file
    mode = "product"                  # every combination; "zip": element-wise
    [vary]
    "model.winkler" = [3e6, 6e6, 1.2e7, 2.4e7]
    "model.toughness" = [0.5, 1.0]
    [set]                             # optional: the same for every run
    "load.steps" = 80
    [repeat]                          # optional: repeats over an integer seed key
    key = "model.toughness_noise_seed"
    count = 3                         # seeds first, first + 1, ..., first + count - 1
    first = 0
    [collect]
    metrics = ["first_event_t", "cracks_at_t_max", "total_at_t_max", "wall_s"]

Each run is the base scene with dotted-key overrides (:func:`thinfilm.scene.apply_overrides`):
the ``[set]`` keys, one value of each varied key, and the seed. :func:`load_plan` builds every
run's scene and validates it before anything runs, so a bad key or value anywhere stops the
scan with one line naming the scan file, the run and the key (:class:`ScanError`).

A run is named by a stable hash of what it computes (the base scene as parsed and the run's
overrides, :func:`run_name`): its directory keeps that name from one scan to the next, which is
how a resumed scan finds its finished runs, and a changed base scene never reuses stale ones.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from thinfilm.scan.metrics import METRICS
from thinfilm.scene import SceneError, Table, load_scene, read_text, show

__all__ = ["ScanError", "RunSpec", "ScanPlan", "parse_plan", "load_plan", "run_name", "check_metrics", "MODES", "MAX_RUNS"]

#: How the varied keys' lists combine.
MODES = ("product", "zip")
#: The most runs a scan may make unless ``thinfilm scan --max-runs`` lifts it: every run's
#: scene is validated before any starts (about 1 ms each), so 10^4 runs take seconds and a
#: mistyped range of 10^7 would take hours before a run began.
MAX_RUNS = 10_000


class ScanError(SceneError):
    """A scan file that cannot be run; the message is one line for the user."""


class _TopLevel(Table):
    """The scan file's top level: its keys are named bare (``base``, not ``scan.base``)."""

    def path(self, key):
        return key


def _table(source, data, name):
    """A ``[name]`` table of dotted scene keys (any key allowed: the scenes check them).

    Quoted (``"model.lam" = ...``) and bare dotted keys (``model.lam = ...``, which TOML reads
    as nested tables) are the same: nested tables are flattened to dotted keys.
    """
    value = data.get(name, {})
    if not isinstance(value, dict):
        raise ScanError(source, name, f"= {show(value)}: must be a table [{name}] of dotted scene keys")

    def flatten(table, prefix):
        for key, item in table.items():
            if isinstance(item, dict):
                yield from flatten(item, f"{prefix}{key}.")
            else:
                yield f"{prefix}{key}", item

    return dict(flatten(value, ""))


@dataclass(frozen=True)
class RunSpec:
    """One run of a scan.

    Attributes
    ----------
    name : str
        Stable hash of the base scene as parsed and the overrides: the run's directory name.
    index : int
        Position in the scan (0-based), the row order of the table.
    values : dict
        The varied keys' values of this run (and the seed's), ``{dotted key: value}``.
    overrides : dict
        Every override applied to the base scene (``[set]``, varied keys, seed).
    """

    name: str
    index: int
    values: dict
    overrides: dict


@dataclass(frozen=True)
class ScanPlan:
    """A validated scan: the base scene, the runs and what to collect.

    Attributes
    ----------
    source : str
        The scan file.
    text : str
        Its TOML text.
    base : Path
        The base scene file (absolute).
    kind : str
        The base scene's model kind (every run has it).
    mode : {"product", "zip"}
    keys : tuple of str
        The table's parameter columns: the varied keys, then the seed key if any.
    seed : str or None
        The ``[repeat]`` seed key.
    metrics : tuple of str
    runs : tuple of RunSpec
    """

    source: str
    text: str
    base: Path
    kind: str
    mode: str
    keys: tuple
    seed: str | None
    metrics: tuple
    runs: tuple = field(default_factory=tuple)


def run_name(base_text, overrides):
    """The stable name of a run: 12 hex digits of the SHA-256 of the base scene as parsed and the
    overrides, as canonical JSON (sorted keys), the same on every machine and Python. The parsed
    scene, not its text: a comment or the layout of the base file does not rename its runs
    (``thinfilm run --resume`` compares scenes the same way). ``[solver] threads`` is left out:
    a scan's local workers run on one thread each, and threads never change a result."""
    base = tomllib.loads(base_text)
    base.get("solver", {}).pop("threads", None)
    blob = json.dumps({"base": base, "overrides": overrides}, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(blob.encode("utf-8")).hexdigest()[:12]


def check_metrics(source, names, kind):
    """Refuse unknown metrics, and metrics that runs of ``kind`` do not record.

    Raises
    ------
    thinfilm.scan.plan.ScanError
    """
    for name in names:
        metric = METRICS.get(name)
        if metric is None:
            raise ScanError(source, "collect.metrics", f"= {show(name)}: unknown metric (allowed: "
                            f"{', '.join(METRICS)})")
        if metric.kinds is not None and kind is not None and kind not in metric.kinds:
            allowed = [m.name for m in METRICS.values() if m.kinds is None or kind in m.kinds]
            raise ScanError(source, "collect.metrics", f"= {show(name)}: not recorded by {kind} runs (allowed:"
                            f" {', '.join(allowed)})")


def _value_list(source, key, values):
    if not isinstance(values, list) or not values:
        raise ScanError(source, f"vary.{key}", f"= {show(values)}: must be a non-empty list of the values to try")
    if any(isinstance(v, dict) for v in values):
        raise ScanError(source, f"vary.{key}", f"= {show(values)}: values must be TOML values, not tables")
    return values


def parse_plan(text, source="<string>", overrides=None, check=None, max_runs=MAX_RUNS):
    """Validate scan text and build its runs.

    Parameters
    ----------
    text : str
        TOML text of the scan file.
    source : str
        The scan file's path (``base`` is relative to its folder).
    overrides : dict, optional
        Dotted scene keys set in every run on top of ``[set]`` (``thinfilm scan --set``); a
        varied key is refused.
    check : callable, optional
        Called with every run's validated scene; may refuse it with a SceneError (the
        command line checks that each run fits the machine: :func:`thinfilm.resources.check`).
    max_runs : int
        A scan of more runs is refused before any is built or validated (validation takes
        about 1 ms per run).

    Returns
    -------
    ScanPlan

    Raises
    ------
    ScanError
        On any problem in the scan file or in any generated scene, in one line.
    """
    try:
        return _parse(text, source, dict(overrides or {}), check, max_runs)
    except ScanError:
        raise
    except SceneError as err:  # from the table getters: the same line, as a scan's error
        raise ScanError(err.source, err.key, err.detail) from None


def _parse(text, source, overrides, check=None, max_runs=None):
    max_runs = MAX_RUNS if max_runs is None else max_runs
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise ScanError(source, None, f"TOML syntax error: {err}") from None
    top = _TopLevel(source, "scan", data, ("base", "mode", "vary", "set", "repeat", "collect"))
    base = top.file("base", 'must name the base scene file, e.g. base = "../cantilever_6e6.toml"')
    if not base.is_file():
        raise ScanError(source, "base", f"= {show(data['base'])}: no such scene file ({base})")
    base = base.resolve()
    if base.suffix.lower() == ".msh":
        raise ScanError(source, "base", f"= {show(data['base'])}: is a gmsh mesh, not a scene; the base must be a"
                        ' scene file (.toml) that names the mesh: [geometry] kind = "file", file = "...msh"')
    base_text = read_text(base, "base scene", ScanError)
    try:  # the base scene as it stands, before any run is built from it
        load_scene(base)
    except SceneError as err:
        raise ScanError(source, "base", f"= {show(data['base'])}: not a valid scene: {err}") from None
    mode = top.choice("mode", MODES, default="product")

    vary = _table(source, data, "vary")
    if not vary:
        raise ScanError(source, "vary", 'missing or empty: give at least one key to vary, e.g. "model.lam" = [10, 20]')
    lists = {key: _value_list(source, key, values) for key, values in vary.items()}
    if mode == "zip" and len({len(v) for v in lists.values()}) > 1:
        lengths = ", ".join(f"{k}: {len(v)}" for k, v in lists.items())
        raise ScanError(source, "vary", f'mode = "zip" needs lists of one length ({lengths})')
    fixed = _table(source, data, "set")
    for key in overrides:
        if key in lists:
            raise ScanError(source, None, f"--set {key}: the key is varied in [vary]; it cannot also be set")
    fixed = {**fixed, **overrides}
    both = sorted(set(fixed) & set(lists))
    if both:
        raise ScanError(source, f"set.{both[0]}", "is also varied in [vary]: give it in one of the two")

    seed_key, seeds = None, [None]
    if "repeat" in data:
        repeat = Table(source, "repeat", data["repeat"], ("key", "count", "first"))
        seed_key = repeat.required("key")
        if not isinstance(seed_key, str) or not seed_key:
            repeat.fail("key", seed_key, 'must name an integer scene key, e.g. "model.toughness_noise_seed"')
        if seed_key in lists or seed_key in fixed:
            raise ScanError(source, "repeat.key", f"= {show(seed_key)}: is also in [vary] or [set]")
        count = repeat.integer("count", minimum=1)
        first = repeat.integer("first", minimum=0, default=0)
        seeds = list(range(first, first + count))

    collect = Table(source, "collect", data.get("collect", {}), ("metrics",))
    metrics = collect.data.get("metrics", ["first_event_t", "total_at_t_max", "wall_s"])
    if not isinstance(metrics, list) or not metrics or not all(isinstance(m, str) for m in metrics):
        raise ScanError(source, "collect.metrics", f"= {show(metrics)}: must be a non-empty list of metric names")

    n_runs = (math.prod(len(v) for v in lists.values()) if mode == "product" else len(next(iter(lists.values())))) * len(seeds)
    if n_runs > max_runs:
        sizes = " x ".join(str(len(v)) for v in lists.values()) + (f" x {len(seeds)} seeds" if seed_key else "")
        raise ScanError(source, "vary", f"makes {n_runs} runs ({sizes}): more than the limit of {max_runs}"
                        " runs per scan (each is validated before any starts); split the scan, or lift the"
                        " limit with --max-runs N")
    keys = tuple(lists)
    combos = itertools.product(*lists.values()) if mode == "product" else zip(*lists.values())
    runs, seen = [], {}
    for combo in combos:
        for seed in seeds:
            values = dict(zip(keys, combo))
            if seed_key is not None:
                values[seed_key] = seed
            overrides = {**fixed, **values}
            name = run_name(base_text, overrides)
            label = ", ".join(f"{k} = {show(v)}" for k, v in values.items())
            if name in seen:
                raise ScanError(source, "vary", f"run {len(runs)} ({label}) repeats run {seen[name]}: give each"
                                " combination once")
            seen[name] = len(runs)
            runs.append(RunSpec(name=name, index=len(runs), values=values, overrides=overrides))

    kind = None
    for spec in runs:
        try:
            scene = load_scene(base, overrides=spec.overrides)
            if check is not None:
                check(scene)
        except SceneError as err:
            label = ", ".join(f"{k} = {show(v)}" for k, v in spec.values.items())
            raise ScanError(source, None, f"run {spec.index} ({label}): {err}") from None
        kind = scene.kind
    check_metrics(source, metrics, kind)
    return ScanPlan(source=str(source), text=text, base=base, kind=kind, mode=mode,
                    keys=keys + ((seed_key,) if seed_key else ()), seed=seed_key, metrics=tuple(metrics), runs=tuple(runs))


def load_plan(path, overrides=None, check=None, max_runs=None):
    """Read and validate a scan file (:func:`parse_plan`), with ``overrides`` set in every run
    and ``check`` called with each run's scene.

    Raises
    ------
    ScanError
        If the file cannot be read or the scan is not valid.
    """
    text = read_text(path, "scan file", ScanError)
    return parse_plan(text, source=str(path), overrides=overrides, check=check,
                      max_runs=MAX_RUNS if max_runs is None else max_runs)
