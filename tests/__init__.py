"""The test suite, one package per package of the toolkit (``core``: scenes, kinds, results,
the command line, the import graph and the docs; ``engine``; ``solvers``; ``plate``;
``onedim``; ``scan``; ``fem3d``). :mod:`tests.helpers` loads the case files with overrides.

What several test modules share lives in helper modules, never in a ``test_*.py`` module
(``tests/core/test_imports.py`` checks it): :mod:`tests.helpers`,
:mod:`tests.solvers.plate_system`, and in ``tests/fem3d`` :mod:`~tests.fem3d.meshes`,
:mod:`~tests.fem3d.checks`, :mod:`~tests.fem3d.manufactured`, :mod:`~tests.fem3d.solves`
and :mod:`~tests.fem3d.strip`. The example model kind the tests run is in ``examples/``."""
