r"""Second-order stability of a state of the regularized thin film.

Alternate minimization stops at a critical point of ``E_h(u, alpha)``; it may be a saddle.
A perfect scene with a symmetry makes this common: started from a symmetric state, the
iterations stay symmetric (to round-off) even where every symmetric state is unstable. This
module measures the curvature of the energy at a converged state in the directions the damage
may still move, and returns the directions in which it is negative.

The reduced energy
==================
At fixed damage the energy is minimized by ``u(alpha) = K(alpha)^{-1} f``; the reduced energy
``E_r(alpha) = E_h(u(alpha), alpha)`` has the Hessian (Schur complement)::

    H = E_aa - E_au K^{-1} E_ua

with, for the discrete energy of :mod:`thinfilm.plate.operators` (``K(alpha) = sum_n g(alpha_n) M_n +
winkler diag(omega)``, bending energy ``1/2 sum_n g(alpha_n) e_n(u)``):

- ``E_aa = A``, the matrix of the alpha-problem: ``diag(1/2 g'' e) + 2 cs eta L`` (+ the AT2
  local term); ``g'' = 2`` so ``1/2 g'' e = e``;
- ``E_ua dalpha = sum_n g'(alpha_n) dalpha_n M_n u`` (:meth:`PlateOperator.apply_bending`
  with ``g = g'(alpha) dalpha``), ``g'(alpha) = -2 (1 - alpha)``;
- ``(E_au z)_n = g'(alpha_n) e_n(u, z)``, the bilinear form of the lumped bending energy,
  computed by polarization: ``e_n(u, z) = (e_n(u + z) - e_n(u - z)) / 4``.

A product ``H dalpha`` costs one solve with the factored ``K(alpha)``.

Which directions
================
Irreversibility (``alpha >= lower``) and ``alpha <= 1`` leave the damage free to move both
ways only at the nodes strictly between its bounds, where the first-order condition is an
equation. Elsewhere a bound is active and (except in degenerate cases) the energy grows at
first order in every admissible direction. The curvature is therefore taken on the free
nodes ``F = {lower + tol < alpha < 1 - tol}``: the state is stable if ``H_FF`` is positive
definite, a saddle if it has a negative eigenvalue. (A negative direction lowers the energy
for perturbations small enough to keep every node between its bounds; a node close to one
limits how far it can be followed, which is why the engine searches the step along it.)
Eigenvalues are taken with respect to the
nodes' areas (``H_FF v = lambda diag(omega_F) v``), so that ``lambda`` is an energy per unit
area per unit ``alpha^2`` and does not depend on the grid; the scale of the damage terms is
``toughness / eta``.

The lowest eigenpairs come from LOBPCG (``scipy.sparse.linalg.lobpcg``) on the symmetric
operator ``diag(omega_F)^{-1/2} H_FF diag(omega_F)^{-1/2}``, preconditioned by the same
scaling of ``E_aa`` (factored once), or from a dense eigensolver when there are few free
nodes.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from thinfilm.solvers.linear import make_solver
from thinfilm.plate.operators import GridDamage, PlateOperator

__all__ = ["Modes", "ReducedProblem", "free_nodes", "damage_hessian", "reduced_hessian", "reduced_problem",
           "lowest_modes"]

#: Distance from a bound below which a node's damage counts as on it.
BOUND_TOL = 1e-6
#: Up to this many free nodes the reduced Hessian is formed and diagonalized densely.
DENSE_NODES = 60


@dataclass
class Modes:
    """The lowest curvatures of the reduced energy at a state.

    Attributes
    ----------
    eigenvalues : ndarray, shape (k,)
        Ascending; energy per unit area per unit ``alpha^2`` (negative: unstable).
    modes : ndarray, shape (k, n_nodes)
        The matching directions of ``alpha``, zero off the free nodes, each scaled to
        ``max |mode| = 1``.
    free : ndarray of int
        The free nodes (flat indices).
    u : ndarray, shape (n_nodes,)
        The displacement minimizing the energy at the state's damage.
    products : int
        Hessian products (one linear solve each) the eigensolver used.
    """

    eigenvalues: np.ndarray
    modes: np.ndarray
    free: np.ndarray
    u: np.ndarray
    products: int

    @property
    def lowest(self) -> float:
        """The lowest eigenvalue (``+inf`` if there is no free node)."""
        return float(self.eigenvalues[0]) if len(self.eigenvalues) else float("inf")


def free_nodes(alpha, lower) -> np.ndarray:
    """Flat indices of the nodes strictly between their bounds ``lower`` and 1."""
    alpha = np.asarray(alpha)
    return np.nonzero((alpha > np.asarray(lower) + BOUND_TOL) & (alpha < 1.0 - BOUND_TOL))[0]


def damage_hessian(plate: PlateOperator, damage: GridDamage, u, free):
    """``E_aa`` on the free nodes: the alpha-problem's matrix at ``u``, shape ``(m, m)`` (CSR)."""
    A, _ = damage.problem(plate.bending_density(u))
    return A.tocsr()[free][:, free]


def reduced_hessian(plate: PlateOperator, damage: GridDamage, u, alpha, free, solve, A_ff=None):
    """The Hessian of the reduced energy on the free nodes, as a function ``dalpha_F -> H_FF dalpha_F``.

    Parameters
    ----------
    plate, damage : PlateOperator, GridDamage
    u : ndarray, shape (n_nodes,)
        The minimizing displacement at ``alpha`` (``K(alpha) u = f``).
    alpha : ndarray, shape (n_nodes,)
    free : ndarray of int, shape (m,)
        The free nodes.
    solve : callable
        ``solve(v) -> K(alpha)^{-1} v``, shape ``(n_nodes,)`` both.
    A_ff : sparse matrix, shape (m, m), optional
        :func:`damage_hessian` at ``u``, if the caller has it already.

    Returns
    -------
    callable
        ``(m,) -> (m,)``.
    """
    n = plate.grid.n_nodes
    if A_ff is None:
        A_ff = damage_hessian(plate, damage, u, free)
    g_prime = -2.0 * (1.0 - np.asarray(alpha))
    clamped = plate.clamped_nodes

    def product(x):
        dalpha = np.zeros(n)
        dalpha[free] = np.ravel(x)
        v = plate.apply_bending(g_prime * dalpha, u)
        v[clamped] = 0.0   # clamped rows are not unknowns
        z = solve(v)
        bilinear = (plate.bending_density(u + z) - plate.bending_density(u - z)) / 4.0
        return A_ff @ np.ravel(x) - (g_prime * bilinear)[free]

    return product


@dataclass
class ReducedProblem:
    """The eigenproblem of :func:`lowest_modes`, set up at a damage field.

    Attributes
    ----------
    u : ndarray, shape (n_nodes,)
        The displacement minimizing the energy at the damage.
    free : ndarray of int, shape (m,)
        The free nodes.
    scale : ndarray, shape (m,)
        ``omega_F^{-1/2}``: an eigenvector ``y`` of :attr:`operator` is the mode ``scale * y``.
    A_ff : sparse matrix, shape (m, m)
        ``E_aa`` on the free nodes.
    operator : scipy.sparse.linalg.LinearOperator, shape (m, m)
        ``diag(scale) H_FF diag(scale)``, symmetric.
    solves : int
        The linear solves (Hessian products) done so far by :attr:`operator`.
    """

    u: np.ndarray
    free: np.ndarray
    scale: np.ndarray
    A_ff: object
    operator: spla.LinearOperator = None  # set by reduced_problem, which counts its solves
    solves: int = 0


def reduced_problem(plate: PlateOperator, damage: GridDamage, alpha, w, lower, solver=None) -> ReducedProblem:
    """Factor ``K(alpha)``, solve for ``u`` and set up the scaled reduced Hessian on the free nodes.

    Parameters are those of :func:`lowest_modes`.
    """
    alpha = np.asarray(alpha, dtype=float)
    K = plate.matrix(alpha)
    if solver is None:
        solver = make_solver("direct", K)
    solver.update(K)
    u, _ = solver.solve(plate.rhs(w))
    free = free_nodes(alpha, lower)
    A_ff = damage_hessian(plate, damage, u, free)
    scale = 1.0 / np.sqrt(plate.grid.weights[free])
    problem = ReducedProblem(u, free, scale, A_ff)

    def solve(v):
        problem.solves += 1
        return solver.solve(v)[0]

    product = reduced_hessian(plate, damage, u, alpha, free, solve, A_ff)
    m = len(free)
    problem.operator = spla.LinearOperator(
        (m, m), matvec=lambda x: scale * product(scale * np.ravel(x)),
        matmat=lambda X: np.column_stack([scale * product(scale * x) for x in X.T]), dtype=float)
    return problem


def lowest_modes(plate: PlateOperator, damage: GridDamage, alpha, w, lower, k=4, tol=1e-4, maxiter=300,
                 solver=None) -> Modes:
    """The ``k`` lowest curvatures of the reduced energy at damage ``alpha`` and their modes.

    Parameters
    ----------
    plate, damage : PlateOperator, GridDamage
    alpha, w, lower : ndarray, shape (n_nodes,)
        Damage, substrate displacement ``w_t`` and the damage's lower bound (irreversibility).
    k : int
        Eigenpairs wanted (fewer if there are fewer free nodes). Asking for a few more than
        one helps LOBPCG with the pairs of equal eigenvalues that symmetric states have.
    tol : float
        Residual norm at which LOBPCG stops (the eigenvalues are energies per unit area of
        order ``toughness / eta``).
    maxiter : int
        LOBPCG iterations at most (one block of ``k`` products each).
    solver : object, optional
        A linear solver of :mod:`thinfilm.solvers.linear` for ``K`` (updated here); default a new
        direct solver.

    Returns
    -------
    Modes
    """
    problem = reduced_problem(plate, damage, alpha, w, lower, solver)
    free, scale, m = problem.free, problem.scale, len(problem.free)
    if m == 0:
        return Modes(np.empty(0), np.empty((0, plate.grid.n_nodes)), free, problem.u, 0)
    if m <= DENSE_NODES:
        # Few free nodes: the dense matrix, column by column.
        H = problem.operator.matmat(np.eye(m))
        values, vectors = np.linalg.eigh(0.5 * (H + H.T))
        values, vectors = values[:k], vectors[:, :k]
    else:
        # Preconditioner: the damage part E_aa alone, which holds the stiff gradient term;
        # H differs from it by the smooth Schur term. This takes LOBPCG to the lowest
        # eigenpairs in a few dozen iterations where plain Lanczos needs hundreds of products.
        lu = spla.splu((sp.diags(scale) @ problem.A_ff @ sp.diags(scale)).tocsc())
        precond = spla.LinearOperator((m, m), matvec=lambda x: lu.solve(np.ravel(x)), matmat=lu.solve, dtype=float)
        start = np.random.default_rng(0).standard_normal((m, k))   # fixed: reproducible results
        with warnings.catch_warnings():
            # LOBPCG warns when it stalls a little short of tol; its best pairs are kept (the
            # check needs the sign of the lowest curvature and its mode, not 1e-4 accuracy).
            warnings.simplefilter("ignore", UserWarning)
            values, vectors = spla.lobpcg(problem.operator, start, M=precond, largest=False, tol=tol,
                                          maxiter=maxiter)
    order = np.argsort(values)
    modes = np.zeros((len(order), plate.grid.n_nodes))
    for row, j in enumerate(order):
        mode = scale * vectors[:, j]
        modes[row, free] = mode / np.abs(mode).max()
    return Modes(values[order], modes, free, problem.u, problem.solves)
