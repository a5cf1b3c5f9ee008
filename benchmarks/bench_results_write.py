"""The cost per step of the ways of writing ``results.h5`` that survive a kill.

Synthetic states (no solver), the per-step layout of :class:`thinfilm.results.writer.ResultsWriter`
(``/fields/u``, ``/fields/alpha`` in rows of one step, chunks of at most 2^20 values, and 20
records in ``/steps``), for two cases:

* the 1500^2 film: ``u`` and ``alpha`` of 1501^2 = 2,253,001 doubles each per step, ``/grid``;
* a 3D solid: ``u`` of 3 x 100,000 doubles, ``alpha`` of 100,000, ``/mesh`` (100,000 points,
  500,000 tetrahedra).

Candidates, each writing the same steps into a fresh file of its own, in turn, round after
round (the ratios are taken within the run):

* ``in place``: the writer before the journal, HDF5's own driver, ``flush`` after each step
  (a kill in the middle of a step's write can leave a file that cannot be read);
* ``journal``: the chosen one, HDF5 through :class:`thinfilm.results.journal.JournaledFile`
  (the old bytes of every committed byte a step changes appended to ``results.h5.journal``
  first, the journal deleted once the step is flushed: a kill returns the file to its last
  finished step);
* ``SWMR``: HDF5's single-writer/multiple-reader mode (``libver="latest"``,
  ``swmr_mode = True``), ``flush`` after each step;
* ``step files``: each step in an HDF5 file of its own, written under a temporary name and
  renamed into place (what a journal of whole steps writes, beside ``results.h5``).

The time of a step is from the first write of its fields to the end of its flush (and
commit, rename); the files stay in the page cache, so this is the cost of the calls, not of
the disk. Every library on one thread. Writes ``benchmarks/results/results_write.md`` and
``.csv``::

    python -m benchmarks.bench_results_write [--rounds 3] [--film-steps 6] [--solid-steps 20]
"""

import os

for _name in ("MKL_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import csv  # noqa: E402
import platform  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import h5py  # noqa: E402
import numpy as np  # noqa: E402

from thinfilm.results.journal import JournaledFile  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"
RECORDS = 20
CANDIDATES = ("in place", "journal", "SWMR", "step files")


def cases():
    """``{name: (discretization datasets, {field: values per step})}``."""
    n = 1501 ** 2
    film = ({"grid/x": np.linspace(-1, 1, 1501), "grid/y": np.linspace(-1, 1, 1501)}, {"u": n, "alpha": n})
    m = 100_000
    rng = np.random.default_rng(0)
    solid = ({"mesh/points": rng.random((m, 3)), "mesh/cells": rng.integers(0, m, (5 * m, 4))},
             {"u": 3 * m, "alpha": m})
    return {"film 1500^2": film, "3D, 100k nodes": solid}


def create(path, static, sizes, **kwargs):
    """The file before its first step: the discretization, empty per-step datasets."""
    f = h5py.File(path, "w", **kwargs)
    f.attrs["scene"] = "x" * 2000
    for name, values in static.items():
        f.create_dataset(name, data=values)
    for k in range(RECORDS):
        f.create_dataset(f"steps/r{k}", shape=(0,), maxshape=(None,), dtype=np.float64, chunks=(256,))
    for name, n in sizes.items():
        f.create_dataset(f"fields/{name}", shape=(0, n), maxshape=(None, n), dtype=np.float64,
                         chunks=(1, min(n, 1 << 20)))
    return f


def append(f, k, state):
    """Step ``k`` as ResultsWriter.write_step stores it: the fields, then the records."""
    for name, values in state.items():
        ds = f["fields"][name]
        ds.resize((k + 1, ds.shape[1]))
        ds[k] = values
    for j in range(RECORDS):
        ds = f["steps"][f"r{j}"]
        ds.resize((k + 1,))
        ds[k] = k + j


def states(sizes, steps):
    base = {name: np.random.default_rng(1).random(n) for name, n in sizes.items()}
    return [{name: values + k for name, values in base.items()} for k in range(steps)]


#: The journal's size at each commit of the journal candidate (bytes), by case.
journal_bytes = []


def run(candidate, folder, static, sizes, steps):
    """Seconds per step of one candidate writing ``steps`` steps into a fresh file."""
    path = folder / "results.h5"
    data = states(sizes, steps)
    times = []
    if candidate == "in place":
        f = create(path, static, sizes)
        commit = f.flush
    elif candidate == "journal":
        create(path, static, sizes).close()
        journaled = JournaledFile(path)
        f = h5py.File(journaled, "r+")

        def commit():
            f.flush()
            journal_bytes.append(os.path.getsize(journaled.journal))
            journaled.commit()
    elif candidate == "SWMR":
        f = create(path, static, sizes, libver="latest")
        f.swmr_mode = True
        commit = f.flush
    for k, state in enumerate(data):
        start = time.perf_counter()
        if candidate == "step files":
            partial, final = folder / f".step{k:06d}.h5.partial", folder / f"step{k:06d}.h5"
            with h5py.File(partial, "w") as g:
                for name, values in state.items():
                    g.create_dataset(name, data=values)
                for j in range(RECORDS):
                    g.attrs[f"r{j}"] = k + j
            os.replace(partial, final)
        else:
            append(f, k, state)
            commit()
        times.append(time.perf_counter() - start)
    if candidate != "step files":
        f.close()
        if candidate == "journal":
            journaled.commit()
            journaled.close()
    for p in folder.iterdir():
        p.unlink()
    return times


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--film-steps", type=int, default=6)
    parser.add_argument("--solid-steps", type=int, default=20)
    args = parser.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory(dir=os.environ.get("TMPDIR")) as tmp:
        folder = Path(tmp)
        for case, (static, sizes) in cases().items():
            steps = args.film_steps if case.startswith("film") else args.solid_steps
            times = {c: [] for c in CANDIDATES}
            journal_bytes.clear()
            for _ in range(args.rounds):
                for candidate in CANDIDATES:
                    times[candidate] += run(candidate, folder, static, sizes, steps)
            mb = sum(sizes.values()) * 8 / 1e6
            base = float(np.median(times["in place"]))
            for candidate in CANDIDATES:
                t = np.array(times[candidate])
                rows.append({"case": case, "MB per step": round(mb, 1), "candidate": candidate,
                             "median ms per step": round(1e3 * float(np.median(t)), 2),
                             "mean ms per step": round(1e3 * float(t.mean()), 2),
                             "max ms per step": round(1e3 * float(t.max()), 2),
                             "ratio to in place (medians)": round(float(np.median(t)) / base, 3),
                             "steps timed": len(t),
                             "journal kB per step (median)": (round(float(np.median(journal_bytes)) / 1e3, 1)
                                                              if candidate == "journal" else "")})
                print(rows[-1], flush=True)
    RESULTS.mkdir(exist_ok=True)
    with open(RESULTS / "results_write.csv", "w", newline="") as out:
        writer = csv.DictWriter(out, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    load = os.getloadavg()
    lines = ["# Writing a step of results.h5: in place, through the journal, SWMR, step files", "",
             "Synthetic states written with the layout of `ResultsWriter` (no solver):"
             " the 1500^2 film (`u` and `alpha` of 2,253,001 doubles each per step) and a 3D solid (`u`"
             " of 3 x 100,000 doubles, `alpha` of 100,000); each candidate writes the same steps into a fresh"
             " file, in turn, round after round; one thread per library. The files stay in the page cache:"
             " the times are those of the calls, not of the disk.",
             f"Machine: {platform.machine()}, {os.cpu_count()} cores, busy (other jobs ran: load average"
             f" {load[0]:.1f} at the end), so single steps vary; the ratios are of medians taken in the same run."
             f" h5py {h5py.__version__}, HDF5 {h5py.version.hdf5_version}."
             " Command: `python -m benchmarks.bench_results_write`.", "",
             "| case | MB per step | candidate | median ms per step | mean | max | ratio to in place |"
             " journal kB per step |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['case']} | {r['MB per step']} | {r['candidate']} | {r['median ms per step']} |"
                     f" {r['mean ms per step']} | {r['max ms per step']} | {r['ratio to in place (medians)']} |"
                     f" {r['journal kB per step (median)']} |")
    lines += ["", "`in place`: the writer before the journal (a kill in the middle of a step's write can leave a"
              " file that cannot be read). `journal`: the chosen one (`thinfilm/results/journal.py`). `SWMR`:"
              " HDF5's single-writer/multiple-reader mode; a killed writer leaves the file marked open, which"
              " only an SWMR reader opens. `step files`: each step in a file of its own, renamed into place;"
              " beside `results.h5` (which readers need) it comes on top of `in place`.", ""]
    (RESULTS / "results_write.md").write_text("\n".join(lines))


if __name__ == "__main__":
    main()
