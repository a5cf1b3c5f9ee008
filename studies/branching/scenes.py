"""The study's scenes: the Fig. 2.14 case files of ``cases/`` and the grids the study puts
them on, as overrides of :func:`thinfilm.scene.load_scene`.

``cases/indentation_branching_G20.toml``, ``_G15`` and ``_G07`` are the figure's three
toughnesses (R = 0.1, winkler = 6.4e7) at eta = 0.005 = 2 dx on (-0.2, 0.2)^2; the study runs
them mostly at the dissertation's eta = 0.0033 on (-0.12, 0.12)^2 (:func:`grid_overrides`: 5 dx at 360
cells, 10 dx at 720, which with a 5% toughness scatter are the ``_fine`` case files).
"""

from __future__ import annotations

from pathlib import Path

from thinfilm.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
CASES_DIR = ROOT / "cases"
RESULTS = Path(__file__).resolve().parent / "results"

CASE_FILES = {"G20": "indentation_branching_G20.toml", "G15": "indentation_branching_G15.toml",
              "G07": "indentation_branching_G07.toml"}
# The dissertation's eta = 5 dx at 1500 nodes on (-0.5, 0.5)
ETA = 0.0033333333333333335
HALF_WIDTH = 0.12


def grid_overrides(cells, eta=ETA):
    """Overrides putting a case on ``cells`` x ``cells`` cells of (-0.12, 0.12)^2 with ``eta``."""
    return {"model.eta": eta, "domain.x": [-HALF_WIDTH, HALF_WIDTH], "domain.y": [-HALF_WIDTH, HALF_WIDTH],
            "domain.cells": [cells, cells]}


# eta = 5 dx and eta = 10 dx (half the grid's bias for the axes, :mod:`.orientation`)
FINE = grid_overrides(360)
FINER = grid_overrides(720)


def load_case(name, overrides=None):
    """The validated scene of case ``name`` (``"G20"``, ``"G15"``, ``"G07"``) with ``overrides``."""
    return load_scene(CASES_DIR / CASE_FILES[name], overrides=overrides)
