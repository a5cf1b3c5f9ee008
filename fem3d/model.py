"""The finite-element solid as the evolution engine sees it, and its boundary conditions.

:class:`Loads` turns the scene's ``[load]`` (prescribed displacements on named groups, with
components left free; tractions on boundaries; forces shared by a group's nodes, all times
``t``) into constrained dofs, their unit values and a unit load vector. :class:`FemModel`
binds the mesh, the elasticity and damage operators (:mod:`fem3d.elasticity`,
:mod:`fem3d.damage`), the loads and a linear solver into the
:class:`thinfilm.engine.protocol.FractureModel` protocol.

The elastic energy the engine sees is the bulk potential ``P(u, alpha) - f(t).u`` (the work
of the forces subtracted). Under proportional loads it is homogeneous of degree 2 in
``(t, u)``, what backtracking's (3.17) needs; with a constant part (``[load.constant]``, held
from step 0 on) the minimizer is affine in t and :meth:`FemModel.elastic_along_load` gives
the exact energy of a state moved to another load (docs/model.md#constant-loads). The reactions are read from the residual ``K u - t f`` on the constrained dofs, the
work-conjugate of the prescribed displacements, not from an average of stresses.
"""

from __future__ import annotations

import numpy as np

from fem3d.derivatives import cross_block
from fem3d.elements.p1 import P1Space
from fem3d.mesh import Mesh
from thinfilm.damage import DamageEnergy
from thinfilm.scene import SceneError

__all__ = ["Loads", "FemModel"]


class Loads:
    """Boundary conditions and loads on a mesh: a part proportional to ``t`` and a constant part.

    Parameters
    ----------
    mesh : Mesh
    loading : fem3d.scene.Loading
    thickness : float
        2D slab thickness (tractions are per unit area of the slab's faces).
    source : str
        The scene file, for messages naming a missing group.
    space : fem3d.elements.space.Space, optional
        The displacement's element on ``mesh`` (default P1: the mesh's vertices). Prescribed
        displacements hold on all the space's nodes of a group, tractions give its consistent
        facet load (:meth:`~fem3d.elements.space.Space.facet_load`), and the dofs and load
        vectors run over its nodes.

    Attributes
    ----------
    constrained : ndarray of int64, shape (k,)
        Sorted constrained dofs (``node * dim + component``).
    unit_values : ndarray, shape (k,)
        Their prescribed values at ``t = 1``.
    unit_force : ndarray, shape (n_dofs,)
        The load vector at ``t = 1`` (tractions and forces).
    constant_values : ndarray, shape (k,)
        The constant part of the prescribed values (``[load.constant] displacement``).
    constant_force : ndarray, shape (n_dofs,)
        The constant load vector (``[load.constant] traction`` and ``force``).
    proportional : bool
        No constant part: the values at ``t`` are ``t`` times the unit ones.
    loaded : dict of str -> (dofs, direction)
        For each group with a non-zero prescribed displacement: the positions of its dofs in
        ``constrained`` and the unit direction of its displacement, shape (k_g,) each.
    """

    def __init__(self, mesh: Mesh, loading, thickness=1.0, source="<string>", space=None):
        d = mesh.dim
        self.space = nodes_of = P1Space(mesh) if space is None else space   # the displacement's nodes and groups
        values, constant = {}, {}
        for group in loading.fixed:
            for node in self._nodes(nodes_of, group, "load.fixed", source):
                for c in range(d):
                    values[node * d + c] = 0.0
        directions = {}
        for group, c, value in loading.displacement:
            nodes = self._nodes(nodes_of, group, f"load.displacement.{group}", source)
            for node in nodes:
                values[node * d + c] = value
            if value != 0.0:
                directions.setdefault(group, (nodes, np.zeros(d)))[1][c] = value
        for group, c, value in loading.constant_displacement:
            for node in self._nodes(nodes_of, group, f"load.constant.displacement.{group}", source):
                constant[node * d + c] = value
                values.setdefault(node * d + c, 0.0)
        self.constrained = np.array(sorted(values), dtype=np.int64)
        self.unit_values = np.array([values[k] for k in self.constrained], dtype=np.float64)
        self.constant_values = np.array([constant.get(k, 0.0) for k in self.constrained], dtype=np.float64)
        position = {dof: i for i, dof in enumerate(self.constrained)}
        self.loaded = {}
        for group, (nodes, vector) in directions.items():
            # The reaction along the prescribed motion: sum over the group's nodes of R . v/|v|.
            unit = vector / np.linalg.norm(vector)
            dofs = [position[node * d + c] for node in nodes for c in range(d) if unit[c] != 0.0]
            weights = [unit[c] for node in nodes for c in range(d) if unit[c] != 0.0]
            self.loaded[group] = (np.array(dofs, dtype=np.int64), np.array(weights))
        self.displacement_scale = {group: float(np.linalg.norm(v)) for group, (_, v) in directions.items()}
        self.unit_force = self._force(mesh, loading.traction, loading.force, thickness, "load", source)
        self.constant_force = self._force(mesh, loading.constant_traction, loading.constant_force, thickness,
                                          "load.constant", source)
        self.proportional = loading.proportional

    def values_at(self, t):
        """The prescribed values of :attr:`constrained` at load ``t``, shape (k,)."""
        return self.constant_values + t * self.unit_values

    def force_at(self, t):
        """The load vector at load ``t``, shape (n_dofs,)."""
        return self.constant_force + t * self.unit_force

    def _force(self, mesh, traction, force, thickness, name, source):
        """The load vector of tractions on boundaries and forces shared by groups' nodes."""
        d = mesh.dim
        f = np.zeros(self.space.n_nodes * d)
        for group, vector in traction:
            facets = mesh.facet_groups.get(group)
            if facets is None:
                raise SceneError(source, f"{name}.traction.{group}", f"no boundary {group!r} in the mesh (its"
                                 f" boundaries: {', '.join(sorted(mesh.facet_groups)) or '-'})")
            area = _facet_measures(mesh.points, facets) * (thickness if d == 2 else 1.0)
            nodes, shares = self.space.facet_load(facets, area, f"{name}.traction.{group}")
            for c in range(d):
                np.add.at(f, nodes * d + c, shares * vector[c])
        for group, vector in force:
            nodes = self._nodes(self.space, group, f"{name}.force.{group}", source)
            for c in range(d):
                f[nodes * d + c] += vector[c] / len(nodes)
        return f

    @staticmethod
    def _nodes(mesh, group, key, source):
        try:
            return mesh.nodes_of(group)
        except KeyError:
            raise SceneError(source, key, f"no group {group!r} in the mesh (its groups: cells"
                             f" {', '.join(sorted(mesh.cell_groups)) or '-'}; boundaries"
                             f" {', '.join(sorted(mesh.facet_groups)) or '-'}; points"
                             f" {', '.join(sorted(mesh.node_groups)) or '-'})") from None


def _facet_measures(points, facets):
    """Lengths (2D) or areas (3D) of boundary facets, shape (k,)."""
    p = points[facets]
    if facets.shape[1] == 2:
        return np.linalg.norm(p[:, 1] - p[:, 0], axis=1)
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


class FemModel:
    """Elasticity (any displacement element) with AT damage on a mesh, in the engine's protocol.

    Parameters
    ----------
    mesh : Mesh
    elasticity : fem3d.elasticity.Elasticity
        Built on the loads' space with their constrained dofs.
    damage : fem3d.damage.P1Damage
    loads : Loads
    linear_solver : object
        A solver of :mod:`thinfilm.solvers.linear` made for ``elasticity.matrix``'s pattern.

    Attributes
    ----------
    n_alpha : int
        One damage unknown per node.
    proportional : bool
        True: every load is ``t`` times a fixed one; else the loads have a constant part, and
        :meth:`elastic_along_load` gives backtracking the energy of a state moved along it.
    toughness : float
        ``Gc`` times the thickness in 2D (the energy of a unit crack length), ``Gc`` in 3D.
    """

    #: Whether ``[solver] nonlinear = "auto"`` uses Newton on this model (docs/speed.md#newton).
    newton_pays = False

    def __init__(self, mesh, elasticity, damage, loads, linear_solver):
        self.mesh, self.elasticity, self.damage, self.loads = mesh, elasticity, damage, loads
        self.proportional = loads.proportional
        self.linear_solver = linear_solver
        self.n_alpha = mesh.n_nodes
        self.toughness = float(damage.toughness * damage.thickness)
        self.last_solve_info = None
        #: With a split: the number of cells whose switch changed after each linear solve,
        #: appended by every u-solve (the run reads and clears it after each step).
        self.switches = []
        #: Linear solves allowed in one u-solve with a split.
        self.max_switch_solves = 30

    def solve_u(self, alpha, t, u0, rtol):
        """The displacement minimizing the energy at fixed ``alpha``, shape ``(n_dofs,)``.

        Without a split one linear solve. With a split (:mod:`fem3d.split`) the switch of
        each cell is frozen at the warm start's, the linear problem solved, the switch
        updated from the solution, and so on until no cell switches, or two solves in a row
        lower the energy by less than 1e-12 of itself (at most :attr:`max_switch_solves`
        solves): for ``"amor"`` the semi-smooth Newton method of a
        convex energy, each step halved until the energy decreases; for ``"positive"``, whose
        energy jumps across the switch, a fixed point that returns the iterate of least
        energy (the warm start itself if it is at this load and none does better), so that
        the u-step never raises the energy. The cells switched by each solve are appended
        to :attr:`switches`.
        """
        values, force = self.loads.values_at(t), self.loads.force_at(t)
        if self.elasticity.split == "none":
            return self._solve_frozen(alpha, values, force, None, u0, rtol)
        return self._solve_split(alpha, values, force, u0, rtol)

    def _solve_frozen(self, alpha, values, force, tension, u0, rtol):
        """The u-problem's solution with the split's switch frozen at ``tension``."""
        el = self.elasticity
        self.linear_solver.update(el.matrix(alpha, tension=tension))
        rhs = el.rhs(alpha, values, force, tension=tension)
        x0 = None if u0 is None else np.asarray(u0)[el.free]
        u_free, self.last_solve_info = self.linear_solver.solve(rhs, x0=x0, rtol=rtol)
        return el.expand(u_free, values)

    def _solve_split(self, alpha, values, force, u0, rtol):
        el = self.elasticity

        def energy(u):
            return el.elastic_energy(u, alpha) - float(force @ u)

        tension = None if u0 is None else el.tension(u0)
        # the warm start competes only if it meets this load's prescribed values
        here = u0 is not None and np.array_equal(np.asarray(u0)[el.constrained], values)
        previous = np.asarray(u0) if here else None
        best, best_energy = (previous, energy(previous)) if here else (None, np.inf)
        stalled = 0
        for _ in range(self.max_switch_solves):
            u = self._solve_frozen(alpha, values, force, tension, u0 if previous is None else previous, rtol)
            e_u = energy(u)
            # points whose trace hovers at 0 may keep switching while the energy no longer moves
            stalled = stalled + 1 if e_u >= best_energy - 1e-12 * abs(best_energy) else 0
            if el.split == "amor" and previous is not None and e_u > best_energy:
                # a semi-smooth Newton step is a descent direction of the convex energy: halve it
                step = u - previous
                for halving in range(1, 31):
                    u = previous + 0.5 ** halving * step
                    e_u = energy(u)
                    if e_u <= best_energy:
                        break
            new = el.tension(u)
            switched = int(np.count_nonzero(new != (True if tension is None else tension)))
            self.switches.append(switched)
            if e_u <= best_energy:
                best, best_energy = u, e_u
            previous, tension = u, new
            if switched == 0 or stalled >= 2:
                break
        return best

    def damage_problem(self, u, t):
        # the damage operator's nodal energy e has P = 1/2 sum e_i g_i, the elasticity's c has
        # P = sum c_i g_i (docs/model.md#the-discrete-damage-problem): e = 2 c, exact
        e = 2.0 * self.elasticity.nodal_energy(u)
        return self.damage.problem(e) if self.damage.at is not None else self.damage.energy(e)

    def energies(self, u, alpha, t):
        work = float(self.loads.force_at(t) @ u)
        return self.elasticity.elastic_energy(u, alpha) - work, self.damage.surface_energy(alpha)

    def elastic_along_load(self, u, alpha, t):
        """``(B, X, P)``: the state moved to the load ``s t`` along its solution line,
        ``u_c + s (u - u_c)`` (``u_c``: the constant loads alone at this damage, one linear
        solve), has the elastic energy ``B + s X + s^2 P`` (exactly: it is a quadratic in s,
        read off at s = 0, 1 and -1). :class:`thinfilm.engine.protocol.AffineLoad`."""
        u_c = self.solve_u(alpha, 0.0, None, None)

        def energy(s):
            return self.energies(u_c + s * (u - u_c), alpha, s * t)[0]

        B, above, below = energy(0.0), energy(1.0), energy(-1.0)
        return B, 0.5 * (above - below), 0.5 * (above + below) - B

    def forces(self, u, alpha, t):
        """The reaction along the prescribed motion of each loaded group: ``{group: force}``."""
        reactions = self.elasticity.reactions(alpha, u, self.loads.force_at(t))
        return {group: float(weights @ reactions[dofs]) for group, (dofs, weights) in self.loads.loaded.items()}

    # --- the optional EnergyDerivatives hook (docs/model.md#second-order-information) --------
    def free_u(self, u):
        """The free dofs of the full displacement ``u`` (shape ``(n_dofs,)``), shape ``(n_free,)``.

        :class:`thinfilm.engine.protocol.EnergyDerivatives`, as the three methods below.
        """
        return np.asarray(u, dtype=np.float64)[self.elasticity.free].copy()

    def u_from_free(self, u_free, t):
        """The full displacement, shape ``(n_dofs,)``, from its free dofs (shape ``(n_free,)``),
        the constrained ones at their prescribed values at load ``t``."""
        return self.elasticity.expand(u_free, self.loads.values_at(t))

    def _switch(self, u):
        return None if self.elasticity.split == "none" else self.elasticity.tension(u)

    def energy_gradient(self, u, alpha, t):
        """``(g_u, g_alpha)``: ``(K(alpha) u - f(t))`` on the free dofs, shape ``(n_free,)``,
        and ``A alpha - b`` of :meth:`damage_problem`, shape ``(n_alpha,)``.

        With a split ``K`` is that of ``u``'s own switch (the true internal force, whose
        gradient is continuous for ``"amor"``; for ``"positive"`` the energy jumps across the
        switch and this is the gradient of the piece ``u`` lies in). On fixed damage nodes
        ``g_alpha`` is that of the damage problem (rows of the identity, ``b = -1``), not the
        energy's. Rewrites the shared values of ``elasticity.matrix`` (as :meth:`solve_u` does
        before each solve).
        """
        el = self.elasticity
        u = np.asarray(u, dtype=np.float64)
        tension = self._switch(u)
        K = el.matrix(alpha, tension=tension)
        g_u = K @ u[el.free] - el.rhs(alpha, u[el.constrained], self.loads.force_at(t), tension=tension)
        problem = self.damage_problem(u, t)
        alpha = np.asarray(alpha, dtype=np.float64)
        if isinstance(problem, DamageEnergy):
            return g_u, problem.gradient(alpha)
        A, b = problem
        return g_u, A @ alpha - b

    def hessian_blocks(self, u, alpha, t):
        """``(K_uu, K_ua, K_aa)``, fresh sparse matrices.

        ``K_uu``: :meth:`fem3d.elasticity.Elasticity.matrix` at ``alpha`` (``u``'s own switch
        with a split), shape ``(n_free, n_free)``; ``K_ua``: :func:`fem3d.derivatives.cross_block`,
        shape ``(n_free, n_alpha)``; ``K_aa``: the ``A`` of :meth:`damage_problem`, shape
        ``(n_alpha, n_alpha)``. With ``"amor"`` or ``"positive"`` the energy is piecewise
        quadratic in ``u``: these are its Hessian's blocks away from the switch surfaces
        (a point with ``tr e = 0``), where it is not defined.
        """
        el = self.elasticity
        u = np.asarray(u, dtype=np.float64)
        tension = self._switch(u)
        K_uu = el.matrix(alpha, tension=tension).copy()
        K_ua = cross_block(el, u, alpha, tension=tension, fixed_nodes=self.damage.fixed_nodes)
        problem = self.damage_problem(u, t)
        if isinstance(problem, DamageEnergy):
            return K_uu, K_ua, problem.hessian(np.asarray(alpha, dtype=np.float64))
        return K_uu, K_ua, problem[0].copy()
