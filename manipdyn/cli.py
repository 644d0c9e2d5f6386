"""The ``manipdyn`` command: validate, inspect, export, play, example, bench, warmup.

Exit codes: 0 success, 1 a validated term failed, 2 bad input (file, URDF, arguments).
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import traceback
import warnings
from pathlib import Path

from .errors import InputError, ManipdynError, MissingExtraError
from .extras import require
from .io.trajectory import MAX_TRAJECTORY_BYTES
from .paths import bundled_dir

BUNDLED = bundled_dir()
MAX_STATES = 100_000       # validate --states: at the cap ~4 min (AAU arm), 0.6 GiB of terms (baxter, 19 joints)
MAX_SAMPLES = 10_001       # example --samples: about 2 min for the AAU arm at the cap
MAX_SEED = 2**32 - 1       # validate --seed: the range every numpy generator accepts
MAX_JOBS = 64              # validate --against --jobs: worker processes
MAX_SWEEP_FILES = 10_000   # validate --against DIR: URDF files one sweep takes

EPILOG = f"""\
exit codes:
  0  success
  1  a validated term failed (validate), or a target was missed (bench --check)
  2  bad input or usage: a bad argument, a missing or unreadable file, a URDF or trajectory manipdyn
     refuses, a missing optional package (the line gives the pip command of its extra, e.g.
     pip install "manipdyn[validate]"), an interrupted run (Ctrl-C), or an internal error; one line on stderr
     ("manipdyn <command>: error: ..."), no traceback unless --debug

limits (checked before any work starts): validate --states 1..{MAX_STATES}, --tol finite and > 0,
--seed 0..{MAX_SEED}, --jobs 1..{MAX_JOBS} (or --scheduler ADDRESS), at most {MAX_SWEEP_FILES} URDF files under
the folders of a sweep (--against with a folder, --jobs or --scheduler: --json is then a folder, created if
missing); example --samples
2..{MAX_SAMPLES}; --json / --html / --mjcf must be a writable file in
an existing folder, --out a folder (created if missing), not a file; trajectory files (play --traj)
are .csv or .npz of at most {MAX_TRAJECTORY_BYTES // 2**20} MiB.
"""


def bundled_models() -> list[Path]:
    """The chapter's models: the repository's urdf/ folder (or their installed copies)."""
    return sorted(p for p in BUNDLED.glob("*.urdf"))


def _validate(args) -> int:
    if args.against is not None:
        return _referee(args)
    if args.markdown:
        raise InputError("--markdown needs --against (the engines referee)")
    from .validation import format_report, validate
    from .validation.mimic import validate_mimic
    from .validation.reference import pin

    pin()                                 # MissingExtraError (exit 2) before any model loads
    tqdm = _progress_bar()

    if args.states is None:
        args.states = 1000
    runs = _validation_runs(args)     # every model and reference loads before the first state runs
    print(f"manipdyn validate: {len(runs)} model(s), {args.states} random states each, seed {args.seed}, "
          f"tolerance {args.tol:g} (err = max|x - y| / max(max|y|, 1))")
    reports = []
    with tqdm(total=2 * len(runs) * args.states, unit="state", disable=args.quiet or None,
              file=sys.stderr, leave=False) as bar:
        for model, ref, notes in runs:
            for note in notes:
                bar.write(f"warning: {note}", file=sys.stderr)
            check = validate_mimic if args.mimic else validate
            rep = check(model, ref, n_states=args.states, seed=args.seed, tol=args.tol, progress=bar.update)
            reports.append(rep)
            bar.write(format_report(rep))
    failed = [r.name for r in reports if not r.passed]
    print(f"\n{len(reports) - len(failed)}/{len(reports)} models pass every term"
          + (f"; FAILED: {', '.join(failed)}" if failed else ""))
    if args.json:
        Path(args.json).write_text(json.dumps([r.as_dict() for r in reports], indent=1))
    return 1 if failed else 0


class _NoBar:
    """Stands in for tqdm's bar when tqdm (the validate extra) is not installed: no bar, messages printed."""
    total = None

    def __init__(self, *args, **kw):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        pass

    def refresh(self):
        pass

    @staticmethod
    def write(s, file=None, end="\n"):
        print(s, file=file or sys.stdout, end=end)


def _progress_bar():
    """tqdm's bar class, or _NoBar without tqdm (the bar is cosmetic: validate runs the same)."""
    try:
        return require("tqdm", "validate", "manipdyn validate's progress bar").tqdm
    except MissingExtraError:
        return _NoBar


def _referee(args) -> int:
    """validate --against ENGINES: τ, M, q̈ of each engine against manipdyn, disagreements explained."""
    from .validation.adapters import parse_engines
    from .validation.referee import format_referee, referee

    engines = parse_engines(args.against)
    states = args.states if args.states is not None else 100
    if args.reference or args.lock or args.root or args.tips or args.prune or args.mimic:
        raise InputError("--against compares the file as written (fixed base, or a free-flyer root with --root-joint "
                         "free_flyer): --reference, --mimic and the reduction options do not apply")
    if args.root_joint and (args.zoo or _sweep_mode(args)):
        raise InputError("--root-joint applies to the files given; --zoo and folder sweeps load each file fixed-base")
    if args.markdown and not args.zoo and not _sweep_mode(args):
        raise InputError("--markdown writes the --against sweep summary: add --zoo, a folder or --jobs")
    if args.zoo:
        if args.urdf:
            raise InputError("--zoo --against runs over every example-robot-data URDF: give no URDF files")
        return _referee_zoo(args, engines, states)
    if _sweep_mode(args):
        return _referee_zoo(args, engines, states, given=True)
    from .io.load import robot_format
    from .io.mjcf_read import load_mjcf
    from .io.urdf import load_urdf
    reports = []
    for path in [Path(p) for p in args.urdf] or bundled_models():
        mjcf = robot_format(path) == "mjcf"             # an MJCF file (ball joints, its own free joint) as written
        if mjcf and args.root_joint:
            raise InputError(f"{path}: an MJCF file: its free joint, if any, is in the file (no --root-joint)")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_mjcf(path) if mjcf else load_urdf(path, root_joint=args.root_joint)
        rep = referee(model, path, engines, n_states=states, seed=args.seed)
        reports.append(rep)
        print(format_referee(rep))
    if args.json:
        Path(args.json).write_text(json.dumps([r.as_dict() for r in reports], indent=1, default=_jsonable))
    return 0 if all(r.explained for r in reports) else 1


def _sweep_mode(args) -> bool:
    """validate --against over folders or with --jobs: the sweep (one summary table, --json a folder)."""
    return bool(getattr(args, "against", None) and not args.zoo and
                (args.jobs is not None or args.scheduler is not None or any(Path(p).is_dir() for p in args.urdf)))


def _referee_zoo(args, engines, states, given=False) -> int:
    """validate --zoo --against (example-robot-data), or --against over the folders and files given (a folder:
    its *.urdf files) with --jobs worker processes: the summary table, --markdown, --json (given: per-file
    JSON files and summary.json in that folder)."""
    from .validation.referee_zoo import json_name, markdown, sweep, urdf_files

    def show(row):
        cells = ", ".join(f"{e} {x.get('status')}" + (f" {x['worst']:.1e}->{x['worst_neutral']:.1e}"
                                                      if x.get("worst") is not None and x.get("worst_neutral")
                                                      is not None else "")
                          for e, x in row["engines"].items())
        print(f"{row['file']}: manipdyn {'loaded' if row['manipdyn'] == 'loaded' else 'refused'}; {cells}",
              flush=True)
    kw = {}
    if given:
        paths = urdf_files(args.urdf, MAX_SWEEP_FILES)
        dirs = [Path(p) for p in args.urdf if Path(p).is_dir()]
        kw = dict(paths=paths, root=dirs[0] if len(dirs) == 1 else Path.cwd())
        where = f"the Dask scheduler at {args.scheduler}" if args.scheduler else f"{args.jobs or 1} job(s)"
        print(f"manipdyn validate --against {','.join(engines)}: {len(paths)} URDF file(s), "
              f"{where}, {states} states each, seed {args.seed}", flush=True)
    rows = sweep(engines, n_states=states, seed=args.seed, progress=show, jobs=args.jobs or 1,
                 scheduler=args.scheduler, **kw)
    md = markdown(rows, engines, states, args.seed, **(dict(
        title=", ".join(map(str, args.urdf))[:200], command="manipdyn " + " ".join(sys.argv[1:])[:400])
        if given else {}))
    print(md.split("## Causes named")[0])
    if args.markdown:
        Path(args.markdown).write_text(md, encoding="utf-8")
    if args.json and given:
        out = Path(args.json)
        for k, row in enumerate(rows):
            (out / json_name(k, row)).write_text(json.dumps(row, indent=1, default=_jsonable), encoding="utf-8")
        (out / "summary.json").write_text(json.dumps(rows, indent=1, default=_jsonable), encoding="utf-8")
        print(f"wrote {len(rows)} per-file JSON files and summary.json to {out}")
    elif args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1, default=_jsonable))
    ok = all(x.get("explained", True) for r in rows for x in r["engines"].values())
    return 0 if ok else 1


def _jsonable(x):
    """numpy scalars in JSON."""
    return float(x) if hasattr(x, "__float__") else str(x)


def _validate_paths(args) -> list[tuple]:
    """(URDF file, root_joint) for every model validate runs on: those given (or the bundled ones) with
    --root-joint, then the zoo's arms (fixed base) and floating robots (free flyer)."""
    from .validation import arm_paths, floating_paths
    paths = [(Path(p), args.root_joint) for p in args.urdf] or [(p, args.root_joint) for p in bundled_models()]
    if args.zoo:
        paths += [(p, None) for p in arm_paths()] + [(p, "free_flyer") for p in floating_paths()]
    if not paths:
        raise ManipdynError(f"no URDF given and no bundled model found in {BUNDLED}")
    return paths


def _validation_runs(args) -> list:
    """(model, reference URDF, loader warnings) per model, each model and its Pinocchio reference built."""
    from .io.urdf import load_urdf
    from .validation.mimic import MimicReference
    from .validation.reference import Reference

    if args.reference:                    # our loader first: its message is one line, urdfdom's is not
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_urdf(args.reference)
    runs = []
    for path, root_joint in _validate_paths(args):
        _check_input_file(path, "URDF")
        from .io.load import robot_format
        if robot_format(path) == "mjcf":
            raise InputError(f"{path}: an MJCF file: the term-by-term validation reads URDF files (Pinocchio's "
                             f"reference); compare an MJCF file with --against mujoco,pinocchio")
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = load_urdf(path, root_joint=root_joint, mimic=args.mimic, **reduction(args))
        ref = Path(args.reference) if args.reference else path
        try:
            (MimicReference if args.mimic else Reference)(model, ref)
        except ManipdynError:
            raise
        except Exception as exc:          # Pinocchio's parser raises bare ValueError/RuntimeError
            raise InputError(f"{ref}: Pinocchio cannot build a reference model from it: "
                             f"{_one_line(str(exc))}") from exc
        runs.append((model, ref, [str(w.message) for w in caught]))
    return runs


def add_root_joint_option(p):
    """--root-joint free_flyer: the root link is a free body (load_urdf's root_joint)."""
    p.add_argument("--root-joint", choices=["free_flyer"], default=None,
                   help="free_flyer: the root link is a free body (legged robots, humanoids, drones), joint 0 "
                        "'root_joint' with q = [x y z qx qy qz qw], as Pinocchio's JointModelFreeFlyer; "
                        "default: the root link is the fixed base")


def add_reduction_options(p):
    """--lock / --root / --tips / --prune: model only what the scene needs (manipdyn.reduce)."""
    p.add_argument("--lock", action="append", default=[], metavar="JOINT=VALUE",
                   help="hold a joint fixed at a value (repeatable); a free flyer at a pose: "
                        "root_joint=x,y,z,qx,qy,qz,qw")
    p.add_argument("--root", help="keep only chains from this link ...")
    p.add_argument("--tips", nargs="+", metavar="LINK", help="... to these links (bodies beyond merge as payload)")
    p.add_argument("--prune", action="store_true", help="drop massless moving leaves")


def reduction(args) -> dict:
    """The reduction keyword arguments of load_urdf from the CLI options."""
    locked = {}
    for item in args.lock:
        name, sep, value = item.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--lock {item!r}: expected JOINT=VALUE")
        try:                                   # a number, or a free flyer's pose x,y,z,qx,qy,qz,qw
            v = [float(x) for x in value.split(",")] if "," in value else float(value)
        except ValueError:
            raise InputError(f"--lock {item!r}: expected JOINT=VALUE with a number (a free flyer: "
                             f"JOINT=x,y,z,qx,qy,qz,qw)") from None
        if name.strip() in locked:
            raise InputError(f"--lock {item!r}: joint {name.strip()!r} is locked twice")
        locked[name.strip()] = v
    return dict(locked=locked or None, root=args.root, tips=args.tips, prune=args.prune)


def load_robot(path, args, mimic=False):
    """The model of a URDF or MJCF file (the reader chosen by the root element, io.load.robot_format) with the
    command's options: an MJCF file takes the reduction options, not --root-joint or --mimic (its free joints and
    equalities are in the file)."""
    from .io.load import robot_format
    if robot_format(path) == "mjcf":
        if getattr(args, "root_joint", None) or (mimic and args.mimic):
            raise InputError(f"{path}: an MJCF file: its free joints and joint equalities are in the file "
                             f"(no --root-joint or --mimic)")
        from .io.mjcf_read import load_mjcf
        return load_mjcf(path, asset_root=getattr(args, "asset_root", None), **reduction(args))
    if getattr(args, "asset_root", None):
        raise InputError(f"{path}: --asset-root grants an MJCF file's includes a folder tree; a URDF's meshes are "
                         f"read from --package-dir folders")
    from .io.urdf import load_urdf
    return load_urdf(path, root_joint=args.root_joint, **(dict(mimic=args.mimic) if mimic else {}), **reduction(args))


def add_asset_root_option(p):
    """--asset-root DIR: an MJCF file's includes may come from DIR's tree (load_mjcf's asset_root)."""
    p.add_argument("--asset-root", metavar="DIR",
                   help="MJCF: a folder holding the model's, whose tree <include> files may come from (suites that "
                        "share assets across folders: ../common/...); default: the model's own folder only")


def add_mimic_option(p):
    """--mimic: honour <mimic> joints (load_urdf mimic=True)."""
    p.add_argument("--mimic", action="store_true",
                   help="honour <mimic> joints: they follow their targets and carry no coordinate (load_urdf "
                        "mimic=True; Pinocchio's buildModelFromUrdf(path, mimic=True)); default: independent joints")


def _inspect(args) -> int:
    from .quirks import QUIRK_KINDS

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = load_robot(args.urdf, args, mimic=True)
    messages = [str(w.message) for w in caught]
    if args.json is not None:
        text = json.dumps(inspect_dict(model, messages), indent=1, ensure_ascii=False)
        if args.json == "-":
            print(text)
        else:
            Path(args.json).write_text(text + "\n", encoding="utf-8")
        return 0
    print(model.summary())
    kinds = [k for k in QUIRK_KINDS if any(q.kind == k for q in model.quirks)]
    if kinds:
        print("quirks (Model.quirks: what the loader noticed), per kind:")
    for kind in kinds:
        these = [q for q in model.quirks if q.kind == kind]
        print(f"  {kind} ({len(these)}): {QUIRK_KINDS[kind]}")
        for q in these[:50]:
            print(f"    {q.name}: {q.detail}")
        if len(these) > 50:
            print(f"    ... {len(these) - 50} more (--json lists all)")
    for m in messages:
        print(f"warning: {m}")
    return 0


def inspect_dict(model, warnings_seen=()) -> dict:
    """What ``inspect --json`` writes: sizes, joints in q order, closures, mimic map, quirks, notes, summary."""
    from .model import MimicModel
    from .quirks import QUIRK_KINDS
    full = model.full if isinstance(model, MimicModel) else model
    out = dict(name=full.name, source=str(full.source), root_link=full.root_link, nq=model.nq, nv=model.nv,
               floating=full.floating, joints=list(model.joint_names), v_names=list(full.v_names),
               gravity=full.gravity.tolist(), actuated=list(full.actuated), locked=dict(full.locked),
               constraints=[dict(name=c.name, type=c.type, rows=c.n_rows, source=c.source, parent_link=c.parent_link,
                                 child_link=c.child_link, **({"ratio": c.ratio} if c.type == "coupling" else {}))
                            for c in full.constraints],
               mimic=[dict(joint=j, target=t, multiplier=m, offset=o) for j, t, m, o in full.mimic],
               mimic_honoured=isinstance(model, MimicModel),
               quirks=[q.as_dict() for q in model.quirks],
               quirk_kinds={k: QUIRK_KINDS[k] for k in dict.fromkeys(q.kind for q in model.quirks)},
               notes=list(full.notes), warnings=list(warnings_seen),
               summary=model.summary())
    if isinstance(model, MimicModel):
        out["full_joints"] = list(full.joint_names)
    return out


def _export(args) -> int:
    """export URDF --mjcf OUT: the model (closures as equality constraints) as MuJoCo MJCF."""
    from .io.mjcf import to_mjcf
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = load_robot(args.urdf, args, mimic=True)
    text = to_mjcf(model)
    Path(args.mjcf).write_text(text, encoding="utf-8")
    for w in caught:
        print(f"warning: {w.message}", file=sys.stderr)
    full = getattr(model, "full", model)
    print(f"wrote {args.mjcf}: {full.njoints} bodies and joints, {len(full.constraints)} closure(s)"
          + (f", {len(full.mimic)} mimic equalit{'y' if len(full.mimic) == 1 else 'ies'}" if args.mimic else ""))
    return 0


def _play(args) -> int:
    from . import viz
    from .viz.geometry import meshcat_module, parse_package_dirs
    meshcat_module()                      # MissingExtraError (exit 2) before any work starts
    package_dirs = parse_package_dirs(args.package_dir)
    if args.html:
        out = Path(args.html)
        if out.is_dir() or not out.resolve().parent.is_dir():
            raise ManipdynError(f"--html {args.html}: not a file in an existing folder")
    with warnings.catch_warnings(record=True) as loading:             # the loader's quirks, one line each
        warnings.simplefilter("always")
        model = load_robot(args.urdf, args)
    for w in loading:
        print(f"warning: {w.message}", file=sys.stderr)
    from .io.load import robot_format
    visuals = None if robot_format(args.urdf) == "mjcf" else args.urdf     # MJCF geoms are not read for drawing
    if visuals is None:
        print("note: an MJCF file: its bodies are drawn as capsules between their joints (geoms are not drawn)",
              file=sys.stderr)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", viz.GeometryWarning)
        warnings.simplefilter("always", viz.PlaybackWarning)
        if args.traj:
            t, Q = viz.read_trajectory(args.traj, model)
            motion = dict(t=t, Q=viz.complete(model, Q) if model.constraints else Q)
        else:
            motion = viz.demo_motion(model, args.urdf)
        t = motion.pop("t")
        sc = viz.scene_for(model, visuals, t, motion.pop("Q"), show_frames=args.frames,
                           package_dirs=package_dirs, **motion)
    for w in caught:
        print(f"{'note' if issubclass(w.category, viz.PlaybackWarning) else 'warning'}: {w.message}",
              file=sys.stderr)
    for note in (sc.plots or {}).get("notes", []):
        print(f"note: {note}", file=sys.stderr)
    if args.html:
        Path(args.html).write_text(viz.scene.html(sc), encoding="utf-8")
        print(f"wrote {args.html}: {len(sc.times)} frames at {sc.fps:.4g} fps over {t[-1] - t[0]:.3g} s "
              f"(open it in a browser; {args.html}#t=1.5 opens at 1.5 s)")
        return 0
    return viz.serve(sc)


MAX_REPORT_BYTES = 16 * 2**20   # bench --from: a report.json is ~100 kB


def _warmup_progress(bar):
    """warmup's progress(done, total, seconds) moving a tqdm bar (``_progress_bar``), its total set once every
    worker has said how many calls it makes."""
    def progress(done, total, seconds):
        if total and bar.total != total:
            bar.total = total
            bar.refresh()
        bar.update(1)
    return progress


def _warmup(args) -> int:
    from .warmup import GROUPS, warmup
    with _progress_bar()(total=None, unit="call", desc="compiling the kernels", disable=None, file=sys.stderr,
                         leave=False) as bar:      # (on a terminal; none in a log)
        seconds = warmup(args.jobs, progress=_warmup_progress(bar))
    workers = min(args.jobs, len(GROUPS))
    print(f"compiled and cached every kernel in {seconds:.1f} s ({workers} worker process"
          f"{'es' if workers > 1 else ''}); later processes load them from the cache")
    return 0


def _bench(args) -> int:
    from .bench import targets
    if args.from_report is not None:
        data = _read_bench_report(args.from_report)
    else:
        from .bench import run
        data = run(args.out, quick=args.quick, progress=lambda msg: print(msg, file=sys.stderr))
        print(f"wrote {Path(args.out) / 'report.md'}, report.json and plots")
        if not args.check:
            return 0
    results = targets.evaluate(data)
    print(targets.text(results))
    return 1 if any(r.misses for r in results) else 0


def _read_bench_report(path) -> dict:
    """A report.json written by `manipdyn bench` (JSON object), size-capped; InputError otherwise."""
    path = Path(path)
    if path.stat().st_size > MAX_REPORT_BYTES:
        raise InputError(f"{path}: larger than {MAX_REPORT_BYTES // 2**20} MiB, not a bench report")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: not a bench report (invalid JSON: {exc})") from None
    if not isinstance(data, dict):
        raise InputError(f"{path}: not a bench report (a JSON {type(data).__name__}, not an object)")
    return data


def _example(args) -> int:
    out = Path(args.out)
    if args.name == "aau":
        from .examples import aau_arm as ex
        from .io.urdf import load_urdf
        require("matplotlib", "plots", ex.PLOTS)          # before the example runs
        model = load_urdf(BUNDLED / "aau_arm.urdf")
        traj, tau = ex.chapter_example(model, samples=args.samples)
        ex.write_csv(out / "aau_arm.csv", model, traj, tau)
        ex.plot(out, model, traj, tau)
        print(f"AAU arm, t in [0, 2π] s, {len(traj.t)} samples: pose error ≤ {traj.pos_err.max():.1e} m / "
              f"{traj.dir_err.max():.1e} rad, σ_min(J_task) ≥ {traj.sigma_min.min():.3f}, "
              f"|τ| ≤ {abs(tau).max():.2f} N·m with a {ex.PAYLOAD_KG:g} kg payload")
        print(f"wrote {out / 'aau_arm.csv'}, fig3_joint_rates.png, fig4_joint_torques.png")
        return 0
    if args.name == "identify":
        from .examples import identify as ex
        res = ex.identify(samples=args.samples)
        print(ex.format_result(res))
        ex.write_csv(out / "identify_aau.csv", res)
        print(f"wrote {out / 'identify_aau.csv'}")
        return 0
    from .validation import fig7
    return fig7.main(out, samples=min(args.samples, 101))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="manipdyn", description=__doc__.splitlines()[0], epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--debug", action="store_true",
                   help="show the Python traceback of an error (also accepted after the subcommand)")
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the Python traceback of an error")
    sub = p.add_subparsers(dest="command", required=True,
                           parser_class=_subparser_class(common, EPILOG))
    p.commands = sub.choices              # name -> subcommand parser (for errors in its own name)
    v = sub.add_parser("validate", help="compare every Newton-Euler term with Pinocchio")
    v.add_argument("urdf", nargs="*", help="URDF files (default: the bundled models in urdf/); with --against, "
                                           "also folders (searched for *.urdf) and MJCF files (ball joints: "
                                           "pinocchio and mujoco)")
    v.add_argument("--zoo", action="store_true",
                   help="also validate example-robot-data's arms (fixed base) and its legged robots, humanoids "
                        "and drones (free-flyer root, whatever --root-joint says)")
    v.add_argument("--states", type=_int_in(1, MAX_STATES), default=None,
                   help=f"random states per model, 1..{MAX_STATES} (default 1000; 100 with --against)")
    v.add_argument("--seed", type=_int_in(0, MAX_SEED), default=0, help=f"0..{MAX_SEED} (default 0)")
    v.add_argument("--tol", type=_positive_finite, default=1e-12,
                   help="largest error measure that passes, finite and > 0 (default 1e-12)")
    v.add_argument("--reference", help="validate against Pinocchio's model of this URDF instead")
    v.add_argument("--json", help="write the report as JSON to this file")
    v.add_argument("--against", metavar="ENGINES",
                   help="compare τ (inverse dynamics), M and q̈ (forward dynamics) with other engines instead, "
                        "comma-separated: pinocchio,mujoco,pybullet,drake (pip install manipdyn[engines]); a "
                        "missing engine is skipped with a note; each disagreement above 1e-9 is explained by "
                        "the engine's read-back link parameters and checked again with them (exit 1 if not)")
    v.add_argument("--markdown", help="with --zoo --against (or a folder, or --jobs): write the summary as "
                                      "markdown to this file")
    v.add_argument("--jobs", type=_int_in(1, MAX_JOBS), default=None,
                   help=f"with --against: run the files in 1..{MAX_JOBS} worker processes, one summary table; "
                        "URDF arguments may then be folders (their *.urdf files, at most "
                        f"{MAX_SWEEP_FILES}) and --json is a folder (one JSON file per URDF and summary.json)")
    v.add_argument("--scheduler", metavar="ADDRESS", type=_address, default=None,
                   help="with --against: send the files to the Dask scheduler at ADDRESS (e.g. tcp://host:8786) "
                        "instead of --jobs processes, the same summary and per-file JSON (pip install "
                        "manipdyn[dask]; the workers need manipdyn and the engines installed)")
    v.add_argument("--quiet", action="store_true", help="no progress bar")
    add_mimic_option(v)
    add_root_joint_option(v)
    add_reduction_options(v)
    v.set_defaults(func=_validate)
    i = sub.add_parser("inspect", help="show what the loader built from a URDF")
    i.add_argument("urdf", help="a URDF or MJCF file (the reader chosen by its root element)")
    i.add_argument("--json", nargs="?", const="-", metavar="FILE",
                   help="write what the loader built as JSON (quirks, closures, mimic map, summary) to FILE, "
                        "or to stdout without FILE")
    add_mimic_option(i)
    add_root_joint_option(i)
    add_reduction_options(i)
    add_asset_root_option(i)
    i.set_defaults(func=_inspect)
    x = sub.add_parser("export", help="write the model in another format (MuJoCo MJCF)")
    x.add_argument("urdf", help="a URDF or MJCF file (the reader chosen by its root element)")
    x.add_argument("--mjcf", required=True, metavar="FILE",
                   help="write MuJoCo MJCF to FILE (a writable file in an existing folder): merged bodies and "
                        "inertials, hinge/slide joints, closures as equality constraints (connect/weld/joint)")
    add_mimic_option(x)
    add_root_joint_option(x)
    add_reduction_options(x)
    add_asset_root_option(x)
    x.set_defaults(func=_export)
    pl = sub.add_parser("play", help="3-D playback in the browser (meshcat): live, or one HTML file")
    pl.add_argument("urdf", help="a URDF or MJCF file (the reader chosen by its root element)")
    pl.add_argument("--traj", help="CSV (t, q_<joint>...) or NPZ (t, q, joint_names); default: a built-in demo")
    pl.add_argument("--html", help="write one self-contained HTML file instead of serving live")
    pl.add_argument("--frames", action="store_true", help="draw each body's frame")
    pl.add_argument("--package-dir", action="append", default=[], metavar="NAME=DIR",
                    help="folder of package://NAME/ meshes (repeatable); meshes are read only there, in the "
                         "URDF's folder, or in an installed example-robot-data")
    add_reduction_options(pl)
    add_root_joint_option(pl)
    add_asset_root_option(pl)
    pl.set_defaults(func=_play)
    e = sub.add_parser("example", help="the chapter's examples: figures (PNG) and data (CSV)")
    e.add_argument("name", choices=["aau", "spm", "identify"],
                   help="aau: Example I (Figs. 3-4); spm: Example II (Fig. 7); identify: the AAU arm's base "
                        "parameters from noisy torques (the regressor), tested on a second trajectory")
    e.add_argument("--out", default=".", help="output folder")
    e.add_argument("--samples", type=_int_in(2, MAX_SAMPLES), default=401,
                   help=f"time samples, 2..{MAX_SAMPLES} (default 401; spm uses at most 101)")
    e.set_defaults(func=_example)
    b = sub.add_parser("bench", help="speed against error, side by side with Pinocchio")
    b.add_argument("--out", help="folder for report.md, report.json and PNG plots (required unless --from)")
    b.add_argument("--quick", action="store_true", help="fewer sizes, states and repeats (about a minute once the kernels are compiled)")
    b.add_argument("--check", action="store_true",
                   help="then check the report against the issue's targets (manipdyn/bench/targets.py): print "
                        "them, exit 1 if any is missed")
    b.add_argument("--from", dest="from_report", metavar="REPORT.json",
                   help="check this existing report.json against the targets, without running the bench "
                        "(implies --check)")
    b.set_defaults(func=_bench)
    w = sub.add_parser("warmup", help="compile every kernel into the disk cache now (the setup command runs it)")
    w.add_argument("--jobs", type=_int_in(1, MAX_JOBS), default=2,
                   help="worker processes compiling at once (default 2)")
    w.set_defaults(func=_warmup)
    return p


def _subparser_class(common, epilog):
    """ArgumentParser for the subcommands: each accepts --debug and shows the exit codes in --help."""
    class Sub(argparse.ArgumentParser):
        def __init__(self, **kw):
            super().__init__(parents=[common], epilog=epilog,
                             formatter_class=argparse.RawDescriptionHelpFormatter, **kw)
    return Sub


def _address(text):
    """An argparse type: a Dask scheduler address (1..200 printable characters, no spaces)."""
    if not 0 < len(text) <= 200 or not text.isprintable() or any(c.isspace() for c in text):
        raise argparse.ArgumentTypeError(f"expected a scheduler address such as tcp://host:8786, got {text[:60]!r}")
    return text


def _int_in(lo, hi):
    """An argparse type: an integer in [lo, hi]."""
    def integer(text):
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer in {lo}..{hi}, got {text!r}") from None
        if not lo <= value <= hi:
            raise argparse.ArgumentTypeError(f"must be in {lo}..{hi}, got {value}")
        return value
    return integer


def _positive_finite(text):
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be finite and > 0, got {text!r}")
    return value


def _check_input_file(path, what):
    """An existing, readable regular file (checked before any work starts)."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: no such {what} file")
    if path.is_dir():
        raise InputError(f"{path}: is a directory, not a {what} file")
    if not path.is_file():
        raise InputError(f"{path}: not a regular file (a {what} must be a file)")
    if not os.access(path, os.R_OK):
        raise InputError(f"{path}: {what} file is not readable (permission denied)")


def _check_output_file(path, option):
    """A file that can be written: its folder exists, it is not a folder, it opens for writing.

    A regular file is opened for appending (nothing written) and removed again if this check created it;
    a device or pipe (/dev/stdout, a FIFO) is only checked for write permission, never opened here."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{option} {path}: is a directory, not a file")
    if not path.parent.is_dir():
        raise InputError(f"{option} {path}: folder {path.parent} does not exist")
    if path.exists() and not path.is_file():
        if not os.access(path, os.W_OK):
            raise InputError(f"{option} {path}: cannot write it (permission denied)")
        return
    existed = path.exists()
    try:
        with open(path, "a"):
            pass
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot write it ({exc.strerror})") from None
    if not existed:
        path.unlink()


def _check_output_dir(path, option):
    """A folder to write into: created if missing; refused if it is a file or not writable."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{option} {path}: is a file, not a folder")
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{option} {path}: cannot create the folder ({exc.strerror})") from None
    if not os.access(path, os.W_OK | os.X_OK):
        raise InputError(f"{option} {path}: the folder is not writable")


def _preflight(args):
    """Check input files and output paths before a subcommand starts any long work."""
    if args.command == "validate" and args.jobs is not None and not args.against:
        raise InputError("--jobs needs --against (the engines referee over many files)")
    if args.command == "validate" and args.scheduler is not None and (not args.against or args.jobs is not None):
        raise InputError("--scheduler needs --against and no --jobs (the cluster's workers run the files)")
    urdf = getattr(args, "urdf", None)
    sweep = args.command == "validate" and _sweep_mode(args)
    for path in urdf if isinstance(urdf, list) else [urdf] if urdf else []:
        if not (sweep and Path(path).is_dir()):        # a sweep's folders are searched for *.urdf
            _check_input_file(path, "URDF")
    if getattr(args, "reference", None):
        _check_input_file(args.reference, "--reference URDF")
    if sweep and args.json:
        _check_output_dir(args.json, "--json")
    for option in ("json", "html", "markdown", "mjcf"):
        if option == "json" and sweep:
            continue
        if getattr(args, option, None) and not (args.command == "inspect" and getattr(args, option) == "-"):
            _check_output_file(getattr(args, option), f"--{option}")
    if getattr(args, "from_report", None) is not None:
        _check_input_file(args.from_report, "bench report")
    if getattr(args, "out", None) is not None:
        _check_output_dir(args.out, "--out")


def _usage_problem(args) -> str | None:
    """Options that do not go together (argparse cannot say it): refused with the subcommand's usage."""
    if args.command == "bench":
        if args.from_report is not None and (args.out is not None or args.quick):
            return "--from checks an existing report: --out and --quick do not apply"
        if args.from_report is None and args.out is None:
            return "--out FOLDER is required (or --from REPORT.json to check an existing report)"
    return None


def _one_line(text) -> str:
    """A message on one line (line breaks become ' | ')."""
    return " | ".join(line.strip() for line in str(text).splitlines() if line.strip()) or "(no message)"


def _os_message(exc: OSError) -> str:
    """'file: reason' for an OSError."""
    names = [f for f in (exc.filename, exc.filename2) if f is not None]
    reason = exc.strerror or str(exc)
    return f"{' -> '.join(map(str, names))}: {reason}" if names else reason


def main(argv=None) -> int:
    """Run one subcommand; return its exit code: 0 success, 1 a term failed, 2 bad input or usage."""
    parser = build_parser()
    try:
        args, extra = parser.parse_known_args(argv)
        if extra:                         # refused by the subcommand, with its usage
            parser.commands[args.command].error(f"unrecognized arguments: {' '.join(extra)}")
        if _usage_problem(args):
            parser.commands[args.command].error(_usage_problem(args))
    except SystemExit as exc:           # argparse: usage + one error line (2), or --help (0)
        return exc.code if isinstance(exc.code, int) else 0 if exc.code is None else 2
    try:
        _preflight(args)
        return args.func(args)
    except KeyboardInterrupt:
        return _fail(args, "interrupted")
    except ManipdynError as exc:
        return _fail(args, _one_line(exc))
    except BrokenPipeError:             # stdout closed early (| head): stop writing to it
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return _fail(args, "output closed (broken pipe)")
    except OSError as exc:
        return _fail(args, _one_line(_os_message(exc)))
    except Exception as exc:            # a bug: still one line and exit 2, the traceback on request
        return _fail(args, f"internal error: {type(exc).__name__}: {_one_line(exc)} "
                           "(run with --debug for the traceback)")


def _fail(args, message) -> int:
    """Print 'manipdyn <command>: error: message' (after the traceback with --debug); return 2."""
    try:
        sys.stdout.flush()
    except OSError:
        pass
    if getattr(args, "debug", False):
        traceback.print_exc()
    print(f"manipdyn {args.command}: error: {message}", file=sys.stderr)
    return 2


if __name__ == "__main__":
    sys.exit(main())
