"""Running a scan's runs on Dask: :func:`execute`.

Dask (``dask.distributed``) does the scheduling, the transport and the retries; this module
only decides what to submit and keeps the table up to date:

* without a scheduler address it starts a :class:`distributed.LocalCluster` of worker
  *processes* with one thread each (the runs hold the GIL in Python and Numba code, so
  threads would not run them in parallel), as many as the machine has cores by default, with
  ``OMP_NUM_THREADS``, ``MKL_NUM_THREADS``, ``OPENBLAS_NUM_THREADS`` and ``NUMBA_NUM_THREADS``
  set to 1 before each worker starts, so that N workers use N cores and the sparse direct
  solver does not oversubscribe them (a second PARDISO thread competing for a busy core
  slows a factorization several-fold); no memory limit (a run that needs the memory should
  get it, not be killed and retried);
* with an address (``tcp://host:8786``) it submits to that cluster's workers, which must have
  thinfilm installed and see the scan directory at the same path (a shared file system);
* each run is one task (:func:`thinfilm.scan.task.run_task`). If the worker running it dies,
  the scheduler gives the task to another worker (up to ``distributed.scheduler.allowed-
  failures`` times, 3 by default), and the run continues from its last finished step;
* the table is rewritten as runs finish (at most every :data:`TABLE_INTERVAL` seconds, since
  it reads every run's files) and at the end; a scan that is killed is continued by running
  it again with ``resume=True``.
"""

from __future__ import annotations

import logging
import os
import shutil
import signal
import threading
import time
from pathlib import Path

from distributed import WorkerPlugin

from thinfilm.results.writer import write_json
from thinfilm.scan.table import collect, run_dir, write_plan
from thinfilm.scan.task import RECORD, read_record, run_task

__all__ = ["execute", "local_cluster", "connect", "IgnoreInterrupt", "THREAD_VARIABLES", "CONNECT_TIMEOUT"]

#: Seconds between two rewrites of scan.csv while runs finish.
TABLE_INTERVAL = 10.0
#: Environment of every local worker: one thread for each numerical library.
THREAD_VARIABLES = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                    "NUMBA_NUM_THREADS": "1"}

#: Seconds ``thinfilm scan --scheduler ADDRESS`` waits for the scheduler to answer before it
#: refuses the scan (a scheduler on a reachable host answers in milliseconds).
CONNECT_TIMEOUT = 5.0
#: Address schemes of Dask's transports that a remote scheduler may use.
SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def connect(address, timeout=CONNECT_TIMEOUT):
    """A client of the running Dask scheduler at ``address``, checked before a scan writes
    anything.

    Parameters
    ----------
    address : str
        ``scheme://host:port`` (scheme one of :data:`SCHEMES`) or ``host:port`` (tcp).
    timeout : float
        Seconds to wait for the scheduler.

    Returns
    -------
    distributed.Client

    Raises
    ------
    ValueError
        If the address is malformed (the message says what is allowed).
    OSError
        If no scheduler answered within ``timeout``.
    """
    from distributed import Client
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location)
    except ValueError as err:
        raise ValueError(f"not a scheduler address ({err}); give scheme://host:port, e.g. tcp://host:8786") from None
    if scheme not in SCHEMES or not host or not 0 < port < 65536:
        raise ValueError(f"not a scheduler address: give scheme://host:port with a scheme of {', '.join(SCHEMES)},"
                         " a host and a port in 1-65535, e.g. tcp://host:8786")
    try:
        return Client(address, timeout=f"{timeout}s")
    except (OSError, TimeoutError) as err:
        raise OSError(f"no Dask scheduler answered within {timeout:g} s ({err})") from None


class IgnoreInterrupt(WorkerPlugin):
    """Local workers leave Ctrl-C to the scan.

    A terminal's Ctrl-C goes to every process of its group, the local workers too; a worker
    would die on it mid-run with a traceback. Ignoring it, the workers stop when the scan,
    which saved what it has, closes its cluster.
    """

    name = "thinfilm-ignore-interrupt"

    def setup(self, worker):
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGINT, signal.SIG_IGN)


def local_cluster(workers=None):
    """A :class:`distributed.LocalCluster` for scans: ``workers`` processes (default: the
    machine's cores) of one thread each, the numerical libraries on one thread, no memory limit,
    its HTTP server on a free port, Dask's own log lines at warnings only."""
    import dask
    from distributed import LocalCluster

    n = int(workers or os.cpu_count() or 1)
    environ = {**dask.config.get("distributed.nanny.pre-spawn-environ", {}), **THREAD_VARIABLES}
    with dask.config.set({"distributed.nanny.pre-spawn-environ": environ}):
        # ":0": the scheduler's HTTP server (it runs even without bokeh's dashboard) on a free
        # port, so that two scans side by side do not warn about port 8787
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True, memory_limit=0,
                            dashboard_address=":0", silence_logs=logging.WARNING)


def execute(plan, outdir, *, client=None, workers=None, scheduler=None, resume=False, progress=None):
    """Run every run of ``plan`` that is not finished, on Dask, and write the table.

    Parameters
    ----------
    plan : thinfilm.scan.plan.ScanPlan
    outdir : str or Path
        The scan directory (``scan.json``, ``scan.csv``, ``scan.png``, ``runs/<name>/``).
    client : distributed.Client, optional
        Use this client (and its cluster); otherwise one is made from ``scheduler`` or a new
        :func:`local_cluster` of ``workers`` processes, and closed at the end.
    workers : int, optional
    scheduler : str, optional
        Address of a running Dask scheduler.
    resume : bool
        Keep the runs already done (their ``run.json`` says so) and continue unfinished ones
        from their last finished step; failed runs are run again. Without it every run starts
        from nothing: the directories of the plan's runs are emptied first (the command line
        refuses a directory that holds a scan unless ``--resume`` or ``--force`` is given).
    progress : callable, optional
        ``progress(record)`` after each run finishes, and at once for each run a resumed scan
        keeps (the command line's progress bar).

    Returns
    -------
    table : Path
    figure : Path
    counts : dict
        Runs per status.
    """
    from distributed import Client, as_completed

    outdir = Path(outdir).resolve()
    outdir.mkdir(parents=True, exist_ok=True)
    write_plan(plan, outdir)
    todo = []
    for spec in plan.runs:
        rundir = run_dir(outdir, spec.name)
        if not resume:
            shutil.rmtree(rundir, ignore_errors=True)
        else:
            record = read_record(rundir)
            if (record or {}).get("status") == "done":
                if progress is not None:
                    progress(record)
                continue
        todo.append(spec)
    if not todo:  # every run done already: no cluster needed
        return collect(outdir)
    collect(outdir, figure=False)
    own = client is None
    cluster = None
    if own:
        if scheduler:
            client = Client(scheduler, timeout="30s")
        else:
            cluster = local_cluster(workers)
            client = Client(cluster)
            client.register_plugin(IgnoreInterrupt())
    try:
        futures = {}
        for spec in todo:
            rundir = run_dir(outdir, spec.name)
            rundir.mkdir(parents=True, exist_ok=True)
            # a unique key: a scan resumed on a cluster that still knows the old task runs it anew
            future = client.submit(run_task, str(plan.base), spec.overrides, str(rundir), spec.name,
                                   key=f"thinfilm-run-{spec.name}-{os.urandom(4).hex()}", pure=False)
            futures[future] = spec
        written = time.monotonic()
        for future in as_completed(futures):
            spec = futures[future]
            try:
                record = future.result()
            except Exception as err:  # the worker died on it too often (KilledWorker), or the cluster failed
                record = {"name": spec.name, "status": "failed", "error": f"{err.__class__.__name__}: "
                          + " ".join(str(err).split()), "wall_s": None, "worker": "", "overrides": spec.overrides}
                write_json(run_dir(outdir, spec.name) / RECORD, record)
            if time.monotonic() - written > TABLE_INTERVAL:  # reading every run's files: not after each one
                collect(outdir, figure=False)
                written = time.monotonic()
            if progress is not None:
                progress(record)
    finally:
        if own:
            client.close()
            if cluster is not None:
                cluster.close()
    return collect(outdir)
