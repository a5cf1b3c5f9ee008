r"""The second-order information of the film's energy: the cross block ``d2E/du dalpha``.

The bending energy is linear in the nodal degradation (:mod:`thinfilm.plate.operators`),

    P_bending = 1/2 sum_n g(alpha_n) u.M_n.u,      K(alpha) = sum_n g(alpha_n) M_n + winkler diag(omega),

``u.M_n.u = e_n`` the lumped bending energy of node ``n`` (:func:`thinfilm.plate.energy.bending_density`;
the twist of a cell is shared by its four corners, so ``gbar_c`` is the mean of their ``g``).
Hence column ``n`` of the cross block is

    d2E / du dalpha_n = g'(alpha_n) M_n u,      g'(a) = -2 (1 - a)

(``docs/model.md#second-order-information``). ``M_n u`` is zero beyond the nodes at most one
step from ``n`` in each direction (the second differences, the cell twists and the clamped
edges' ghost nodes are all within it), so nodes three steps apart in every direction have
disjoint ``M_n u``: one product :meth:`thinfilm.plate.operators.PlateOperator.apply_bending`
with the indicator of such a set of nodes gives all of their columns at once, and ``3^dim``
products (3 in 1D, 9 in 2D) give the block. The Numba stencil kernels do the work; the
rest is NumPy index arithmetic.
"""

from __future__ import annotations

import itertools

import numpy as np
import scipy.sparse as sp

__all__ = ["cross_block"]


def cross_block(plate, u, alpha) -> sp.csr_matrix:
    """``d2E/du_free dalpha`` of the film (module docstring).

    Parameters
    ----------
    plate : thinfilm.plate.operators.PlateOperator
    u : ndarray, shape (n_nodes,)
        Displacement (its values on clamped nodes are ignored, as the energy does).
    alpha : ndarray, shape (n_nodes,)
        Damage.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (n_free, n_nodes)
        Rows: the free (not clamped) nodes, ``plate.free_nodes``; columns: every node.
    """
    grid = plate.grid
    u = plate.constrain(u)
    dg = -2.0 * (1.0 - grid.nodal("alpha", alpha))
    shape = np.array(grid.shape)
    index = np.indices(grid.shape).reshape(len(shape), -1)      # each node's index along each axis
    nodes = np.arange(grid.n_nodes)
    rows, cols, vals = [], [], []
    for color in itertools.product(range(3), repeat=len(shape)):
        color = np.array(color)[:, None]
        members = np.all(index % 3 == color, axis=0)
        product = plate.apply_bending(members.astype(np.float64), u)
        # the one member within a step of each node, along each axis: +0, +1 or -1 (= +2 mod 3)
        step = (color - index) % 3
        owner = index + np.where(step == 2, -1, step)
        inside = np.all((owner >= 0) & (owner < shape[:, None]), axis=0)
        owner_flat = np.ravel_multi_index(tuple(owner[:, inside]), grid.shape)
        rows.append(nodes[inside])
        cols.append(owner_flat)
        vals.append(product[inside] * dg[owner_flat])
    n = grid.n_nodes
    block = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    return block[plate.free_nodes]
