"""The loads of a run's steps: ``t_k = t_max k / steps``, as the scene writes them.

``np.linspace(0, t_max, steps + 1)`` computes ``k * (t_max / steps)`` in binary floating
point: ``t_max = 3.0`` in 100 steps gives ``t_10 = 0.30000000000000004``, and a run in twice
the steps to twice the load gives other doubles at the same loads (a different rounding of
the spacing). Here ``t_max`` is read as the decimal the scene wrote (the shortest decimal
that gives its double: ``repr``), ``t_max k / steps`` is computed exactly as a fraction and
rounded once: every ``t_k`` is the double nearest to the exact load, so ``t_10 = 0.3`` above,
and two scenes with the same spacing ``t_max / steps`` (as exact decimals) have the very same
loads at the steps they share, the property that lets a run be extended
(``docs/results.md#extending-a-run``).
"""

from __future__ import annotations

from fractions import Fraction

import numpy as np

__all__ = ["load_steps", "equal_steps"]


def equal_steps(t_max, steps):
    """``t_0 = 0, ..., t_steps = t_max`` in ``steps`` equal steps, each the double nearest to
    ``t_max k / steps`` with ``t_max`` read as its shortest decimal.

    Parameters
    ----------
    t_max : float
    steps : int

    Returns
    -------
    ndarray, shape (steps + 1,)
        ``t[0] == 0.0`` and ``t[-1] == t_max`` exactly.
    """
    top = Fraction(repr(float(t_max)))
    steps = int(steps)
    return np.array([float(top * k / steps) for k in range(steps + 1)], dtype=float)


def load_steps(load):
    """The loads of a scene's steps: its explicit list ``load.values`` if it has one (a
    solid's ``load.t``), else :func:`equal_steps` of ``load.t_max`` and ``load.steps``.

    Parameters
    ----------
    load : object
        A scene's ``load`` (attributes ``t_max``, ``steps`` and optionally ``values``).

    Returns
    -------
    ndarray, shape (steps + 1,)
    """
    values = getattr(load, "values", None)
    if values is not None:
        return np.asarray(values, dtype=float)
    return equal_steps(load.t_max, load.steps)
