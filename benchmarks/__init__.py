"""Speed against error of the toolkit's solvers and evolutions.

Each benchmark runs from the repository root as a module, e.g.
``python -m benchmarks.bench_usolve``, and writes into ``benchmarks/results/``.
"""
