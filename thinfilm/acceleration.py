"""Anderson acceleration of alternate minimization.

Alternate minimization is the fixed-point iteration ``alpha <- G(alpha)``, with ``G`` one
u-solve followed by one damage solve. Anderson acceleration (type II, depth ``m``) replaces
``G(alpha_k)`` by the combination of the last ``m + 1`` images whose residuals
``f_i = G(alpha_i) - alpha_i`` combine to the smallest norm:

    gamma = argmin || f_k - dF gamma ||,   alpha_{k+1} = G(alpha_k) - dG gamma,

with ``dF``, ``dG`` the differences of consecutive residuals and images. The engine projects
the result on the bounds and keeps it only if it does not raise the energy at the current
``u`` above that of ``alpha_k`` (so the energy still decreases monotonically); otherwise it
takes ``G(alpha_k)`` and restarts the history.
"""

from __future__ import annotations

from collections import deque

import numpy as np


class Anderson:
    """Anderson mixing over the last ``depth`` iterates.

    Parameters
    ----------
    depth : int
        Number of differences kept (``m`` >= 1).
    """

    def __init__(self, depth=5):
        self.depth = int(depth)
        self.alphas = deque(maxlen=self.depth + 1)
        self.images = deque(maxlen=self.depth + 1)

    def reset(self):
        """Forget the history (after a rejected step)."""
        self.alphas.clear()
        self.images.clear()

    def step(self, alpha, image):
        """The accelerated iterate from ``alpha_k`` and its image ``G(alpha_k)``.

        Parameters
        ----------
        alpha, image : ndarray, shape (n,)

        Returns
        -------
        ndarray, shape (n,)
            ``G(alpha_k)`` itself while fewer than two iterates are known.
        """
        self.alphas.append(alpha.copy())
        self.images.append(image.copy())
        if len(self.alphas) < 2:
            return image
        G = np.array(self.images)
        F = G - np.array(self.alphas)
        dF = np.diff(F, axis=0).T  # (n, m)
        dG = np.diff(G, axis=0).T
        gamma, *_ = np.linalg.lstsq(dF, F[-1], rcond=1e-10)
        return image - dG @ gamma
