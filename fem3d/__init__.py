"""Bulk solids by finite elements (``kind = "fem"``): linear elasticity with Ambrosio-Tortorelli
damage on P1 triangles (plane stress or strain, with a thickness) and tetrahedra, meshed by
gmsh, driven by the toolkit's shared engine, solvers, results and command line.

:mod:`~fem3d.kind` registers the kind; :mod:`~fem3d.scene` reads its scenes;
:mod:`~fem3d.specimens` meshes the experiments' specimens; :mod:`~fem3d.mesh` is the mesh with
its named groups; :mod:`~fem3d.elements` the displacement's elements (P1, P2: ``[model]
element``), each a module of its nodes, quadrature and loads; :mod:`~fem3d.elasticity` (over
any element) and :mod:`~fem3d.damage` are the two operators, their Numba kernels in
:mod:`~fem3d.kernels`; :mod:`~fem3d.model` binds the operators for the engine;
:mod:`~fem3d.plots` draws the kind's own figures. The equations are in
``docs/model.md#bulk-solids-finite-elements``.
"""
