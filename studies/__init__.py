"""Research questions answered with the toolkit, one package per study (``studies/README.md``).

Each study's scripts run from the repository root as modules, e.g.
``python -m studies.branching.seeds``, and write into the study's ``results/``.
"""
