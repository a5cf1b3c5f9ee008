"""Cost of the plate operator kernels on large grids.

For 1000^2 and 1500^2 nodes: building the CSR pattern, writing the values of K(alpha) into
it, the matrix-free apply against the CSR matvec, and the bending-density and energy
kernels. Writes ``benchmarks/results/operator.md``.

Usage (from the repository root)::

    python -m benchmarks.bench_operator [--sizes 1000 1500] [--repeat 7]
"""

import argparse
import time
from pathlib import Path

import numba
import numpy as np

from thinfilm.plate import energy
from thinfilm.plate.grid import Grid
from thinfilm.plate.operators import PlateOperator

RESULTS = Path(__file__).resolve().parent / "results"


def median_time(f, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1000, 1500])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        grid = Grid.rectangle(-0.5, 0.5, n - 1, -0.5, 0.5, n - 1)
        t0 = time.perf_counter()
        plate = PlateOperator(grid, 0.3, 4e4, 1e-6, clamped=("x0",))
        t_setup = time.perf_counter() - t0
        rng = np.random.default_rng(0)
        alpha = rng.random(grid.n_nodes)
        u = rng.standard_normal(grid.n_nodes)
        y = np.empty(grid.n_nodes)
        K = plate.matrix(alpha)
        plate.apply(alpha, u, out=y)
        rows.append({
            "nodes": f"{n}^2", "nnz": plate.nnz, "setup_s": t_setup,
            "values_ms": 1e3 * median_time(lambda: plate.matrix(alpha), args.repeat),
            "apply_ms": 1e3 * median_time(lambda: plate.apply(alpha, u, out=y), args.repeat),
            "csr_matvec_ms": 1e3 * median_time(lambda: K @ u, args.repeat),
            "density_ms": 1e3 * median_time(lambda: energy.bending_density(plate, u), args.repeat),
            "energy_ms": 1e3 * median_time(lambda: plate.elastic_energy(u, alpha, u), args.repeat),
        })
    lines = ["# Plate operator kernels", "",
             f"numba {numba.__version__}, {numba.get_num_threads()} threads; median of {args.repeat}.", "",
             "| nodes | nnz | set-up (pattern + csr) s | values of K(alpha) ms | matrix-free apply ms | CSR matvec ms | bending density ms | elastic energy ms |",
             "|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['nodes']} | {r['nnz']:,} | {r['setup_s']:.2f} | {r['values_ms']:.0f} | {r['apply_ms']:.0f} |"
              f" {r['csr_matvec_ms']:.0f} | {r['density_ms']:.0f} | {r['energy_ms']:.0f} |" for r in rows]
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "operator.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
