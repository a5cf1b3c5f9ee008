"""The record of a specimen: what a scene's ``[geometry]`` may say about it and how it is meshed.

Each specimen module ends in one :class:`Specimen`: its name (the scene's ``geometry.kind``),
the model dimensions it supports, its scene keys (:class:`Key`: type, default, range, meaning,
declared once with :func:`number`, :func:`numbers`, :func:`choice` or :func:`path`), its mesh
function, the named groups the mesh has (:class:`Groups`) and its crack front for the energy
release rate (:class:`Front`). The scene reader (:mod:`fem3d.scene`), the mesher
(:func:`fem3d.kind.build_mesh`), the energy release rate (:func:`fem3d.kind.crack_front`) and
the scene reference (:func:`fem3d.specimens.reference`) read the record and nothing else.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from thinfilm.options import Rule

__all__ = ["Key", "Groups", "Front", "Extent", "Specimen", "NODES_PER_MEASURE", "number", "numbers", "choice",
           "path", "box_area", "NO_FRONT", "MESH_FRONT", "DIMS"]

#: Both model dimensions.
DIMS = (2, 3)


@dataclass(frozen=True)
class Key:
    """One scene key of ``[geometry]``.

    Attributes
    ----------
    name : str
        The scene key.
    default : object
        The value the mesh function takes when the scene does not give the key (a float, a
        tuple of floats or a string); None if the function derives it from other keys (then
        ``doc`` says how) or if the key is required (a file).
    doc : str
        One sentence: what it sets.
    rule : Rule or None
        What a number, each number of a list, or a choice allows (:class:`thinfilm.options.Rule`);
        None for a file.
    count : int or None
        The value is a list of ``count`` finite numbers (each allowed by ``rule``).
    file : bool
        The value is the path of an existing file, relative to the scene file; required.
    units : str
        Its units ("" for none, ``"length"`` for the scene's length unit).
    argument : str
        The mesh function's parameter that receives the value (default: ``name``).
    dims : tuple of int
        The model dimensions in which the key is allowed.
    note : str
        The refusal's phrase in the other dimensions (``"is for 3D runs only"``).
    """

    name: str
    default: object
    doc: str
    rule: Rule | None = None
    count: int | None = None
    file: bool = False
    units: str = ""
    argument: str = ""
    dims: tuple = DIMS
    note: str = ""

    def __post_init__(self):
        if not self.argument:
            object.__setattr__(self, "argument", self.name)

    def allowed(self):
        """The allowed values as a phrase, in the words of the scene errors."""
        if self.file:
            return "must be the path of a file"
        if self.count is not None:
            return f"must be a list of {self.count} finite numbers"
        return self.rule.allowed()

    def accepts(self, value):
        """Whether ``value`` (as the scene reader returns it: floats, tuples, strings) is allowed."""
        if self.file:
            return isinstance(value, str) and bool(value)
        if self.count is not None:
            return (isinstance(value, tuple) and len(value) == self.count
                    and all(self.rule.accepts(v) for v in value))
        return self.rule.accepts(value)


def number(name, default, doc, *, minimum=0, exclusive=True, units="length", argument="", dims=DIMS, note=""):
    """A finite number, ``> minimum`` (``exclusive``) or ``>= minimum``: a :class:`Key`."""
    return Key(name, default, doc, Rule("number", minimum=minimum, exclusive=exclusive), units=units,
               argument=argument, dims=dims, note=note)


def numbers(name, count, default, doc, *, units="length", argument="", dims=DIMS, note=""):
    """A list of ``count`` finite numbers: a :class:`Key`."""
    return Key(name, tuple(default), doc, Rule("number"), count=count, units=units, argument=argument, dims=dims,
               note=note)


def choice(name, choices, default, doc, *, argument="", dims=DIMS, note=""):
    """One of the strings ``choices``: a :class:`Key`."""
    return Key(name, default, doc, Rule("choice", choices=tuple(choices)), argument=argument, dims=dims, note=note)


def path(name, doc, *, argument=""):
    """The path of an existing file, relative to the scene file, required: a :class:`Key`."""
    return Key(name, None, doc, file=True, argument=argument)


@dataclass(frozen=True)
class Groups:
    """The named groups a specimen's mesh may have (for the docs and the checks); a group made
    only for some values of the keys is listed too.

    Attributes
    ----------
    cells, facets, nodes : tuple of str
        Regions (cell groups), boundaries (facet groups) and point groups (node groups).
    """

    cells: tuple = ()
    facets: tuple = ()
    nodes: tuple = ()


@dataclass(frozen=True)
class Front:
    """The straight crack front of a 3D run, as the energy release rate reads it
    (:func:`fem3d.release.energy_release_rate`: ``a = S / (Gc width) + a0``).

    Attributes
    ----------
    width : str or None
        The key whose value is the front's width (the crack runs through it); None: no
        straight front (G is not computed), unless ``mesh``.
    start : str or None
        The key whose value is the starter crack's length a0; None: a0 = 0.
    mesh : bool
        The width is the mesh's extent in z, read from the results (a mesh file).
    """

    width: str | None = None
    start: str | None = None
    mesh: bool = False


#: No straight crack front: G is not computed in 3D.
NO_FRONT = Front()
#: The front's width is the mesh's extent in z.
MESH_FRONT = Front(mesh=True)


@dataclass(frozen=True)
class Extent:
    """Where a specimen is and how much of it is meshed fine, reckoned from its keys alone
    (before meshing: the scene's sizes are judged against it).

    Attributes
    ----------
    lower, upper : tuple of float
        Corners of its bounding box (``dim`` coordinates, the scene's length unit).
    measure : float
        Its area (2D) or volume (3D), frames and platens included.
    fine : float
        The part of ``measure`` meshed at ``mesh.h`` (the rest at ``mesh.h_coarse``).
    """

    lower: tuple
    upper: tuple
    measure: float
    fine: float

    @property
    def size(self):
        """The largest side of the bounding box."""
        return max(u - l for l, u in zip(self.lower, self.upper))


def box_area(box, lower, upper):
    """The area of the box ``(x0, x1, y0, y1)`` within the rectangle ``lower``-``upper``."""
    x0, x1, y0, y1 = box
    return max(min(x1, upper[0]) - max(x0, lower[0]), 0.0) * max(min(y1, upper[1]) - max(y0, lower[1]), 0.0)


#: Mesh nodes per unit area (2D) or volume (3D) at element size 1, graded transitions
#: included, fitted to the built-in specimens at moderate sizes: the estimate of
#: :meth:`Specimen.nodes_estimate` is within 25% of the node counts of all six
#: (docs/scenes.md#sizes).
NODES_PER_MEASURE = {2: 1.5, 3: 3.0}


@dataclass(frozen=True)
class Specimen:
    """A specimen: everything the toolkit knows of a ``geometry.kind``.

    Attributes
    ----------
    name : str
        The scene's ``geometry.kind``.
    dims : tuple of int
        The model dimensions it supports (``model.dim``).
    keys : tuple of Key
        Its scene keys, in the order the docs and the errors list them.
    mesh : callable
        The mesh function, returning a :class:`fem3d.mesh.Mesh`; called with the keys'
        ``argument`` names, and ``h``, ``h_coarse`` if ``sized``, and ``dim`` if ``takes_dim``.
    groups : Groups
        The named groups of its mesh.
    front : Front
        Its crack front in 3D (in 2D the front is the slab's thickness and a0 = 0).
    doc : str
        One sentence for the scene reference.
    sized : bool
        The mesh function takes the scene's ``mesh.h`` and ``mesh.h_coarse``.
    takes_dim : bool
        The mesh function takes the model's dimension as ``dim``.
    extent : callable or None
        ``extent(dim, value) -> Extent`` from the keys' values (``value(name)``: the scene's
        or the default); None for a specimen whose extent is only known from its mesh (a
        mesh file).
    """

    name: str
    dims: tuple
    keys: tuple
    mesh: Callable
    groups: Groups
    front: Front = NO_FRONT
    doc: str = ""
    sized: bool = True
    takes_dim: bool = False
    extent: Callable | None = None

    def key(self, name):
        """The :class:`Key` called ``name``.

        Raises
        ------
        KeyError
            If the specimen has no such key.
        """
        for key in self.keys:
            if key.name == name:
                return key
        raise KeyError(f"geometry.kind = {self.name!r} has no key {name!r}")

    def value(self, name, options):
        """The value of key ``name``: the scene's (``options``: ``{argument: value}`` or its
        items) or the record's default."""
        key = self.key(name)
        return dict(options).get(key.argument, key.default)

    def make(self, dim, h, h_coarse, options):
        """The specimen's mesh.

        Parameters
        ----------
        dim : {2, 3}
            The model's dimension (passed on if :attr:`takes_dim`).
        h, h_coarse : float
            The scene's ``mesh.h`` and ``mesh.h_coarse`` (passed on if :attr:`sized`).
        options : mapping or iterable of (str, object)
            The scene's keys as ``{argument: value}``; the mesh function's defaults (the
            record's) for the others.

        Returns
        -------
        fem3d.mesh.Mesh
        """
        arguments = dict(options)
        if self.sized:
            arguments.update(h=h, h_coarse=h_coarse)
        if self.takes_dim:
            arguments["dim"] = dim
        return self.mesh(**arguments)

    def extent_of(self, dim, options):
        """The :class:`Extent` for the scene's keys ``options`` (``{argument: value}``), or
        None if the record has no :attr:`extent`."""
        if self.extent is None:
            return None
        return self.extent(dim, lambda name: self.value(name, options))

    def nodes_estimate(self, dim, h, h_coarse, options):
        """About how many nodes the mesh of these sizes has (:data:`NODES_PER_MEASURE`), from
        :meth:`extent_of` alone; None without an extent."""
        extent = self.extent_of(dim, options)
        if extent is None:
            return None
        c = NODES_PER_MEASURE[dim]
        return c * (extent.fine / h**dim + max(extent.measure - extent.fine, 0.0) / h_coarse**dim)

    def crack_front(self, dim, thickness, options):
        """The crack front for the energy release rate.

        Parameters
        ----------
        dim : {2, 3}
            The model's dimension.
        thickness : float
            The 2D slab's thickness.
        options : mapping or iterable of (str, object)
            The scene's keys as ``{argument: value}`` (the record's defaults for the others).

        Returns
        -------
        width : float or {"none", "mesh"}
            In 2D ``thickness``; in 3D the value of :attr:`front`'s width key, ``"none"``
            without a straight front, ``"mesh"`` for the mesh's extent in z (read from the
            results).
        a0 : float
            The value of the front's start key, or 0.
        """
        if dim == 2:
            return thickness, 0.0
        if self.front.mesh:
            return "mesh", 0.0
        if self.front.width is None:
            return "none", 0.0
        a0 = 0.0 if self.front.start is None else float(self.value(self.front.start, options))
        return float(self.value(self.front.width, options)), a0
