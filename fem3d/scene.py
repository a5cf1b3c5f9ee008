"""The finite-element scene (``kind = "fem"``): a bulk solid, its geometry and mesh, its loads.

Units are the scene's own, consistent set: with lengths in mm, E in MPa (N/mm^2) and Gc in
N/mm, forces come out in N and energies in N mm; with inches, psi and lbf/in, in lbf and
lbf in. A 2D run is a slab of the given ``thickness``: its forces and energies are those of
the whole slab, not per unit thickness. ::

    [model]
    kind = "fem"
    dim = 2                 # 2 (triangles) or 3 (tetrahedra)
    E = 25850.0             # Young's modulus
    nu = 0.18
    Gc = 0.095              # toughness (energy per unit crack area)
    eps = 3.125             # regularization length
    k_res = 1e-6            # residual stiffness of g = (1 - alpha)^2 + k_res
    at = 1                  # AT1 (default) or AT2; or instead:
    # law = "czm"           # Wu's cohesive law (docs/model.md#the-cohesive-law), with
    # ft = 2.7              #   the tensile strength and
    # softening = "linear"  #   "linear", "exponential" or "cornelissen"
    plane = "stress"        # 2D only: "stress" or "strain"
    thickness = 100.0       # 2D only
    undamaged = ["gray"]    # regions (cell groups) where alpha is held at 0
    buffers = {top = 25.85} # regions of their own Young's modulus, alpha held at 0 there
    split = "none"          # energy the damage degrades: "none" (4.10), "amor" (4.11), "positive" (4.12)
    element = "P1"          # displacement element: "P1" or "P2" (quadratic; the damage stays P1)

    [geometry]
    kind = "lpanel"         # a specimen of fem3d.specimens, or "file" (with file = "x.msh")

    [mesh]
    h = 0.625               # size where the crack may run
    h_coarse = 12.5         # size elsewhere
    # or: a uniform first mesh refined where the crack goes (docs/adaptivity.md)
    # adapt = true, h_min = 0.625, h_max = 12.5, adapt_alpha = 0.01, adapt_energy = 0.5,
    # adapt_buffer = 0

    [load]
    t_max = 0.4             # or t = [0.0, 0.1, ...], an explicit list of loads
    steps = 80
    fixed = ["bottom"]      # u = 0 on these groups (every component)
    [load.displacement.load]
    y = 1.0                 # u_y = t * 1.0 on group "load"; x stays free
    [load.traction.top]     # traction t * (x, y) on a boundary (force per area)
    y = -1.0
    [load.force.load_point] # total force t * (x, y), shared by the group's nodes
    y = -1.0
    [load.constant.force.side]  # held at this value from step 0 on (also displacement, traction)
    x = 10000.0

The reference is ``docs/scenes.md``; every check raises :class:`thinfilm.scene.SceneError`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fem3d import specimens
from fem3d.elements import ELEMENTS as ELEMENT_REGISTRY
from fem3d.mesh_check import FINE_PERCENTILE, element_sizes, fine_size
from fem3d.specimens.specimen import Extent
from fem3d.split import SPLITS
from thinfilm.laws import LAWS, SOFTENING, law_from_name
from thinfilm.scene import SceneError, SolverSettings, Table, read_snapshots, read_solver, require_tables, show

__all__ = ["FemModelParameters", "Geometry", "MeshSizes", "Loading", "FemScene", "parse"]

COMPONENTS = ("x", "y", "z")
#: The least ``eps / h`` a scene may ask for: at ``eps = h / 2`` the discrete 1D optimal AT1
#: profile already costs ``(1 + 1/8) Gc`` (``tests/core/test_damage.py``), and below it the
#: profile falls within one element (the run warns below ``eps = 2 h``).
EPS_PER_H_MIN = 0.5
#: The largest ``eps`` as a fraction of the specimen's largest side.
EPS_PER_SIZE_MAX = 0.5
#: A mesh file's declared ``mesh.h`` must be within this factor of its measured fine size.
H_FACTOR = 2.0
#: Displacement elements (``[model] element``): those of the registry, :data:`fem3d.elements.ELEMENTS`.
ELEMENTS = tuple(ELEMENT_REGISTRY)


@dataclass(frozen=True)
class FemModelParameters:
    """Material and regularization, in the scene's units.

    Attributes
    ----------
    dim : {2, 3}
    E, nu : float
        Young's modulus and Poisson ratio.
    Gc : float
        Toughness: energy per unit crack area.
    eps : float
        Regularization length.
    k_res : float
        Residual stiffness.
    at : {0, 1, 2}
        AT1 or AT2; 0 with the cohesive law.
    plane : {"stress", "strain"}
        2D only (3D: "none").
    thickness : float
        2D slab thickness (1 in 3D).
    undamaged : tuple of str
        Regions where the damage is held at 0.
    buffers : tuple of (str, float)
        Buffer layers: regions of their own Young's modulus ``E_b`` (the same nu), where the
        damage is also held at 0 (dissertation section 4.3).
    split : {"none", "amor", "positive"}
        The part of the strain energy the damage degrades (:mod:`fem3d.split`).
    element : {"P1", "P2"}
        The displacement's element (:mod:`fem3d.elements`); the damage is
        P1 on the vertices either way.
    law : {"at1", "at2", "czm"}
        The damage law (:mod:`thinfilm.laws`).
    ft : float
        The cohesive law's tensile strength (None otherwise).
    softening : str
        The cohesive law's softening curve (:data:`thinfilm.laws.SOFTENING`).
    """

    dim: int
    E: float
    nu: float
    Gc: float
    eps: float
    k_res: float
    at: int
    plane: str
    thickness: float
    undamaged: tuple
    buffers: tuple = ()
    split: str = "none"
    element: str = "P1"
    law: str = "at1"
    ft: float | None = None
    softening: str = "linear"

    def damage_law(self):
        """The :class:`thinfilm.laws.DamageLaw` of these parameters."""
        return law_from_name(self.law, E=self.E, Gc=self.Gc, ft=self.ft, eta=self.eps, softening=self.softening)


@dataclass(frozen=True)
class Geometry:
    """``[geometry]``: the specimen (:mod:`fem3d.specimens`) and the keys the scene gives.

    Attributes
    ----------
    kind : str
        The specimen's name.
    options : tuple of (str, object)
        The keys the scene gives, as ``(argument, value)`` pairs of the specimen's mesh function
        (sorted; the record's defaults for the others).
    file : str or None
        The file a key of the specimen names (the ``.msh`` file of ``kind = "file"``).
    """

    kind: str
    options: tuple = ()
    file: str | None = None


@dataclass(frozen=True)
class AdaptOptions:
    """``[mesh] adapt = true``: a uniform first mesh refined where the crack goes
    (:mod:`fem3d.adaptive`, docs/adaptivity.md).

    Attributes
    ----------
    h_min : float
        Smallest cell the refinement makes (its longest edge; length).
    h_max : float
        Element size of the first mesh (length).
    alpha : float
        Damage at a vertex that marks its cells, in (0, 1].
    energy : float
        Fraction of the damage-onset energy density (:func:`fem3d.adaptive.onset_density`)
        at which a cell's degradable elastic energy density marks it, > 0.
    buffer : float
        Distance from a vertex of damage ``alpha`` within which cells are marked too (length).
    """

    h_min: float
    h_max: float
    alpha: float = 0.01
    energy: float = 0.5
    buffer: float = 0.0


#: Defaults of an adaptive mesh, as fractions or multiples of eps: h_min = eps / 5 (the
#: banded cases' eps/h), h_max = 4 eps. No buffer about the damage by default: one of 2 eps
#: doubled the nodes and the time without changing the L-panel's crack (docs/adaptivity.md#measured).
ADAPT_H_MIN_PER_EPS = 0.2
ADAPT_H_MAX_PER_EPS = 4.0


@dataclass(frozen=True)
class MeshSizes:
    """``[mesh]``: element size ``h`` where the crack may run, ``h_coarse`` elsewhere; for a
    mesh file, its elements' sizes as measured (:func:`fem3d.mesh_check.fine_size`: ``h``,
    and the largest: ``h_coarse``), ``measured`` True. With ``adapt`` (an adaptive mesh),
    ``h`` is its ``h_min`` and ``h_coarse`` its ``h_max``."""

    h: float
    h_coarse: float
    measured: bool = False
    adapt: AdaptOptions | None = None


@dataclass(frozen=True)
class Loading:
    """``[load]``: the loads, all proportional to t.

    Attributes
    ----------
    t_max : float
    steps : int
    values : tuple of float or None
        An explicit list of loads (``t``), from 0 to ``t_max``; None: ``steps`` equal steps.
    fixed : tuple of str
        Groups with u = 0.
    displacement : tuple of (group, component index, value)
        u_component = t * value on the group's nodes.
    traction : tuple of (group, vector)
        Traction t * vector (force per area; per length times thickness in 2D) on a boundary.
    force : tuple of (group, vector)
        Total force t * vector, shared equally by the group's nodes.
    constant_displacement, constant_traction, constant_force : tuple
        ``[load.constant]``: the same kinds of load, held at their full value at every step
        (from step 0 on) while the others grow with t.
    """

    t_max: float
    steps: int
    values: tuple | None = None
    fixed: tuple = ()
    displacement: tuple = ()
    traction: tuple = ()
    force: tuple = ()
    constant_displacement: tuple = ()
    constant_traction: tuple = ()
    constant_force: tuple = ()

    @property
    def proportional(self):
        """Whether every load is t times a fixed one (no ``[load.constant]`` part)."""
        return not (any(v != 0.0 for _, _, v in self.constant_displacement)
                    or any(any(c != 0.0 for c in v) for _, v in self.constant_traction + self.constant_force))

    @property
    def loaded(self):
        """The displacement groups with a non-zero prescribed value, in order (the first is
        the one whose reaction is the run's ``force``)."""
        out = []
        for group, _, value in self.displacement:
            if value != 0.0 and group not in out:
                out.append(group)
        return tuple(out)


@dataclass(frozen=True)
class FemScene:
    """A validated ``kind = "fem"`` scene."""

    model: FemModelParameters
    geometry: Geometry
    mesh: MeshSizes
    load: Loading
    solver: SolverSettings
    text: str
    source: str
    kind: str = "fem"
    snapshots: tuple | None = None
    #: ``[output] reference``: a measured force-displacement curve drawn with the run's (CSV
    #: with two columns, displacement and force, in the scene's units).
    reference: str | None = None
    overrides: str | None = None
    #: ``[units]``: the names of the scene's length and force units (``("mm", "N")``), which
    #: the figures' axes carry; None: the scene does not say.
    units: tuple | None = None


def _numbers(table, key, count=None, *, required=False):
    """A list of finite numbers (``count`` of them if given), or None if absent and optional."""
    if not table.has(key):
        if required:
            table.required(key)
        return None
    value = table.data[key]
    ok = (isinstance(value, list) and (count is None or len(value) == count)
          and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value))
    if not ok:
        table.fail(key, value, f"must be a list of {count or 'some'} finite numbers")
    return tuple(float(v) for v in value)


def _names(table, key):
    """A list of group names (strings)."""
    if not table.has(key):
        return ()
    value = table.data[key]
    if not (isinstance(value, list) and all(isinstance(v, str) and v for v in value)):
        table.fail(key, value, "must be a list of group names (strings)")
    return tuple(value)


def _path(table, key):
    """An existing file named relative to the scene file."""
    path = table.file(key, "must be the path of a file")
    if not path.is_file():
        table.fail(key, table.data[key], "must be the path of a file; there is no such file")
    return str(path)


def _model(source, data):
    model = Table(source, "model", data["model"], ("kind", "dim", "E", "nu", "Gc", "eps", "k_res", "at", "plane",
                                                   "thickness", "undamaged", "buffers", "split", "element", "law",
                                                   "ft", "softening"))
    dim = model.integer("dim", minimum=2)
    if dim not in (2, 3):
        model.fail("dim", dim, "must be 2 or 3")
    nu = model.number("nu")
    if not -1.0 < nu < 0.5:
        model.fail("nu", nu, "must be in (-1, 0.5)")
    at = model.integer("at", minimum=1, default=1)
    if at not in (1, 2):
        model.fail("at", at, "must be 1 (AT1) or 2 (AT2)")
    law = model.choice("law", LAWS, default=f"at{at}")
    if model.has("law") and model.has("at"):
        model.fail("at", at, f'is the law\'s older spelling: give law = "{law}" alone')
    ft, softening = None, "linear"
    if law == "czm":
        at = 0
        ft = model.number("ft", minimum=0)
        softening = model.choice("softening", tuple(SOFTENING), default="linear")
    else:
        at = int(law[2])
        for key in ("ft", "softening"):
            if model.has(key):
                model.fail(key, model.data[key], 'is a key of the cohesive law (law = "czm") only')
    if dim == 3:
        for key in ("plane", "thickness"):
            if model.has(key):
                model.fail(key, model.data[key], "is for 2D runs only (model.dim = 2)")
        plane, thickness = "none", 1.0
    else:
        plane = model.choice("plane", ("stress", "strain"), default="stress")
        thickness = model.number("thickness", minimum=0, default=1.0)
    return FemModelParameters(dim=dim, E=model.number("E", minimum=0), nu=nu, Gc=model.number("Gc", minimum=0),
                              eps=model.number("eps", minimum=0), k_res=model.number("k_res", minimum=0, default=1e-6),
                              at=at, plane=plane, thickness=thickness, undamaged=_names(model, "undamaged"),
                              buffers=_buffers(model), split=model.choice("split", SPLITS, default="none"),
                              element=model.choice("element", ELEMENTS, default="P1"), law=law, ft=ft,
                              softening=softening)


def _buffers(model):
    """``buffers = {region = E_b, ...}``: each region's Young's modulus."""
    if not model.has("buffers"):
        return ()
    table = Table(model.source, "model.buffers", model.data["buffers"], tuple(model.data["buffers"])
                  if isinstance(model.data["buffers"], dict) else ())
    return tuple((name, table.number(name, minimum=0)) for name in table.data)


def _geometry(source, data, dim):
    """``[geometry]``, validated from the specimen's record (:class:`fem3d.specimens.specimen.Specimen`)."""
    records = {name: specimens.get(name) for name in specimens.names()}
    all_keys = sorted({key.name for record in records.values() for key in record.keys})
    geometry = Table(source, "geometry", data["geometry"], ("kind",) + tuple(all_keys))
    kind = geometry.choice("kind", tuple(records))
    record = records[kind]
    keys = [key.name for key in record.keys]
    for key in geometry.data:
        if key != "kind" and key not in keys:
            geometry.fail(key, geometry.data[key], f'is not a key of geometry.kind = "{kind}" (its keys:'
                           f' {", ".join(keys)})')
    if dim not in record.dims:
        geometry.fail("kind", kind, f"is a {record.dims[0]}D geometry (model.dim = {record.dims[0]})")
    options, file = {}, None
    for key in record.keys:
        if key.file:
            file = options[key.argument] = _path(geometry, key.name)
        elif geometry.has(key.name):
            options[key.argument] = _key_value(geometry, key)
    for key in record.keys:
        if geometry.has(key.name) and dim not in key.dims:
            geometry.fail(key.name, options[key.argument], key.note or f"is for {key.dims[0]}D runs only")
    return Geometry(kind, tuple(sorted(options.items())), file)


def _key_value(table, key):
    """The value of the specimen's ``key`` (:class:`fem3d.specimens.specimen.Key`) in ``table``."""
    if key.count is not None:
        return _numbers(table, key.name, key.count)
    if key.rule.type == "choice":
        return table.choice(key.name, key.rule.choices)
    return table.number(key.name, minimum=key.rule.minimum, exclusive=key.rule.exclusive)


def _vector(table, key, dim):
    """``{x = .., y = ..}``: a vector of ``dim`` components (missing ones 0)."""
    value = table.data[key]
    sub = Table(table.source, f"{table.name}.{key}", value, COMPONENTS[:dim])
    return tuple(sub.number(c, default=0.0) if sub.has(c) else 0.0 for c in COMPONENTS[:dim])


def _load_parts(source, name, load, dim):
    """The ``displacement``, ``traction`` and ``force`` tables of ``[name]``: a list of
    ``(group, component, value)`` and ``{"traction": ..., "force": ...}`` of ``(group, vector)``."""
    displacement = []
    if load.has("displacement"):
        table = Table(source, f"{name}.displacement", load.data["displacement"], tuple(load.data["displacement"]))
        for group in table.data:
            sub = Table(source, f"{name}.displacement.{group}", table.data[group], COMPONENTS[:dim])
            if not sub.data:
                table.fail(group, table.data[group], f"must give at least one component ({', '.join(COMPONENTS[:dim])})")
            for c, component in enumerate(COMPONENTS[:dim]):
                if sub.has(component):
                    displacement.append((group, c, sub.number(component)))
    vectors = {}
    for key in ("traction", "force"):
        items = []
        if load.has(key):
            table = Table(source, f"{name}.{key}", load.data[key], tuple(load.data[key]))
            items = [(group, _vector(table, group, dim)) for group in table.data]
        vectors[key] = tuple(items)
    return displacement, vectors


def _loading(source, data, dim):
    load = Table(source, "load", data["load"], ("t_max", "steps", "t", "fixed", "displacement", "traction", "force",
                                                "constant"))
    values = None
    if load.has("t"):
        values = _numbers(load, "t")
        ok = len(values) >= 2 and values[0] == 0.0 and all(b > a for a, b in zip(values, values[1:]))
        if not ok:
            load.fail("t", list(values), "must be a list of at least two loads, increasing from 0")
        for key in ("t_max", "steps"):
            if load.has(key):
                load.fail(key, load.data[key], "is not allowed with load.t (an explicit list of loads)")
        t_max, steps = values[-1], len(values) - 1
    else:
        t_max, steps = load.number("t_max", minimum=0), load.integer("steps", minimum=2)
    displacement, vectors = _load_parts(source, "load", load, dim)
    constant = {}
    if load.has("constant"):
        table = Table(source, "load.constant", load.data["constant"], ("displacement", "traction", "force"))
        parts, more = _load_parts(source, "load.constant", table, dim)
        constant = {"constant_displacement": tuple(parts), "constant_traction": more["traction"],
                    "constant_force": more["force"]}
    loading = Loading(t_max=t_max, steps=steps, values=values, fixed=_names(load, "fixed"),
                      displacement=tuple(displacement), **vectors, **constant)
    if not (loading.fixed or loading.displacement):
        raise SceneError(source, "load.fixed", "give load.fixed or load.displacement: without any prescribed"
                         " displacement the solid is free to move")
    if not (loading.loaded or loading.traction or loading.force):
        raise SceneError(source, "load", "nothing loads the solid: give a non-zero load.displacement, a"
                         " load.traction or a load.force")
    return loading


def parse(source, data, text):
    """Validate a ``kind = "fem"`` scene (module docstring); returns :class:`FemScene`."""
    require_tables(source, data, ("model", "geometry", "load"), ("mesh", "units", "solver", "output"))
    model = _model(source, data)
    geometry = _geometry(source, data, model.dim)
    mesh, extent = _sizes(source, data, model, geometry)
    loading = _loading(source, data, model.dim)
    solver, _ = read_solver(source, data.get("solver", {}), proportional=True)
    if model.split != "none" and not loading.proportional and solver.backtrack.kind != "none":
        # the exact test moves a state along its solution line, affine in the load only for
        # a quadratic energy; a split's is piecewise quadratic
        raise SceneError(source, "model.split", f'= "{model.split}": backtracking under a load with a constant part'
                         ' ([load.constant]) needs split = "none"; set solver.backtrack = "none" or drop the split')
    output = data.get("output", {})
    reference = None
    if isinstance(output, dict) and "reference" in output:
        table = Table(source, "output", output, ("snapshots", "reference"))
        reference = _path(table, "reference")
        output = {k: v for k, v in output.items() if k != "reference"}
    snapshots = read_snapshots(source, output, loading.t_max)
    return FemScene(model=model, geometry=geometry, mesh=mesh, load=loading, solver=solver, text=text,
                    source=str(source), snapshots=snapshots, reference=reference, units=_units(source, data))


def _units(source, data):
    """``[units] length = "mm", force = "N"``: the words of the scene's consistent units (the
    numbers are not converted); None if the table is absent."""
    if "units" not in data:
        return None
    table = Table(source, "units", data["units"], ("length", "force"))
    names = []
    for key in ("length", "force"):
        value = table.required(key)
        if not isinstance(value, str) or not value.strip() or len(value) > 20:
            table.fail(key, value, 'must be the name of a unit, e.g. "mm" or "N" (1-20 characters)')
        names.append(value.strip())
    return tuple(names)


def _mesh_file(source, model, geometry):
    """The mesh file of ``kind = "file"``, read and checked now (before anything is built or
    written; :func:`fem3d.specimens.file.read` keeps it for the run), and its extent."""
    from fem3d.specimens.file import read

    def refuse(detail):
        return SceneError(source, "geometry.file", f"= {show(Path(geometry.file).name)}: {detail}")

    try:
        mesh = read(geometry.file)
    except (OSError, ValueError) as error:
        detail = str(error)
        for prefix in (f"{geometry.file}: ", "from_file: "):  # the file is named once, by the key
            detail = detail.removeprefix(prefix)
        raise refuse(detail) from None
    if mesh.dim != model.dim:
        raise refuse(f"a {mesh.dim}D mesh, but model.dim = {model.dim}")
    lower, upper = mesh.points.min(axis=0), mesh.points.max(axis=0)
    return mesh, Extent(tuple(lower), tuple(upper), float(np.prod(upper - lower)), float(np.prod(upper - lower)))


def _sizes(source, data, model, geometry):
    """``[mesh]`` read and judged against the specimen's extent and ``eps``; returns the
    :class:`MeshSizes` and the extent (:class:`fem3d.specimens.specimen.Extent`).

    A mesh file's sizes are measured (``h`` may be left out; a declared one must be within
    :data:`H_FACTOR` of the measured one). Then, unless ``mesh.check_eps = false``: ``eps`` at
    least :data:`EPS_PER_H_MIN` ``h`` and at most :data:`EPS_PER_SIZE_MAX` times the
    specimen's largest side; ``h`` at most half of that side in any case. With
    ``mesh.adapt = true`` (:class:`AdaptOptions`) ``h`` and ``h_coarse`` stand for ``h_min``
    and ``h_max`` (a banded scene made adaptive keeps its sizes), and a mesh file is the first
    mesh.
    """
    record = specimens.get(geometry.kind)
    table = Table(source, "mesh", data.get("mesh", {}), ("h", "h_coarse", "check_eps", "adapt", "h_min", "h_max",
                                                         "adapt_alpha", "adapt_energy", "adapt_buffer"))
    check_eps = table.boolean("check_eps", default=True)
    adapt = table.boolean("adapt", default=False)
    for key in ("h_min", "h_max", "adapt_alpha", "adapt_energy", "adapt_buffer") if not adapt else ():
        if table.has(key):
            table.fail(key, table.data[key], "is read only with mesh.adapt = true (an adaptive mesh)")
    if adapt:
        # a banded scene made adaptive (--set mesh.adapt=true) keeps its sizes: h where the
        # crack runs becomes the smallest, h_coarse the first mesh's
        for banded, adaptive in (("h", "h_min"), ("h_coarse", "h_max")):
            if table.has(banded) and table.has(adaptive):
                table.fail(adaptive, table.data[adaptive], f"and mesh.{banded} are the same size with mesh.adapt ="
                           f" true (mesh.{banded} is taken as mesh.{adaptive}): give one of them")
        if model.element != "P1":
            raise SceneError(source, "model.element", f'= "{model.element}": mesh.adapt = true needs "P1" (the'
                             " refinement carries P1 fields exactly)")
    if geometry.file is not None:
        mesh, extent = _mesh_file(source, model, geometry)
        cell_sizes = element_sizes(mesh.points, mesh.cells)
        measured = fine_size(cell_sizes)
        if table.has("h") and not adapt:
            h = table.number("h", minimum=0)
            if not measured / H_FACTOR <= h <= measured * H_FACTOR:
                table.fail("h", h, f"must be within a factor {H_FACTOR:g} of the mesh file's element size where it is"
                            f" finest, {measured:.4g} (the {FINE_PERCENTILE:g}th percentile of its cells' longest"
                            " edges), or left out to take that")
        sizes = MeshSizes(h=measured, h_coarse=float(cell_sizes.max()), measured=True)
        if adapt:   # the file is the first mesh: its largest cell is h_max
            for key in ("h_max", "h_coarse"):
                if table.has(key):
                    table.fail(key, table.data[key], "is the mesh file's own largest element with geometry.file and"
                               " mesh.adapt = true: leave it out")
            options = _adapt_options(table, model, sizes.h_coarse)
            sizes = MeshSizes(h=options.h_min, h_coarse=options.h_max, measured=True, adapt=options)
    elif adapt:
        options = _adapt_options(table, model, None)
        sizes = MeshSizes(h=options.h_min, h_coarse=options.h_max, adapt=options)
        extent = record.extent_of(model.dim, geometry.options)
    else:
        if not table.has("h"):
            table.required("h")
        h = table.number("h", minimum=0)
        sizes = MeshSizes(h=h, h_coarse=table.number("h_coarse", minimum=0, default=h))
        if sizes.h_coarse < sizes.h:
            table.fail("h_coarse", sizes.h_coarse, f"must be >= mesh.h = {h:g}")
        extent = record.extent_of(model.dim, geometry.options)   # None: not known before meshing
    side = math.inf if extent is None else extent.size
    if sizes.adapt is not None and sizes.adapt.h_max > 0.5 * side and not sizes.measured:
        table.fail("h_coarse" if table.has("h_coarse") else "h_max", sizes.adapt.h_max, "must be at most half the"
                   f" specimen's largest side, {side:.4g}: the first mesh would have fewer than two elements across it")
    if sizes.h > 0.5 * side:
        if sizes.adapt is not None:
            key, value = ("h" if table.has("h") else "h_min"), sizes.h
        else:
            key, value = ("h", sizes.h) if table.has("h") else ("h_coarse", sizes.h)
        table.fail(key, value, f"must be at most half the specimen's largest side, {side:.4g}: the mesh would have"
                    " fewer than two elements across it")
    if check_eps:
        if model.eps > EPS_PER_SIZE_MAX * side:
            raise SceneError(source, "model.eps", f"= {model.eps:g}: must be at most {EPS_PER_SIZE_MAX:g} times the"
                             f" specimen's largest side, {side:.4g} (a crack band about 4 eps wide must fit in"
                             " it); set mesh.check_eps = false to run it anyway")
        if model.eps < EPS_PER_H_MIN * sizes.h:
            raise SceneError(source, "model.eps", f"= {model.eps:g}: must be at least {EPS_PER_H_MIN:g} times the"
                             f" element size where the crack runs, h = {sizes.h:.4g}"
                             f"{' (measured in the mesh file)' if sizes.measured else ''}: below, the damage"
                             " profile falls within one element and a crack costs several times Gc; refine the"
                             " mesh, or set mesh.check_eps = false to run it anyway")
    return sizes, extent


def _adapt_options(table, model, h_max):
    """The :class:`AdaptOptions` of ``[mesh]`` (``h_max`` given: a mesh file's own); ``h`` and
    ``h_coarse`` stand for ``h_min`` and ``h_max``."""
    key = "h" if table.has("h") else "h_min"
    h_min = table.number(key, minimum=0, default=ADAPT_H_MIN_PER_EPS * model.eps)
    if h_max is None:
        key = "h_coarse" if table.has("h_coarse") else "h_max"
        h_max = table.number(key, minimum=0, default=ADAPT_H_MAX_PER_EPS * model.eps)
        if h_max < h_min:
            table.fail(key, h_max, f"must be >= the smallest size, {h_min:g}")
    alpha = table.number("adapt_alpha", minimum=0, default=0.01)
    if alpha > 1.0:
        table.fail("adapt_alpha", alpha, "must be in (0, 1]: the damage at a vertex that marks its cells")
    energy = table.number("adapt_energy", minimum=0, default=0.5)
    buffer = table.number("adapt_buffer", minimum=0, exclusive=False, default=0.0)
    return AdaptOptions(h_min=h_min, h_max=h_max, alpha=alpha, energy=energy, buffer=buffer)


def describe_group_error(source, key, name, mesh):
    """The :class:`SceneError` for a group the mesh does not have."""
    return SceneError(source, key, f"= {show(name)}: no such group in the mesh (its groups: cells"
                      f" {', '.join(sorted(mesh.cell_groups)) or '-'}; boundaries"
                      f" {', '.join(sorted(mesh.facet_groups)) or '-'}; points {', '.join(sorted(mesh.node_groups)) or '-'})")
