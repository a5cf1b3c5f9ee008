"""The exact 1D film as a model kind (``kind = "exact1d"``).

:data:`KIND` is what :mod:`thinfilm.kinds` finds. Its runs are not driven by the engine: the
global-minimizer evolution of :mod:`onedim` is computed in one go
(:mod:`thinfilm.exact1d.evolution`) and written whole (:mod:`thinfilm.exact1d.results`). A
resumed run (``--resume``) is checked against the stored scene as any other
(:func:`thinfilm.resume.check_resume`: only the loads may be extended, and ``[output]``
changed) and then computed again in one go: the exact evolution locates its events within
``[0, t_max]``, so a longer run is not the shorter one continued but the same computation to
the new ``t_max`` (a few seconds), and its results are those of an uninterrupted run.
"""

from __future__ import annotations

from pathlib import Path

from thinfilm.exact1d import scene as exact_scene

__all__ = ["KIND", "Exact1DKind"]


class Exact1DKind:
    """``kind = "exact1d"``: the exact evolution of a film under pure bending."""

    name = "exact1d"
    resumable = True
    required_datasets = ()

    def parse(self, source, data, text):
        return exact_scene.parse(source, data, text)

    def estimate(self, scene):
        """Memory and time of the run (:func:`thinfilm.exact1d.resources.estimate`)."""
        from thinfilm.exact1d.resources import estimate

        return estimate(scene)

    def run(self, scene, outdir, progress=lambda n: None, resume=False, threads=None):
        """Compute both tracks, write ``results.h5``, ``summary.json`` and the two figures.

        ``resume=True`` first checks the scene against the one ``outdir/results.h5`` was
        written from (:class:`thinfilm.resume.ResumeError` if it may not continue it; the
        file is left as it was), then computes the whole evolution again. The evolution is
        serial: ``threads`` (:mod:`thinfilm.threads`) only sets the libraries once, at the
        start (OpenBLAS to one thread).
        """
        from thinfilm.threads import ThreadGovernor

        ThreadGovernor(threads if threads is not None else 1).start()
        from thinfilm.exact1d.evolution import run_exact1d
        from thinfilm.exact1d.plots import plot_exact1d
        from thinfilm.exact1d.results import write_exact1d

        results = Path(outdir) / "results.h5"
        if resume and results.exists():
            import h5py

            from thinfilm.results.reader import attrs_dict
            from thinfilm.resume import ResumeError, check_resume

            try:
                with h5py.File(results, "r") as f:
                    attrs = attrs_dict(f)
            except OSError as err:
                raise ResumeError(f"{results} cannot be read back to resume it ({err}); run with --force to start"
                                  " over") from None
            check_resume(results, attrs, scene)
        tracks = run_exact1d(scene, progress=progress)
        results, summary = write_exact1d(Path(outdir), scene, tracks)
        figures = plot_exact1d(results, outdir)
        report = [f"t = {event.t:.8g}: {len(event.cracks)} crack(s) at " + ", ".join(f"{c:+.5f}" for c in event.cracks)
                  for event in tracks["refined"].events]
        return {"results": results, "summary": summary, "figures": figures, "report": report}

    def plot(self, results, outdir=None, loads=None, animate=False):
        """``energy.png`` and ``cracks.png`` (``loads`` and ``animate`` do not apply)."""
        from thinfilm.exact1d.plots import plot_exact1d

        return plot_exact1d(results, outdir)

    def info(self, f, steps):
        events = f["events/t"][()] if "events/t" in f else []
        counts = f["events/crack_count"][()] if "events/crack_count" in f else [0] * len(events)
        return ["events: " + ("; ".join(f"t = {te:.8g}: {c} crack(s)" for te, c in zip(events, counts))
                              if len(events) else "none"),
                "timings: not recorded for exact 1D runs"]


KIND = Exact1DKind()
