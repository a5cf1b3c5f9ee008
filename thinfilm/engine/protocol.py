"""What the engine needs from a model: :class:`FractureModel` and its optional hooks.

The engine (:mod:`thinfilm.engine.evolution`) knows nothing of grids or meshes. A model is
any object with the attributes and methods of :class:`FractureModel`; the finite-difference
film (:class:`thinfilm.plate.model.PlateModel`) is one, a finite-element solid another, and
``examples/bar/model.py`` the smallest, a 1D bar written to be copied (``examples/README.md``).

Six hooks are optional, each a protocol of its own that the engine recognizes with
``isinstance`` (they are ``runtime_checkable``):

* :class:`AffineLoad`, for backtracking under a load with a constant part (not proportional);
* :class:`TrialStates`, needed by the nucleation search;
* :class:`StabilityModes`, needed by the stability check;
* :class:`DamageProjection`, for a model whose damage is restricted to a subset of fields
  (the symmetric fields of a film restricted to a mirror group);
* :class:`EnergyDerivatives`, the gradient and the Hessian blocks of the energy in
  ``(u, alpha)`` on the free dofs, needed by the Newton method on both fields
  (:mod:`thinfilm.engine.newton`);
* :class:`AdaptiveMesh`, a model whose discretization refines itself around a converged state
  (the finite elements' adaptive mesh), each step then solved again on the finer one.

A model's ``solve_u`` that fails raises :class:`thinfilm.solvers.errors.SolverError` (every
solver of the toolkit does); the engine turns it into an
:class:`thinfilm.engine.evolution.EvolutionError` naming the step and the iteration.
"""

from __future__ import annotations

from typing import Protocol, Sequence, runtime_checkable

import numpy as np

__all__ = ["FractureModel", "AffineLoad", "TrialStates", "StabilityModes", "DamageProjection", "EnergyDerivatives",
           "AdaptiveMesh", "FieldTransfer"]


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
        """``(A, b)`` with ``E(u, alpha) = 1/2 alpha.A.alpha - b.alpha + const(u, t)``; A sparse SPD.

        A model whose damage energy at fixed ``u`` is not quadratic (the cohesive law) returns
        a :class:`thinfilm.damage.DamageEnergy` instead (value, gradient, Hessian and a convex
        model); the engine then solves the damage step by bound-constrained Newton
        (:func:`thinfilm.solvers.box_newton.solve_box_newton`)."""

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


@runtime_checkable
class EnergyDerivatives(Protocol):
    """First and second derivatives of ``E(u, alpha) = P + S`` in both fields.

    Convention: every method takes the model's full displacement ``u`` (what ``solve_u``
    returns, shape ``(n_u,)``) whose constrained dofs hold their prescribed values at the
    load ``t``; the derivatives in ``u`` are taken with respect to the free dofs only,
    ``free_u(u)``, shape ``(n_u_free,)``, the constrained ones held fixed. The map back is
    ``u_from_free(free_u(u), t) == u``. In ``alpha`` they are taken with respect to all
    ``n_alpha`` damage unknowns (the bounds ``lower <= alpha <= 1`` are the solver's).

    ``E`` is quadratic in ``alpha`` at fixed ``u`` (AT1, AT2), so ``K_aa`` is the ``A`` of
    ``damage_problem(u, t)`` and ``g_alpha = A alpha - b``; ``K_uu`` is the matrix
    ``solve_u`` factorizes at ``alpha`` (on the free dofs). Where a model's energy is only
    piecewise quadratic in ``u`` (a unilateral split) the blocks are those of the piece
    ``u`` lies in, the Hessian away from the switch surfaces.

    Attributes
    ----------
    newton_pays : bool
        Whether ``[solver] nonlinear = "auto"`` hands this model's load steps over to Newton:
        the measured choice (docs/speed.md#newton).
    """

    newton_pays: bool

    def free_u(self, u: np.ndarray) -> np.ndarray:
        """The free dofs of the full displacement ``u``: shape ``(n_u,)`` -> ``(n_u_free,)``."""

    def u_from_free(self, u_free: np.ndarray, t: float) -> np.ndarray:
        """The full displacement, shape ``(n_u,)``, from its free dofs, shape ``(n_u_free,)``,
        with the constrained dofs at their prescribed values at load ``t``."""

    def energy_gradient(self, u: np.ndarray, alpha: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(g_u, g_alpha)``: ``dE/du_free``, shape ``(n_u_free,)``, and ``dE/dalpha``, shape
        ``(n_alpha,)``, at the state ``(u, alpha)`` and load ``t``."""

    def hessian_blocks(self, u: np.ndarray, alpha: np.ndarray, t: float) -> tuple:
        """``(K_uu, K_ua, K_aa)``, sparse: ``d2E/du_free^2``, shape ``(n_u_free, n_u_free)``;
        ``d2E/du_free dalpha``, shape ``(n_u_free, n_alpha)``; ``d2E/dalpha^2``, shape
        ``(n_alpha, n_alpha)``. Fresh matrices, owned by the caller."""


@runtime_checkable
class NonlinearDamage(Protocol):
    """A damage energy at fixed ``u`` that is not quadratic (:class:`thinfilm.damage.DamageEnergy`),
    as :meth:`FractureModel.damage_problem` may return it: what
    :func:`thinfilm.solvers.box_newton.solve_box_newton` needs."""

    n: int

    def value(self, alpha: np.ndarray) -> float:
        """The energy (up to a constant)."""

    def gradient(self, alpha: np.ndarray) -> np.ndarray:
        """Its gradient, shape ``(n,)``."""

    def hessian(self, alpha: np.ndarray):
        """Its Hessian, sparse, shape ``(n, n)``; a new matrix."""

    def convex_model(self, alpha: np.ndarray) -> tuple:
        """``(A, b)``: a convex quadratic model about ``alpha`` with the energy's gradient there."""


class FieldTransfer(Protocol):
    """The exact transfer of a model's fields from its discretization before a refinement to
    the one after it."""

    def alpha(self, values: np.ndarray) -> np.ndarray:
        """A damage-like field (a damage, a bound), shape ``(n_alpha_before,)`` ->
        ``(n_alpha_after,)``."""

    def u(self, values: np.ndarray) -> np.ndarray:
        """A displacement, shape ``(n_u_before,)`` -> ``(n_u_after,)``."""


@runtime_checkable
class AdaptiveMesh(Protocol):
    """A model whose discretization refines itself around a converged state.

    After each load step has converged (and after its search and stability check) the
    engine calls :meth:`refine`; while it returns a transfer, the engine carries every field
    it holds (the states of earlier steps, the bounds, the converged state) to the new
    discretization and solves the step again from the transferred state (a
    predictor-corrector step). The model's sizes (``n_alpha``, its ``u``) change with it.
    """

    def refine(self, u: np.ndarray, alpha: np.ndarray, t: float) -> FieldTransfer | None:
        """Refine around the state ``(u, alpha)`` at load ``t``: None if nothing is to be
        refined, else the model now lives on the finer discretization and the transfer of
        fields to it is returned."""
