"""Substrate displacements ``w_t``: the loads of the thin-film scenes (``docs/model.md#loads``).

Each load is a :class:`Load`: a function ``t -> w_t`` at the grid nodes, whether it is
proportional to ``t`` (then the minimizing ``u`` scales with ``t`` at fixed damage, which
the engine's backtracking and u-solve skipping need), and the edges the load clamps.

* ``bending``: ``w_t = -t x^2 / 2`` (pure bending of a strip or 1D film);
* ``cantilever``: ``w_t = t (x - x0)^2 (3 lx - (x - x0))``, clamped at ``x = x0`` (the
  deflection of a cantilever of length ``lx`` under an end force);
* ``indenter``: a sphere of radius ``R`` whose centre is at height ``R (1 - t)``; the
  substrate follows it where it touches, ``r^2 < r_c^2 = R^2 t (2 - t)``, and stays flat
  elsewhere. Not proportional to ``t``;
* ``field``: a displacement given at the nodes, scaled by ``t``.

Each load also knows its rate ``dw_t/dt`` (what the force conjugate to the load needs:
:func:`thinfilm.plate.energy.load_force`) and the displacement it imposes, a multiple of
``t`` (:attr:`Load.displacement_scale`): the indenter's depth ``R t``, the cantilever's tip
deflection ``w_t(lx) = 2 lx^3 t``, ``t`` itself for the others.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from thinfilm.plate.grid import Grid


@dataclass(frozen=True)
class Load:
    """A substrate displacement as a function of the load parameter.

    Attributes
    ----------
    w : callable
        ``w(t) -> ndarray, shape (n_nodes,)``, the substrate displacement at the nodes
        (non-dimensional, units of L).
    proportional : bool
        ``w(t) = t w(1)``.
    clamped : tuple of str
        Edges clamped by the load (``"x0"``, ``"x1"``, ``"y0"``, ``"y1"``).
    rate : callable, optional
        ``rate(t) -> ndarray, shape (n_nodes,)``, the derivative ``dw_t/dt`` at the nodes;
        None for a proportional load, whose rate is ``w(1)``.
    displacement_scale : float
        The displacement the load imposes per unit of ``t`` (units of L): the indenter's depth
        ``R t``, the cantilever's tip deflection ``2 lx^3 t``; 1 for the others, whose
        displacement is ``t`` itself. The recorded force is conjugate to this displacement.
    """

    w: Callable[[float], np.ndarray]
    proportional: bool
    clamped: tuple = ()
    rate: Callable[[float], np.ndarray] | None = None
    displacement_scale: float = 1.0

    def dw(self, t):
        """``dw_t/dt`` at the nodes, shape ``(n_nodes,)``."""
        if self.rate is not None:
            return self.rate(t)
        if self.proportional:
            return self.w(1.0)
        raise ValueError("a load that is not proportional to t needs its rate dw_t/dt")


def bending(grid: Grid) -> Load:
    """Pure bending ``w_t = -t x^2 / 2``."""
    w1 = -0.5 * grid.coordinates[0] ** 2
    return Load(lambda t: t * w1, True)


def cantilever(grid: Grid) -> Load:
    """Coated cantilever clamped at ``x = x0``: ``w_t = t s^2 (3 lx - s)``, ``s = x - x0``."""
    s = grid.coordinates[0] - grid.x0
    lx = grid.x1 - grid.x0
    w1 = s**2 * (3.0 * lx - s)
    return Load(lambda t: t * w1, True, clamped=("x0",), displacement_scale=2.0 * lx**3)


def contact_radius(radius, t):
    """Radius ``r_c = R sqrt(t (2 - t))`` of the disk where a sphere of radius ``R`` whose
    centre is at height ``R (1 - t)`` touches the film (units of L; ``t`` in [0, 1])."""
    return radius * np.sqrt(t * (2.0 - t))


def indenter_displacement(x, y, radius, t):
    """The substrate under a sphere of radius ``R`` pressed to depth ``R t``.

    Parameters
    ----------
    x, y : ndarray
        Node coordinates (units of L), same shape.
    radius : float
        ``R`` (units of L).
    t : float
        Load in [0, 1]: the sphere's centre is at height ``R (1 - t)``.

    Returns
    -------
    ndarray
        ``R (1 - t) - sqrt(R^2 - r^2)`` where ``r^2 < R^2 t (2 - t)``, else 0; it is
        continuous at the contact radius and ``-R t`` at the centre.
    """
    r2 = np.asarray(x) ** 2 + np.asarray(y) ** 2
    contact = r2 < contact_radius(radius, t) ** 2
    out = np.zeros(np.shape(r2))
    out[contact] = radius * (1.0 - t) - np.sqrt(radius**2 - r2[contact])
    return out


def indenter_rate(x, y, radius, t):
    """``d w_t / d t`` of :func:`indenter_displacement`: ``-R`` under the contact disk
    (``r^2 < R^2 t (2 - t)``, where the substrate moves down with the sphere), 0 outside.

    At a node the substrate displacement is continuous in ``t`` (0 when the contact edge
    passes it) and its rate jumps from 0 to ``-R`` there; the node on the contact circle
    itself takes the rate from before (0), as :func:`indenter_displacement` takes it outside.
    """
    r2 = np.asarray(x) ** 2 + np.asarray(y) ** 2
    return np.where(r2 < contact_radius(radius, t) ** 2, -float(radius), 0.0)


def indenter(grid: Grid, radius: float) -> Load:
    """Spherical indenter of radius ``radius`` centred at the origin (not proportional); its
    displacement is the depth ``R t``."""
    if grid.dim == 1:
        x, y = grid.coordinates[0], np.zeros_like(grid.coordinates[0])
    else:
        x, y = grid.coordinates
    return Load(lambda t: indenter_displacement(x, y, radius, t), False,
                rate=lambda t: indenter_rate(x, y, radius, t), displacement_scale=float(radius))


def field(grid: Grid, w1: np.ndarray) -> Load:
    """A given substrate displacement ``w1`` at the nodes, scaled by t.

    Parameters
    ----------
    w1 : ndarray, shape ``grid.shape`` or ``(n_nodes,)``
    """
    w1 = np.asarray(w1, dtype=float).reshape(grid.n_nodes)
    return Load(lambda t: t * w1, True)
