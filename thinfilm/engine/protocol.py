"""What the engine needs from a model: :class:`FractureModel` and its optional hooks.

The engine (:mod:`thinfilm.engine.evolution`) knows nothing of grids or meshes. A model is
any object with the attributes and methods of :class:`FractureModel`; the finite-difference
film (:class:`thinfilm.plate.model.PlateModel`) is one, a finite-element solid another, and
``examples/bar/model.py`` the smallest, a 1D bar written to be copied (``examples/README.md``).

Four hooks are optional, each a protocol of its own that the engine recognizes with
``isinstance`` (they are ``runtime_checkable``):

* :class:`AffineLoad`, for backtracking under a load with a constant part (not proportional);
* :class:`TrialStates`, needed by the nucleation search;
* :class:`StabilityModes`, needed by the stability check;
* :class:`DamageProjection`, for a model whose damage is restricted to a subset of fields
  (the symmetric fields of a film restricted to a mirror group).

A model's ``solve_u`` that fails raises :class:`thinfilm.solvers.errors.SolverError` (every
solver of the toolkit does); the engine turns it into an
:class:`thinfilm.engine.evolution.EvolutionError` naming the step and the iteration.
"""

from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

import numpy as np

__all__ = ["FractureModel", "AffineLoad", "TrialStates", "StabilityModes", "DamageProjection"]


@runtime_checkable
class FractureModel(Protocol):
    """A discretized Ambrosio-Tortorelli model ``E(u, alpha) = P(u, alpha) + S(alpha)``.

    Attributes
    ----------
    n_alpha : int
        Number of damage unknowns.
    proportional : bool
        True if the load is ``t`` times a fixed one, so that at fixed alpha the minimizer ``u``
        scales with ``t`` and the elastic energy with ``t^2`` (backtracking needs it, and the
        engine then skips u-solves whose damage did not change).
    toughness : float
        The energy of a unit of crack (length in 2D, area in 3D, one crack in 1D), in the
        model's units: the scale of the nucleation search's threshold.
    """

    n_alpha: int
    proportional: bool
    toughness: float

    def solve_u(self, alpha: np.ndarray, t: float, u0: np.ndarray | None, rtol: float) -> np.ndarray:
        """Minimize the energy over u at fixed alpha (warm start ``u0``, relative tolerance ``rtol``)."""

    def damage_problem(self, u: np.ndarray, t: float):
        """``(A, b)`` with ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + const(u, t)``; A sparse SPD."""

    def energies(self, u: np.ndarray, alpha: np.ndarray, t: float) -> tuple[float, float]:
        """Elastic energy ``P`` and surface energy ``S``."""


@runtime_checkable
class AffineLoad(Protocol):
    """A load with a constant part, held at every step, and a part proportional to ``t``.

    At fixed damage the minimizer is then affine in the load, ``u(t) = u_c + t u_1`` (``u_c``:
    the constant loads alone), and a state moved to another load along that line has an
    elastic energy quadratic in the ratio of the loads: what backtracking compares
    (docs/model.md#constant-loads).
    """

    def elastic_along_load(self, u: np.ndarray, alpha: np.ndarray, t: float) -> tuple[float, float, float]:
        """``(B, X, P)``: the state ``(u, alpha)`` at load ``t`` > 0 moved to the load ``s t``,
        ``u_c + s (u - u_c)`` with ``u_c`` the constant loads' displacement at ``alpha``, has
        the elastic energy ``B + s X + s^2 P`` (``B``: the constant loads' energy, ``P``: the
        proportional part's, ``X``: their cross term)."""


@runtime_checkable
class TrialStates(Protocol):
    """Trial cracks for the nucleation search."""

    def trial_states(self, u: np.ndarray, alpha: np.ndarray, t: float) -> Sequence[np.ndarray]:
        """Damage fields with one trial crack each, shape ``(n_alpha,)`` each."""


@runtime_checkable
class StabilityModes(Protocol):
    """The second-order check of a converged state."""

    def stability_modes(self, alpha: np.ndarray, t: float, lower: np.ndarray, k: int) -> tuple[float, np.ndarray]:
        """``(lowest, modes)``: the lowest curvature of the reduced energy on the free damage
        nodes, in units of ``toughness / eta``, and the ``k`` lowest modes, shape
        ``(k, n_alpha)``, the most unstable first."""


@runtime_checkable
class DamageProjection(Protocol):
    """A model whose damage lives in a subset of fields (e.g. fields invariant under mirrors)."""

    def project_lower(self, lower: np.ndarray) -> np.ndarray:
        """The least admissible damage above ``lower``; applied once per load step."""

    def project_alpha(self, alpha: np.ndarray) -> np.ndarray:
        """The admissible field the engine keeps after an alpha-solve and at the start of a
        step. It must keep a field that is above an admissible bound above it."""
