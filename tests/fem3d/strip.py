"""The strip in uniaxial tension shared by the ``fem3d`` model tests: its dimensions, its
material and its mesh.
"""

from __future__ import annotations

import numpy as np

from fem3d.mesh import Mesh

# A strip (0, L) x (0, H), plane stress, thickness T, pulled at x = L by u_x = t; u_x = 0 at
# x = 0 and one corner pinned: a uniaxial stress state while it is sound.
L, H, T = 10.0, 1.0, 2.0
E, NU, GC, EPS, K_RES = 1000.0, 0.3, 0.01, 0.2, 1e-6


def strip_mesh(nx=100, ny=10, length=L, height=H):
    """Right triangles with alternating diagonals on the strip ``(0, length) x (0, height)``,
    with its ends as groups."""
    x, y = np.meshgrid(np.linspace(0.0, length, nx + 1), np.linspace(0.0, height, ny + 1))
    points = np.column_stack([x.ravel(), y.ravel()])
    index = np.arange(points.shape[0]).reshape(ny + 1, nx + 1)
    cells = []
    for j in range(ny):
        for i in range(nx):
            a, b, c, d = index[j, i], index[j, i + 1], index[j + 1, i], index[j + 1, i + 1]
            cells += [(a, b, d), (a, d, c)] if (i + j) % 2 == 0 else [(a, b, c), (b, d, c)]
    left = np.column_stack([index[:-1, 0], index[1:, 0]])
    right = np.column_stack([index[:-1, -1], index[1:, -1]])
    # A weak spot would be needed for a localized crack; the onset of damage needs none.
    return Mesh(points, np.array(cells), facet_groups={"left": left, "right": right},
                node_groups={"pin": np.array([index[0, 0]])})
