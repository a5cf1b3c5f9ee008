"""The thin film (``kind = "plate"``): a Kirchhoff plate on a Winkler foundation with
Ambrosio-Tortorelli damage, by finite differences on a structured grid.

:mod:`~thinfilm.plate.kind` registers it; :mod:`~thinfilm.plate.model` is what the engine
drives; the grid, the operators and their kernels, the loads, symmetry, imperfection, grid
sequencing, crack readings, stability, physical units, scene, results and figures each have a
module of their own. The equations are in ``docs/model.md#thin-film-on-a-winkler-foundation``.
"""
