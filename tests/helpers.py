"""What the tests share: the repository's paths and the case files with overrides.

The case files of ``cases/`` are the tests' inputs: a test loads one with the keys it changes
(a smaller grid, fewer steps), as a user would, instead of a scene of its own::

    scene = load_case("fig2_7", {"domain.cells": [150, 30], "load.t_max": 6.6, "load.steps": 66})
"""

from __future__ import annotations

from pathlib import Path

from thinfilm.scene import load_scene

ROOT = Path(__file__).resolve().parent.parent
CASES = ROOT / "cases"


def load_case(name, overrides=None):
    """The validated scene of ``cases/<name>.toml`` with ``overrides`` (dotted keys) set."""
    return load_scene(CASES / f"{name}.toml", overrides=overrides)
