"""Why the dissertation's Fig. 2.14 (branching under a small indenter at G/a = 2.0, 1.5 and
0.7) is or is not reproduced: ``studies/branching/README.md``.

Modules: :mod:`.scenes` (the case files and the grids the study puts them on),
:mod:`.orientation` (the grid's bias for axis-aligned cracks), :mod:`.seeds` (seeded
patterns at one load), :mod:`.extrapolation` (their energies extrapolated to h = 0),
:mod:`.imperfect` (the evolutions in imperfect films), :mod:`.saddles` (the curvatures at
the symmetric states), :mod:`.contact_edge` (where the intact film reaches AT1's elastic limit).
"""
