"""The ``manipdyn`` command: validate, inspect, play, example, bench.

Exit codes: 0 success, 1 a validated term failed, 2 bad input (file, URDF, arguments).
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

from .errors import ManipdynError
from .paths import bundled_dir

BUNDLED = bundled_dir()


def bundled_models() -> list[Path]:
    """The chapter's models: the repository's urdf/ folder (or their installed copies)."""
    return sorted(p for p in BUNDLED.glob("*.urdf"))


def _validate(args) -> int:
    from tqdm import tqdm

    from .io.urdf import load_urdf
    from .validation import arm_paths, format_report, validate

    paths = [Path(p) for p in args.urdf] or bundled_models()
    if args.zoo:
        paths += arm_paths()
    if not paths:
        raise ManipdynError(f"no URDF given and no bundled model found in {BUNDLED}")
    print(f"manipdyn validate: {len(paths)} model(s), {args.states} random states each, seed {args.seed}, "
          f"tolerance {args.tol:g} (err = max|x - y| / max(max|y|, 1))")
    reports = []
    with tqdm(total=2 * len(paths) * args.states, unit="state", disable=args.quiet or None,
              file=sys.stderr, leave=False) as bar:
        for path in paths:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                model = load_urdf(path, **reduction(args))
            for w in caught:
                bar.write(f"warning: {w.message}", file=sys.stderr)
            ref = Path(args.reference) if args.reference else path
            rep = validate(model, ref, n_states=args.states, seed=args.seed, tol=args.tol,
                           progress=bar.update)
            reports.append(rep)
            bar.write(format_report(rep))
    failed = [r.name for r in reports if not r.passed]
    print(f"\n{len(reports) - len(failed)}/{len(reports)} models pass every term"
          + (f"; FAILED: {', '.join(failed)}" if failed else ""))
    if args.json:
        Path(args.json).write_text(json.dumps([r.as_dict() for r in reports], indent=1))
    return 1 if failed else 0


def add_reduction_options(p):
    """--lock / --root / --tips / --prune: model only what the scene needs (manipdyn.reduce)."""
    p.add_argument("--lock", action="append", default=[], metavar="JOINT=VALUE",
                   help="hold a joint fixed at a value (repeatable)")
    p.add_argument("--root", help="keep only chains from this link ...")
    p.add_argument("--tips", nargs="+", metavar="LINK", help="... to these links (bodies beyond merge as payload)")
    p.add_argument("--prune", action="store_true", help="drop massless moving leaves")


def reduction(args) -> dict:
    """The reduction keyword arguments of load_urdf from the CLI options."""
    locked = {}
    for item in args.lock:
        name, sep, value = item.partition("=")
        try:
            locked[name] = float(value)
        except ValueError:
            raise ManipdynError(f"--lock {item!r}: expected JOINT=VALUE with a number") from None
        if not sep:
            raise ManipdynError(f"--lock {item!r}: expected JOINT=VALUE")
    return dict(locked=locked or None, root=args.root, tips=args.tips, prune=args.prune)


def _inspect(args) -> int:
    from .io.urdf import load_urdf

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = load_urdf(args.urdf, **reduction(args))
    print(model.summary())
    for w in caught:
        print(f"warning: {w.message}")
    return 0


def _play(args) -> int:
    from . import viz
    from .io.urdf import load_urdf
    from .viz.geometry import parse_package_dirs
    package_dirs = parse_package_dirs(args.package_dir)
    if args.html:
        out = Path(args.html)
        if out.is_dir() or not out.resolve().parent.is_dir():
            raise ManipdynError(f"--html {args.html}: not a file in an existing folder")
    model = load_urdf(args.urdf, **reduction(args))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", viz.GeometryWarning)
        warnings.simplefilter("always", viz.PlaybackWarning)
        if args.traj:
            t, Q = viz.read_trajectory(args.traj, model)
            Q = viz.complete(model, Q) if model.constraints else Q
        else:
            t, Q = viz.demo(model, args.urdf)
        sc = viz.scene_for(model, args.urdf, t, Q, show_frames=args.frames, package_dirs=package_dirs)
    for w in caught:
        print(f"{'note' if issubclass(w.category, viz.PlaybackWarning) else 'warning'}: {w.message}",
              file=sys.stderr)
    if args.html:
        Path(args.html).write_text(viz.scene.html(sc), encoding="utf-8")
        print(f"wrote {args.html}: {len(sc.times)} frames at {sc.fps:.4g} fps over {t[-1] - t[0]:.3g} s "
              f"(open it in a browser; {args.html}#t=1.5 opens at 1.5 s)")
        return 0
    return viz.serve(sc)


def _bench(args) -> int:
    from .bench import run
    run(args.out, quick=args.quick, progress=lambda msg: print(msg, file=sys.stderr))
    print(f"wrote {Path(args.out) / 'report.md'}, report.json and plots")
    return 0


def _example(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.name == "aau":
        from .examples import aau_arm as ex
        from .io.urdf import load_urdf
        model = load_urdf(BUNDLED / "aau_arm.urdf")
        traj, tau = ex.chapter_example(model, samples=args.samples)
        ex.write_csv(out / "aau_arm.csv", model, traj, tau)
        ex.plot(out, model, traj, tau)
        print(f"AAU arm, t in [0, 2π] s, {len(traj.t)} samples: pose error ≤ {traj.pos_err.max():.1e} m / "
              f"{traj.dir_err.max():.1e} rad, σ_min(J_task) ≥ {traj.sigma_min.min():.3f}, "
              f"|τ| ≤ {abs(tau).max():.2f} N·m with a {ex.PAYLOAD_KG:g} kg payload")
        print(f"wrote {out / 'aau_arm.csv'}, fig3_joint_rates.png, fig4_joint_torques.png")
        return 0
    from .validation import fig7
    return fig7.main(out, samples=min(args.samples, 101))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="manipdyn", description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="command", required=True)
    v = sub.add_parser("validate", help="compare every Newton-Euler term with Pinocchio")
    v.add_argument("urdf", nargs="*", help="URDF files (default: the bundled models in urdf/)")
    v.add_argument("--zoo", action="store_true", help="also validate example-robot-data's arms")
    v.add_argument("--states", type=int, default=1000, help="random states per model (default 1000)")
    v.add_argument("--seed", type=int, default=0)
    v.add_argument("--tol", type=float, default=1e-12)
    v.add_argument("--reference", help="validate against Pinocchio's model of this URDF instead")
    v.add_argument("--json", help="write the report as JSON to this file")
    v.add_argument("--quiet", action="store_true", help="no progress bar")
    add_reduction_options(v)
    v.set_defaults(func=_validate)
    i = sub.add_parser("inspect", help="show what the loader built from a URDF")
    i.add_argument("urdf")
    add_reduction_options(i)
    i.set_defaults(func=_inspect)
    pl = sub.add_parser("play", help="3-D playback in the browser (meshcat): live, or one HTML file")
    pl.add_argument("urdf")
    pl.add_argument("--traj", help="CSV (t, q_<joint>...) or NPZ (t, q, joint_names); default: a built-in demo")
    pl.add_argument("--html", help="write one self-contained HTML file instead of serving live")
    pl.add_argument("--frames", action="store_true", help="draw each body's frame")
    pl.add_argument("--package-dir", action="append", default=[], metavar="NAME=DIR",
                    help="folder of package://NAME/ meshes (repeatable); meshes are read only there, in the "
                         "URDF's folder, or in an installed example-robot-data")
    add_reduction_options(pl)
    pl.set_defaults(func=_play)
    e = sub.add_parser("example", help="the chapter's examples: figures (PNG) and data (CSV)")
    e.add_argument("name", choices=["aau", "spm"], help="aau: Example I (Figs. 3-4); spm: Example II (Fig. 7)")
    e.add_argument("--out", default=".", help="output folder")
    e.add_argument("--samples", type=int, default=401)
    e.set_defaults(func=_example)
    b = sub.add_parser("bench", help="speed against error, side by side with Pinocchio")
    b.add_argument("--out", required=True, help="folder for report.md, report.json and PNG plots")
    b.add_argument("--quick", action="store_true", help="fewer sizes and repeats (about a minute)")
    b.set_defaults(func=_bench)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ManipdynError as exc:
        print(f"manipdyn {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
