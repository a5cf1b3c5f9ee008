"""Structured grids of nodes on an interval (1D) or a rectangle (2D).

A :class:`Grid` is geometry only: node coordinates, spacing, the flattening convention of
nodal fields and the node quadrature weights. Boundary conditions (which edges are clamped)
belong to the operators (:mod:`thinfilm.plate.operators`), not to the grid.

Flattening convention
---------------------
Every nodal field (``u``, ``alpha``, ``w``, ...) is a 1D, C-contiguous ``float64`` array of
length ``grid.n_nodes``. In 2D the node ``(i, j)`` at ``(x0 + i hx, y0 + j hy)``,
``0 <= i <= nx``, ``0 <= j <= ny``, has flat index ``k = j (nx + 1) + i``: x runs fastest, so
``field.reshape(grid.shape)`` is an array indexed ``[j, i]`` (rows of constant y), which is
what ``matplotlib.pyplot.imshow(..., origin="lower")`` expects. In 1D, ``k = i`` and
``grid.shape == (nx + 1,)``.

Quadrature
----------
The node weights are the trapezoidal (tensor-product trapezoidal in 2D) weights: ``hx`` in
the interior, ``hx / 2`` at the two ends, times the same in y. They sum to the length (area)
of the domain and integrate smooth functions to ``O(h^2)``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: Names of the four edges of a 2D grid (the first two only in 1D): the edge ``x = x0`` is
#: ``"x0"``, and so on.
EDGES_2D = ("x0", "x1", "y0", "y1")
EDGES_1D = ("x0", "x1")


def _readonly(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


@dataclass(frozen=True)
class Grid:
    """Uniform structured grid of nodes on ``[x0, x1]`` (1D) or ``[x0, x1] x [y0, y1]`` (2D).

    Build one with :meth:`line` or :meth:`rectangle`. A 1D grid has ``ny = 0`` and
    ``y0 = y1 = 0``.

    Parameters
    ----------
    x0, x1 : float
        Ends of the domain in x (non-dimensional length, units of L), ``x0 < x1``.
    nx : int
        Number of cells in x (``nx + 1`` nodes), at least 2 (a second difference needs
        three nodes).
    y0, y1 : float
        Ends in y for a 2D grid; ignored (0) in 1D.
    ny : int
        Number of cells in y, at least 2 for a 2D grid, 0 for a 1D grid.
    """

    x0: float
    x1: float
    nx: int
    y0: float = 0.0
    y1: float = 0.0
    ny: int = 0

    def __post_init__(self) -> None:
        for key in ("x0", "x1", "y0", "y1"):
            value = getattr(self, key)
            if not math.isfinite(value):
                raise ValueError(f"Grid: {key} = {value!r} must be finite")
        for key in ("nx", "ny"):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise TypeError(f"Grid: {key} = {value!r} must be an int")
        if not self.x1 > self.x0:
            raise ValueError(f"Grid: x1 = {self.x1!r} must be > x0 = {self.x0!r}")
        if self.nx < 2:
            raise ValueError(f"Grid: nx = {self.nx!r} must be >= 2")
        if self.ny != 0:
            if self.ny < 2:
                raise ValueError(f"Grid: ny = {self.ny!r} must be 0 (1D) or >= 2 (2D)")
            if not self.y1 > self.y0:
                raise ValueError(f"Grid: y1 = {self.y1!r} must be > y0 = {self.y0!r}")
        elif self.y0 != 0.0 or self.y1 != 0.0:
            raise ValueError(f"Grid: a 1D grid (ny = 0) needs y0 = y1 = 0, got y0 = {self.y0!r}, y1 = {self.y1!r}")
        # Normalize numeric types so that equal grids compare and hash equal.
        object.__setattr__(self, "nx", int(self.nx))
        object.__setattr__(self, "ny", int(self.ny))
        for key in ("x0", "x1", "y0", "y1"):
            object.__setattr__(self, key, float(getattr(self, key)))

    # --- constructors -------------------------------------------------------------------
    @classmethod
    def line(cls, x0: float, x1: float, nx: int) -> "Grid":
        """1D grid of ``nx`` cells on ``[x0, x1]``."""
        return cls(x0, x1, nx)

    @classmethod
    def rectangle(cls, x0: float, x1: float, nx: int, y0: float, y1: float, ny: int) -> "Grid":
        """2D grid of ``nx`` x ``ny`` cells on ``[x0, x1] x [y0, y1]``."""
        return cls(x0, x1, nx, y0, y1, ny)

    # --- sizes --------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        """Space dimension, 1 or 2."""
        return 1 if self.ny == 0 else 2

    @property
    def edges(self) -> tuple[str, ...]:
        """Names of the boundary edges (points in 1D): ``("x0", "x1"[, "y0", "y1"])``."""
        return EDGES_1D if self.dim == 1 else EDGES_2D

    @property
    def hx(self) -> float:
        """Node spacing in x."""
        return (self.x1 - self.x0) / self.nx

    @property
    def hy(self) -> float:
        """Node spacing in y (1.0 in 1D, so that formulas with ``hx * hy`` stay valid)."""
        return 1.0 if self.ny == 0 else (self.y1 - self.y0) / self.ny

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of a nodal field reshaped to the grid: ``(nx+1,)`` or ``(ny+1, nx+1)``."""
        return (self.nx + 1,) if self.ny == 0 else (self.ny + 1, self.nx + 1)

    @property
    def n_nodes(self) -> int:
        """Number of nodes, the length of every flat nodal field."""
        return (self.nx + 1) * (self.ny + 1)

    @property
    def n_cells(self) -> int:
        """Number of cells (``nx`` in 1D, ``nx * ny`` in 2D)."""
        return self.nx if self.ny == 0 else self.nx * self.ny

    # --- coordinates --------------------------------------------------------------------
    @cached_property
    def x(self) -> np.ndarray:
        """Node abscissae, shape ``(nx+1,)``, read-only."""
        return _readonly(self.x0 + self.hx * np.arange(self.nx + 1, dtype=np.float64))

    @cached_property
    def y(self) -> np.ndarray:
        """Node ordinates, shape ``(ny+1,)`` (``[0.0]`` in 1D), read-only."""
        if self.ny == 0:
            return _readonly(np.zeros(1))
        return _readonly(self.y0 + self.hy * np.arange(self.ny + 1, dtype=np.float64))

    @cached_property
    def coordinates(self) -> tuple[np.ndarray, ...]:
        """Flat node coordinates: ``(X,)`` in 1D, ``(X, Y)`` in 2D, each shape ``(n_nodes,)``."""
        if self.ny == 0:
            return (self.x,)
        X = np.ascontiguousarray(np.broadcast_to(self.x[None, :], self.shape).ravel())
        Y = np.ascontiguousarray(np.broadcast_to(self.y[:, None], self.shape).ravel())
        return (_readonly(X), _readonly(Y))

    def index(self, i: int, j: int = 0) -> int:
        """Flat index of node ``(i, j)``: ``j (nx + 1) + i``."""
        if not (0 <= i <= self.nx and 0 <= j <= self.ny):
            raise IndexError(f"Grid.index: node (i, j) = ({i}, {j}) outside 0..{self.nx} x 0..{self.ny}")
        return j * (self.nx + 1) + i

    def field(self, values) -> np.ndarray:
        """A flat nodal field (1D C-contiguous float64 copy) from an array of ``shape``
        or of length ``n_nodes``."""
        a = np.asarray(values, dtype=np.float64)
        if a.shape != self.shape and a.shape != (self.n_nodes,):
            raise ValueError(f"Grid.field: shape {a.shape} is neither {self.shape} nor ({self.n_nodes},)")
        return np.array(a.ravel(), dtype=np.float64, order="C")

    def nodal(self, name: str, values) -> np.ndarray:
        """A flat nodal field as a C-contiguous float64 array of length ``n_nodes``, without a
        copy if it is one already (the operators' inputs: ``u``, ``alpha``, ``w``...).

        Raises
        ------
        ValueError
            Naming ``name`` if the shape is not ``(n_nodes,)``.
        """
        a = np.ascontiguousarray(values, dtype=np.float64)
        if a.shape != (self.n_nodes,):
            raise ValueError(f"{name} has shape {a.shape}, expected ({self.n_nodes},) (flat nodal field)")
        return a

    def description(self):
        """The grid as results files, XDMF and plots see it
        (:class:`thinfilm.discretization.StructuredGrid`)."""
        from thinfilm.discretization import StructuredGrid

        if self.ny == 0:
            return StructuredGrid(np.asarray(self.x), None, (self.x0, self.x1))
        return StructuredGrid(np.asarray(self.x), np.asarray(self.y), (self.x0, self.x1), (self.y0, self.y1))

    def evaluate(self, function) -> np.ndarray:
        """Sample ``function(x)`` (1D) or ``function(x, y)`` (2D) at the nodes, flat."""
        return self.field(np.broadcast_to(function(*self.coordinates), (self.n_nodes,)))

    # --- quadrature ---------------------------------------------------------------------
    @cached_property
    def weights_x(self) -> np.ndarray:
        """Trapezoidal weights along x, shape ``(nx+1,)``: ``hx``, halved at the ends."""
        w = np.full(self.nx + 1, self.hx)
        w[0] = w[-1] = 0.5 * self.hx
        return _readonly(w)

    @cached_property
    def weights_y(self) -> np.ndarray:
        """Trapezoidal weights along y, shape ``(ny+1,)`` (``[1.0]`` in 1D)."""
        if self.ny == 0:
            return _readonly(np.ones(1))
        w = np.full(self.ny + 1, self.hy)
        w[0] = w[-1] = 0.5 * self.hy
        return _readonly(w)

    @cached_property
    def weights(self) -> np.ndarray:
        """Node quadrature weights (trapezoidal rule), flat, shape ``(n_nodes,)``.

        ``weights @ f`` integrates a nodal field over the domain with error ``O(h^2)``.
        """
        return _readonly(np.ascontiguousarray(np.outer(self.weights_y, self.weights_x).ravel()))

    def integrate(self, field) -> float:
        """Trapezoidal integral of a flat nodal field over the domain."""
        return float(self.weights @ np.asarray(field, dtype=np.float64))

    def edge_nodes(self, edge: str) -> np.ndarray:
        """Flat indices of the nodes on an edge (``"x0"``, ``"x1"``, ``"y0"``, ``"y1"``),
        corners included, as an int64 array."""
        if edge not in self.edges:
            raise ValueError(f"Grid.edge_nodes: edge = {edge!r} not in {self.edges}")
        idx = np.arange(self.n_nodes, dtype=np.int64).reshape(self.shape)
        if self.ny == 0:
            return idx[[0]] if edge == "x0" else idx[[-1]]
        return np.ascontiguousarray({"x0": idx[:, 0], "x1": idx[:, -1], "y0": idx[0, :], "y1": idx[-1, :]}[edge])
