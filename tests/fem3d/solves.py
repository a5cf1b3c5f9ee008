"""Direct solves of the P1 elasticity problems the ``fem3d`` tests set up."""

from __future__ import annotations

import scipy.sparse.linalg as spla


def solve(el, alpha, u_d, f=None):
    u_f = spla.spsolve(el.matrix(alpha).tocsc(), el.rhs(alpha, u_d, f))
    return el.expand(u_f, u_d)
