"""Threads of the numerical libraries, chosen to fit the machine: :class:`ThreadGovernor`.

A run spends its time in three places that can use several cores: MKL's PARDISO (the sparse
direct u-solve; MKL threads through Intel OpenMP), Numba's ``prange`` kernels (the film's
operator) and OpenBLAS (numpy's and scipy's dense algebra: small matrices here, such as the
AMG hierarchy's coarsest level). Left alone, each starts one thread per core. On a machine
whose cores are taken by other processes that is slower than one thread (the threads wait for
each other and spin while they wait): ``docs/speed.md#threads`` and ``benchmarks/results/threads.md``
give the measurements.

What this module does:

* ``threads = "auto"`` (the default of ``[solver] threads`` and ``--threads``): the thread
  count of MKL, OpenMP and Numba is the number of cores *the other processes leave idle*,
  measured from the operating system's CPU times (:class:`IdleCores`: the machine's busy time
  minus this process's own, over the last interval), at least 1 and at most the cores this
  process may use. It is chosen before the first load step and again after every step of at
  least :data:`MIN_INTERVAL` seconds, so a run that starts on an idle machine drops to one
  thread when another job starts, and takes the second core back when it ends;
* ``"auto"`` never goes above a count the environment set when the toolkit was imported
  (``MKL_NUM_THREADS``, ``OMP_NUM_THREADS``; :data:`ENVIRONMENT_CAP`): a user or a batch
  system that pins one thread per job keeps it;
* ``threads = N``: N threads, whatever the machine does;
* OpenBLAS always runs on one thread: its threads change the order of its sums, and so the
  last bits of a run's results (with the AMG solver, whose coarsest level OpenBLAS factorizes;
  measured: docs/speed.md#threads), while its matrices are too small for a second thread to
  pay. MKL PARDISO (with conditional numerical reproducibility,
  :func:`thinfilm.solvers.linear.pardiso_reproducible`) and the Numba kernels (no reduction
  across threads) give the same bits on any number of threads, so the choice, fixed or
  automatic, never changes a result: ``tests/core/test_threads.py`` checks it.

The libraries are set through their own controls: ``threadpoolctl`` for those already loaded
(MKL, Intel OpenMP, OpenBLAS), ``numba.set_num_threads`` for Numba (at most the pool size
Numba started with, ``NUMBA_NUM_THREADS``, by default the cores), and the environment
variables ``MKL_NUM_THREADS`` and ``OMP_NUM_THREADS`` for a library loaded later (MKL is
loaded when the first direct solver is made; it reads them then).
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

__all__ = ["ThreadGovernor", "IdleCores", "usable_cores", "parse_threads", "threads_summary", "threads_line",
           "AUTO", "MIN_INTERVAL", "ENVIRONMENT_CAP"]

#: The setting that chooses from the machine's idle cores.
AUTO = "auto"
#: Seconds of CPU accounting a choice needs at least (the kernel counts CPU time in ticks of
#: 10 ms: shorter intervals would make the measured load jump from step to step).
MIN_INTERVAL = 0.5


def _environment_cap():
    """The smallest thread count ``MKL_NUM_THREADS`` or ``OMP_NUM_THREADS`` sets (None if
    neither gives a positive integer)."""
    counts = []
    for name in ("MKL_NUM_THREADS", "OMP_NUM_THREADS"):
        text = os.environ.get(name, "").split(",")[0].strip()
        if text.isdigit() and int(text) >= 1:
            counts.append(int(text))
    return min(counts) if counts else None


#: The thread count the environment set before this module was imported (read once: the
#: governor itself sets these variables for libraries loaded later), or None.
ENVIRONMENT_CAP = _environment_cap()


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity (``os.sched_getaffinity``) where
    the system has one, else ``os.cpu_count()``."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def parse_threads(value):
    """``"auto"`` or a positive integer from a scene value or a command-line string; None if
    ``value`` is neither (the caller names the key)."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value if value >= 1 else None
    if isinstance(value, str):
        text = value.strip().lower()
        if text == AUTO:
            return AUTO
        if text.isdigit() and int(text) >= 1:
            return int(text)
    return None


class IdleCores:
    """The cores other processes leave idle, measured over the interval since the last reading.

    ``busy`` is the machine's CPU time spent outside the idle and I/O-wait states (user,
    system, interrupts, and time stolen by a hypervisor) summed over its CPUs; this process's
    own user and system time (all its threads) is taken off, what is left is the other
    processes' work. Divided by the wall time between two readings it is the number of cores
    they kept busy on average.
    """

    def __init__(self):
        import psutil

        self._psutil = psutil
        self._process = psutil.Process()
        self._last = self._read()

    def _read(self):
        t = self._psutil.cpu_times()
        total = sum(t)
        # guest time is already counted in user (and guest_nice in nice) on Linux
        busy = total - t.idle - getattr(t, "iowait", 0.0) - getattr(t, "guest", 0.0) - getattr(t, "guest_nice", 0.0)
        own = self._process.cpu_times()
        return time.monotonic(), busy, own.user + own.system

    def elapsed(self) -> float:
        """Seconds since the last reading."""
        return time.monotonic() - self._last[0]

    def others(self) -> float:
        """Cores kept busy by other processes since the last reading (>= 0); starts a new
        interval."""
        now = self._read()
        (t0, busy0, own0), (t1, busy1, own1) = self._last, now
        self._last = now
        wall = t1 - t0
        if wall <= 0:
            return 0.0
        return max(0.0, ((busy1 - busy0) - (own1 - own0)) / wall)


@dataclass
class ThreadChoice:
    """One choice of thread counts.

    Attributes
    ----------
    threads : int
        Threads of MKL, OpenMP and Numba.
    others : float or None
        Cores the other processes kept busy when it was made (None for a fixed setting).
    """

    threads: int
    others: float | None = None


class ThreadGovernor:
    """Sets the numerical libraries' threads for a run, and changes them as the machine does.

    Parameters
    ----------
    setting : "auto" or int
        ``"auto"``: as many threads as idle cores, measured before the first step and after
        each step; an integer: that many, always.

    Attributes
    ----------
    cores : int
        The cores this process may use (:func:`usable_cores`).
    current : int
        The threads MKL, OpenMP and Numba have now (0 before :meth:`start`).
    last : ThreadChoice or None
        The last choice made (None before :meth:`start`).
    """

    def __init__(self, setting=AUTO):
        if parse_threads(setting) is None:
            raise ValueError(f"threads = {setting!r}: must be \"auto\" or an integer >= 1")
        self.setting = parse_threads(setting)
        self.cores = usable_cores()
        #: The most "auto" gives: the cores, or fewer if the environment said so.
        self.cap = min(self.cores, ENVIRONMENT_CAP or self.cores)
        self.current = 0
        self.last = None
        self._idle = IdleCores() if self.setting == AUTO else None

    # -- the choice ------------------------------------------------------------------------------
    def _choose(self):
        if self.setting != AUTO:
            return ThreadChoice(self.setting)
        others = self._idle.others()
        return ThreadChoice(min(self.cap, max(1, round(self.cores - others))), others)

    def start(self):
        """Choose and set the threads before the first step; returns the count. With
        ``"auto"``, measures the machine for at least 0.2 s (since the governor was made)."""
        if self._idle is not None and self._idle.elapsed() < 0.2:
            time.sleep(0.2 - self._idle.elapsed())
        return self._set(self._choose())

    def update(self):
        """After a step: choose again (``"auto"`` only, once :data:`MIN_INTERVAL` seconds have
        passed since the last choice) and set the threads if the count changed; returns the
        count."""
        if self._idle is None or self._idle.elapsed() < MIN_INTERVAL:
            return self.current
        return self._set(self._choose())

    # -- the libraries ---------------------------------------------------------------------------
    def _set(self, choice):
        self.last = choice
        if choice.threads != self.current:
            limit_threads(choice.threads)
            self.current = choice.threads
        return self.current

    def describe(self) -> str:
        """The last choice in words, for the run log."""
        if self.setting != AUTO:
            return f"set to {self.setting}"
        others = self.last.others if self.last else None
        busy = "" if others is None else f", other processes keep {others:.1f} busy"
        cap = f", at most {self.cap} (MKL_NUM_THREADS/OMP_NUM_THREADS)" if self.cap < self.cores else ""
        return f"auto: {self.cores} core(s){busy}{cap}"

    def record(self) -> dict:
        """What the results file keeps of the setting (root attribute ``threads``, JSON)."""
        return {"setting": self.setting, "cores": self.cores, "cap": self.cap, "openblas": 1,
                "numba_pool": numba_pool()}


def numba_pool() -> int:
    """Threads Numba's pool was started with (``NUMBA_NUM_THREADS``): the most it can use."""
    import numba

    return int(numba.config.NUMBA_NUM_THREADS)


def limit_threads(n):
    """Set MKL, OpenMP and Numba to ``n`` threads (Numba to at most its pool) and OpenBLAS to
    one, in this process, now and for MKL and OpenMP if they are loaded later."""
    import numba
    from threadpoolctl import ThreadpoolController

    # a library loaded later (MKL with the first PARDISO solver) reads its variables then
    os.environ["MKL_NUM_THREADS"] = os.environ["OMP_NUM_THREADS"] = str(n)
    libraries = ThreadpoolController()
    libraries.select(internal_api=["mkl", "openmp"]).limit(limits=n)
    # every other BLAS (OpenBLAS, BLIS, FlexiBLAS) on one thread
    libraries.select(internal_api=["openblas", "blis", "flexiblas"]).limit(limits=1)
    numba.set_num_threads(min(n, numba_pool()))


def threads_summary(attribute, per_step):
    """A run's threads as ``summary.json`` gives them, or None if the run did not record them.

    Parameters
    ----------
    attribute : str or None
        The results' root attribute ``threads`` (JSON, :meth:`ThreadGovernor.record`).
    per_step : ndarray of int or None
        ``/steps/threads`` (0 for a step not recorded: resumed from an older file).

    Returns
    -------
    dict or None
        ``{"setting", "cores", "openblas", "numba_pool", "steps": {"<threads>": <steps>}}``.
    """
    if not attribute:
        return None
    import json

    import numpy as np

    out = json.loads(attribute)
    counts = np.asarray(per_step if per_step is not None else [], dtype=int)
    out["steps"] = {str(int(n)): int(np.count_nonzero(counts == n)) for n in np.unique(counts[counts > 0])}
    return out


def threads_line(summary):
    """``"threads: auto on 2 cores: 2 in 18 steps, 1 in 3"`` for ``thinfilm info``."""
    setting = summary["setting"]
    head = f"threads: {'auto' if setting == AUTO else f'set to {setting}'} on {summary['cores']} core(s)"
    parts = [f"{n} in {k} step{'s' if k != 1 else ''}" for n, k in sorted(summary["steps"].items(),
                                                                         key=lambda item: -int(item[0]))]
    return head + (": " + ", ".join(parts) if parts else "") + " (OpenBLAS on 1)"
