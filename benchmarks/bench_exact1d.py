"""Speed of the exact 1D evolution: Numba kernels against the plain NumPy version.

Times the Fig. 2.18 evolution (l0 = 1, lam = 31.62, G/a = 1, t up to 12, 1000 cells, every
event located by bisection to a relative 1e-13) with the Numba kernels of
:mod:`onedim.dynprog` and with the NumPy kernels of :mod:`onedim.reference` (the same
algorithm, line for line), in the same run, for the grid and the refined track. Both must
find the same events. Writes ``benchmarks/results/exact1d.md`` and ``.csv``.

Usage (from the repository root)::

    python -m benchmarks.bench_exact1d [--repeat 5] [--cells 1000]
"""

import argparse
import csv
import platform
import time
from pathlib import Path

import numba
import numpy as np

from onedim import dynprog, reference
from onedim.evolution import evolve

RESULTS = Path(__file__).resolve().parent / "results"


def best_time(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - start)
    return min(times), out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--cells", type=int, default=1000)
    args = parser.parse_args()
    scene = dict(length=1.0, lam=31.62, toughness=1.0, cells=args.cells, t_max=12.0)

    start = time.perf_counter()
    evolve(**scene, refine=True)  # JIT compilation, or loading it from the cache
    first_call = time.perf_counter() - start

    rows = []
    for refine in (False, True):
        track = "refined" if refine else "grid"
        t_numba, ev_numba = best_time(lambda: evolve(**scene, refine=refine), args.repeat)
        t_numpy, ev_numpy = best_time(
            lambda: evolve(**scene, refine=refine, locate_nucleation=reference.locate_nucleation),
            max(1, args.repeat // 2))
        assert ev_numba == ev_numpy, "the two implementations disagree"
        rows.append({"track": track, "numba_s": t_numba, "numpy_s": t_numpy, "speedup": t_numpy / t_numba,
                     "events": "; ".join(f"t={e.t:.6f}: {len(e.cracks)} cracks" for e in ev_numba)})

    # The kernel alone: one Algorithm 2.1 pass over the whole film.
    coef = np.zeros(args.cells + 1)
    from onedim.fragment import fragment_coefficient
    coef[1:] = fragment_coefficient(np.arange(1, args.cells + 1) / args.cells, 31.62)
    k_numba, _ = best_time(lambda: dynprog.best_partition_energies(coef, 5.0, 1.0), 20)
    k_numpy, _ = best_time(lambda: reference.best_partition_energies(coef, 5.0, 1.0), 5)

    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "exact1d.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    lines = [
        "# Exact 1D evolution, Fig. 2.18 scene",
        "",
        f"l0 = 1, lam = 31.62, G/a = 1, t in [0, 12], {args.cells} cells, events located to 1e-13;"
        f" best of {args.repeat} runs after warm-up.",
        f"Machine: {platform.machine()}, {platform.processor() or 'cpu'}, numba {numba.__version__}, numpy {np.__version__}.",
        f"First call (JIT compile or cache load): {first_call:.2f} s.",
        "",
        "| track | Numba (s) | NumPy (s) | speed-up |",
        "|---|---|---|---|",
    ]
    lines += [f"| {r['track']} | {r['numba_s']:.4f} | {r['numpy_s']:.3f} | {r['speedup']:.1f}x |" for r in rows]
    lines += ["", f"One Algorithm 2.1 pass over {args.cells} cells: Numba {k_numba * 1e3:.3f} ms,"
              f" NumPy {k_numpy * 1e3:.2f} ms ({k_numpy / k_numba:.1f}x).", "",
              "Events: " + rows[-1]["events"], ""]
    (RESULTS / "exact1d.md").write_text("\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
