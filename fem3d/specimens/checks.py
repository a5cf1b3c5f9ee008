"""Argument checks of the specimens' mesh functions: each returns the value as the function
uses it (floats, tuples) or raises :class:`ValueError` naming the parameter."""

from __future__ import annotations

import math

__all__ = ["check_dim", "check_positive", "check_nonnegative", "check_sizes", "check_sequence", "check_box"]


def check_dim(dim):
    """``dim`` as an int, 2 or 3."""
    if isinstance(dim, bool) or dim not in (2, 3):
        raise ValueError(f"dim = {dim!r} must be 2 or 3")
    return int(dim)


def check_positive(name, value):
    """``value`` as a finite float ``> 0``."""
    value = float(value)
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} = {value!r} must be finite and > 0")
    return value


def check_nonnegative(name, value):
    """``value`` as a finite float ``>= 0``."""
    value = float(value)
    if not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{name} = {value!r} must be finite and >= 0")
    return value


def check_sizes(h, h_coarse, grading):
    """``(h, h_coarse, grading)`` as positive floats with ``h_coarse >= h``."""
    h = check_positive("h", h)
    h_coarse = check_positive("h_coarse", h_coarse)
    if h_coarse < h:
        raise ValueError(f"h_coarse = {h_coarse!r} must be >= h = {h!r}")
    return h, h_coarse, check_positive("grading", grading)


def check_sequence(name, value, n):
    """``value`` as a tuple of ``n`` finite numbers."""
    value = tuple(value)
    if len(value) != n or not all(math.isfinite(float(v)) for v in value):
        raise ValueError(f"{name} = {value!r} must be {n} finite numbers")
    return value


def check_box(name, box):
    """``box`` as floats ``(x0, x1, y0, y1)`` with ``x0 < x1`` and ``y0 < y1``."""
    x0, x1, y0, y1 = (float(v) for v in check_sequence(name, box, 4))
    if not (x0 < x1 and y0 < y1):
        raise ValueError(f"{name} = {box!r} must be (x0, x1, y0, y1) with x0 < x1 and y0 < y1")
    return x0, x1, y0, y1
