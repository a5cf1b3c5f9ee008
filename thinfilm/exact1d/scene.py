"""The exact 1D scene (``kind = "exact1d"``): a film under pure bending, solved exactly.

::

    [model]
    kind = "exact1d"
    length = 0.5        # l0; the film occupies (-length/2, length/2)
    lam = 10.0          # lambda; or winkler = K/a^4 (= 4 lam^4), exactly one of the two
    toughness = 0.05    # G/a
    [load]
    t_max = 3.0
    steps = 300         # load steps for the curves; events are located exactly regardless
    [grid]
    cells = 1000
"""

from __future__ import annotations

import sys
from dataclasses import dataclass

from onedim.fragment import lam_from_winkler, winkler_from_lam
from thinfilm.scene import SceneError, Table, require_tables

__all__ = ["Exact1DModel", "Load", "Grid1D", "Exact1DScene", "lam_or_winkler", "parse"]


@dataclass(frozen=True)
class Exact1DModel:
    """Film and material of the exact 1D problem.

    Attributes
    ----------
    length : float
        Film length ``l0``; the film occupies ``(-length/2, length/2)`` (units of L).
    lam : float
        Internal length scale ``lambda = winkler^(1/4) / sqrt(2)`` (units of 1/L).
    toughness : float
        ``G/a``: the energy of one crack (per unit width).
    """

    length: float
    lam: float
    toughness: float

    @property
    def winkler(self):
        """Foundation stiffness ``K/a^4 = 4 lam^4``."""
        return float(winkler_from_lam(self.lam))


@dataclass(frozen=True)
class Load:
    """Pure bending ``w_t = -t x^2 / 2``, ``t`` in ``[0, t_max]``, recorded at ``steps`` equal steps."""

    t_max: float
    steps: int
    proportional = True


@dataclass(frozen=True)
class Grid1D:
    """A uniform grid of ``cells`` cells on the film."""

    cells: int


@dataclass(frozen=True)
class Exact1DScene:
    """A validated ``kind = "exact1d"`` scene.

    Attributes
    ----------
    model : Exact1DModel
    load : Load
    grid : Grid1D
    text : str
        The scene file's text, stored with the results.
    source : str
        Where the scene came from.
    overrides : str or None
        Keys set over the file's (:func:`thinfilm.scene.apply_overrides`), as JSON.
    """

    model: Exact1DModel
    load: Load
    grid: Grid1D
    text: str
    source: str
    kind: str = "exact1d"
    overrides: str | None = None


#: The largest ``lam`` whose ``winkler = 4 lam^4`` is a finite float64, and the least whose
#: ``winkler`` is a positive (normal) one.
LAM_MAX = (sys.float_info.max / 4.0) ** 0.25
LAM_MIN = (sys.float_info.min / 4.0) ** 0.25


def lam_or_winkler(model):
    """Exactly one of ``lam`` and ``winkler`` (= 4 lam^4), such that both are finite and
    positive (a ``lam`` beyond :data:`LAM_MAX` would make ``winkler`` infinite)."""
    has_lam, has_winkler = model.has("lam"), model.has("winkler")
    if has_lam == has_winkler:
        both = "both are given" if has_lam else "neither is given"
        raise SceneError(model.source, "model.lam", f"give exactly one of model.lam and model.winkler ({both})")
    if has_lam:
        lam = model.number("lam", minimum=0)
        if not LAM_MIN <= lam <= LAM_MAX:
            model.fail("lam", model.data["lam"], f"must be in [{LAM_MIN:.2g}, {LAM_MAX:.2g}], so that winkler ="
                        " 4 lam^4 is a finite positive number")
        return lam
    winkler = model.number("winkler", minimum=0)
    if winkler < sys.float_info.min:
        model.fail("winkler", model.data["winkler"], f"must be a positive number >= {sys.float_info.min:.2g}")
    return float(lam_from_winkler(winkler))


def parse(source, data, text):
    """Validate an exact 1D scene's tables (see the module docstring); returns :class:`Exact1DScene`."""
    require_tables(source, data, ("model", "load", "grid"))
    model = Table(source, "model", data["model"], ("kind", "length", "lam", "winkler", "toughness"))
    load = Table(source, "load", data["load"], ("t_max", "steps"))
    grid = Table(source, "grid", data["grid"], ("cells",))
    return Exact1DScene(
        model=Exact1DModel(
            length=model.number("length", minimum=0),
            lam=lam_or_winkler(model),
            toughness=model.number("toughness", minimum=0),
        ),
        load=Load(t_max=load.number("t_max", minimum=0), steps=load.integer("steps", minimum=2)),
        grid=Grid1D(cells=grid.integer("cells", minimum=2)),
        text=text,
        source=str(source),
    )
