"""The engine's options, each declared once with its default, units and allowed values.

Five groups, one per part of the evolution (:mod:`thinfilm.engine.evolution`), and
:class:`EngineOptions` that holds one of each. A scene sets them in its ``[solver]`` table
under the keys :data:`SCENE_GROUPS` gives (``tol``, ``omega``, ``backtrack``,
``backtrack_delta``, ``search``, ``search_delta``, ``stability_tol``...), read straight into
these objects by :func:`thinfilm.scene.read_options`; every value is checked here, when the
object is made (:func:`thinfilm.options.validate`), whoever makes it.

Energies are in the model's units; ``search.delta`` is relative to the model's toughness
(:attr:`thinfilm.engine.protocol.FractureModel.toughness`), so that one default serves every
model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from thinfilm.options import OptionError, Rule, option, validate

__all__ = ["AltMinOptions", "NewtonOptions", "BacktrackOptions", "SearchOptions", "StabilityOptions",
           "EngineOptions", "SCENE_GROUPS"]

_POSITIVE = Rule("number", minimum=0.0, exclusive=True)


@dataclass(frozen=True)
class AltMinOptions:
    """Alternate minimization.

    Attributes
    ----------
    tol : float
        Convergence when ``max |alpha_new - alpha| < tol``.
    stop : {"change", "energy"}
        ``"energy"``: also converged, before the change of alpha is below ``tol``, once the
        energy has settled: its decrease has fallen for a few iterations and, summed with the
        geometric tail it promises, is below ``energy_tol |E|``, the damage's scaled KKT
        residual is below ``kkt_factor tol`` and the change of alpha is falling
        (:meth:`thinfilm.engine.evolution.Engine._energy_settled`). ``"change"``: ``tol``
        only.
    energy_tol : float
        The energy stop's bound on the remaining decrease of the energy, relative to it.
    kkt_factor : float
        The energy stop's bound on the scaled KKT residual, in units of ``tol``.
    max_iter : int
        Iterations per load step before :class:`thinfilm.engine.evolution.EvolutionError`.
    acceleration : {"none", "overrelax"}
        ``"overrelax"``: the growth of damage is extrapolated (see ``omega``), and so is the
        linear settling tail of a step (see ``omega_tail``); each extrapolation is projected on
        the bounds and kept only if the energy after the next u-solve is below that of the
        plain update it replaces (chosen over Anderson acceleration by measurement:
        docs/speed.md#acceleration).
    omega : float
        With ``acceleration = "overrelax"``: the largest over-relaxation factor (>= 1) of the
        damage growth, ``alpha <- alpha* + (omega_k - 1) max(alpha* - alpha, 0)`` with
        ``alpha*`` the plain update. ``omega_k`` starts at 1 and grows by ``omega_growth`` at
        each extrapolation in a slow, steady phase, up to ``omega`` while a damage mode grows
        through its instability and up to ``omega_front`` while a crack front crosses the
        film (see :meth:`thinfilm.engine.evolution.Engine._extrapolate`); it falls back to 1
        when the phase ends, and after a rejected extrapolation its cap is lowered to the last
        accepted factor until the phase ends (1 = plain alternate minimization). The default,
        4, was chosen by measurement (docs/speed.md#acceleration).
    omega_front : float
        The cap of ``omega_k`` in a front-crossing phase (>= 1).
    omega_tail : float
        The cap of the factor of the tail extrapolation, by which the last plain update is
        extended once the change of alpha is below ``10 tol`` and decays geometrically (1 turns
        it off).
    omega_growth : float
        Growth factor of ``omega_k`` (> 1).
    u_rtol_min, u_rtol_max : float
        Linear-solver tolerance range. The u-solve of iteration k asks for a relative
        residual ``1e-2 * change_{k-1}`` (the last change of alpha; ``tol`` before the
        first), clipped to ``[u_rtol_min, u_rtol_max]``: loose while alpha still moves a
        lot, tighter than ``1e-2 tol`` when it has settled, so a step that converges at its
        first iteration has an accurate u. Direct solvers reach round-off whatever they are
        asked; this saves CG iterations with an iterative solver.
    damage_rtol : float
        KKT tolerance of the damage QP (:func:`thinfilm.solvers.boxqp.solve_box_qp`).
    """

    tol: float = option(1e-4, "alternate minimization stops when no node's damage changes by this much",
                        rule=_POSITIVE, units="damage")
    stop: str = option("change", "stop criterion: the change of alpha below tol only, or also a settled energy"
                       " (energy_tol) at a near-stationary state (kkt_factor)",
                       rule=Rule("choice", choices=("change", "energy")))
    energy_tol: float = option(1e-6, "the energy stop: largest remaining decrease of the energy, relative to it",
                               rule=_POSITIVE)
    kkt_factor: float = option(10.0, "the energy stop: largest scaled KKT residual of the damage, in units of tol",
                               rule=Rule("number", minimum=1.0))
    max_iter: int = option(2000, "alternate-minimization iterations allowed per load step",
                           rule=Rule("integer", minimum=1))
    acceleration: str = option("none", "over-relaxation of the damage updates (kept only where it lowers the"
                               " energy)", rule=Rule("choice", choices=("none", "overrelax")))
    omega: float = option(4.0, "largest over-relaxation factor while a damage mode grows",
                          rule=Rule("number", minimum=1.0, maximum=64.0))
    omega_front: float = option(2.0, "largest over-relaxation factor while a crack front crosses the domain",
                                rule=Rule("number", minimum=1.0))
    omega_tail: float = option(8.0, "largest factor of the extrapolation of a step's geometric settling tail"
                               " (1: off)", rule=Rule("number", minimum=1.0))
    omega_growth: float = option(2.0, "factor by which the over-relaxation grows at each accepted extrapolation",
                                 rule=Rule("number", minimum=1.0, exclusive=True))
    u_rtol_min: float = option(1e-8, "tightest relative residual asked of a u-solve", rule=_POSITIVE)
    u_rtol_max: float = option(1e-5, "loosest relative residual asked of a u-solve", rule=_POSITIVE)
    damage_rtol: float = option(1e-9, "KKT tolerance of the damage problem", rule=_POSITIVE, units="damage")

    def __post_init__(self):
        validate(self)
        if self.u_rtol_min > self.u_rtol_max:
            raise OptionError("u_rtol_min", self.u_rtol_min, f"must be <= u_rtol_max = {self.u_rtol_max:g}")


@dataclass(frozen=True)
class NewtonOptions:
    """The nonlinear solver of a load step: alternate minimization alone, or followed by a
    reduced-space active-set Newton method on ``(u, alpha)`` (:mod:`thinfilm.engine.newton`).

    Attributes
    ----------
    method : {"altmin", "newton", "auto"}
        ``"altmin"``: alternate minimization to ``tol`` (:class:`AltMinOptions`).
        ``"newton"``: alternate minimization (with its over-relaxation) until the change of
        alpha is below ``switch``, then Newton steps on both fields to a KKT point
        (``tol``); the model must offer
        :class:`thinfilm.engine.protocol.EnergyDerivatives`. ``"auto"``: ``"newton"`` for a
        model that offers the derivatives and asks for it
        (:attr:`thinfilm.engine.protocol.EnergyDerivatives.newton_pays`), else ``"altmin"``
        (the choice per model was measured: docs/speed.md#newton).
    tol : float
        A Newton step ends when the scaled KKT residual of the state
        (:func:`thinfilm.engine.newton.kkt_residual`: the larger of the damage's, in units of
        damage, and the displacement's relative residual) is below ``tol`` and the last
        Newton step lowered the energy by less than ``energy_tol |E|``.
    energy_tol : float
    switch : float
        The change of alpha of an alternate-minimization iteration below which Newton takes
        over.
    max_steps : int
        Newton steps per attempt; an attempt that has not converged then returns its last
        state to alternate minimization, which hands over again when its change of alpha
        has fallen ``10`` times below the one at which the attempt failed.
    attempts : int
        Newton attempts per load step (after the last, alternate minimization finishes it).
    indefinite : {"altmin", "shift"}
        What a Newton attempt does where the reduced Hessian is not positive definite (a crack
        on its way): give the state back to alternate minimization, or correct the inertia
        (``shift``) and go on.
    shift : float
        With ``indefinite = "shift"``: the first inertia correction: where the reduced Hessian is not positive definite, its
        damage block ``H_aa`` becomes ``H_aa + delta diag(H_aa)``, with ``delta`` = ``shift``,
        then 10 times more at each refactorization until it is.
    max_shift : float
        The largest ``delta`` tried before the attempt gives up.
    """

    method: str = option("altmin", "the nonlinear solver of a load step: alternate minimization, or alternate"
                         " minimization handing over to a Newton method on both fields (newton), or the"
                         " measured choice per model (auto)", rule=Rule("choice", choices=("altmin", "newton", "auto")),
                         scene="nonlinear")
    tol: float = option(1e-6, "Newton: a step ends when the scaled KKT residual of the state is below this",
                        rule=_POSITIVE, units="damage")
    energy_tol: float = option(1e-10, "Newton: and the last Newton step lowered the energy by less than this,"
                               " relative to it", rule=_POSITIVE)
    switch: float = option(1e-2, "Newton takes over when alternate minimization changes no node's damage by"
                           " this much", rule=_POSITIVE, units="damage")
    max_steps: int = option(25, "Newton steps per attempt", rule=Rule("integer", minimum=1))
    attempts: int = option(3, "Newton attempts per load step", rule=Rule("integer", minimum=1))
    indefinite: str = option("altmin", "Newton, where the reduced Hessian is not positive definite: back to"
                             " alternate minimization, or an inertia correction (shift)",
                             rule=Rule("choice", choices=("altmin", "shift")))
    shift: float = option(1e-4, "first inertia correction of the damage block, relative to its diagonal",
                          rule=_POSITIVE)
    max_shift: float = option(1e4, "largest inertia correction tried", rule=_POSITIVE)

    def __post_init__(self):
        validate(self)
        if self.shift > self.max_shift:
            raise OptionError("shift", self.shift, f"must be <= max_shift = {self.max_shift:g}")


@dataclass(frozen=True)
class BacktrackOptions:
    """Backtracking (dissertation Alg. 3.1, ``kind = "standard"``) or deep backtracking (Alg. 3.2).

    Attributes
    ----------
    kind : {"none", "standard", "deep"}
    delta : float
        Energy gain that triggers a backtrack (``delta_BT`` > 0), in the model's energy units.
    interval : int
        Deep: test every ``interval`` alternate-minimization iterations (``bi``).
    direction : {1, -1}
        Deep: scan earlier steps oldest first (+1) or newest first (-1) (``bd``).
    scope : int
        Deep: how many earlier steps are scanned (``bs``; 0 = all).
    limit : int
        Total backtracks allowed in one evolution (a guard against cycling).
    test : {"exact", "dissertation"}
        With a constant part of the load (:class:`thinfilm.engine.protocol.AffineLoad`):
        the moved state's energy evaluated exactly, or the dissertation's (3.18), which drops
        the cross term between the constant and the proportional parts.
    """

    kind: str = option("none", "go back to an earlier load step that the current state beats (needs a load"
                       " proportional to t, or with a constant part)", rule=Rule("choice", choices=("none", "standard", "deep")))
    delta: float = option(1e-6, "energy gain that triggers a backtrack", rule=_POSITIVE, units="energy")
    interval: int = option(10, "deep: test every this many alternate-minimization iterations",
                           rule=Rule("integer", minimum=1))
    direction: int = option(1, "deep: scan earlier steps oldest first (1) or newest first (-1)",
                            rule=Rule("choice", choices=(1, -1),
                                      phrase="must be 1 (oldest first) or -1 (newest first)"))
    scope: int = option(0, "deep: how many earlier steps are scanned (0: all)", rule=Rule("integer", minimum=0))
    limit: int = option(200, "backtracks allowed in one evolution", rule=Rule("integer", minimum=0))
    test: str = option("exact", "with a constant part of the load: the moved state's energy exactly, or the"
                       " dissertation's (3.18) without the cross term", rule=Rule("choice", choices=("exact", "dissertation")))

    def __post_init__(self):
        validate(self)


@dataclass(frozen=True)
class SearchOptions:
    """Nucleation search.

    Attributes
    ----------
    enabled : bool
    delta : float
        A trial state is kept only if it lowers the total energy by more than
        ``delta * toughness`` (the model's toughness: the default keeps a trial that gains
        the energy of a crack 1e-3 long).
    rounds : int
        After a trial is accepted the search is repeated (another crack may follow), at
        most ``rounds`` times per load step.
    """

    enabled: bool = option(False, "after each step, try trial cracks where the film is sound and keep the lowest"
                           " energy", rule=Rule("boolean"))
    delta: float = option(1e-3, "energy gain a trial must bring to be kept, as a multiple of the model's"
                          " toughness (the energy of a crack 1e-3 long by default)", rule=Rule("number", minimum=0.0),
                          units="toughness")
    rounds: int = option(3, "searches per load step at most", rule=Rule("integer", minimum=1))

    def __post_init__(self):
        validate(self)


@dataclass(frozen=True)
class StabilityOptions:
    """Leaving saddles: a second-order check of every converged state.

    After a load step converges, the lowest curvatures of the reduced energy on the free
    damage nodes are computed (the model's ``stability_modes``). If the lowest is below
    ``-tol`` (units of the model's ``toughness / eta``), the state is a saddle: the damage is
    moved along the most unstable mode, both ways, by the step of at most ``amplitude`` that
    lowers the energy most (``Engine._descent_along``), alternate minimization is restarted
    from there, and its result is kept if it lowers the energy by more than ``delta``; then
    the new state is checked, at most ``rounds`` times per load step. The check's time counts
    in the step's ``time_total``.

    Attributes
    ----------
    enabled : bool
    tol : float
    amplitude : float
        Largest change of alpha of the perturbation.
    delta : float
        Energy gain (model units) a restart must bring to be kept.
    rounds : int
    modes : int
        Eigenpairs computed (the lowest is followed; a block of a few helps LOBPCG with the
        pairs of equal eigenvalues that symmetric states have).
    """

    enabled: bool = option(False, "check each converged state's second-order stability and leave saddles",
                           rule=Rule("boolean"))
    tol: float = option(1e-3, "a lowest curvature below -tol makes a saddle", rule=_POSITIVE,
                        units="toughness / eta")
    amplitude: float = option(0.1, "largest change of damage along an unstable mode",
                              rule=Rule("number", minimum=0.0, exclusive=True, maximum=1.0,
                                        phrase="must be in (0, 1]"), units="damage")
    delta: float = option(1e-9, "energy gain a restart must bring to be kept", rule=Rule("number", minimum=0.0),
                          units="energy")
    rounds: int = option(3, "saddles left per load step at most", rule=Rule("integer", minimum=1))
    modes: int = option(4, "eigenpairs computed", rule=Rule("integer", minimum=1))

    def __post_init__(self):
        validate(self)


@dataclass(frozen=True)
class EngineOptions:
    """One of each option group: everything the engine can be told."""

    altmin: AltMinOptions = field(default_factory=AltMinOptions)
    newton: NewtonOptions = field(default_factory=NewtonOptions)
    backtrack: BacktrackOptions = field(default_factory=BacktrackOptions)
    search: SearchOptions = field(default_factory=SearchOptions)
    stability: StabilityOptions = field(default_factory=StabilityOptions)


#: How a scene's ``[solver]`` keys map onto the groups: ``(attribute of EngineOptions, class,
#: key prefix, the field the bare prefix sets)``. ``backtrack = "deep"`` sets
#: ``BacktrackOptions.kind``, ``backtrack_delta`` its ``delta``; AltMinOptions' keys have no
#: prefix (``tol``, ``omega``...).
SCENE_GROUPS = (
    ("altmin", AltMinOptions, "", None),
    ("newton", NewtonOptions, "newton", None),
    ("backtrack", BacktrackOptions, "backtrack", "kind"),
    ("search", SearchOptions, "search", "enabled"),
    ("stability", StabilityOptions, "stability", "enabled"),
)
