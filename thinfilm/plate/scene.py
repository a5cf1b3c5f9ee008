"""The thin-film scene (``kind = "plate"``): a Kirchhoff plate on a Winkler foundation with
Ambrosio-Tortorelli damage, on a structured grid.

Tables: ``[model]`` (the non-dimensional film: ``at``, ``nu``, ``lam`` or ``winkler``,
``toughness``, ``eta`` or ``eta_dx``, ``k_res``, the imperfect film's ``toughness_noise*``),
or ``[material]`` (physical E, nu, h, Gc or K_IC, bond stiffness, L, turned into the
non-dimensional groups by :mod:`thinfilm.plate.units`); ``[domain]`` (``x``, ``y``, ``cells``,
``symmetry``); ``[load]`` (``kind``, ``t_max``, ``steps`` and the kind's own keys);
``[solver]`` (the engine's options, :func:`thinfilm.scene.read_solver`, and ``coarse``);
``[output]`` (``snapshots``). The reference, with every default and range, is
``docs/scenes.md``.
"""

from __future__ import annotations

import math
import sys
import zipfile
from dataclasses import dataclass

import numpy as np

from onedim.fragment import lam_from_winkler, winkler_from_lam
from thinfilm.exact1d.scene import lam_or_winkler
from thinfilm.plate.symmetry import GROUPS, GROUPS_2D, GROUPS_SQUARE
from thinfilm.plate.units import Material, toughness_from_KIC
from thinfilm.scene import SceneError, SolverSettings, Table, read_snapshots, read_solver, require_tables, show

__all__ = ["PlateParameters", "Domain", "PlateLoad", "PlateScene", "parse"]


@dataclass(frozen=True)
class PlateParameters:
    """Material and regularization of the thin-film model (non-dimensional: ``docs/model.md#continuous-energy``).

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
class PlateScene:
    """A validated ``kind = "plate"`` scene."""

    model: PlateParameters
    domain: Domain
    load: PlateLoad
    solver: SolverSettings
    text: str
    source: str
    kind: str = "plate"
    material: Material | None = None
    #: Loads of the snapshot figures (``[output] snapshots``); None: 5 spread over the run.
    snapshots: tuple | None = None
    #: ``[solver] coarse``: ``results.h5`` of a coarser run of the same model whose damage
    #: starts each step (grid sequencing, :mod:`thinfilm.plate.sequencing`); None: each step
    #: starts from the previous one.
    coarse: str | None = None
    #: Keys set over the file's (:func:`thinfilm.scene.apply_overrides`), as JSON.
    overrides: str | None = None


def parse(source, data, text):
    """Validate a plate scene's tables (``docs/scenes.md``); returns :class:`PlateScene`."""
    top = require_tables(source, data, ("model", "domain", "load"), ("solver", "material", "output"))
    model = Table(source, "model", data["model"],
                   ("kind", "at", "nu", "lam", "winkler", "toughness", "eta", "eta_dx", "k_res", "toughness_noise",
                    "toughness_noise_length", "toughness_noise_seed"))
    domain = Table(source, "domain", data["domain"], ("x", "y", "cells", "symmetry"))
    load = Table(source, "load", data["load"], ("kind", "t_max", "steps", "radius", "file", "name"))

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
            domain.fail("cells", cells if cells is not None else "missing",
                         "must be [nx, ny], two integers >= 2, for a 2D domain (y given)")
        cells = tuple(cells)
    symmetry = domain.choice("symmetry", tuple(GROUPS), default="none")
    if dim == 1 and symmetry in GROUPS_2D:
        domain.fail("symmetry", symmetry, 'must be "none" or "mirror_x" for a 1D domain')
    if symmetry in GROUPS_SQUARE and not (cells[0] == cells[1] and math.isclose(x[1] - x[0], y[1] - y[0], rel_tol=1e-12)):
        domain.fail("symmetry", symmetry, f"needs a square grid (x and y intervals of the same length and"
                                           f" cells = [n, n]), got cells = [{cells[0]}, {cells[1]}]")
    dom = Domain(x=x, y=y, cells=cells, symmetry=symmetry)

    at = model.integer("at", minimum=1, default=1)
    if at not in (1, 2):
        model.fail("at", at, "must be 1 (AT1) or 2 (AT2)")
    material = _parse_material(source, data, model) if top.has("material") else None
    nu = material.nu if material else model.number("nu", default=0.3)
    if not -1.0 < nu < 0.5:
        model.fail("nu", nu, "must be in (-1, 0.5)")
    if model.has("eta") == model.has("eta_dx"):
        both = "both are given" if model.has("eta") else "neither is given"
        raise SceneError(source, "model.eta", f"give exactly one of model.eta and model.eta_dx ({both})")
    eta = model.number("eta", minimum=0) if model.has("eta") else model.number("eta_dx", minimum=0) * dom.dx
    size = max(x[1] - x[0], (y[1] - y[0]) if y else 0.0)
    if not 0.0 < eta <= size:
        # (a damage band wider than the film; also the default toughness_noise_length)
        if model.has("eta"):
            model.fail("eta", model.data["eta"], f"must be a positive length up to the domain's size {size:g}")
        model.fail("eta_dx", model.data["eta_dx"], f"gives eta = eta_dx * dx = {eta:g} (dx = {dom.dx:g}); must give"
                    f" a positive length up to the domain's size {size:g}")
    k_res = model.number("k_res", minimum=0, default=1e-6)
    if material:
        lam, toughness = float(lam_from_winkler(material.winkler)), material.toughness
    else:
        lam, toughness = lam_or_winkler(model), model.number("toughness", minimum=0)
    noise = model.number("toughness_noise", minimum=0, exclusive=False, default=0.0)
    if noise > 2.0:
        model.fail("toughness_noise", noise, "must be in [0, 2] (the scatter of log G; 2 already puts a factor"
                    " 2500 between the 2.5% and 97.5% quantiles of G)")
    noise_length = model.number("toughness_noise_length", minimum=0, exclusive=False, default=eta)
    if noise_length > size:
        # (longer correlations make a field that is nearly uniform over the film, and a
        # smoothing kernel larger than the grid)
        model.fail("toughness_noise_length", noise_length, f"must be in [0, {size:g}] (the domain's size)")
    noise_seed = model.integer("toughness_noise_seed", minimum=0, default=0)
    params = PlateParameters(at=at, nu=nu, lam=lam, toughness=toughness, eta=eta, k_res=k_res,
                             toughness_noise=noise, toughness_noise_length=noise_length,
                             toughness_noise_seed=noise_seed)

    plate_load = _parse_load(source, load, dom)

    options, solver = read_solver(source, data.get("solver", {}), proportional=plate_load.proportional,
                                  load=f'load.kind = "{plate_load.kind}"', extra=("coarse",))
    if options.stability.enabled and dom.symmetry != "none":
        solver.fail("stability", True, f'follows modes that break the symmetry; it needs domain.symmetry ='
                     f' "none" (not "{dom.symmetry}")')
    coarse = _check_coarse(solver, params, plate_load, dim) if solver.has("coarse") else None
    snapshots = read_snapshots(source, data.get("output", {}), plate_load.t_max)
    return PlateScene(model=params, domain=dom, load=plate_load, solver=options, text=text, source=str(source),
                      material=material, snapshots=snapshots, coarse=coarse)


def _check_coarse(solver, params, load, dim):
    """``[solver] coarse``: the path of a plate run of the same model and load, checked."""
    path = solver.file("coarse", "must be the path of the results.h5 of a coarser run of the same scene")
    raw = solver.data["coarse"]
    if not path.exists():
        solver.fail("coarse", raw, "must be the results.h5 of a coarser run of the same scene; there is no such"
                     " file (run that scene first)")
    import h5py

    try:
        with h5py.File(path, "r", locking=False) as f:
            kind, p, grid_dim = f.attrs.get("kind"), dict(f["parameters"].attrs), int(f["grid"].attrs["dim"])
    except (OSError, KeyError) as err:
        solver.fail("coarse", raw, f"must be the results.h5 of a plate run; it cannot be read as one"
                     f" ({err.__class__.__name__})")
    if kind != "plate" or grid_dim != dim:
        solver.fail("coarse", raw, f"must be the results of a {dim}D plate run (it is a {grid_dim}D {kind} run)")
    ours = {"at": params.at, "nu": params.nu, "lam": params.lam, "toughness": params.toughness, "eta": params.eta,
            "load": load.kind, **({"radius": load.radius} if load.radius else {})}
    for key, value in ours.items():
        theirs = p.get(key)
        same = (theirs == value if isinstance(value, str)
                else theirs is not None and math.isclose(float(theirs), value, rel_tol=1e-9))
        if not same:
            solver.fail("coarse", raw, f"must be a run of the same model and load; it has {key} = {theirs},"
                         f" this scene {value}")
    return str(path)


_MATERIAL_KEYS = ("E", "nu", "h", "Gc", "K_IC", "bond_stiffness", "L")


def _parse_material(source, data, model):
    """``[material]``: physical E, nu, h, Gc or K_IC, bond stiffness, L (SI units)."""
    for key in ("lam", "winkler", "toughness", "nu"):
        if model.has(key):
            raise SceneError(source, f"model.{key}", "not allowed with a [material] table, which gives"
                             " winkler, toughness and nu through (2.13)")
    table = Table(source, "material", data["material"], _MATERIAL_KEYS)
    E = table.number("E", minimum=0)
    if table.has("Gc") == table.has("K_IC"):
        both = "both are given" if table.has("Gc") else "neither is given"
        raise SceneError(source, "material.Gc", f"give exactly one of material.Gc and material.K_IC ({both})")
    if table.has("Gc"):
        Gc = table.number("Gc", minimum=0)
    else:
        K_IC = table.number("K_IC", minimum=0)
        Gc = _derived(lambda: toughness_from_KIC(K_IC, E))
        if not 0.0 < Gc < math.inf:
            table.fail("K_IC", table.data["K_IC"], f"gives Gc = K_IC^2 / E = {Gc:g} with E = {E:g}; must give a"
                        " finite positive Gc")
    nu = table.number("nu", default=0.3)
    if not -1.0 < nu < 0.5:
        table.fail("nu", nu, "must be in (-1, 0.5)")
    material = Material(E=E, nu=nu, h=table.number("h", minimum=0), Gc=Gc,
                        bond_stiffness=table.number("bond_stiffness", minimum=0), L=table.number("L", minimum=0))
    # (2.13): winkler = 12 K_b (1 - nu^2) L^4 / (E h^3), toughness = 12 Gc (1 - nu^2) L / (E h^2)
    for name, keys in (("winkler", ("E", "h", "bond_stiffness", "L")), ("toughness", ("E", "h", "Gc", "L"))):
        value = _derived(lambda: getattr(material, name))
        if not sys.float_info.min <= value < math.inf:
            given = ", ".join(f"{k} = {getattr(material, k):g}" for k in keys)
            raise SceneError(source, "material", f"{given}: (2.13) gives {name} = {value:g}; they must give a finite"
                             f" positive {name}")
    return material


def _derived(compute):
    """A derived parameter, ``inf`` where Python's float arithmetic overflows."""
    try:
        return float(compute())
    except OverflowError:
        return math.inf


_LOAD_KINDS = ("bending", "cantilever", "indenter", "field")


def _parse_load(source, load, dom):
    """``[load]``: kind, t_max, steps, and the kind's own keys (radius; file, name)."""
    kind = load.choice("kind", _LOAD_KINDS, default="bending")
    t_max = load.number("t_max", minimum=0)
    steps = load.integer("steps", minimum=2)
    own = {"indenter": ("radius",), "field": ("file", "name")}.get(kind, ())
    for key in ("radius", "file", "name"):
        if load.has(key) and key not in own:
            load.fail(key, load.data[key], f'is not used by load.kind = "{kind}"')
    radius = field = file = None
    if kind == "indenter":
        radius = load.number("radius", minimum=0)
        if t_max > 1.0:
            load.fail("t_max", t_max, "must be <= 1 for the indenter (t = 1: pressed to its radius)")
    if kind == "cantilever" and dom.x[0] != 0.0:
        raise SceneError(source, "domain.x", f"= {show(list(dom.x))}: the cantilever is clamped at x = 0;"
                         " the domain must start there")
    if kind == "field":
        file, field = _read_field(load, dom)
    return PlateLoad(kind=kind, t_max=t_max, steps=steps, radius=radius, field=field, file=file)


def _read_field(load, dom):
    """The substrate displacement of a ``"field"`` load, from ``.npz`` or HDF5, checked."""
    name = load.data.get("name", "w")
    if not isinstance(name, str):
        load.fail("name", name, "must be a string (the array's name in the file)")
    path = load.file("file", "must be the path of an .npz or HDF5 file")
    raw = load.data["file"]
    if path.suffix not in (".npz", ".h5", ".hdf5"):
        load.fail("file", raw, "must end in .npz, .h5 or .hdf5")
    if not path.is_file():
        load.fail("file", raw, f"no such file ({path})")
    if path.suffix == ".npz" and not zipfile.is_zipfile(path):
        load.fail("file", raw, "cannot be read: not an .npz archive (numpy.savez writes them)")
    # What cannot be read is the file's fault, an array it does not hold the name's: the two
    # are told apart outside the try, so that one message never wraps the other.
    missing = None
    try:
        if path.suffix == ".npz":
            with np.load(path) as archive:
                if name in archive:
                    w = np.asarray(archive[name], dtype=float)
                else:
                    missing = f"no array of that name in {raw} (it has: {', '.join(archive.files) or 'none'})"
        else:
            import h5py

            with h5py.File(path, "r") as f:
                if name in f and isinstance(f[name], h5py.Dataset):
                    w = np.asarray(f[name][()], dtype=float)
                else:
                    missing = f"no dataset of that name in {raw} (it has: {', '.join(f) or 'none'})"
    except (OSError, ValueError, KeyError, zipfile.BadZipFile) as err:
        load.fail("file", raw, f"cannot be read as {'an .npz' if path.suffix == '.npz' else 'an HDF5'} file"
                   f" ({err.__class__.__name__}: {err})".replace("\n", " "))
    if missing is not None:
        load.fail("name", name, missing)
    shape = tuple(c + 1 for c in reversed(dom.cells))  # (ny + 1, nx + 1) or (nx + 1,)
    n_nodes = int(np.prod(shape))
    if w.shape not in (shape, (n_nodes,)):
        load.fail("file", raw, f"array {name!r} has shape {w.shape}; the grid needs {shape} (nodes, [y, x] order)"
                   f" or ({n_nodes},)")
    if not np.all(np.isfinite(w)):
        load.fail("file", raw, f"array {name!r} has {int(np.sum(~np.isfinite(w)))} non-finite values")
    return str(path), w.reshape(n_nodes)
