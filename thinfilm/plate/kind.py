"""The thin film as a model kind (``kind = "plate"``): scene, model, results, figures.

:data:`KIND` is what :mod:`thinfilm.kinds` finds. It reads ``kind = "plate"`` scenes
(:mod:`thinfilm.plate.scene`), builds the :class:`thinfilm.plate.model.PlateModel` on its grid
with its load, symmetry, imperfection and linear solver, and adds to what every run writes the
film's readings: the force conjugate to the load and the displacement it imposes at every step
(``/steps/force``, ``/steps/displacement``, as a solid's reaction; in SI units too when the
scene has a ``[material]``), the crack events along ``y = 0`` (``summary.json``),
``cracks.png``, ``force_displacement.png`` (indenter, cantilever) and the toughness field of
an imperfect film; on a 2D grid also the crack metrics of the damage field
(:mod:`thinfilm.plate.crack_metrics`: lengths, cracks, fragments, branch points, rings) in
``summary.json``, ``thinfilm info``, ``crack_metrics.png`` and ``crack_pattern.png``.
"""

from __future__ import annotations

import math

import numpy as np

from thinfilm.plate import loads, scene as plate_scene
from thinfilm.plate.cracks import CRACK_THRESHOLD, SOUND_THRESHOLD
from thinfilm.plate.grid import Grid
from thinfilm.plate.imperfection import toughness_factor
from thinfilm.plate.model import PlateModel
from thinfilm.plate.operators import near_nullspace
from thinfilm.plate.results import PlateResults, crack_events
from thinfilm.plate.sequencing import CoarseDamage
from thinfilm.plate.symmetry import GridSymmetry
from thinfilm.run import EvolutionKind, Setup, json_list, peak_force_line
from thinfilm.scene import SceneError
from thinfilm.steps import load_steps
from thinfilm.solvers.linear import make_solver

__all__ = ["KIND", "PlateKind", "build_grid", "make_model", "make_symmetry", "resolution_warnings", "describe"]


def build_grid(domain):
    """The structured grid of a :class:`thinfilm.scene.Domain`."""
    if domain.dim == 1:
        return Grid.line(domain.x[0], domain.x[1], domain.cells[0])
    return Grid.rectangle(domain.x[0], domain.x[1], domain.cells[0], domain.y[0], domain.y[1], domain.cells[1])


def make_load(scene, grid):
    """The scene's substrate displacement (:mod:`thinfilm.plate.loads`)."""
    load = scene.load
    if load.kind == "bending":
        return loads.bending(grid)
    if load.kind == "cantilever":
        return loads.cantilever(grid)
    if load.kind == "indenter":
        return loads.indenter(grid, load.radius)
    return loads.field(grid, load.field)


def resolution_warnings(scene):
    """Warnings for scenes whose regularization cannot resolve the expected pattern.

    The damage band has width ``~ 4 eta``; the plate's response decays over ``1/lam`` and
    cracks of the exact 1D solution are at least ``~ 3/lam`` apart, so ``eta lam`` well below
    1 is needed (measured on the Fig. 2.7 strip: docs/solvers.md#regularized-model-on-the-strip).
    An indenter whose contact disk comes within a few decay lengths of a free edge feels the
    edge (and would better be run on a larger domain).
    """
    m, dom = scene.model, scene.domain
    out = []
    if m.eta * m.lam > 0.4:
        out.append(f"eta * lam = {m.eta * m.lam:.2f} > 0.4: the regularization length is not small against the"
                   f" decay length 1/lam = {1 / m.lam:.4g}; damage may go diffuse and cracks merge")
    if m.eta < 2.0 * dom.dx:
        out.append(f"eta = {m.eta:.4g} is less than 2 grid cells (dx = {dom.dx:.4g}): the damage"
                   " profile is not resolved and the crack energy is overestimated")
    if scene.load.kind == "indenter":
        t = scene.load.t_max
        contact = scene.load.radius * math.sqrt(t * (2.0 - t))
        edges = [abs(v) for v in dom.x] + ([abs(v) for v in dom.y] if dom.y else [])
        gap = min(edges) - contact
        if gap < 3.0 / m.lam:
            out.append(f"the contact radius reaches {contact:.4g} at t = {t:g}, {gap:.4g} from a free edge: less than"
                       f" 3 decay lengths (3/lam = {3 / m.lam:.4g}); the edge changes the cracks")
    return out


def describe(scene):
    """Lines for the run log: the non-dimensional groups, the decay length, the grid."""
    m, dom = scene.model, scene.domain
    lines = []
    if scene.material is not None:
        mat = scene.material
        g = mat.groups()
        lines.append(f"material: E = {mat.E:.4g} Pa, nu = {mat.nu:g}, h = {mat.h:.4g} m, Gc = {mat.Gc:.4g} J/m^2,"
                     f" K_b = {mat.bond_stiffness:.4g} Pa/m, L = {mat.L:.4g} m")
        lines.append(f"groups (2.13): K~ = {g['K_tilde']:.4g}, G~ = {g['G_tilde']:.4g}, a = h/L = {g['a']:.4g}"
                     f" -> winkler = K~/a^4 = {g['winkler']:.4g}, toughness = G~/a = {g['toughness']:.4g}")
    lines.append(f"decay length 1/lam = {1 / m.lam:.4g} (lam = {m.lam:.4g}, winkler = {m.winkler:.4g});"
                 f" eta = {m.eta:.4g} = {m.eta / dom.dx:.3g} dx; eta * lam = {m.eta * m.lam:.3g}")
    if m.toughness_noise > 0:
        lines.append(f"imperfect film: toughness G/a = {m.toughness:g} exp({m.toughness_noise:g} xi), xi Gaussian with"
                     f" correlation length {m.toughness_noise_length:.4g} ({m.toughness_noise_length / dom.dx:.3g} dx),"
                     f" seed {m.toughness_noise_seed}")
    return lines


def make_model(scene, grid):
    """The :class:`PlateModel` of a plate scene, with its linear solver.

    Raises
    ------
    SceneError
        If the scene's symmetry does not fit its clamped edges or load (:func:`make_symmetry`).
    """
    m = scene.model
    load = make_load(scene, grid)
    plate_nu = m.nu if grid.dim == 2 else 0.0
    symmetry = make_symmetry(scene, grid, load)
    factor = toughness_factor(grid, m.toughness_noise, m.toughness_noise_length, m.toughness_noise_seed, symmetry)
    model = PlateModel(grid, plate_nu, m.winkler, m.k_res, m.eta, m.toughness, m.at, load.w,
                       proportional=load.proportional, linear_solver=None, clamped=load.clamped,
                       trial_radius=m.eta, symmetry=symmetry, toughness_factor=factor, load_rate=load.dw)
    coords = np.column_stack(grid.coordinates)
    if symmetry is not None:
        coords = coords[symmetry.representative]
    model.linear_solver = make_solver(scene.solver.linear, model.reduced_matrix(np.zeros(grid.n_nodes)),
                                      near_nullspace=near_nullspace(coords), precision=scene.solver.precision)
    return model


def make_symmetry(scene, grid, load):
    """The :class:`GridSymmetry` of ``[domain] symmetry`` (None for ``"none"``), after
    checking that the clamped edges and the load are invariant under it.

    Raises
    ------
    SceneError
        If they are not: the restriction would then solve another problem.
    """
    group = scene.domain.symmetry
    if group == "none":
        return None
    symmetry = GridSymmetry(grid, group)
    if not symmetry.maps_edges(load.clamped):
        raise SceneError(scene.source, "domain.symmetry",
                         f'= "{group}": the clamped edges ({", ".join(load.clamped)}) are not mapped onto'
                         f' themselves by its mirrors; use "none" or a group that keeps them')
    # Every load of the run (a non-proportional load may change shape with t).
    for t in load_steps(scene.load)[1:]:
        w = load.w(t)
        scale = float(np.max(np.abs(w)))
        asymmetry = symmetry.asymmetry(w)
        # Not to round-off: node coordinates are mirrored only to round-off, which the
        # indenter's sqrt(R^2 - r^2) amplifies near the contact edge (5e-9 of |w| at t = 1).
        if asymmetry > 1e-6 * scale:
            raise SceneError(scene.source, "domain.symmetry",
                             f'= "{group}": the load ({scene.load.kind}) at t = {t:g} is not invariant under its'
                             f" mirrors (largest difference {asymmetry:.3g} against |w| <= {scale:.3g});"
                             ' use "none" or a group the load has')
    return symmetry


def force_observer(model, load, material=None, dim=2):
    """``observe(u, alpha, t)`` of a plate run: the force conjugate to the load's displacement.

    ``displacement = s t`` with ``s = load.displacement_scale`` (the indenter's depth, the
    cantilever's tip deflection, t itself for the other loads) and ``force = (dE/dt) / s``
    (:meth:`PlateModel.force`), so that ``force d(displacement)`` is the work of the load:
    positive when pressing in. With a material, ``force_si`` (N, 1D: N per metre of width)
    and ``displacement_si`` (m) too (:meth:`thinfilm.plate.units.Material.force_unit`).

    Returns
    -------
    observe : callable
    observables : tuple of str
    """
    scale = float(load.displacement_scale)

    def observe(u, alpha, t):
        force = model.force(u, t) / scale
        out = {"force": force, "displacement": scale * t}
        if material is not None:
            out["force_si"] = force * material.force_unit(dim)
            out["displacement_si"] = scale * t * material.L
        return out

    return observe, ("force", "displacement") + (("force_si", "displacement_si") if material is not None else ())


class PlateKind(EvolutionKind):
    """``kind = "plate"``: the thin film on a Winkler foundation, on a structured grid."""

    name = "plate"
    required_datasets = ("grid/x", "fields/u", "fields/alpha")
    labels = {"alpha": r"damage $\alpha$", "u": "deflection u (L)", "energy": "energy (non-dimensional, units of D)"}
    length_unit = "L"
    results_class = PlateResults

    def parse(self, source, data, text):
        return plate_scene.parse(source, data, text)

    def inputs(self, scene):
        """The files the scene reads: a ``"field"`` load's ``load.file``, the coarse run of
        ``solver.coarse`` (their digests are stored with the results)."""
        files = {"load.file": scene.load.file, "solver.coarse": scene.coarse}
        return {key: path for key, path in files.items() if path}

    def estimate(self, scene):
        """Memory of the run (:func:`thinfilm.plate.resources.estimate`)."""
        from thinfilm.plate.resources import estimate

        return estimate(scene)

    def setup(self, scene):
        grid = build_grid(scene.domain)
        model = make_model(scene, grid)
        lines = describe(scene)
        if model.symmetry is not None:
            lines.append(f'symmetry "{model.symmetry.group}": u and alpha invariant under its mirrors;'
                         f" u-solves of {model.symmetry.n_orbits} unknowns instead of {grid.n_nodes}")
        guess = None
        if scene.coarse is not None:
            guess = CoarseDamage(scene.coarse, grid)
            lines.append(f"grid sequencing: each step starts from the damage of {scene.coarse}"
                         f" ({guess.t.size} steps) at the same load")
        factor = model.damage.toughness_factor
        constant = {} if factor is None else {"toughness": scene.model.toughness * factor}
        groups = {}
        if scene.material is not None:
            mat = scene.material
            groups["material"] = {"E": mat.E, "nu": mat.nu, "h": mat.h, "Gc": mat.Gc,
                                  "bond_stiffness": mat.bond_stiffness, "L": mat.L, **mat.groups()}
        observe, observables = force_observer(model, make_load(scene, grid), scene.material, grid.dim)
        return Setup(model=model, discretization=grid.description(), constant=constant, groups=groups,
                     guess=guess, observe=observe, observables=observables, log=lines)

    def parameters(self, scene):
        m, load = scene.model, scene.load
        return {
            "at": m.at, "nu": m.nu, "lam": m.lam, "winkler": m.winkler, "toughness": m.toughness,
            "eta": m.eta, "k_res": m.k_res, "t_max": load.t_max, "steps": load.steps, "load": load.kind,
            "symmetry": scene.domain.symmetry,
            **({"toughness_noise": m.toughness_noise, "toughness_noise_length": m.toughness_noise_length,
                "toughness_noise_seed": m.toughness_noise_seed} if m.toughness_noise > 0 else {}),
            **({"radius": load.radius} if load.radius else {}), **({"field_file": load.file} if load.file else {}),
            **({"snapshots": scene.snapshots} if scene.snapshots else {}),
        }

    def warnings(self, scene):
        return resolution_warnings(scene)

    def physical(self, results):
        """With a ``[material]``: the SI value of L, of the energy unit D (D/L per metre of
        width in 1D) and of the force unit (:func:`thinfilm.plate.units.physical_scales`)."""
        from thinfilm.plate.units import file_scales

        return file_scales(results.file)

    def summary(self, scene, results):
        """``"events"``: the steps where the number of cracks along y = 0 changes, with their
        positions; ``"steps"``: the force and displacement of each step (and in SI units, with a
        material; null where not recorded), on a 2D grid the crack length from the surface
        energy at every step (``"crack_length"``) and ``"crack_metrics"`` at the measured steps.
        With a material, ``"units"`` (the SI value of each unit) and the energies, the crack
        length and the crack positions in SI too (``elastic_si``, ... ``crack_length_si``,
        each event's ``cracks_si``)."""
        events = crack_events(results.t, results.cracks())
        steps = {name: json_list(results.steps[name]) for name in ("force", "displacement", "force_si",
                                                                    "displacement_si") if name in results.steps}
        out = {"events": [{"t": float(t), "cracks": [float(c) for c in cracks]} for t, cracks in events],
               "steps": steps}
        if results.dim == 2:
            from thinfilm.plate.crack_metrics import branch_radius

            p = results.parameters
            out["crack_metrics"] = {
                "threshold": CRACK_THRESHOLD, "sound": SOUND_THRESHOLD,
                "branch_radius": branch_radius(float(p["eta"]), min(results.discretization.spacing)),
                "measured": [m.as_json() for m in results.crack_metrics()]}
            steps["crack_length"] = results.crack_length().tolist()
        physical = self.physical(results)
        if physical is not None:
            # the same numbers in SI: energies, the crack length and the crack positions
            out["units"] = physical
            for name in ("elastic", "surface", "total"):
                steps[f"{name}_si"] = json_list(results.steps[name] * physical["energy"])
            if "crack_length" in steps:
                steps["crack_length_si"] = json_list(np.asarray(steps["crack_length"]) * physical["length"])
            for event in out["events"]:
                event["cracks_si"] = [c * physical["length"] for c in event["cracks"]]
        return out

    def report(self, scene, results, summary):
        lines = [f"t = {e['t']:.6g}: {len(e['cracks'])} crossing(s) of the line y = 0 at "
                 + ", ".join(f"{c:+.4f}" for c in e["cracks"]) for e in summary["events"]]
        if "force" in results.steps and results.n:
            force = peak_force_line(results.t, results.steps["force"], results.steps.get("displacement"))
            if force is not None:
                lines.append(force)
        if results.dim == 2 and results.n:
            last = results.crack_metrics()[-1]
            lines.append(f"t = {last.t:.6g} (last step): {last.describe()}")
        return lines

    def info(self, f, steps):
        """The engine's lines; the peak force and the last energies also in SI units if the scene
        had a material; on a
        2D grid the crack metrics of the last finished step with the count along the centre line
        beside them."""
        from thinfilm.plate.units import file_scales

        lines = super().info(f, steps)
        scales = file_scales(f)
        peak = [i for i, line in enumerate(lines) if line.startswith("peak force")]
        if peak and "force_si" in steps and scales is not None:
            k = int(np.nanargmax(steps["force"]))
            lines.insert(peak[0] + 1, f"  in SI units: {steps['force_si'][k]:.6g} {scales['force_unit']} at a"
                                      f" displacement of {steps['displacement_si'][k]:.6g} m")
        n = len(steps["t"])
        if n and scales is not None:
            e, unit = scales["energy"], scales["energy_unit"]
            lines.append(f"energies at the last finished step in SI units: elastic {steps['elastic'][-1] * e:.6g},"
                         f" surface {steps['surface'][-1] * e:.6g}, total {steps['total'][-1] * e:.6g} {unit}"
                         f" (a unit of energy: {e:.6g} {unit}; of length: L = {scales['length']:.6g} m)")
        if n and int(f["grid"].attrs["dim"]) == 2:
            from thinfilm.plate.cracks import crack_positions
            from thinfilm.plate.crack_metrics import measure_step

            x, y = f["grid/x"][()], f["grid/y"][()]
            alpha = f["fields/alpha"][n - 1]
            j = int(np.argmin(np.abs(y)))
            along = crack_positions(x, alpha.reshape(len(y), len(x))[j])
            lines.append(f"cracks at the last finished step (alpha >= {CRACK_THRESHOLD:g}): "
                         + measure_step(f, n - 1).describe())
            lines.append(f"  centre line y = {y[j]:.4g}: {len(along)} crossing(s) (local maxima of alpha >="
                         f" {CRACK_THRESHOLD:g}; the 1D reading of events and cracks.png)")
        return lines

    def figures(self, results, outdir):
        from thinfilm.plate.plots import crack_metrics_figure, crack_pattern_figure, cracks_figure, force_figure

        figures = [force_figure(results, outdir), cracks_figure(results, outdir)]
        if results.dim == 2:
            figures += [crack_metrics_figure(results, outdir), crack_pattern_figure(results, outdir)]
        return figures

    def overlay(self, results, ax, t):
        from thinfilm.plate.plots import contact_circle

        return contact_circle(results, ax, t)

    def constant_figures(self, results, outdir):
        from thinfilm.plate.plots import toughness_figure

        return [toughness_figure(results, outdir)]

    def check_compare(self, scene):
        """Refuse to compare a scene whose load the exact 1D evolution does not solve: it is a
        film under pure bending (:mod:`thinfilm.plate.compare`).

        Raises
        ------
        SceneError
            Naming ``load.kind`` if it is not ``"bending"``.
        """
        if scene.load.kind != "bending":
            raise SceneError(scene.source, "load.kind", f'= "{scene.load.kind}": compare draws the run against the'
                             ' exact 1D evolution of a film under pure bending; it needs load.kind = "bending"')

    def compare(self, results, outdir):
        """Draw the run against the exact 1D evolution of the same film
        (:func:`thinfilm.plate.compare.compare`); returns the files written and report lines."""
        import json

        from thinfilm.plate.compare import compare

        figure, report = compare(results, outdir)
        lines = []
        for e in json.loads(report.read_text())["events"]:
            reached = "not reached" if e["regularized_t"] is None else f"t = {e['regularized_t']:.4g}"
            lines.append(f"exact t = {e['exact_t']:.4f} ({len(e['exact_cracks'])} cracks); regularized: {reached}")
        return [figure, report], lines

    def title(self, parameters):
        p = parameters
        return (f"AT{p.get('at', '?')}, $\\lambda$ = {p.get('lam', float('nan')):g}, "
                f"G/a = {p.get('toughness', float('nan')):g}, $\\eta$ = {p.get('eta', float('nan')):.3g}")


KIND = PlateKind()
