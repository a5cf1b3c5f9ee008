"""Grid sequencing: start each load step from a coarser run's damage at the same load.

Alternate minimization moves a crack front about one grid node per iteration, so the
iterations of a load step in which cracks grow scale like ``1/dx``, and each one is a
u-solve. A coarser run of the same model (same ``eta``: the damage band has the same width
in physical units) has already found where the cracks go; its damage at the same load,
interpolated to the fine grid, starts the fine step near its answer, and alternate
minimization only has to settle the band's profile and any small shift.

The start is only a first iterate: irreversibility is still against the fine run's own
previous step (``alpha_start = max(alpha_{i-1}, coarse)``), every iteration still lowers the
energy, and the step ends at a stationary point of the fine problem. It may be another
local minimizer than the one reached from ``alpha_{i-1}`` alone (as any change of the path
may, see ``docs/speed.md#acceleration``); ``tests/plate/test_sequencing.py`` compares both.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
from scipy.interpolate import RegularGridInterpolator

from thinfilm.results.reader import finished_steps

#: Two loads are the same step when they differ by less than this (relative to max(1, |t|)).
T_MATCH = 1e-9


class CoarseDamage:
    """The damage of a finished coarser run, interpolated to a finer grid at matching loads.

    Parameters
    ----------
    path : str or Path
        ``results.h5`` of a plate run (its finished steps are used).
    grid : thinfilm.plate.grid.Grid
        The fine grid (1D or 2D, the same dimension as the coarse run's).

    Notes
    -----
    Bilinear (2D) or linear (1D) interpolation between the coarse nodes; fine nodes outside
    the coarse domain get no damage (0).
    """

    def __init__(self, path, grid):
        self.path = Path(path)
        self.grid = grid
        with h5py.File(self.path, "r", locking=False) as f:
            n = finished_steps(f)
            self.t = np.asarray(f["steps/t"][:n], dtype=float)
            g = f["grid"]
            self.x = np.asarray(g["x"][()], dtype=float)
            self.y = np.asarray(g["y"][()], dtype=float) if g.attrs["dim"] == 2 else None
        if (self.y is None) != (grid.dim == 1):
            raise ValueError(f"{self.path}: a {1 if self.y is None else 2}D run cannot start a {grid.dim}D one")

    def step_of(self, t):
        """Index of the coarse step at load ``t``, or None."""
        if self.t.size == 0:
            return None
        k = int(np.argmin(np.abs(self.t - t)))
        return k if abs(self.t[k] - t) <= T_MATCH * max(1.0, abs(t)) else None

    def __call__(self, t):
        """Coarse damage at load ``t`` on the fine grid's nodes, shape (n_nodes,), or None.

        None when the coarse run has no step at ``t``.
        """
        k = self.step_of(t)
        if k is None:
            return None
        with h5py.File(self.path, "r", locking=False) as f:
            alpha = np.asarray(f["fields/alpha"][k], dtype=float)
        if self.y is None:
            fine = np.interp(self.grid.x, self.x, alpha, left=0.0, right=0.0)
        else:
            field = alpha.reshape(self.y.size, self.x.size)
            interpolate = RegularGridInterpolator((self.y, self.x), field, bounds_error=False, fill_value=0.0)
            x, y = self.grid.coordinates
            fine = interpolate(np.column_stack([y, x]))
        return np.clip(fine, 0.0, 1.0)
