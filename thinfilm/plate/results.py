"""A film's ``results.h5`` read back: the grid's rows, the cracks along ``y = 0`` and the
crack metrics of a 2D film.

:class:`PlateResults` is :class:`thinfilm.results.reader.Results` with the structured grid's
coordinates at hand (``x``, ``y``, ``dim``, ``shape``) and the readings of a film's evolution
that the summary, the figures and the comparison with the exact solution use.
"""

from __future__ import annotations

import numpy as np

from thinfilm.plate.cracks import crack_positions
from thinfilm.results.reader import Results, ResultsError

__all__ = ["PlateResults", "crack_events"]


class PlateResults(Results):
    """A plate ``results.h5`` opened for reading, cut to its finished steps.

    Attributes (besides those of :class:`thinfilm.results.reader.Results`)
    ------------------------------------------------------------------------
    dim : int
        1 or 2.
    x : ndarray, shape (nx+1,)
    y : ndarray, shape (ny+1,) or None
        Node coordinates (units of L); ``y`` is None in 1D.
    shape : tuple of int
        ``(nx+1,)`` or ``(ny+1, nx+1)``: a flat field reshaped to the grid (x fastest).
    """

    def __init__(self, path):
        super().__init__(path)
        if self.kind != "plate":
            self.close()
            raise ResultsError(f"{self.path}: kind = {self.kind!r}, not a plate run")
        grid = self.discretization
        self.dim, self.x, self.y, self.shape = grid.dim, grid.x, grid.y, grid.shape
        self._crack_metrics = None

    def centre_rows(self, name):
        """Field ``name`` along ``y = 0`` (the row nearest to it in 2D) at every finished step.

        Returns
        -------
        ndarray, shape (n, nx+1)
            Read by hyperslab, so only one row per step leaves the disk.
        """
        ds = self.file[f"fields/{name}"]
        if self.dim == 1:
            return ds[: self.n]
        j = int(np.argmin(np.abs(self.y)))
        width = len(self.x)
        return ds[: self.n, j * width:(j + 1) * width]

    def cracks(self):
        """Crack positions along ``y = 0`` at every finished step.

        Returns
        -------
        list of ndarray
            Sorted positions (units of L) of the local maxima of alpha above 0.9
            (:func:`thinfilm.plate.cracks.crack_positions`), one array per step.
        """
        return [crack_positions(self.x, row) for row in self.centre_rows("alpha")]

    def crack_length(self):
        """Crack length read from the surface energy at every finished step (2D).

        Returns
        -------
        ndarray, shape (n,)
            Units of L: ``surface / toughness`` for a uniform film; for an imperfect one, the
            surface energy of each step's damage at unit toughness
            (:func:`thinfilm.plate.crack_metrics.energy_length`), so that its weaker places do
            not count shorter.
        """
        from thinfilm.plate.crack_metrics import energy_length

        p = self.parameters
        if "toughness" not in self.file["fields"]:
            return np.asarray(self.steps["surface"], dtype=float) / float(p["toughness"])
        hx, hy = self.discretization.spacing
        return np.array([energy_length(self.field("alpha", k), hx, hy, float(p["eta"]), int(p["at"]))
                         for k in range(self.n)])

    def crack_metrics(self):
        """The crack metrics of a 2D run at the steps :func:`thinfilm.plate.crack_metrics.measured_steps`
        chooses (every step of a small run; else the snapshot steps and the last).

        Returns
        -------
        list of thinfilm.plate.crack_metrics.CrackMetrics
            Computed once per opened file: the summary and the report of a run share them, and
            so do its two figures.
        """
        from thinfilm.plate.crack_metrics import measure_step, measured_steps

        if self._crack_metrics is None:
            steps = measured_steps(len(self.x) * len(self.y), self.t, self.parameters.get("snapshots"))
            self._crack_metrics = [measure_step(self.file, int(k)) for k in steps]
        return self._crack_metrics

    @property
    def width(self):
        """Width ``y1 - y0`` of a 2D strip (units of L); 1 in 1D, so energies per unit width divide by it."""
        return float(self.y[-1] - self.y[0]) if self.dim == 2 else 1.0


def crack_events(t, cracks):
    """Crack events of a run: the steps where the number of cracks changes.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Loads of the steps.
    cracks : sequence of ndarray
        Crack positions at each step (:meth:`PlateResults.cracks`).

    Returns
    -------
    list of (float, ndarray)
        ``(t, crack positions)`` at every step where the number of cracks changes.
    """
    events, last = [], 0
    for ti, positions in zip(t, cracks):
        if len(positions) != last:
            events.append((float(ti), positions))
            last = len(positions)
    return events
