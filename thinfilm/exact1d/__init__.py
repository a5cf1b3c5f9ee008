"""The exact 1D film (``kind = "exact1d"``): the global-minimizer evolution of :mod:`onedim`
as a scene kind, with its results file and figures (``docs/model.md#exact-1d-solution``)."""
