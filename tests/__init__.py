"""The test suite, one package per package of the toolkit (``core``: scenes, kinds, results,
the command line, the import graph and the docs; ``engine``; ``solvers``; ``plate``;
``onedim``). :mod:`tests.helpers` loads the case files with overrides."""
