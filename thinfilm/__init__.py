"""thinfilm: variational fracture of brittle thin films and solids.

The Ambrosio-Tortorelli regularization of the variational approach to fracture,
discretized by finite differences for thin films bonded to a substrate (a Kirchhoff
plate on a Winkler foundation), verified against the exact one-dimensional solutions
of :mod:`onedim`.
"""

__version__ = "0.1.0"
