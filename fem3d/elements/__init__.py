"""Displacement elements: the registry.

An element is a module defining ``SPACE``, a subclass of :class:`fem3d.elements.space.Space`
(its nodes, quadrature, basis and loads; the elasticity operator, the kernels and the loads
are written once over any space). Adding one is a new module and one line in
:data:`ELEMENTS`; the scene's ``[model] element`` takes the names listed here.
"""

from __future__ import annotations

import importlib

__all__ = ["ELEMENTS", "space_class", "make_space"]

#: Element name -> the module defining its ``SPACE``.
ELEMENTS = {
    "P1": "fem3d.elements.p1",
    "P2": "fem3d.elements.p2",
}


def space_class(name: str):
    """The :class:`~fem3d.elements.space.Space` subclass of element ``name``.

    Raises
    ------
    KeyError
        If no element has that name (the message lists them).
    """
    if name not in ELEMENTS:
        raise KeyError(f"no element {name!r} (elements: {', '.join(ELEMENTS)})")
    return importlib.import_module(ELEMENTS[name]).SPACE


def make_space(name: str, mesh):
    """The space of element ``name`` on ``mesh`` (a :class:`fem3d.mesh.Mesh`)."""
    return space_class(name)(mesh)
