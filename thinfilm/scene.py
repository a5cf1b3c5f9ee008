"""Scene files: TOML text -> validated, frozen dataclasses.

A scene names the model (``[model] kind``), its parameters, the load and the discretization.
Everything is checked here, before anything is computed or written: unknown keys (with the
closest valid key suggested), wrong types, values out of range, and inconsistent choices.
Each problem raises :class:`SceneError`, whose message is one line naming the file, the key
path, the value and what is allowed; the command line prints it and exits with status 2.

The exact one-dimensional scene (``kind = "exact1d"``)::

    [model]
    kind = "exact1d"
    length = 0.5        # l0; the film occupies (-length/2, length/2)
    lam = 10.0          # lambda; or winkler = K/a^4 (= 4 lam^4), exactly one of the two
    toughness = 0.05    # G/a
    [load]
    t_max = 3.0
    steps = 300         # load steps for the curves; events are located exactly regardless
    [grid]
    cells = 1000
"""

from __future__ import annotations

import difflib
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from onedim.fragment import lam_from_winkler, winkler_from_lam
from thinfilm.plate.symmetry import GROUPS, GROUPS_2D, GROUPS_SQUARE
from thinfilm.plate.units import Material, toughness_from_KIC

MODEL_KINDS = ("exact1d", "plate")


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


def _show(value):
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        if len(value) <= 6 and all(not isinstance(v, (list, dict)) for v in value):
            return "[" + ", ".join(_show(v) for v in value) + "]"
        return "an array"
    return repr(value)


class _Table:
    """One TOML table being read: typed getters that raise :class:`SceneError`."""

    def __init__(self, source, name, data, allowed):
        self.source, self.name = source, name
        if not isinstance(data, dict):
            raise SceneError(source, name, f"= {_show(data)}: must be a table [{name}]")
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

    def _fail(self, key, value, allowed):
        raise SceneError(self.source, self.path(key), f"= {_show(value)}: {allowed}")

    def _required(self, key):
        if key not in self.data:
            raise SceneError(self.source, self.path(key), "missing (required)")
        return self.data[key]

    def number(self, key, *, minimum=None, exclusive=True, default=None):
        """A finite real number (TOML float or integer), optionally bounded below."""
        if default is not None and key not in self.data:
            return float(default)
        value = self._required(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self._fail(key, value, "must be a finite number")
        if minimum is not None:
            if exclusive and not value > minimum:
                self._fail(key, value, "must be a positive number" if minimum == 0 else f"must be > {minimum}")
            if not exclusive and not value >= minimum:
                self._fail(key, value, f"must be >= {minimum}")
        return float(value)

    def integer(self, key, *, minimum=None, default=None):
        """An integer, optionally bounded below (inclusive)."""
        if default is not None and key not in self.data:
            return int(default)
        value = self._required(key)
        if isinstance(value, bool) or not isinstance(value, int):
            self._fail(key, value, "must be an integer")
        if minimum is not None and value < minimum:
            self._fail(key, value, f"must be an integer >= {minimum}")
        return int(value)

    def boolean(self, key, *, default):
        """A TOML boolean."""
        if key not in self.data:
            return default
        value = self.data[key]
        if not isinstance(value, bool):
            self._fail(key, value, "must be true or false")
        return value

    def interval(self, key, *, required=True):
        """A pair ``[a, b]`` of finite numbers with ``a < b``; None if absent and optional."""
        if key not in self.data and not required:
            return None
        value = self._required(key)
        ok = (isinstance(value, list) and len(value) == 2
              and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
        if not ok or not value[0] < value[1]:
            self._fail(key, value, "must be an interval [a, b] of two finite numbers with a < b")
        return float(value[0]), float(value[1])

    def choice(self, key, choices, *, default=None):
        """A string among ``choices``."""
        if default is not None and key not in self.data:
            return default
        value = self._required(key)
        if not isinstance(value, str) or value not in choices:
            self._fail(key, value, "must be one of " + ", ".join(f'"{c}"' for c in choices))
        return value


@dataclass(frozen=True)
class Exact1DModel:
    """Film and material of the exact 1D problem.

    Attributes
    ----------
    length : float
        Film length ``l0``; the film occupies ``(-length/2, length/2)`` (units of L).
    lam : float
        Internal length scale ``lambda = winkler^(1/4) / sqrt(2)`` (units of 1/L).
    toughness : float
        ``G/a``: the energy of one crack (per unit width).
    """

    length: float
    lam: float
    toughness: float

    @property
    def winkler(self):
        """Foundation stiffness ``K/a^4 = 4 lam^4``."""
        return float(winkler_from_lam(self.lam))


@dataclass(frozen=True)
class Load:
    """Monotone loading ``t`` in ``[0, t_max]``, recorded at ``steps`` equal steps."""

    t_max: float
    steps: int


@dataclass(frozen=True)
class Grid1D:
    """A uniform grid of ``cells`` cells on the film."""

    cells: int


@dataclass(frozen=True)
class Exact1DScene:
    """A validated ``kind = "exact1d"`` scene.

    Attributes
    ----------
    model : Exact1DModel
    load : Load
    grid : Grid1D
    text : str
        The scene file's text, stored with the results.
    source : str
        Where the scene came from.
    """

    model: Exact1DModel
    load: Load
    grid: Grid1D
    text: str
    source: str
    kind: str = "exact1d"


def _lam_or_winkler(model):
    """Exactly one of ``lam`` and ``winkler`` (= 4 lam^4)."""
    has_lam, has_winkler = model.has("lam"), model.has("winkler")
    if has_lam == has_winkler:
        both = "both are given" if has_lam else "neither is given"
        raise SceneError(model.source, "model.lam", f"give exactly one of model.lam and model.winkler ({both})")
    if has_lam:
        return model.number("lam", minimum=0)
    return float(lam_from_winkler(model.number("winkler", minimum=0)))


def _parse_exact1d(source, data, text):
    top = _Table(source, "scene", data, ("model", "load", "grid"))
    for name in ("model", "load", "grid"):
        if not top.has(name):
            raise SceneError(source, name, f"missing table [{name}] (required)")
    model = _Table(source, "model", data["model"], ("kind", "length", "lam", "winkler", "toughness"))
    load = _Table(source, "load", data["load"], ("t_max", "steps"))
    grid = _Table(source, "grid", data["grid"], ("cells",))
    return Exact1DScene(
        model=Exact1DModel(
            length=model.number("length", minimum=0),
            lam=_lam_or_winkler(model),
            toughness=model.number("toughness", minimum=0),
        ),
        load=Load(t_max=load.number("t_max", minimum=0), steps=load.integer("steps", minimum=2)),
        grid=Grid1D(cells=grid.integer("cells", minimum=2)),
        text=text,
        source=str(source),
    )


@dataclass(frozen=True)
class PlateParameters:
    """Material and regularization of the thin-film model (non-dimensional, MODEL.md).

    Attributes
    ----------
    at : {1, 2}
        Ambrosio-Tortorelli variant.
    nu : float
        Poisson ratio (ignored by a 1D film).
    lam : float
        Internal length scale; ``winkler = 4 lam^4``.
    toughness : float
        ``G/a``.
    eta : float
        Regularization length (units of L).
    k_res : float
        Residual stiffness of ``g(alpha) = (1 - alpha)^2 + k_res``.
    toughness_noise : float
        Relative scatter ``s`` of a log-normal toughness field ``G exp(s xi)``
        (:mod:`thinfilm.plate.imperfection`); 0 for a uniform film.
    toughness_noise_length : float
        Correlation length of ``xi`` (units of L).
    toughness_noise_seed : int
        Seed of the random field.
    """

    at: int
    nu: float
    lam: float
    toughness: float
    eta: float
    k_res: float
    toughness_noise: float = 0.0
    toughness_noise_length: float = 0.0
    toughness_noise_seed: int = 0

    @property
    def winkler(self):
        """Foundation stiffness ``K/a^4 = 4 lam^4``."""
        return float(winkler_from_lam(self.lam))


@dataclass(frozen=True)
class Domain:
    """The film: ``x`` (and ``y`` in 2D) intervals and the number of cells along each.

    ``symmetry`` names a mirror group (:data:`thinfilm.plate.symmetry.GROUPS`) under which the
    solution is sought among invariant fields, or ``"none"``.
    """

    x: tuple
    y: tuple | None
    cells: tuple
    symmetry: str = "none"

    @property
    def dim(self):
        return 1 if self.y is None else 2

    @property
    def dx(self):
        return (self.x[1] - self.x[0]) / self.cells[0]


@dataclass(frozen=True)
class PlateLoad:
    """The substrate displacement (:mod:`thinfilm.plate.loads`), t in ``[0, t_max]`` in ``steps`` steps.

    Attributes
    ----------
    kind : {"bending", "cantilever", "indenter", "field"}
    t_max : float
    steps : int
    radius : float or None
        Indenter radius (units of L).
    field : ndarray or None, shape (n_nodes,)
        The displacement at t = 1 of a ``"field"`` load, read from ``file``.
    file : str or None
        Where the field came from.
    """

    kind: str
    t_max: float
    steps: int
    radius: float | None = None
    field: object = None
    file: str | None = None

    @property
    def proportional(self):
        """All loads but the indenter scale with t."""
        return self.kind != "indenter"


@dataclass(frozen=True)
class SolverOptions:
    """Numerical choices of a plate run (see :mod:`thinfilm.engine.evolution`)."""

    linear: str = "auto"
    tol: float = 1e-4
    max_iter: int = 2000
    acceleration: str = "none"
    omega: float = 4.0
    backtrack: str = "none"
    backtrack_delta: float = 1e-6
    backtrack_interval: int = 10
    backtrack_direction: int = 1
    backtrack_scope: int = 0
    search: bool = False
    search_delta: float = 0.0
    #: The second-order stability check after each step (:class:`thinfilm.engine.evolution.StabilityOptions`).
    stability: bool = False
    stability_tol: float = 1e-3
    #: ``results.h5`` of a coarser run of the same model whose damage starts each step
    #: (grid sequencing, :mod:`thinfilm.plate.sequencing`); None: start from the previous step.
    coarse: str | None = None


@dataclass(frozen=True)
class PlateScene:
    """A validated ``kind = "plate"`` scene."""

    model: PlateParameters
    domain: Domain
    load: PlateLoad
    solver: SolverOptions
    text: str
    source: str
    kind: str = "plate"
    material: Material | None = None
    #: Loads of the snapshot figures (``[output] snapshots``); None: 5 spread over the run.
    snapshots: tuple | None = None


def _parse_snapshots(source, data, t_max):
    """``[output] snapshots``: the loads at which the run draws alpha and u (in [0, t_max])."""
    output = _Table(source, "output", data, ("snapshots",))
    if not output.has("snapshots"):
        return None
    value = output.data["snapshots"]
    ok = (isinstance(value, list) and 1 <= len(value) <= 12
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and 0 <= v <= t_max
                  for v in value))
    if not ok:
        output._fail("snapshots", value, f"must be a list of 1 to 12 loads in [0, load.t_max = {t_max:g}]")
    return tuple(float(v) for v in value)


def _parse_plate(source, data, text):
    top = _Table(source, "scene", data, ("model", "domain", "load", "solver", "material", "output"))
    for name in ("model", "domain", "load"):
        if not top.has(name):
            raise SceneError(source, name, f"missing table [{name}] (required)")
    model = _Table(source, "model", data["model"],
                   ("kind", "at", "nu", "lam", "winkler", "toughness", "eta", "eta_dx", "k_res", "toughness_noise",
                    "toughness_noise_length", "toughness_noise_seed"))
    domain = _Table(source, "domain", data["domain"], ("x", "y", "cells", "symmetry"))
    load = _Table(source, "load", data["load"], ("kind", "t_max", "steps", "radius", "file", "name"))
    solver = _Table(source, "solver", data.get("solver", {}),
                    ("linear", "tol", "max_iter", "acceleration", "omega", "backtrack", "backtrack_delta", "backtrack_interval",
                     "backtrack_direction", "backtrack_scope", "search", "search_delta", "stability", "stability_tol",
                     "coarse"))

    x = domain.interval("x")
    y = domain.interval("y", required=False)
    cells = domain.data.get("cells")
    dim = 1 if y is None else 2
    if dim == 1:
        cells = (domain.integer("cells", minimum=2),)
    else:
        ok = (isinstance(cells, list) and len(cells) == 2
              and all(isinstance(c, int) and not isinstance(c, bool) and c >= 2 for c in cells))
        if not ok:
            domain._fail("cells", cells if cells is not None else "missing",
                         "must be [nx, ny], two integers >= 2, for a 2D domain (y given)")
        cells = tuple(cells)
    symmetry = domain.choice("symmetry", tuple(GROUPS), default="none")
    if dim == 1 and symmetry in GROUPS_2D:
        domain._fail("symmetry", symmetry, 'must be "none" or "mirror_x" for a 1D domain')
    if symmetry in GROUPS_SQUARE and not (cells[0] == cells[1] and math.isclose(x[1] - x[0], y[1] - y[0], rel_tol=1e-12)):
        domain._fail("symmetry", symmetry, f"needs a square grid (x and y intervals of the same length and"
                                           f" cells = [n, n]), got cells = [{cells[0]}, {cells[1]}]")
    dom = Domain(x=x, y=y, cells=cells, symmetry=symmetry)

    at = model.integer("at", minimum=1, default=1)
    if at not in (1, 2):
        model._fail("at", at, "must be 1 (AT1) or 2 (AT2)")
    material = _parse_material(source, data, model) if top.has("material") else None
    nu = material.nu if material else model.number("nu", default=0.3)
    if not -1.0 < nu < 0.5:
        model._fail("nu", nu, "must be in (-1, 0.5)")
    if model.has("eta") == model.has("eta_dx"):
        both = "both are given" if model.has("eta") else "neither is given"
        raise SceneError(source, "model.eta", f"give exactly one of model.eta and model.eta_dx ({both})")
    eta = model.number("eta", minimum=0) if model.has("eta") else model.number("eta_dx", minimum=0) * dom.dx
    k_res = model.number("k_res", minimum=0, default=1e-6)
    if material:
        lam, toughness = float(lam_from_winkler(material.winkler)), material.toughness
    else:
        lam, toughness = _lam_or_winkler(model), model.number("toughness", minimum=0)
    noise = model.number("toughness_noise", minimum=0, exclusive=False, default=0.0)
    if noise > 2.0:
        model._fail("toughness_noise", noise, "must be in [0, 2] (the scatter of log G; 2 already puts a factor"
                    " 2500 between the 2.5% and 97.5% quantiles of G)")
    noise_length = model.number("toughness_noise_length", minimum=0, exclusive=False, default=eta)
    size = max(x[1] - x[0], (y[1] - y[0]) if y else 0.0)
    if noise_length > size:
        # (longer correlations make a field that is nearly uniform over the film, and a
        # smoothing kernel larger than the grid)
        model._fail("toughness_noise_length", noise_length, f"must be in [0, {size:g}] (the domain's size)")
    noise_seed = model.integer("toughness_noise_seed", minimum=0, default=0)
    params = PlateParameters(at=at, nu=nu, lam=lam, toughness=toughness, eta=eta, k_res=k_res,
                             toughness_noise=noise, toughness_noise_length=noise_length,
                             toughness_noise_seed=noise_seed)

    plate_load = _parse_load(source, load, dom)

    d = SolverOptions()
    backtrack = solver.choice("backtrack", ("none", "standard", "deep"), default=d.backtrack)
    if backtrack != "none" and not plate_load.proportional:
        solver._fail("backtrack", backtrack, f'backtracking needs a load proportional to t; load.kind ='
                     f' "{plate_load.kind}" is not (use "none")')
    direction = solver.integer("backtrack_direction", default=d.backtrack_direction)
    if direction not in (1, -1):
        solver._fail("backtrack_direction", direction, "must be 1 (oldest first) or -1 (newest first)")
    stability = solver.boolean("stability", default=d.stability)
    if stability and dom.symmetry != "none":
        solver._fail("stability", stability, f'follows modes that break the symmetry; it needs domain.symmetry ='
                     f' "none" (not "{dom.symmetry}")')
    omega = solver.number("omega", default=d.omega)
    if not 1.0 <= omega <= 64.0:
        solver._fail("omega", omega, "must be in [1, 64]")
    options = SolverOptions(
        linear=solver.choice("linear", ("auto", "direct", "amg"), default=d.linear),
        tol=solver.number("tol", minimum=0, default=d.tol),
        max_iter=solver.integer("max_iter", minimum=1, default=d.max_iter),
        acceleration=solver.choice("acceleration", ("none", "overrelax"), default=d.acceleration),
        omega=omega,
        backtrack=backtrack,
        backtrack_delta=solver.number("backtrack_delta", minimum=0, default=d.backtrack_delta),
        backtrack_interval=solver.integer("backtrack_interval", minimum=1, default=d.backtrack_interval),
        backtrack_direction=direction,
        backtrack_scope=solver.integer("backtrack_scope", minimum=0, default=d.backtrack_scope),
        search=solver.boolean("search", default=d.search),
        search_delta=(solver.number("search_delta", minimum=0, exclusive=False)
                      if solver.has("search_delta") else 1e-3 * params.toughness),
        stability=stability,
        stability_tol=solver.number("stability_tol", minimum=0, default=d.stability_tol),
        coarse=_check_coarse(source, solver, params, plate_load, dim) if solver.has("coarse") else None,
    )
    snapshots = _parse_snapshots(source, data.get("output", {}), plate_load.t_max)
    return PlateScene(model=params, domain=dom, load=plate_load, solver=options, text=text, source=str(source),
                      material=material, snapshots=snapshots)


def _check_coarse(source, solver, params, load, dim):
    """``[solver] coarse``: the path of a plate run of the same model and load, checked."""
    raw = solver.data["coarse"]
    if not isinstance(raw, str):
        solver._fail("coarse", raw, "must be the path of the results.h5 of a coarser run of the same scene")
    path = Path(raw)
    if not path.is_absolute() and source != "<string>":
        path = Path(source).parent / path
    if not path.exists():
        solver._fail("coarse", raw, "must be the results.h5 of a coarser run of the same scene; there is no such"
                     " file (run that scene first)")
    import h5py

    try:
        with h5py.File(path, "r", locking=False) as f:
            kind, p, grid_dim = f.attrs.get("kind"), dict(f["parameters"].attrs), int(f["grid"].attrs["dim"])
    except (OSError, KeyError) as err:
        solver._fail("coarse", raw, f"must be the results.h5 of a plate run; it cannot be read as one"
                     f" ({err.__class__.__name__})")
    if kind != "plate" or grid_dim != dim:
        solver._fail("coarse", raw, f"must be the results of a {dim}D plate run (it is a {grid_dim}D {kind} run)")
    ours = {"at": params.at, "nu": params.nu, "lam": params.lam, "toughness": params.toughness, "eta": params.eta,
            "load": load.kind, **({"radius": load.radius} if load.radius else {})}
    for key, value in ours.items():
        theirs = p.get(key)
        same = (theirs == value if isinstance(value, str)
                else theirs is not None and math.isclose(float(theirs), value, rel_tol=1e-9))
        if not same:
            solver._fail("coarse", raw, f"must be a run of the same model and load; it has {key} = {theirs},"
                         f" this scene {value}")
    return str(path)


_MATERIAL_KEYS = ("E", "nu", "h", "Gc", "K_IC", "bond_stiffness", "L")


def _parse_material(source, data, model):
    """``[material]``: physical E, nu, h, Gc or K_IC, bond stiffness, L (SI units)."""
    for key in ("lam", "winkler", "toughness", "nu"):
        if model.has(key):
            raise SceneError(source, f"model.{key}", "not allowed with a [material] table, which gives"
                             " winkler, toughness and nu through (2.13)")
    table = _Table(source, "material", data["material"], _MATERIAL_KEYS)
    E = table.number("E", minimum=0)
    if table.has("Gc") == table.has("K_IC"):
        both = "both are given" if table.has("Gc") else "neither is given"
        raise SceneError(source, "material.Gc", f"give exactly one of material.Gc and material.K_IC ({both})")
    Gc = table.number("Gc", minimum=0) if table.has("Gc") else toughness_from_KIC(table.number("K_IC", minimum=0), E)
    nu = table.number("nu", default=0.3)
    if not -1.0 < nu < 0.5:
        table._fail("nu", nu, "must be in (-1, 0.5)")
    return Material(E=E, nu=nu, h=table.number("h", minimum=0), Gc=Gc,
                    bond_stiffness=table.number("bond_stiffness", minimum=0), L=table.number("L", minimum=0))


_LOAD_KINDS = ("bending", "cantilever", "indenter", "field")


def _parse_load(source, load, dom):
    """``[load]``: kind, t_max, steps, and the kind's own keys (radius; file, name)."""
    kind = load.choice("kind", _LOAD_KINDS, default="bending")
    t_max = load.number("t_max", minimum=0)
    steps = load.integer("steps", minimum=2)
    own = {"indenter": ("radius",), "field": ("file", "name")}.get(kind, ())
    for key in ("radius", "file", "name"):
        if load.has(key) and key not in own:
            load._fail(key, load.data[key], f'is not used by load.kind = "{kind}"')
    radius = field = file = None
    if kind == "indenter":
        radius = load.number("radius", minimum=0)
        if t_max > 1.0:
            load._fail("t_max", t_max, "must be <= 1 for the indenter (t = 1: pressed to its radius)")
    if kind == "cantilever" and dom.x[0] != 0.0:
        raise SceneError(source, "domain.x", f"= {_show(list(dom.x))}: the cantilever is clamped at x = 0;"
                         " the domain must start there")
    if kind == "field":
        file, field = _read_field(source, load, dom)
    return PlateLoad(kind=kind, t_max=t_max, steps=steps, radius=radius, field=field, file=file)


def _read_field(source, load, dom):
    """The substrate displacement of a ``"field"`` load, from ``.npz`` or HDF5, checked."""
    name = load.data.get("name", "w")
    if not isinstance(name, str):
        load._fail("name", name, "must be a string (the array's name in the file)")
    raw = load.data.get("file")
    if not isinstance(raw, str):
        load._fail("file", raw if raw is not None else "missing", "must be the path of an .npz or HDF5 file")
    path = Path(raw)
    if not path.is_absolute() and source != "<string>":
        path = Path(source).parent / path
    try:
        if path.suffix == ".npz":
            with np.load(path) as archive:
                if name not in archive:
                    load._fail("name", name, f"no array of that name in {raw} (it has: {', '.join(archive.files)})")
                w = np.asarray(archive[name], dtype=float)
        elif path.suffix in (".h5", ".hdf5"):
            import h5py

            with h5py.File(path, "r") as f:
                if name not in f:
                    load._fail("name", name, f"no dataset of that name in {raw}")
                w = np.asarray(f[name][()], dtype=float)
        else:
            load._fail("file", raw, "must end in .npz, .h5 or .hdf5")
    except (OSError, ValueError) as err:
        load._fail("file", raw, f"cannot be read ({err.__class__.__name__}: {err})".replace("\n", " "))
    shape = tuple(c + 1 for c in reversed(dom.cells))  # (ny + 1, nx + 1) or (nx + 1,)
    n_nodes = int(np.prod(shape))
    if w.shape not in (shape, (n_nodes,)):
        load._fail("file", raw, f"array {name!r} has shape {w.shape}; the grid needs {shape} (nodes, [y, x] order)"
                   f" or ({n_nodes},)")
    if not np.all(np.isfinite(w)):
        load._fail("file", raw, f"array {name!r} has {int(np.sum(~np.isfinite(w)))} non-finite values")
    return str(path), w.reshape(n_nodes)


_PARSERS = {"exact1d": _parse_exact1d, "plate": _parse_plate}


def parse_scene(text, source="<string>"):
    """Validate scene text.

    Parameters
    ----------
    text : str
        TOML text of the scene.
    source : str, optional
        Name used in error messages.

    Returns
    -------
    Exact1DScene
        The frozen, validated scene.

    Raises
    ------
    SceneError
        On any problem, with a one-line message.
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(source, None, f"TOML syntax error: {err}") from None
    model = data.get("model")
    if not isinstance(model, dict):
        raise SceneError(source, "model", "missing table [model] (required), with kind = " +
                         " or ".join(f'"{k}"' for k in MODEL_KINDS))
    kind = _Table(source, "model", {"kind": model.get("kind")} if "kind" in model else {}, ("kind",))
    kind = kind.choice("kind", MODEL_KINDS)
    return _PARSERS[kind](source, data, text)


def load_scene(path):
    """Read and validate a scene file.

    Parameters
    ----------
    path : str or Path
        The TOML scene file.

    Returns
    -------
    Exact1DScene

    Raises
    ------
    SceneError
        If the file cannot be read or is not a valid scene.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(path, None, "no such file") from None
    except (IsADirectoryError, PermissionError, UnicodeDecodeError) as err:
        raise SceneError(path, None, f"cannot read the scene file ({err.__class__.__name__})") from None
    return parse_scene(text, source=str(path))
