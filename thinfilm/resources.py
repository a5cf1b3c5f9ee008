"""What a run needs against what this machine has: memory, and time where a simple estimate
exists, reckoned from the scene alone before anything is built or written.

A scene whose run cannot fit is refused like any bad input (:class:`thinfilm.scene.SceneError`,
one line naming the key, its value, the estimate and the limit) instead of failing after
minutes with a ``MemoryError`` or running for years. Each kind reckons its own needs
(``estimate(scene) -> Estimate``, :mod:`thinfilm.kinds`): the thin film from its nodes and
steps (:mod:`thinfilm.plate.resources`), the exact 1D film from its cells and steps
(:mod:`thinfilm.exact1d.resources`); a kind driven by the engine whose size is only known once
it is built (a mesh) from its steps alone (:func:`steps_estimate`). The byte counts are those
of what the code allocates, measured on runs of moderate size
(docs/speed.md#memory-and-time-estimates; against whole runs: docs/scenes.md#sizes).

The memory limit is the machine's available memory (``MemAvailable`` of ``/proc/meminfo``,
else the free pages); it cannot be lifted. The time limit (:data:`TIME_LIMIT`) is there to
catch a mistyped size, and the command line's ``--no-time-limit`` lifts it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

__all__ = ["Size", "Estimate", "TIME_LIMIT", "BASE_BYTES", "STEP_BYTES", "available_memory", "check",
           "steps_estimate", "size", "duration", "count"]

#: Default time limit (s): a run estimated to take longer is refused unless the limit is lifted.
TIME_LIMIT = 3600.0

#: Memory of a run whatever its size (bytes): the interpreter with numpy, scipy, numba, h5py,
#: matplotlib and MKL loaded, and the figures drawn at the end (measured:
#: docs/speed.md#memory-and-time-estimates).
BASE_BYTES = 300e6

#: Memory per load step of a run driven by the engine, besides its fields (bytes): the figures
#: of the per-step curves drawn at the end (one line point, and the film's one crack marker,
#: per step), which outweigh the engine's records kept during the run (the StepRecord, the
#: State and its energy history). Measured: docs/speed.md#memory-and-time-estimates.
STEP_BYTES = 20e3


@dataclass(frozen=True)
class Size:
    """A scene key that sets a run's size, with what the run would need if only it were large.

    Attributes
    ----------
    key : str
        Dotted key path (``"domain.cells"``).
    value : object
        Its value as the scene gives it.
    memory : float
        Bytes the run needs with this key's value and every other size at its least.
    share : float
        Bytes of the run's estimate that grow with this key (the film's fields of every step
        grow with its steps, though their size is set by its nodes).
    seconds : float
        Likewise, a lower bound of the run's time with every other size at its least (0: not
        estimated).
    remedy : str
        What to change, for the message (``"use fewer cells"``).
    """

    key: str
    value: object
    memory: float
    share: float
    seconds: float = 0.0
    remedy: str = ""


@dataclass(frozen=True)
class Estimate:
    """What a run needs.

    Attributes
    ----------
    memory : float
        Bytes, the peak of the whole run.
    memory_detail : str
        How it was reckoned, for the message (``"801 nodes x 1.3 kB, and 101 steps x 33 kB"``).
    sizes : tuple of Size
        The keys that set it. A run that does not fit is blamed on the first whose value alone
        does not fit, else on the one with the largest share (of memory; of time: the one
        whose value alone takes longest).
    seconds : float or None
        A lower bound of the run's time, if the kind can tell; None otherwise.
    time_detail : str
        How it was reckoned.
    """

    memory: float
    memory_detail: str
    sizes: tuple
    seconds: float | None = None
    time_detail: str = ""

    def blame(self, what, limit):
        """The :class:`Size` a run over ``limit`` is blamed on (``what``: "memory" or "seconds")."""
        over = [s for s in self.sizes if getattr(s, what) > limit]
        share = "share" if what == "memory" else what
        return over[0] if over else max(self.sizes, key=lambda s: getattr(s, share))


def available_memory():
    """The memory this machine can give a new run (bytes), or None if it cannot be told.

    ``MemAvailable`` of ``/proc/meminfo`` (free memory plus what the kernel can reclaim),
    else ``os.sysconf``'s free pages.
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def size(n):
    """Bytes for a message: ``"140 B"``, ``"23.9 GB"``, ``"2.64e+05 TB"`` (decimal units)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n:.0f} B"


def duration(s):
    """Seconds for a message: ``"40 s"``, ``"11 h"``, ``"3.2e+07 years"``."""
    for unit, scale in (("years", 3.156e7), ("days", 86400.0), ("h", 3600.0), ("min", 60.0)):
        if s >= scale:
            return f"{s / scale:.3g} {unit}"
    return f"{s:.3g} s"


def count(n):
    """A count for a message: ``"801"``, ``"1e+12"``."""
    return str(int(n)) if n < 1e6 else f"{n:.3g}"


def check(scene, time_limit=TIME_LIMIT, memory=None):
    """Refuse a scene whose run cannot fit this machine, before anything is built.

    Parameters
    ----------
    scene : object
        A validated scene (:func:`thinfilm.scene.load_scene`).
    time_limit : float or None
        Seconds; None: no time limit.
    memory : float, optional
        The memory limit in bytes (default: :func:`available_memory`; none if it cannot be told).

    Raises
    ------
    thinfilm.scene.SceneError
        Naming the key whose size does not fit, its value, the estimate and the limit.
    """
    from thinfilm import kinds
    from thinfilm.scene import SceneError, show

    estimate = getattr(kinds.get(scene.kind), "estimate", None)
    if estimate is None:
        return
    need = estimate(scene)
    limit = available_memory() if memory is None else memory
    if limit is not None and need.memory > limit:
        key = need.blame("memory", limit)
        raise SceneError(scene.source, key.key, f"= {show(key.value)}: the run needs about {size(need.memory)} of"
                         f" memory ({need.memory_detail}), more than the {size(limit)} available on this machine"
                         + (f"; {key.remedy}" if key.remedy else ""))
    if time_limit is not None and need.seconds is not None and need.seconds > time_limit:
        key = need.blame("seconds", time_limit)
        raise SceneError(scene.source, key.key, f"= {show(key.value)}: the run takes at least about"
                         f" {duration(need.seconds)} ({need.time_detail}), more than the time limit of"
                         f" {duration(time_limit)}" + (f"; {key.remedy}" if key.remedy else "")
                         + " (or lift the limit with --no-time-limit)")


def steps_estimate(scene):
    """The memory of a run driven by the engine from its load steps alone (:data:`BASE_BYTES`
    and :data:`STEP_BYTES` per step), for a kind whose nodes are not known before it is built.

    Returns
    -------
    Estimate
        Blamed on ``load.steps`` (or ``load.t``, an explicit list of loads).
    """
    load = scene.load
    values = getattr(load, "values", None)
    key, value = ("load.t", list(values)) if values is not None else ("load.steps", load.steps)
    memory = BASE_BYTES + (load.steps + 1) * STEP_BYTES
    return Estimate(memory, f"{count(load.steps + 1)} steps x {size(STEP_BYTES)}",
                    (Size(key, value, memory, memory - BASE_BYTES, remedy="use fewer steps"),))
