"""The solvers every model shares: the bound-constrained damage problem
(:mod:`~thinfilm.solvers.boxqp`, its Numba kernels in :mod:`~thinfilm.solvers.kernels`), the
linear solvers of the u-problem (:mod:`~thinfilm.solvers.linear`) and the error they raise
(:mod:`~thinfilm.solvers.errors`). They know nothing of any model."""
