"""What the solvers have done in this process: numeric factorizations and linear solves.

A step's cost is mostly its factorizations (the u-problem's matrix at each u-solve, the coupled
matrix at each Newton step, the damage problem's small reduced systems), whichever solver
makes them. Each solver of :mod:`thinfilm.solvers` adds to :data:`WORK` when it factors or
solves, and the engine reads the difference across a load step
(:class:`thinfilm.engine.records.StepRecord`). One counter per process: a run is one process
(a scan's worker runs one scene at a time).
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SolverWork", "WORK"]


@dataclass
class SolverWork:
    """Running totals.

    Attributes
    ----------
    factorizations : int
        Numeric factorizations of any matrix (a single-precision one counts as one).
    linear_solves : int
        Solves of the u-problem (:mod:`thinfilm.solvers.linear`) or of the coupled Newton
        system (:mod:`thinfilm.solvers.linear.indefinite`), each counted once whatever its
        refinement steps or CG iterations; the damage problem's small reduced systems count
        only as factorizations.
    """

    factorizations: int = 0
    linear_solves: int = 0

    def snapshot(self) -> tuple[int, int]:
        """``(factorizations, linear_solves)`` now, to subtract from a later snapshot."""
        return self.factorizations, self.linear_solves


#: The process's totals.
WORK = SolverWork()
