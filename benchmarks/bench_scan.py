"""The cost of running a scan on Dask against running its scenes one after another.

Eight short runs (the 1D coated cantilever of ``cases/scans/cantilever_film_1d.toml`` at
eight substrate stiffnesses, about 3-5 s each) are run

* one after another in one fresh Python process (the baseline: what a shell loop over
  ``thinfilm run`` costs at best, imports and compiled-kernel loading paid once), and
* in two plain processes started together, the runs dealt out in turn (what the machine
  gives in parallel with no scheduler at all), and
* as ``thinfilm scan --workers 2`` in a fresh process (cluster start, two fresh workers,
  scheduling, the table and figure included),

in the same session, and the ratio of wall times is set against the ideal 2x. Then the
overheads, separately: the start of a two-worker LocalCluster, the round trip of a task that
does nothing, and a fresh worker's first run against the same run repeated on it (imports and
Numba's on-disk kernel cache). Writes ``benchmarks/results/scan.md`` and ``.csv``.

Every process runs its numerical libraries on one thread (MKL, OpenMP, Numba), as the scan's
workers do. Run it on an otherwise idle machine::

    python -m benchmarks.bench_scan [--runs 8] [--workers 2]
"""

import argparse
import csv
import json
import os
import platform
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RESULTS = Path(__file__).resolve().parent / "results"
BASE = ROOT / "cases" / "scans" / "cantilever_film_1d.toml"
ONE_THREAD = {"MKL_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "NUMBA_NUM_THREADS": "1"}


def winklers(n):
    """``n`` substrate stiffnesses from 3e6 up by factors of 2^(1/2)."""
    return [3e6 * 2 ** (k / 2) for k in range(n)]


def python(codes, cwd):
    """Run each of ``codes`` in a fresh interpreter, all at once, on one thread per library;
    the wall time until the last one ends (s)."""
    start = time.perf_counter()
    env = dict(os.environ, **ONE_THREAD, PYTHONPATH=str(ROOT))
    processes = [subprocess.Popen([sys.executable, "-c", code], cwd=cwd, env=env) for code in codes]
    for process in processes:
        if process.wait() != 0:
            raise RuntimeError("a run failed")
    return time.perf_counter() - start


def loop(values, workdir, steps):
    """A script running the scenes one after another."""
    return textwrap.dedent(f"""
        from thinfilm.run import run
        from thinfilm.scene import load_scene
        for k, w in enumerate({values!r}):
            run(load_scene({str(BASE)!r}, overrides={{"model.winkler": w, "load.steps": {steps}}}),
                {str(workdir)!r} + f"/run{{w:g}}")
        """)


def sequential(values, workdir, steps):
    return python([loop(values, workdir, steps)], workdir)


def side_by_side(values, workdir, steps, workers):
    """The runs dealt out to ``workers`` plain processes started together: what the machine
    gives in parallel without any scheduler."""
    return python([loop(values[k::workers], workdir, steps) for k in range(workers)], workdir)


def scan(values, workdir, workers, steps):
    path = Path(workdir) / "scan.toml"
    path.write_text(f'base = "{BASE}"\n[vary]\n"model.winkler" = {json.dumps(values)}\n[set]\n"load.steps" = {steps}\n'
                    '[collect]\nmetrics = ["cracks_at_t_max", "wall_s"]\n')
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "thinfilm", "scan", str(path), "--out", str(Path(workdir) / "scan"),
                    "--workers", str(workers), "--quiet"], cwd=ROOT, check=True,
                   env=dict(os.environ, **ONE_THREAD, PYTHONPATH=str(ROOT)))
    return time.perf_counter() - start


def overheads(workdir, workers):
    """Cluster start, empty-task round trip, and a fresh worker's first run against its second."""
    from distributed import Client

    from thinfilm.scan.execute import local_cluster
    from thinfilm.scan.task import run_task

    start = time.perf_counter()
    cluster = local_cluster(workers)
    client = Client(cluster)
    client.wait_for_workers(workers)
    cluster_s = time.perf_counter() - start
    try:
        client.submit(int, 0, pure=False).result()
        n = 200
        start = time.perf_counter()
        for k in range(n):
            client.submit(int, k, pure=False).result()
        round_trip_s = (time.perf_counter() - start) / n
        worker = next(iter(client.scheduler_info()["workers"]))

        def once(tag):
            record = client.submit(run_task, str(BASE), {"model.winkler": 6e6}, str(Path(workdir) / tag), tag,
                                   workers=[worker], pure=False).result()
            return record["wall_s"]

        first, second = once("first"), once("second")
    finally:
        client.close()
        cluster.close()
    return cluster_s, round_trip_s, first, second


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=8)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--steps", type=int, nargs="+", default=[120, 480],
                        help="load steps of the runs (the base scene's 120: about 3 s a run; 480: about 11 s)")
    args = parser.parse_args()
    values = winklers(args.runs)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "warm").mkdir()
        sequential(values[:1], Path(tmp) / "warm", 120)    # Numba's cache filled, files in the page cache
        for steps in args.steps:
            for name in ("seq", "par", "scan"):
                (Path(tmp) / f"{name}{steps}").mkdir()
            t_seq = sequential(values, Path(tmp) / f"seq{steps}", steps)
            t_par = side_by_side(values, Path(tmp) / f"par{steps}", steps, args.workers)
            t_scan = scan(values, Path(tmp) / f"scan{steps}", args.workers, steps)
            rows.append({"runs": args.runs, "steps": steps, "workers": args.workers, "sequential_s": t_seq,
                         "side_by_side_s": t_par, "scan_s": t_scan, "speedup": t_seq / t_scan,
                         "side_by_side_speedup": t_seq / t_par, "scan_over_side_by_side": t_scan / t_par})
        (Path(tmp) / "over").mkdir()
        cluster_s, round_trip_s, first_s, second_s = overheads(Path(tmp) / "over", args.workers)
    for row in rows:
        row.update(cluster_start_s=cluster_s, task_round_trip_ms=1e3 * round_trip_s,
                   fresh_worker_first_run_s=first_s, same_run_again_s=second_s)
    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "scan.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    table = "\n".join(f"| {r['steps']} | {r['sequential_s'] / args.runs:.1f} | {r['sequential_s']:.1f} |"
                      f" {r['side_by_side_s']:.1f} ({r['side_by_side_speedup']:.2f}x) | {r['scan_s']:.1f}"
                      f" ({r['speedup']:.2f}x) | {r['scan_over_side_by_side']:.2f} |" for r in rows)
    text = f"""# Scan overhead: {args.runs} runs on {args.workers} Dask workers against one process

The 1D coated cantilever (`cases/scans/cantilever_film_1d.toml`, 800 cells) at {args.runs}
substrate stiffnesses, with the base scene's 120 load steps and with 480; every process on one
thread per numerical library, the machine otherwise idle.
Machine: {platform.machine()}, {os.cpu_count()} cores. Command: `python -m benchmarks.bench_scan`.

| load steps | s per run | one after another, one process (s) | {args.workers} plain processes side by side (s, speed-up) | `thinfilm scan --workers {args.workers}` (s, speed-up) | scan / side by side |
|---|---|---|---|---|---|
{table}

The ideal speed-up is {args.workers}x; the plain processes (the runs dealt out in turn, no scheduler)
show what the machine gives in parallel. The scan's time includes starting the cluster, the
table and the figure.

Overheads: a {args.workers}-worker LocalCluster starts in {cluster_s:.2f} s; a task that does nothing
takes {1e3 * round_trip_s:.1f} ms from submit to result; a fresh worker's first run took {first_s:.2f} s and
the same run again on it {second_s:.2f} s ({first_s - second_s:+.2f} s: imports and loading Numba's
compiled kernels from its on-disk cache, paid once per worker).
"""
    (RESULTS / "scan.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
