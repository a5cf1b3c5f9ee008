"""What the engine returns: a converged :class:`State` and the :class:`StepRecord` of each step."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ["StepRecord", "State"]


@dataclass
class StepRecord:
    """What happened at one load step (the last time it was computed).

    Attributes
    ----------
    index : int
        Step number (1-based; step 0 is the unloaded state).
    t : float
        Load.
    elastic, surface, total : float
        Energies of the converged state.
    iterations : int
        Alternate-minimization iterations (one u-solve each, skipped or not) of the accepted
        state, including its accepted trials and rejected extrapolations.
    u_solves, u_solves_skipped : int
        Linear solves done, and skipped because alpha had not changed (proportional load).
    backtracks : int
        Backtracks that went back to this step and restarted it.
    trials, trials_accepted : int
        Trials tried and kept: those of the nucleation search and the restarts of the
        stability check.
    extrapolations_rejected : int
        Accelerated damage updates that raised the energy and were undone (each cost one
        u-solve).
    lowest_curvature : float
        With the stability check: the lowest curvature of the reduced energy at the kept
        state, in units of ``toughness / eta`` (negative: a saddle that could not be left
        in the rounds allowed); NaN without it.
    saddles_left : int
        Saddles the stability check left at this step.
    u_rescalable : int
        1 if the step's ``u`` is, bit for bit, the last u-solve's at the step's own damage
        (solved, or rescaled from an earlier solve at that damage): with a proportional load
        the next step may then rescale it instead of solving while its damage stays the same.
        Stored, so that a resumed run makes the same choice as an uninterrupted one.
    time_u, time_alpha, time_newton, time_total : float
        Wall-clock seconds in u-solves, alpha-solves, Newton attempts and the whole step.
    kkt : float
        Scaled KKT residual of the damage problem at the last u-solve, before the last
        alpha-solve (units of damage): how far that pair ``(u, alpha)`` is from stationary.
    stopped_by_energy : int
        1 if alternate minimization stopped on its settled energy (``stop = "energy"``)
        before the change of alpha fell below ``tol``.
    newton_steps : int
        Accepted Newton steps (:mod:`thinfilm.engine.newton`), those of the kept trials
        included.
    newton_attempts, newton_failures : int
        Hand-overs to Newton, and those that gave the state back to alternate minimization.
    newton_rejections : int
        Points the Newton line search rejected.
    inertia_corrections : int
        Newton steps whose Hessian had to be shifted to be positive definite.
    linear_solves, factorizations : int
        Linear solves of the u-problem or the coupled Newton system, and numeric
        factorizations of any matrix, by the toolkit's solvers (:mod:`thinfilm.solvers.work`;
        a model with a solver of its own, as ``examples/bar``, adds none of its own), over the
        whole step: rejected trials, undone extrapolations and the stability check included.
    kkt_final : float
        The scaled KKT residual of the kept state (:func:`thinfilm.engine.newton.state_kkt`:
        the larger of the damage's, in units of damage, and the displacement's relative
        residual); NaN for a model without :class:`thinfilm.engine.protocol.EnergyDerivatives`.
    refinements : int
        Corrector passes of the step: times the model refined its discretization around the
        converged state and the step was solved again (:class:`thinfilm.engine.protocol.AdaptiveMesh`).
    damage_newton_iterations : int
        Bound-constrained Newton iterations (box QPs) of the damage steps, for a damage energy
        that is not quadratic (:func:`thinfilm.solvers.box_newton.solve_box_newton`); 0 for
        the AT laws, whose damage step is one QP.
    elastic_previous, surface_previous : float
        A step that refined the discretization: the energies of the previous step's damage
        at the previous load, with ``u`` solved on this step's final discretization (the pair
        an energy difference across the refinement needs); NaN otherwise.
    energy_history : list of float
        Total energy after every half-step of alternate minimization (non-increasing).
    """

    index: int
    t: float
    elastic: float = math.nan
    surface: float = math.nan
    total: float = math.nan
    iterations: int = 0
    u_solves: int = 0
    u_solves_skipped: int = 0
    backtracks: int = 0
    trials: int = 0
    trials_accepted: int = 0
    time_u: float = 0.0
    time_alpha: float = 0.0
    time_total: float = 0.0
    time_newton: float = 0.0
    extrapolations_rejected: int = 0
    lowest_curvature: float = math.nan
    saddles_left: int = 0
    u_rescalable: int = 0
    kkt: float = math.nan
    stopped_by_energy: int = 0
    newton_steps: int = 0
    newton_attempts: int = 0
    newton_failures: int = 0
    newton_rejections: int = 0
    inertia_corrections: int = 0
    linear_solves: int = 0
    factorizations: int = 0
    kkt_final: float = math.nan
    refinements: int = 0
    damage_newton_iterations: int = 0
    elastic_previous: float = math.nan
    surface_previous: float = math.nan
    energy_history: list = field(default_factory=list)


@dataclass
class State:
    """A converged state ``(u, alpha)`` at load ``t`` with its energies.

    ``u_rescalable``: a resumed run's last state whose step recorded
    :attr:`StepRecord.u_rescalable` (the engine's own states do not use it).
    ``stale``: the state was carried to a refined discretization and its energies are the
    coarser one's; the backtracking test solves ``u`` again before comparing with them (a
    refined mesh is more compliant, and a stale energy would make any later state seem to
    beat it).
    """

    t: float
    u: np.ndarray
    alpha: np.ndarray
    elastic: float
    surface: float
    u_rescalable: bool = False
    stale: bool = False

    @property
    def total(self):
        return self.elastic + self.surface
