"""The command line: ``thinfilm run SCENE.toml [--out DIR] [--quiet]``.

Library code raises exceptions; only this module turns them into messages and exit codes.
A bad scene is reported in one line on stderr with exit status 2, before anything is
computed or written.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

from tqdm import tqdm

from thinfilm import __version__
from thinfilm.scene import SceneError, load_scene

EXIT_BAD_INPUT = 2


def default_outdir(scene_path):
    """Output directory next to the scene, named after it: ``cases/fig2_15.toml -> cases/fig2_15``."""
    scene_path = Path(scene_path)
    return scene_path.with_suffix("") if scene_path.suffix else scene_path.with_name(scene_path.name + "_out")


def _run(args):
    scene = load_scene(args.scene)
    outdir = Path(args.out) if args.out else default_outdir(args.scene)
    if outdir.exists() and not outdir.is_dir():
        raise SceneError(args.scene, None, f"output path {outdir} exists and is not a directory (use --out DIR)")

    if scene.kind == "plate":
        return _run_plate(scene, outdir, args)

    # Imported here so that argument and scene errors are reported without loading the
    # numerical stack.
    from thinfilm.exact import run_exact1d
    from thinfilm.io import write_exact1d
    from thinfilm.plots import plot_exact1d

    with tqdm(total=scene.load.steps + 1, desc=Path(args.scene).stem, unit="step",
              disable=True if args.quiet else None, file=sys.stderr) as bar:
        tracks = run_exact1d(scene, progress=bar.update)
    results, summary = write_exact1d(outdir, scene, tracks)
    figures = plot_exact1d(results, outdir)
    if not args.quiet:
        for event in tracks["refined"].events:
            cracks = ", ".join(f"{c:+.5f}" for c in event.cracks)
            print(f"t = {event.t:.8g}: {len(event.cracks)} crack(s) at {cracks}")
        print(f"wrote {results}, {summary}, " + ", ".join(str(p) for p in figures))
    return 0


def _run_plate(scene, outdir, args):
    from thinfilm.run import run_plate

    with tqdm(total=scene.load.steps + 1, desc=Path(args.scene).stem, unit="step",
              disable=True if args.quiet else None, file=sys.stderr) as bar:
        out = run_plate(scene, outdir, progress=bar.update)
    if not args.quiet:
        for t, cracks in out["events"]:
            print(f"t = {t:.6g}: {len(cracks)} crack(s) along y = 0 at " + ", ".join(f"{c:+.4f}" for c in cracks))
        print(f"wrote {out['results']}, {out['summary']}, " + ", ".join(str(p) for p in out["figures"]))
    return 0


def _compare(args):
    scene = load_scene(args.scene)
    if scene.kind != "plate":
        raise SceneError(args.scene, "model.kind", f'= "{scene.kind}": compare needs a "plate" scene')
    outdir = Path(args.out) if args.out else default_outdir(args.scene)
    results = outdir / "results.h5"
    if not results.exists():
        _run_plate(scene, outdir, args)
    from thinfilm.compare import compare

    figure, report = compare(results, outdir)
    if not args.quiet:
        import json

        for e in json.loads(report.read_text())["events"]:
            reg = "not reached" if e["regularized_t"] is None else f"t = {e['regularized_t']:.4g}"
            print(f"exact t = {e['exact_t']:.4f} ({len(e['exact_cracks'])} cracks); regularized: {reg}")
        print(f"wrote {figure}, {report}")
    return 0


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
    run.set_defaults(func=_run)
    cmp_ = sub.add_parser("compare", help="run a plate scene (unless its results exist) and draw it against the exact 1D evolution")
    cmp_.add_argument("scene", help="plate scene file (TOML)")
    cmp_.add_argument("--out", metavar="DIR", help="output directory (default: next to the scene, named after it)")
    cmp_.add_argument("--quiet", action="store_true", help="no progress bar and no report")
    cmp_.set_defaults(func=_compare)
    return parser


def main(argv=None):
    """Entry point of the ``thinfilm`` console script; returns the exit status."""
    args = build_parser().parse_args(argv)
    logging.basicConfig(format="thinfilm: warning: %(message)s", level=logging.WARNING)
    try:
        return args.func(args)
    except SceneError as err:
        print(f"thinfilm: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
