"""The crack pattern of a 2D film in a few numbers: lengths, counts, branch points and rings.

:func:`measure` reads one damage field; :func:`measure_step` reads a step of a results file;
:func:`measured_steps` chooses the steps a run's ``summary.json`` and figures measure. The
definitions (``docs/results.md#crack-metrics-of-a-2d-film``):

* length from the energy: the surface energy of ``alpha`` at unit toughness,
  ``1/(4 c_m) Int(alpha^m / eta + eta |grad alpha|^2)`` on the grid (:mod:`thinfilm.plate.energy`):
  the normalization ``1/(4 c_m)`` makes a straight regularized crack cost exactly its length,
  so for a uniform film this is ``surface / toughness``. Sampling the optimal profile on the
  grid gives between ``1 - h / (4 c_m eta)`` (the crack midway between node lines) and
  ``1 + (h/eta)^2 / 32`` (AT1; ``/ 8`` for AT2, the crack on a node line) times the length;
* length of the skeleton: the nodes with ``alpha >= 0.9`` thinned to lines one node wide,
  measured along their chains of 8-neighbours (:mod:`thinfilm.plate.skeleton`: exact along
  grid lines and diagonals, up to 8.2 % long in between);
* cracks: 8-connected components of ``alpha >= 0.9``; fragments: 4-connected components of
  ``alpha < 0.9``, the intact ones those with a node of ``alpha < 0.5``
  (:mod:`thinfilm.plate.cracks`);
* branch points: :func:`thinfilm.plate.cracks.branch_points` with circles of radius
  ``max(1.5 eta, 3 h)``, looked for at the junctions of the skeleton only (three or more
  cracks must also cut the circle, so a spur of the thinning shorter than the radius is not
  one, and two close parallel cracks, cut four times, have no junction to look at);
* under the indenter: the ring radii about the origin, the contact radius ``R sqrt(t (2 - t))``
  (:func:`thinfilm.plate.loads.contact_radius`) and the radial cracks that cut the middle
  circle of each gap between rings.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from thinfilm.plate import cracks as readings
from thinfilm.plate import skeleton
from thinfilm.plate.cracks import CRACK_THRESHOLD, SOUND_THRESHOLD
from thinfilm.plate.kernels import stencil as kernels
from thinfilm.plate.loads import contact_radius

__all__ = ["CrackMetrics", "FIELD_BUDGET", "branch_radius", "energy_length", "measure", "measure_step",
           "measured_steps"]

#: Node-steps (nodes times finished steps) up to which every step is measured; a larger run
#: is measured at its snapshot steps and its last. The budget bounds the reading to some 20 s
#: (the cost of a step: docs/speed.md#crack-metrics).
FIELD_BUDGET = 4_000_000


@dataclass
class CrackMetrics:
    """The crack pattern of one damage field.

    Attributes
    ----------
    step : int
        The finished step it was read at (-1 for a field not from a run).
    t : float
        Its load.
    length_energy : float
        Crack length from the surface energy at unit toughness (units of L).
    length_skeleton : float
        Length of the skeleton of ``alpha >= 0.9`` (units of L).
    cracks : int
        Separate cracks.
    fragments, intact_fragments : int
        Pieces of film between the cracks, and those holding a sound node.
    branch_points : list of (float, float, int)
        ``(x, y, arms)`` of each junction, sorted by distance from the origin.
    rings : list of float
        Radii of the circular cracks about the indenter (empty for other loads).
    contact_radius : float or None
        The indenter's contact radius at ``t`` (None for other loads).
    radial_cracks : list of (float, float, int)
        ``(inner, outer, count)`` for each gap between rings (indenter only).
    """

    step: int
    t: float
    length_energy: float
    length_skeleton: float
    cracks: int
    fragments: int
    intact_fragments: int
    branch_points: list = field(default_factory=list)
    rings: list = field(default_factory=list)
    contact_radius: float | None = None
    radial_cracks: list = field(default_factory=list)

    @property
    def radial_total(self):
        """Radial cracks summed over the gaps."""
        return sum(count for _, _, count in self.radial_cracks)

    def as_json(self):
        """A dict of plain numbers and lists for ``summary.json``."""
        out = {"step": self.step, "t": self.t, "length_energy": self.length_energy,
               "length_skeleton": self.length_skeleton, "cracks": self.cracks, "fragments": self.fragments,
               "intact_fragments": self.intact_fragments,
               "branch_points": [[x, y, arms] for x, y, arms in self.branch_points]}
        if self.contact_radius is not None:
            out.update(rings=list(self.rings), contact_radius=self.contact_radius,
                       radial_cracks=self.radial_total,
                       radial_gaps=[[inner, outer, count] for inner, outer, count in self.radial_cracks])
        return out

    def describe(self):
        """The metrics in a few words, for reports and titles."""
        text = (f"{self.cracks} separate crack(s) in the plane, {self.fragments} fragment(s) ({self.intact_fragments} intact),"
                f" {len(self.branch_points)} branch point(s); length {self.length_energy:.4g} (energy),"
                f" {self.length_skeleton:.4g} (skeleton)")
        if self.contact_radius is not None:
            rings = ", ".join(f"{r:.4g}" for r in self.rings) or "none"
            text += (f"; rings at r = {rings} (contact radius {self.contact_radius:.4g}),"
                     f" {self.radial_total} radial crack(s)")
        return text


def energy_length(alpha, hx, hy, eta, at):
    """The crack length of a damage field read from its surface energy at unit toughness.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a 2D grid (``[j, i]`` order).
    hx, hy : float
        Grid spacings (units of L).
    eta : float
        Regularization length (units of L).
    at : {1, 2}

    Returns
    -------
    float
        ``S_h(alpha)`` with ``toughness = 1`` (:func:`thinfilm.plate.energy.surface_energy`), units
        of L: a straight crack's length, to the grid's error stated in the module notes.
    """
    alpha = np.ascontiguousarray(alpha, dtype=np.float64)
    ny, nx = alpha.shape[0] - 1, alpha.shape[1] - 1
    return float(kernels.surface_energy(alpha.ravel(), nx, ny, hx, hy, eta, 1.0, int(at)))


def branch_radius(eta, h):
    """Radius of the circles that find branch points: ``1.5 eta`` (beyond a crack's broken core
    and a junction's blob of damage, as in the branching studies), at least 3 grid spacings."""
    return max(1.5 * eta, 3.0 * h)


def measure(alpha, x, y, eta, at, t=math.nan, step=-1, indenter_radius=None, threshold=CRACK_THRESHOLD,
            sound=SOUND_THRESHOLD):
    """The crack metrics of one 2D damage field.

    Parameters
    ----------
    alpha : ndarray, shape (ny + 1, nx + 1)
        Damage on a uniform 2D grid (``[j, i]`` order).
    x, y : ndarray, shape (nx + 1,), (ny + 1,)
        Node coordinates (units of L).
    eta : float
        Regularization length (units of L).
    at : {1, 2}
    t : float, optional
        The load (needed for the contact radius under the indenter).
    step : int, optional
        The step it comes from, recorded as is.
    indenter_radius : float, optional
        ``R`` of a spherical indenter centred at the origin: rings, contact radius and radial
        cracks are read about it.
    threshold, sound : float, optional
        Damage from which a node is broken, below which it is sound.

    Returns
    -------
    CrackMetrics
    """
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    alpha = np.asarray(alpha, dtype=float).reshape(len(y), len(x))
    hx, hy = (x[-1] - x[0]) / (len(x) - 1), (y[-1] - y[0]) / (len(y) - 1)
    broken = alpha >= threshold
    lines = skeleton.thin(broken)
    fragments, intact = readings.count_fragments(alpha, threshold, sound)
    points = []
    near = skeleton.junctions(lines)
    if near.any():
        from scipy import ndimage

        radius = branch_radius(eta, min(hx, hy))
        # Only the skeleton's nodes within one circle radius of a junction of the skeleton:
        # a few per junction instead of every broken node.
        reach = ndimage.distance_transform_edt(~near, sampling=(hy, hx)) <= radius
        points = readings.branch_points(alpha, x, y, radius, within=lines & reach, threshold=threshold)
    metrics = CrackMetrics(step=int(step), t=float(t), length_energy=energy_length(alpha, hx, hy, eta, at),
                           length_skeleton=skeleton.length(lines, hx, hy),
                           cracks=readings.count_cracks(alpha, threshold), fragments=fragments,
                           intact_fragments=intact, branch_points=points)
    if indenter_radius is not None:
        rings = readings.ring_radii(alpha, x, y, threshold=threshold)
        metrics.rings = [float(r) for r in rings]
        metrics.contact_radius = float(contact_radius(indenter_radius, min(max(float(t), 0.0), 1.0)))
        metrics.radial_cracks = readings.radial_cracks(alpha, x, y, rings, threshold=threshold)
    return metrics


def measure_step(file, k):
    """The crack metrics of step ``k`` of an open plate ``results.h5`` (2D).

    Parameters
    ----------
    file : h5py.File
        A plate results file on a 2D grid (``/grid/x``, ``/grid/y``, ``/parameters``,
        ``/fields/alpha``).
    k : int
        A finished step.

    Returns
    -------
    CrackMetrics
    """
    from thinfilm.results.reader import attrs_dict

    p = attrs_dict(file["parameters"])
    x, y = file["grid/x"][()], file["grid/y"][()]
    radius = float(p["radius"]) if p.get("load") == "indenter" and "radius" in p else None
    return measure(file["fields/alpha"][k], x, y, float(p["eta"]), int(p["at"]), t=float(file["steps/t"][k]),
                   step=k, indenter_radius=radius)


def measured_steps(n_nodes, t, snapshots=None, budget=FIELD_BUDGET):
    """The steps whose damage a run's summary and figures measure.

    Parameters
    ----------
    n_nodes : int
        Nodes of the grid.
    t : ndarray, shape (n,)
        Loads of the finished steps.
    snapshots : sequence of float, optional
        The scene's snapshot loads (default: five spread evenly, as the snapshot figures).
    budget : int, optional
        Node-steps up to which every step is measured.

    Returns
    -------
    ndarray of int
        Every step if ``n_nodes * n <= budget``; else the snapshot steps
        (:func:`thinfilm.plots.snapshot_steps`) and the last, sorted.
    """
    n = len(t)
    if n == 0:
        return np.empty(0, dtype=int)
    if n_nodes * n <= budget:
        return np.arange(n)
    from thinfilm.plots import snapshot_steps

    return np.union1d(snapshot_steps(t, snapshots), [n - 1]).astype(int)
