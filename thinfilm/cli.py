"""The command line: ``thinfilm run SCENE.toml [--out DIR] [--resume | --force] [--quiet]``,
``thinfilm scan SCAN.toml`` (:mod:`thinfilm.scan`), ``compare``, ``plot`` and ``info``.

Library code raises exceptions; only this module turns them into messages and exit codes.
A bad scene is reported in one line on stderr with exit status 2, before anything is
computed or written; so is a scene whose run cannot fit this machine's memory, or is
estimated to take longer than the time limit (unless ``--no-time-limit``:
:mod:`thinfilm.resources`), and an output directory that already holds results (unless
``--resume`` or ``--force``). Ctrl-C stops a run driven by the engine after saving its
finished steps (exit 130); a solver failure keeps them too (exit 1). Scenes are run by their
kind (:mod:`thinfilm.kinds`), found from ``[model] kind``.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from tqdm import tqdm

from thinfilm import __version__, kinds, resources
from thinfilm.scene import SceneError, load_scene

EXIT_BAD_INPUT = 2
EXIT_FAILED = 1
EXIT_INTERRUPTED = 130


def default_outdir(scene_path):
    """Output directory next to the scene, named after it: ``cases/fig2_15.toml -> cases/fig2_15``."""
    scene_path = Path(scene_path)
    return scene_path.with_suffix("") if scene_path.suffix else scene_path.with_name(scene_path.name + "_out")


def _run_scene(scene, outdir, args, resume=False):
    """Run a validated scene through its kind; returns the exit status."""
    from thinfilm.engine.evolution import EvolutionError
    from thinfilm.results.writer import ResumeError
    from thinfilm.run import RunInterrupted, run

    try:
        with tqdm(total=scene.load.steps + 1, desc=Path(args.scene).stem, unit="step",
                  disable=True if args.quiet else None, file=sys.stderr) as bar:
            out = run(scene, outdir, progress=bar.update, resume=resume, threads=args.threads)
    except ResumeError as err:
        raise SceneError(args.scene, None, str(err)) from None
    except RunInterrupted as err:
        print(f"thinfilm: {err}; continue with: thinfilm run {args.scene} --resume"
              + (f" --out {args.out}" if args.out else ""), file=sys.stderr)
        return EXIT_INTERRUPTED
    except EvolutionError as err:
        print(f"thinfilm: error: {err} (the finished steps are in {outdir / 'results.h5'})", file=sys.stderr)
        return EXIT_FAILED
    if not args.quiet:
        for line in out["report"]:
            print(line)
        print(f"wrote {out['results']}, {out['summary']}, " + ", ".join(str(p) for p in out["figures"]))
    return 0


def _threads_argument(text):
    """``--threads``: "auto" or a positive integer (:func:`thinfilm.threads.parse_threads`)."""
    from thinfilm.threads import parse_threads

    value = parse_threads(text)
    if value is None:
        raise argparse.ArgumentTypeError(f'{text!r}: must be "auto" or an integer >= 1')
    return value


def _overrides(args):
    """``--set KEY=VALUE`` options as scene overrides (values read as TOML)."""
    import tomllib

    out = {}
    source = getattr(args, "scene", None) or getattr(args, "scan", None) or "thinfilm"
    for item in args.overrides:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise SceneError(source, None, f"--set {item}: must be KEY=VALUE, e.g. --set model.toughness=1.5")
        try:
            out[key] = tomllib.loads(f"value = {value.strip()}")["value"]
        except tomllib.TOMLDecodeError:
            raise SceneError(source, key, f"--set {item}: the value must be a TOML value (a number, true/false,"
                             ' a "string" or an [array])') from None
    return out


def _check_size(scene, args):
    """Refuse a scene whose run cannot fit this machine (:func:`thinfilm.resources.check`)."""
    resources.check(scene, time_limit=None if args.no_time_limit else resources.TIME_LIMIT)


def _run(args):
    scene = load_scene(args.scene, overrides=_overrides(args))
    _check_size(scene, args)
    outdir = Path(args.out) if args.out else default_outdir(args.scene)
    if outdir.exists() and not outdir.is_dir():
        raise SceneError(args.scene, None, f"output path {outdir} exists and is not a directory (use --out DIR)")
    if args.resume and args.force:
        raise SceneError(args.scene, None, "--resume and --force exclude each other")
    if args.resume and not kinds.get(scene.kind).resumable:
        raise SceneError(args.scene, None, f'--resume: runs of kind "{scene.kind}" cannot be resumed (they are'
                         " computed in one go)")
    existing = [p.name for p in (outdir / "results.h5", outdir / "summary.json") if p.exists()]
    if existing and not args.resume and not args.force:
        raise SceneError(args.scene, None, f"output directory {outdir} already holds {', '.join(existing)};"
                         " use --resume to continue the run or --force to overwrite it")
    # --resume without results yet starts the run from its beginning.
    return _run_scene(scene, outdir, args, resume=args.resume and (outdir / "results.h5").exists())


def _compare(args):
    scene = load_scene(args.scene, overrides=_overrides(args))
    kind = kinds.get(scene.kind)
    if not callable(getattr(kind, "compare", None)):
        raise SceneError(args.scene, "model.kind", f'= "{scene.kind}": compare needs a kind with an exact'
                         ' counterpart ("plate")')
    check = getattr(kind, "check_compare", None)
    if callable(check):
        check(scene)
    outdir = Path(args.out) if args.out else default_outdir(args.scene)
    results = outdir / "results.h5"
    if not results.exists():
        _check_size(scene, args)
        status = _run_scene(scene, outdir, args)
        if status:
            return status
    paths, lines = kind.compare(results, outdir)
    if not args.quiet:
        for line in lines:
            print(line)
        print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _inspect_error(err):
    """One line on stderr for a results file that cannot be read; the exit status."""
    print(f"thinfilm: error: {err}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _plot(args):
    """``thinfilm plot RESULTS.h5``: redraw every figure from the file alone."""
    import math

    from thinfilm.plots import plot_results
    from thinfilm.results.reader import ResultsError
    from thinfilm.run import EvolutionKind

    if args.t is not None and not all(math.isfinite(t) for t in args.t):
        return _inspect_error(f"--t {' '.join(map(str, args.t))}: loads must be finite numbers")
    try:
        outdir = Path(args.out) if args.out else None
        if outdir is not None and outdir.exists() and not outdir.is_dir():
            return _inspect_error(f"--out {outdir}: exists and is not a directory")
        kind, paths = plot_results(args.results, outdir, loads=args.t, animate=args.animate)
    except (ResultsError, OSError) as err:
        return _inspect_error(err)
    if not isinstance(kinds.get(kind), EvolutionKind) and (args.t or args.animate):
        print(f"thinfilm: warning: --t and --animate do not apply to {kind} runs", file=sys.stderr)
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def _info(args):
    """``thinfilm info RESULTS.h5``: scene, versions, progress, last energies, timings."""
    from thinfilm.results.info import describe
    from thinfilm.results.reader import ResultsError

    try:
        print(describe(args.results))
    except (ResultsError, OSError) as err:
        return _inspect_error(err)
    return 0


def _scan(args):
    """``thinfilm scan SCAN.toml``: every run of a parameter scan on Dask, one table and figure;
    ``thinfilm scan --collect DIR``: the table and figure rebuilt from a scan directory."""
    from thinfilm.scan.plan import ScanError, load_plan
    from thinfilm.scan.table import TableError, collect

    if args.collect is not None:
        if args.scan is not None or args.resume or args.force or args.workers or args.scheduler or args.overrides:
            raise ScanError(args.collect, None, "--collect DIR reads a scan directory alone: give no scan file"
                            " and none of --resume, --force, --workers, --scheduler, --set")
        try:
            table, figure, counts = collect(args.collect)
        except TableError as err:
            return _inspect_error(err)
        return _scan_report(args, table, figure, counts)
    if args.scan is None:
        raise ScanError("thinfilm scan", None, "give a scan file (thinfilm scan SCAN.toml) or --collect DIR")
    if args.resume and args.force:
        raise ScanError(args.scan, None, "--resume and --force exclude each other")
    if args.workers is not None and args.scheduler:
        raise ScanError(args.scan, None, f"--workers {args.workers}: applies to the local cluster; with"
                        " --scheduler the cluster's own workers run the scan")
    if args.workers is not None and args.workers < 1:
        raise ScanError(args.scan, None, f"--workers {args.workers}: must be an integer >= 1")
    # every run's scene validated, and checked against this machine unless another cluster
    # runs them: nothing starts on a bad one
    check = None if args.scheduler else (lambda scene: _check_size(scene, args))
    if args.max_runs is not None and args.max_runs < 1:
        raise ScanError(args.scan, None, f"--max-runs {args.max_runs}: must be an integer >= 1")
    plan = load_plan(args.scan, _overrides(args), check=check, max_runs=args.max_runs)
    outdir = Path(args.out) if args.out else default_outdir(args.scan)
    if outdir.exists() and not outdir.is_dir():
        raise ScanError(args.scan, None, f"output path {outdir} exists and is not a directory (use --out DIR)")
    if (outdir / "scan.json").exists() and not args.resume and not args.force:
        raise ScanError(args.scan, None, f"output directory {outdir} already holds a scan; use --resume to"
                        " continue it or --force to run it again from nothing")
    from thinfilm.scan.execute import connect, execute

    client = None
    if args.scheduler:  # the cluster must answer before anything is written
        try:
            client = connect(args.scheduler)
        except (ValueError, OSError) as err:
            raise ScanError(args.scan, None, f"--scheduler {args.scheduler}: {err}") from None
    with tqdm(total=len(plan.runs), desc=Path(args.scan).stem, unit="run", disable=True if args.quiet else None,
              file=sys.stderr) as bar:
        try:
            table, figure, counts = execute(plan, outdir, client=client, workers=args.workers,
                                            resume=args.resume, progress=lambda record: bar.update())
        except OSError as err:  # no scheduler at that address, for one
            print(f"thinfilm: error: {args.scan}: the Dask cluster failed: {err}", file=sys.stderr)
            return EXIT_FAILED
        except KeyboardInterrupt:
            print(f"thinfilm: interrupted; the finished runs and steps are kept in {outdir}; continue with:"
                  f" thinfilm scan {args.scan} --resume" + (f" --out {args.out}" if args.out else "")
                  + "".join(f" --set '{item}'" for item in args.overrides),
                  file=sys.stderr)
            return EXIT_INTERRUPTED
        finally:
            if client is not None:
                client.close()
    return _scan_report(args, table, figure, counts)


def _scan_report(args, table, figure, counts):
    """The scan's last lines; exit status 1 if any run failed or is not finished."""
    total = sum(counts.values())
    if not args.quiet:
        print(f"{total} runs: " + ", ".join(f"{n} {status}" for status, n in sorted(counts.items())))
        print(f"wrote {table}" + (f", {figure}" if figure else ""))
    return 0 if counts.get("done", 0) == total else EXIT_FAILED


def _add_inspect_commands(sub):
    """The subcommands that work from a results file alone: ``plot`` and ``info``."""
    plot = sub.add_parser("plot", help="redraw every figure (and results.xdmf) from a results.h5 alone")
    plot.add_argument("results", help="results.h5 of a run (or its run directory)")
    plot.add_argument("--t", metavar="T", type=float, nargs="+",
                      help="loads of the snapshot figures (nearest finished steps; default: 5 spread evenly)")
    plot.add_argument("--out", metavar="DIR", help="output directory (default: beside the results file)")
    plot.add_argument("--animate", action="store_true", help="also write alpha.gif, the damage over the load")
    plot.set_defaults(func=_plot)
    info = sub.add_parser("info", help="print a results.h5's scene, versions, progress, energies and timings")
    info.add_argument("results", help="results.h5 of a run (or its run directory)")
    info.set_defaults(func=_info)


def build_parser():
    """The argument parser (exposed for documentation and tests)."""
    parser = argparse.ArgumentParser(
        prog="thinfilm",
        description="Variational fracture of brittle thin films: run a scene file.",
    )
    parser.add_argument("--version", action="version", version=f"thinfilm {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    run = sub.add_parser("run", help="run a scene and write results.h5, summary.json and figures")
    run.add_argument("scene", help="scene file (TOML)")
    run.add_argument("--out", metavar="DIR", help="output directory (default: next to the scene, named after it)")
    run.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    run.add_argument("--resume", action="store_true",
                     help="continue the run in the output directory from its last finished step")
    run.add_argument("--force", action="store_true", help="overwrite results already in the output directory")
    run.add_argument("--no-time-limit", action="store_true",
                     help="run a scene estimated to take longer than an hour (memory stays limited to what the"
                          " machine has)")
    run.add_argument("--threads", metavar="N", type=_threads_argument,
                     help='threads of MKL (PARDISO), OpenMP and Numba: "auto" (the cores other processes leave'
                          ' idle, measured at each step) or a number; overrides [solver] threads')
    run.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides",
                     help="set a scene key for this run, the value in TOML (e.g. --set model.toughness=1.5"
                          " --set 'domain.cells=[200, 200]'); stored with the results, and needed again to"
                          " --resume")
    run.set_defaults(func=_run)
    cmp_ = sub.add_parser("compare", help="run a plate scene (unless its results exist) and draw it against the exact 1D evolution")
    cmp_.add_argument("scene", help="plate scene file (TOML)")
    cmp_.add_argument("--out", metavar="DIR", help="output directory (default: next to the scene, named after it)")
    cmp_.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    cmp_.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides",
                      help="set a scene key, as for run")
    cmp_.add_argument("--no-time-limit", action="store_true", help="as for run")
    cmp_.add_argument("--threads", metavar="N", type=_threads_argument, help="as for run")
    cmp_.set_defaults(func=_compare)
    _add_inspect_commands(sub)
    scan = sub.add_parser("scan", help="run a parameter scan (a base scene, keys varied) on Dask and tabulate it",
                          description="Run every scene of a scan file on a Dask cluster (local worker processes"
                          " by default) and write DIR/scan.csv, DIR/scan.png and one directory per run"
                          " (docs/scans.md).")
    scan.add_argument("scan", nargs="?", help="scan file (TOML)")
    scan.add_argument("--out", metavar="DIR", help="scan directory (default: next to the scan file, named after it)")
    scan.add_argument("--workers", metavar="N", type=int,
                      help="local worker processes, one thread each (default: the machine's cores)")
    scan.add_argument("--scheduler", metavar="ADDRESS",
                      help="submit to a running Dask scheduler (e.g. tcp://host:8786) instead of a local cluster")
    scan.add_argument("--resume", action="store_true",
                      help="keep the finished runs of DIR and continue the unfinished ones from their last step")
    scan.add_argument("--force", action="store_true", help="run every run again from nothing, overwriting DIR's runs")
    scan.add_argument("--collect", metavar="DIR", help="rebuild DIR/scan.csv and scan.png from the runs' files;"
                      " run nothing")
    scan.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides",
                      help="set a scene key in every run, as [set] does (value in TOML); repeatable. Give the"
                      " same --set to --resume")
    scan.add_argument("--no-time-limit", action="store_true",
                      help="run scenes estimated to take longer than an hour each (memory stays limited)")
    scan.add_argument("--max-runs", metavar="N", type=int,
                      help="allow a scan of more than N runs (default: 10000; every run is validated before any"
                      " starts)")
    scan.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    scan.set_defaults(func=_scan)
    return parser


class _LogFormat(logging.Formatter):
    def format(self, record):
        prefix = "thinfilm: warning: " if record.levelno >= logging.WARNING else "thinfilm: "
        return prefix + record.getMessage()


def _configure_log(quiet):
    """Warnings always go to stderr; the run log's information lines unless ``--quiet``."""
    logger = logging.getLogger("thinfilm")
    logger.handlers.clear()
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_LogFormat())
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.INFO)
    logger.propagate = False


def main(argv=None):
    """Entry point of the ``thinfilm`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    _configure_log(quiet=getattr(args, "quiet", False))
    try:
        return args.func(args)
    except SceneError as err:
        print(f"thinfilm: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:  # outside an evolution (which saves its steps itself): nothing to save
        print("thinfilm: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
