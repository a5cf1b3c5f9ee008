r"""A finite-element solid whose mesh refines itself where the crack goes.

:class:`AdaptiveModel` is the engine's model (:class:`thinfilm.engine.protocol.FractureModel`
and the hooks of :class:`fem3d.model.FemModel`, by delegation to the model on its current
mesh) with the :class:`thinfilm.engine.protocol.AdaptiveMesh` hook: after a load step has
converged, the engine asks it to refine around the state it found; if anything was marked
the model rebuilds itself on the refined mesh and hands back the exact transfer of nodal
fields, and the engine solves the step again from the transferred state (a
predictor-corrector step, docs/adaptivity.md#the-corrector-loop).

A cell is marked (:func:`mark`) when it is larger than ``h_min`` (its longest edge), has a
vertex where the damage is free, and either the damage reaches ``alpha`` at one of its
vertices or within ``buffer`` of such a vertex (room for the damage to grow into before the
next corrector pass) or the undamaged elastic energy density (its degradable part, the split's
``psi_plus``), scaled by ``max(1, h / eps)``, reaches ``energy`` times :func:`onset_density`,
the density at which a homogeneous bar of the material starts to damage (AT1) or reaches its
peak stress (AT2). Marked cells are bisected (:func:`fem3d.refine.refine`) and their children
marked again by the same rule; the model is then built once on the final mesh. The mesh
never coarsens.

The refinement is recorded (:class:`thinfilm.discretization.Refinement`: each pass's marked
cells and each new vertex's parents), which the results file stores; :meth:`restore` replays
it on the first mesh to rebuild the model of a resumed run, bit for bit.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from fem3d.refine import cell_sizes, refine
from thinfilm.discretization import Refinement, SimplexMesh, prolong

__all__ = ["AdaptiveModel", "Transfer", "onset_density", "mark", "near_damage", "refine_pass"]


def onset_density(at, Gc, eps, law=None):
    r"""The undamaged elastic energy density at which a homogeneous bar starts to damage
    (AT1: :math:`3 G_c / (16 \epsilon)`; the cohesive law ``law``: :math:`f_t^2 / (2 E)`) or,
    for AT2, which damages at once, at which its stress peaks (:math:`G_c / (6 \epsilon)`)
    (energy per volume; docs/adaptivity.md#marking)."""
    if law is not None and not law.quadratic:
        return law.ft ** 2 / (2.0 * law.E)
    return 3.0 * Gc / (16.0 * eps) if at == 1 else Gc / (6.0 * eps)


def mark(sizes, alpha_cell, density, damageable, options, onset, eps, near_damage=None):
    """The cells to refine (boolean mask, shape (n_cells,)).

    A cell larger than ``eps`` averages a singular density (a corner's, a crack tip's) over
    more than the length the damage sees, so its density is scaled by ``h / eps`` before it
    is compared with the threshold: exact for a density falling as ``1 / r`` from a point of
    the cell, the strongest singularity of linear elasticity at a crack tip
    (docs/adaptivity.md#marking).

    Parameters
    ----------
    sizes : ndarray, shape (n_cells,)
        Longest edges (length).
    alpha_cell : ndarray, shape (n_cells,)
        Largest damage at the cell's vertices.
    density : ndarray, shape (n_cells,)
        Degradable elastic energy density of the undamaged material (energy per volume).
    damageable : ndarray of bool, shape (n_cells,)
        Cells with a vertex where the damage is free.
    options : fem3d.scene.AdaptOptions
    onset : float
        :func:`onset_density` of the material.
    eps : float
        The regularization length.
    near_damage : ndarray of bool, shape (n_cells,), optional
        Cells within ``options.buffer`` of a vertex where the damage reaches
        ``options.alpha`` (:func:`near_damage`).
    """
    large = sizes > options.h_min * (1.0 + 1e-9)
    scaled = density * np.maximum(1.0, sizes / eps)
    wanted = (alpha_cell >= options.alpha) | (scaled >= options.energy * onset)
    if near_damage is not None:
        wanted |= near_damage
    return large & damageable & wanted


def near_damage(points, cells, alpha, threshold, buffer):
    """The cells that reach within ``buffer`` of a vertex where ``alpha >= threshold``: their
    centroid is closer to one than ``buffer`` plus their longest edge (mask, shape (n_cells,))."""
    damaged = np.flatnonzero(np.asarray(alpha) >= threshold)
    if damaged.size == 0 or buffer <= 0.0:
        return np.zeros(cells.shape[0], dtype=bool)
    centroids = points[cells].mean(axis=1)
    distance, _ = cKDTree(points[damaged]).query(centroids, k=1)
    return distance <= buffer + cell_sizes(points, cells)


def refine_pass(mesh, refinement, marked):
    """One refinement pass of ``mesh`` (:func:`fem3d.refine.refine` of the ``marked`` cells),
    recorded: ``(mesh, refinement, cell_parent)``, the refined mesh, ``refinement`` extended by
    the pass (its parents, vertex count and marked cells), and the old cell each new one lies
    in."""
    refined = refine(mesh, marked)
    pass_nodes = np.append(refinement.pass_nodes, refined.mesh.n_nodes)
    refinement = Refinement(np.concatenate([refinement.parents, refined.parents]), pass_nodes,
                            refinement.marked + (np.asarray(marked, dtype=np.int64),))
    return refined.mesh, refinement, refined.cell_parent


class Transfer:
    """The exact transfer of P1 nodal fields from the mesh before a refinement to the mesh
    after it (:func:`thinfilm.discretization.prolong`).

    Parameters
    ----------
    refinement : Refinement
        The refinement after (its last mesh is the new one).
    n_from : int
        Vertices of the mesh before.
    dim : int
        Components of the displacement.
    """

    def __init__(self, refinement, n_from, dim):
        self.refinement, self.n_from, self.dim = refinement, n_from, dim

    def alpha(self, values):
        """A nodal scalar field (the damage, a bound), shape (n_from,) -> (n_to,)."""
        return prolong(values, self.refinement, self.n_from, 1)

    def u(self, values):
        """A displacement, shape (n_from * dim,) -> (n_to * dim,)."""
        return prolong(values, self.refinement, self.n_from, self.dim)


class AdaptiveModel:
    """The finite-element model on a mesh that refines itself (module docstring).

    Parameters
    ----------
    mesh : fem3d.mesh.Mesh
        The first mesh.
    build : callable
        ``build(mesh) -> fem3d.model.FemModel``: the model on a mesh (the scene's).
    options : fem3d.scene.AdaptOptions
    at : {1, 2}
    Gc, eps : float
        The material's toughness and length (for :func:`onset_density`).
    law : thinfilm.laws.DamageLaw, optional
        The cohesive law, whose onset density is its own.

    Attributes
    ----------
    model : fem3d.model.FemModel
        The model on the current mesh: every attribute the engine asks for that this class
        does not define is its.
    first_mesh, mesh : fem3d.mesh.Mesh
        The first and the current mesh.
    refinement : Refinement
        How the current mesh was made from the first.
    """

    def __init__(self, mesh, build, options, *, at, Gc, eps, law=None):
        self.first_mesh = self.mesh = mesh
        self.build, self.options = build, options
        self.onset, self.eps = onset_density(at, Gc, eps, law), eps
        self.model = build(mesh)
        self.refinement = Refinement.initial(mesh.n_nodes)

    def __getattr__(self, name):
        # only reached for what this class does not define: the model's protocol and hooks
        if name in ("model", "__setstate__"):
            raise AttributeError(name)
        return getattr(self.model, name)

    def description(self):
        """The current mesh as the results file stores it
        (:class:`thinfilm.discretization.SimplexMesh` with its refinement)."""
        return SimplexMesh(self.mesh.points, self.mesh.cells, refinement=self.refinement)

    def _indicators(self, u):
        """Per cell of the current mesh: the degradable energy density of ``u`` and whether a
        vertex has free damage."""
        model, mesh = self.model, self.mesh
        fixed = np.zeros(mesh.n_nodes, dtype=bool)
        if model.damage.fixed_nodes is not None:
            fixed[model.damage.fixed_nodes] = True
        density = model.elasticity.cell_mean(model.elasticity.energy_parts(u)[0])
        return density, ~fixed[mesh.cells].all(axis=1)

    def _mark(self, mesh, alpha, density, damageable):
        o = self.options
        near = near_damage(mesh.points, mesh.cells, alpha, o.alpha, o.buffer)
        return mark(cell_sizes(mesh.points, mesh.cells), np.asarray(alpha)[mesh.cells].max(axis=1), density,
                    damageable, o, self.onset, self.eps, near)

    def refine(self, u, alpha, t):
        """Refine around the converged state ``(u, alpha)`` at load ``t``
        (:class:`thinfilm.engine.protocol.AdaptiveMesh`).

        The marked cells are bisected; their children are marked again by the same rule,
        with the damage carried to them and their parent's density (exact: ``u`` is affine
        on the parent), until none is: a region marked by its damage goes down to ``h_min``
        in one call, one marked by the scaled density only as far as the density on the
        coarse cells reaches (the next corrector pass sees the finer solution's).

        Returns
        -------
        Transfer or None
            None if no cell was marked; else the model is rebuilt on the refined mesh and the
            transfer of nodal fields to it is returned.
        """
        density, damageable = self._indicators(u)
        mesh, refinement = self.mesh, self.refinement
        marked = self._mark(mesh, alpha, density, damageable)
        if not marked.any():
            return None
        n_from = mesh.n_nodes
        while marked.any():
            n_before = mesh.n_nodes
            mesh, refinement, cell_parent = refine_pass(mesh, refinement, np.flatnonzero(marked))
            alpha = prolong(alpha, refinement, n_before, 1)
            density, damageable = density[cell_parent], damageable[cell_parent]
            marked = self._mark(mesh, alpha, density, damageable)
        self._set(mesh, refinement)
        return Transfer(refinement, n_from, mesh.dim)

    def _set(self, mesh, refinement):
        self.model = self.build(mesh)
        self.mesh, self.refinement = mesh, refinement

    def restore(self, refinement):
        """Rebuild the model on the mesh of a stored refinement (a resumed run): its passes
        replayed on the first mesh, which must be the one this model started from."""
        mesh, replayed = self.first_mesh, self.refinement
        if replayed.passes:
            raise RuntimeError("restore needs a model that has not refined yet")
        for marked in refinement.marked:
            mesh, replayed, _ = refine_pass(mesh, replayed, np.asarray(marked, dtype=np.int64))
        if not (np.array_equal(replayed.parents, refinement.parents)
                and np.array_equal(replayed.pass_nodes, refinement.pass_nodes)):
            raise ValueError("the stored refinement does not replay on this first mesh (another mesh or"
                             " another version of the refinement)")
        if refinement.passes:
            self._set(mesh, replayed)
