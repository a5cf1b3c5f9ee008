"""The error every solver of the toolkit raises when a solve fails."""

__all__ = ["SolverError"]


class SolverError(RuntimeError):
    """A linear or damage solve that failed (no convergence, a breakdown, a non-finite value).

    The engine catches this class, and only this class, around a model's solves: a model
    whose own solver fails should raise it (or a subclass) with a one-line message.
    """
