"""The adaptive L-panel (``cases/lpanel.toml --set mesh.adapt=true``, eps = 3.125 mm) from a
first mesh whose interior vertices are moved at random, against the same run from gmsh's mesh
and the banded run: does the refined mesh's direction bias set the crack's path?

A vertex on the boundary, in a named group or on an interface between regions stays; every
other one moves by up to ``fraction * h_max`` in each direction (seeded). The refinement then
keeps the moved first mesh's directions instead of gmsh's rows.

Usage (from the repository root; the two other runs from ``python -m benchmarks.bench_adaptive
--cases lpanel``)::

    python -m studies.adaptive_mesh_direction.jittered 0.2 /tmp/jittered      # about 3 min
    python -m studies.adaptive_mesh_direction.jittered --compare /tmp/jittered \\
        /tmp/thinfilm_bench_adaptive/lpanel-adaptive /tmp/thinfilm_bench_adaptive/lpanel-banded

Writes ``results/paths.csv`` (one row per run: critical load and force, final energy against
the banded run's, the distance between the cracks at 0.5 mm, nodes and step time) and
``results/paths.png`` (each run's crack: its nodes with alpha >= 0.9 at the last step).
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def jittered_build_mesh(build_mesh, fraction, seed=0):
    """``build_mesh`` whose mesh has its free interior vertices moved (module docstring)."""
    from fem3d.mesh import Mesh

    def build(scene):
        mesh = build_mesh(scene)
        d = mesh.dim
        faces = np.sort(np.concatenate([np.delete(mesh.cells, i, axis=1) for i in range(d + 1)]), axis=1)
        unique, counts = np.unique(faces, axis=0, return_counts=True)
        keep = np.zeros(mesh.n_nodes, dtype=bool)
        keep[unique[counts == 1].ravel()] = True
        for nodes in mesh.node_groups.values():
            keep[nodes] = True
        for cells in mesh.cell_groups.values():
            inside = np.zeros(mesh.n_cells, dtype=bool)
            inside[cells] = True
            a, b = np.zeros(mesh.n_nodes, dtype=bool), np.zeros(mesh.n_nodes, dtype=bool)
            a[mesh.cells[inside].ravel()] = True
            b[mesh.cells[~inside].ravel()] = True
            keep |= a & b
        points = mesh.points.copy()
        move = ~keep
        rng = np.random.default_rng(seed)
        points[move] += fraction * scene.mesh.adapt.h_max * 2.0 * (rng.random((move.sum(), d)) - 0.5)
        edges = points[mesh.cells[:, 1:]] - points[mesh.cells[:, :1]]
        if not np.all(np.linalg.det(edges) > 0):
            raise ValueError(f"fraction = {fraction}: a moved cell is inverted; take a smaller one")
        return Mesh(points, mesh.cells, mesh.cell_groups, mesh.facet_groups, mesh.node_groups)

    return build


def run_jittered(fraction, out):
    import fem3d.kind as kind
    from thinfilm.run import run
    from thinfilm.scene import load_scene

    kind.build_mesh = jittered_build_mesh(kind.build_mesh, fraction)
    scene = load_scene("cases/lpanel.toml", overrides={"mesh.adapt": True})
    start = time.perf_counter()
    run(scene, out)
    print(f"wall {time.perf_counter() - start:.1f} s")


def compare(runs, banded):
    from benchmarks.bench_adaptive import crack_distance
    from fem3d.kind import crack_events, crack_lengths
    from thinfilm.results.reader import Results

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    fig, ax = plt.subplots(figsize=(8, 3.5))
    with Results(banded) as b:
        for path in list(runs) + [banded]:
            with Results(path) as r:
                k = min(r.n, b.n) - 1
                length, jump = crack_lengths(r)
                j = int(np.searchsorted(r.t, crack_events(r.t, length, jump)[0]["t"]))
                rows.append({"run": Path(path).name, "u_c": float(r.t[j]),
                             "F_c": round(float(r.steps["force"][j - 1]), 1),
                             "energy_vs_banded": round(float(r.steps["total"][k] / b.steps["total"][k] - 1.0), 4),
                             "crack_distance": round(crack_distance(r, k, b, k), 2), "at": float(r.t[k]),
                             "nodes": int(r.steps["nodes"][k]) if "nodes" in r.steps else r.discretization.n_nodes,
                             "steps_s": round(float(r.steps["time_total"].sum()), 1)})
                points, alpha = r.discretization_at(k).points, r.field("alpha", k)
                ax.plot(points[alpha >= 0.9, 0], points[alpha >= 0.9, 1], ".", ms=1, label=Path(path).name)
    (HERE / "results").mkdir(exist_ok=True)
    with open(HERE / "results" / "paths.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    ax.set(xlim=(0, 260), ylim=(230, 320), aspect="equal", xlabel="x (mm)", ylabel="y (mm)",
           title="cracks at the last step (alpha >= 0.9)")
    ax.legend(markerscale=8)
    fig.savefig(HERE / "results" / "paths.png", dpi=100, bbox_inches="tight")
    for row in rows:
        print(row)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fraction", nargs="?", type=float)
    parser.add_argument("out", nargs="?")
    parser.add_argument("--compare", nargs="+", metavar="RUN", help="runs to compare; the last is the banded one")
    args = parser.parse_args(argv)
    if args.compare:
        compare(args.compare[:-1], args.compare[-1])
    else:
        run_jittered(args.fraction, args.out)


if __name__ == "__main__":
    main()
