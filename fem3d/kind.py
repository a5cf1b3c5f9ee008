"""Bulk solids by finite elements as a model kind (``kind = "fem"``).

:data:`KIND` is what :mod:`thinfilm.kinds` finds. It reads ``kind = "fem"`` scenes
(:mod:`fem3d.scene`), meshes the specimen with gmsh (:mod:`fem3d.specimens`), builds the P1 or
P2 elasticity and the damage operator and the boundary conditions, chooses the linear solver, and
adds to what every run writes the reaction force, the prescribed displacement and the crack
length of each step, the crack events, and the figures of :mod:`fem3d.plots`.
"""

from __future__ import annotations

import math

import numpy as np

from fem3d import scene as fem_scene, specimens
from thinfilm.run import EvolutionKind, Setup, peak_force_line
from thinfilm.scene import SceneError

__all__ = ["KIND", "FemKind", "build_mesh", "build_model", "crack_lengths", "crack_events", "units_of",
           "AMG_MIN_DOFS_3D", "AMG_OPTIONS", "CUT_THROUGH"]

#: ``[solver] linear = "auto"`` uses AMG-preconditioned CG for 3D problems from this many free
#: dofs, a sparse direct solver below and in 2D, where each wins (docs/speed.md#finite-elements).
AMG_MIN_DOFS_3D = 20_000

#: Fraction of the peak elastic energy below which a specimen no longer carries its load:
#: no energy release rate is computed there (``fem3d.release.energy_release_rate``).
CUT_THROUGH = 0.01

#: Smoothed-aggregation settings for elasticity (passed over the plate-tuned defaults of
#: :data:`thinfilm.solvers.linear.AMG_DEFAULTS`): pyamg's own, symmetric strength with
#: theta = 0 and a Jacobi-smoothed prolongator, far cheaper to set up than the plate's
#: (docs/solvers.md#p1-finite-elements).
AMG_OPTIONS = {"strength": ("symmetric", {"theta": 0.0}), "smooth": ("jacobi", {})}


def build_mesh(scene):
    """The scene's mesh (gmsh, deterministic), with its named groups: its specimen's mesh
    function (:mod:`fem3d.specimens`) with the scene's sizes and ``[geometry]`` keys.

    Raises
    ------
    SceneError
        If a mesh file's dimension is not the model's.
    """
    g = scene.geometry
    adapt = scene.mesh.adapt
    # an adaptive mesh starts uniform, without the band where the crack may run
    h, h_coarse = (adapt.h_max, adapt.h_max) if adapt is not None else (scene.mesh.h, scene.mesh.h_coarse)
    mesh = specimens.get(g.kind).make(scene.model.dim, h, h_coarse, g.options)
    if mesh.dim != scene.model.dim:
        raise SceneError(scene.source, "geometry.file", f"= {g.file!r}: a {mesh.dim}D mesh, but model.dim ="
                         f" {scene.model.dim}")
    return mesh


def build_model(scene, mesh):
    """The :class:`fem3d.model.FemModel` of a scene on its mesh, with its linear solver.

    Raises
    ------
    SceneError
        If a group the scene names is not in the mesh.
    """
    from fem3d.damage import P1Damage
    from fem3d.elasticity import Elasticity
    from fem3d.elements import make_space
    from fem3d.model import FemModel, Loads
    from thinfilm.solvers.linear import make_solver

    m = scene.model
    space = make_space(m.element, mesh)   # the displacement's element: its nodes, rule and loads
    loads = Loads(mesh, scene.load, m.thickness, scene.source, space=space)
    fixed = []
    modulus = np.ones(mesh.n_cells)
    regions = [("model.undamaged", name) for name in m.undamaged] + [(f"model.buffers.{name}", name)
                                                                      for name, _ in m.buffers]
    for key, region in regions:
        if region not in mesh.cell_groups:
            raise SceneError(scene.source, key, f'= "{region}": no region of that name in the mesh'
                             f" (its regions: {', '.join(sorted(mesh.cell_groups)) or '-'})")
        fixed.append(mesh.nodes_of(region))     # buffers are not damageable either
    for region, E_b in m.buffers:
        modulus[mesh.cell_groups[region]] = E_b / m.E
    fixed_nodes = np.unique(np.concatenate(fixed)) if fixed else None
    law = m.damage_law()
    elasticity = Elasticity(mesh, m.E, m.nu, plane=m.plane if m.dim == 2 else "stress", thickness=m.thickness,
                            k_res=m.k_res, constrained=loads.constrained, modulus=modulus, split=m.split, space=space,
                            law=law)
    damage = P1Damage(mesh, m.Gc, m.eps, at=m.at, thickness=m.thickness, fixed_nodes=fixed_nodes, law=law)
    K = elasticity.matrix(np.zeros(mesh.n_nodes))
    kind = scene.solver.linear
    if kind == "auto":
        kind = "amg" if (m.dim == 3 and K.shape[0] >= AMG_MIN_DOFS_3D) else "direct"
    options = (dict(near_nullspace=elasticity.rigid_modes(), **AMG_OPTIONS) if kind == "amg"
               else {"precision": scene.solver.precision})
    solver = make_solver(kind, K, **options)
    return FemModel(mesh, elasticity, damage, loads, solver)


def crack_front(scene):
    """``(width, a0)`` of the scene's crack front for the energy release rate: 2D, the slab's
    thickness and 0; 3D, from its specimen's record (:attr:`fem3d.specimens.specimen.Specimen.front`)
    and the scene's ``[geometry]`` keys (the record's defaults where the scene gives none); width
    ``"none"`` if the specimen has no straight front, ``"mesh"`` for a mesh file (its extent in
    z, read from the results)."""
    m, g = scene.model, scene.geometry
    return specimens.get(g.kind).crack_front(m.dim, m.thickness, g.options)


def release_rate(results):
    """G and a of each finished step (:func:`fem3d.release.energy_release_rate`), not across a
    jump of the crack nor once the specimen is cut through (:data:`CUT_THROUGH`): the crack
    front's width and starter length as the run recorded them (:func:`crack_front`; files
    written before: the thickness in 2D, the mesh's extent in z in 3D, a0 = 0), G taken over
    growths of at least one mesh size ``h``; NaN throughout if the load has a constant part or
    the geometry has no straight front."""
    from fem3d.release import energy_release_rate

    p = results.parameters
    width = p.get("front_width", "mesh")
    if width == "mesh":
        width = p["thickness"] if int(p["dim"]) == 2 else float(np.ptp(results.discretization.points[:, 2]))
    width = math.nan if width == "none" else float(width)
    a0 = float(p.get("a0", 0.0))
    nan_steps = np.full(len(results.t), np.nan)   # a file written before they were recorded
    # a jump is a growth of a crack band's width, 4 eps, at once (as crack_lengths counts an
    # event); below a hundredth of its peak elastic energy the specimen is cut through
    G, a = energy_release_rate(results.t, results.steps["elastic"], results.steps["surface"], p["Gc"],
                               width if math.isfinite(width) else 1.0, a0=a0, da_min=p["h"],
                               jump=4.0 * p["eps"], carried=CUT_THROUGH, meshes=results.steps.get("mesh"),
                               previous=(results.steps.get("elastic_previous", nan_steps),
                                         results.steps.get("surface_previous", nan_steps)))
    if not p.get("proportional", True) or not math.isfinite(width):
        # (4.16) dB/dt = 2B/t holds for a load proportional to t only: with a constant part
        # the steps alone do not give G; without a straight front there is no a
        G[:] = np.nan
    return G, a


def crack_lengths(results):
    """The crack length of each finished step (2D: surface energy over ``Gc T``; 3D: an area,
    over ``Gc``) and the growth in one step that counts as an event (:func:`crack_events`):
    the width of a crack band, ``4 eps``, times the mesh's extent in z in 3D."""
    p = results.parameters
    length = np.asarray(results.steps["surface"]) / (p["Gc"] * p["thickness"])
    jump = 4.0 * p["eps"]
    if int(p["dim"]) == 3:
        jump *= float(np.ptp(results.discretization.points[:, 2]))
    return length, jump


def units_of(parameters):
    """``(length, force)``: the names of a run's units (``[units]``), or ``("", "")``."""
    return str(parameters.get("length_unit", "")), str(parameters.get("force_unit", ""))


def crack_events(t, length, jump):
    """The steps where the crack length grows by more than ``jump`` at once.

    Returns
    -------
    list of dict
        ``{"t", "crack_length_before", "crack_length"}`` for each such step.
    """
    out = []
    for k in range(1, len(t)):
        if length[k] - length[k - 1] > jump:
            out.append({"t": float(t[k]), "crack_length_before": float(length[k - 1]),
                        "crack_length": float(length[k])})
    return out


class FemKind(EvolutionKind):
    """``kind = "fem"``: linear elasticity with AT damage on triangles or tetrahedra (P1 or P2
    displacements, P1 damage)."""

    name = "fem"
    required_datasets = ("mesh/points", "fields/u", "fields/alpha")
    labels = {"alpha": r"damage $\alpha$", "u": "displacement u", "energy": "energy (scene units)"}
    length_unit = ""

    def figure_labels(self, parameters):
        """The labels in the scene's ``[units]`` if it names them."""
        length, force = units_of(parameters)
        if not length:
            return self.labels
        return {**self.labels, "u": f"displacement u ({length})", "energy": f"energy ({force} {length})"}

    def figure_length_unit(self, parameters):
        return units_of(parameters)[0]

    def parse(self, source, data, text):
        return fem_scene.parse(source, data, text)

    def estimate(self, scene):
        """Memory of the run, before anything is meshed (:func:`fem3d.resources.estimate`)."""
        from fem3d.resources import estimate

        return estimate(scene)

    def inputs(self, scene):
        """The ``.msh`` file of ``geometry.kind = "file"`` (its digest is stored with the results)."""
        return {"geometry.file": scene.geometry.file} if scene.geometry.file else {}

    def setup(self, scene):
        mesh = build_mesh(scene)
        m, adapt = scene.model, scene.mesh.adapt
        if adapt is not None:
            from fem3d.adaptive import AdaptiveModel

            model = AdaptiveModel(mesh, lambda refined: build_model(scene, refined), adapt, at=m.at, Gc=m.Gc, eps=m.eps,
                                  law=m.damage_law())
            first = "from the file" if scene.mesh.measured else f"of h_max = {adapt.h_max:g}"
            buffer = f" (and {adapt.buffer:g} about it)" if adapt.buffer else ""
            sizes_line = (f" adaptive, the first mesh {first}, refined down to h_min = {adapt.h_min:g}"
                          f" (eps/h_min = {m.eps / adapt.h_min:.3g}) where alpha >= {adapt.alpha:g}{buffer} or the"
                          f" energy density >= {adapt.energy:g} of the damage onset")
        else:
            model = build_model(scene, mesh)
            sizes_line = (f" elements of {scene.mesh.h:.4g} where finest (measured: the 5th percentile of their longest"
                          f" edges; eps/h = {m.eps / scene.mesh.h:.3g}), up to {scene.mesh.h_coarse:.4g}"
                          if scene.mesh.measured else
                          f" h = {scene.mesh.h:g} where the crack may run (eps/h = {m.eps / scene.mesh.h:.3g}),"
                          f" {scene.mesh.h_coarse:g} elsewhere")
        loads = model.loads
        loaded = list(loads.loaded)
        lines = [f"mesh: {mesh.dim}D, {mesh.n_nodes} nodes, {mesh.n_cells} {'triangles' if mesh.dim == 2 else 'tetrahedra'};"
                 + sizes_line,
                 f"u-solve: {model.linear_solver.kind}, {m.element}, {model.elasticity.free.size} free dofs;"
                 f" damage held at 0 on {0 if model.damage.fixed_nodes is None else model.damage.fixed_nodes.size}"
                 " nodes"]
        if m.law == "czm":
            # the material's characteristic length: the cohesive law's softening is the
            # material's only where the damage band, a few eps wide, is well inside it
            # (docs/cases.md#three-point-bending-with-the-cohesive-law)
            l_ch = m.E * m.Gc / m.ft ** 2
            lines.append(f"cohesive law: {m.softening} softening, ft = {m.ft:g}; l_ch = E Gc / ft^2 = {l_ch:.4g},"
                         f" eps / l_ch = {m.eps / l_ch:.3g}")

        def observe(u, alpha, t):
            forces = model.forces(u, alpha, t)
            out = {f"force_{group}": forces[group] for group in loaded[1:]}
            if adapt is not None:
                out["nodes"], out["cells"] = model.mesh.n_nodes, model.mesh.n_cells
            if loaded:
                out["force"] = forces[loaded[0]]
                out["displacement"] = t * loads.displacement_scale[loaded[0]]
            if m.split != "none":
                # the step's linear solves inside its u-solves and the cells they switched
                out["split_solves"], out["split_switches"] = len(model.switches), sum(model.switches)
                model.switches.clear()
            return out

        observables = ((("force", "displacement") if loaded else ()) + tuple(f"force_{g}" for g in loaded[1:])
                       + (("split_solves", "split_switches") if m.split != "none" else ())
                       + (("nodes", "cells") if adapt is not None else ()))
        # /mesh is the P1 mesh (the damage's, what the plots and XDMF draw) and what the element
        # adds (P2: its edges); /fields/u holds the vertices' values, then the other nodes'
        if adapt is not None:   # P1 (the scene refuses P2): the mesh and its refinement
            discretization, sizes = model.description(), {}
        else:
            discretization, sizes = model.elasticity.space.description(), {"u": model.elasticity.n_dofs}
        return Setup(model=model, discretization=discretization, components={"u": mesh.dim}, sizes=sizes,
                     observe=observe, observables=observables, log=lines,
                     adaptive=model if adapt is not None else None)

    def parameters(self, scene):
        m, g = scene.model, scene.geometry
        front_width, a0 = crack_front(scene)   # the energy release rate's a = S / (Gc width) + a0
        return {"dim": m.dim, "E": m.E, "nu": m.nu, "Gc": m.Gc, "eps": m.eps, "k_res": m.k_res, "at": m.at,
                **({"law": m.law, "ft": m.ft, "softening": m.softening} if m.law == "czm" else {}),
                "plane": m.plane, "thickness": m.thickness, "undamaged": ",".join(m.undamaged),
                "buffers": ",".join(f"{name}:{E_b:g}" for name, E_b in m.buffers), "split": m.split,
                "front_width": front_width, "a0": a0,
                "element": m.element,
                "geometry": g.kind, **({"file": g.file} if g.file else {}), "h": scene.mesh.h,
                "h_coarse": scene.mesh.h_coarse,
                **({"adapt": True, "h_min": scene.mesh.adapt.h_min, "h_max": scene.mesh.adapt.h_max,
                    "adapt_alpha": scene.mesh.adapt.alpha, "adapt_energy": scene.mesh.adapt.energy,
                    "adapt_buffer": scene.mesh.adapt.buffer}
                   if scene.mesh.adapt is not None else {}),
                "t_max": scene.load.t_max, "steps": scene.load.steps,
                "loaded": ",".join(scene.load.loaded), "proportional": scene.load.proportional,
                **({"snapshots": scene.snapshots} if scene.snapshots else {}),
                **({"reference": scene.reference} if scene.reference else {}),
                **({"length_unit": scene.units[0], "force_unit": scene.units[1]} if scene.units else {})}

    def warnings(self, scene):
        m = scene.model
        out = []
        if m.eps < 2.0 * scene.mesh.h:
            out.append(f"eps = {m.eps:g} is less than 2 h (h = {scene.mesh.h:g}): the damage profile is not resolved"
                       " and the crack's effective toughness is inflated")
        return out

    def summary(self, scene, results):
        length, jump = crack_lengths(results)
        G, a = release_rate(results)
        # JSON has no NaN: null where the front did not move
        steps = {"crack_length": length.tolist(), "G": [None if np.isnan(g) else float(g) for g in G],
                 "a": a.tolist()}
        for name in ("force", "displacement"):
            if name in results.steps:
                steps[name] = results.steps[name].tolist()
        return {"events": crack_events(results.t, length, jump), "steps": steps}

    def report(self, scene, results, summary):
        lines = [f"t = {e['t']:.6g}: crack length {e['crack_length_before']:.4g} -> {e['crack_length']:.4g}"
                 for e in summary["events"]]
        if "force" in results.steps and results.n:
            force = peak_force_line(results.t, results.steps["force"], results.steps.get("displacement"))
            if force is not None:
                lines.append(force)
        return lines

    def figures(self, results, outdir):
        from fem3d.plots import (crack_length_figure, crack_surface_figure, force_displacement_figure,
                                 release_rate_figure)

        p = results.parameters
        length, jump = crack_lengths(results)
        paths = [crack_length_figure(results, outdir, length, int(p["dim"])),
                 release_rate_figure(results, outdir, *release_rate(results))]
        if "force" in results.steps:
            events = [e["t"] for e in crack_events(results.t, length, jump)]
            paths.insert(0, force_displacement_figure(results, outdir, p.get("reference"), events))
        if int(p["dim"]) == 3:
            from fem3d.plots import alpha_slices_figure

            paths += [crack_surface_figure(results, outdir), alpha_slices_figure(results, outdir)]
        return paths

    def title(self, parameters):
        p = parameters
        length, force = units_of(p)
        stress, toughness = (f" {force}/{length}$^2$", f" {force}/{length}") if length else ("", "")
        law = (f"PF-CZM ({p['softening']}, ft = {p['ft']:g}{stress})" if p.get("law") == "czm"
               else f"AT{p.get('at', '?')}")
        return (f"{law}, E = {p.get('E', float('nan')):g}{stress},"
                f" Gc = {p.get('Gc', float('nan')):g}{toughness}, $\\epsilon$ = {p.get('eps', float('nan')):g}"
                f"{' ' + length if length else ''}")


KIND = FemKind()
