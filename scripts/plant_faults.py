"""Planted-fault harness: does the test suite catch each named semantic bug of scripts/fault_catalog.py?

For every fault: copy the repo (manipdyn/, tests/, urdf/, scripts/, pyproject.toml) to a temporary
directory, apply the fault there (one exact text replacement), and run pytest in the copy with PYTHONPATH =
the copy: the fault's relevant tests first, then, if they all pass, the rest of the suite. A fault is
*caught* when some test fails (the first failing test is reported), *missed* when the whole suite passes.

Compiled code: each worker (``--jobs``) copies into its own folder, the same path fault after fault, with its
own numba cache (NUMBA_CACHE_DIR; no __pycache__ is copied). The cache is keyed by a hash of every kernel
source (``manipdyn/_jit.py``), so a fault in a kernel source compiles afresh into a folder of its own (removed
after the fault), and a fault anywhere else loads the unchanged kernels the worker compiled before — never a
stale kernel, and minutes less per fault.

    python scripts/plant_faults.py --list
    python scripts/plant_faults.py --only spm-eq59a-drop-term integrate-explicit-euler
    python scripts/plant_faults.py --rotate 3                 # CI: 3 faults chosen by the day of the year
    python scripts/plant_faults.py --jobs 2 --report docs/faults/report.md

Exit code: 0 when every fault run was caught, 1 when one was missed (or timed out), 2 on bad usage (unknown fault name,
or a fault whose snippet no longer matches its file exactly once: the message names the fault).
"""
from __future__ import annotations

import argparse
import datetime as _dt
import json
import os
import queue
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from fault_catalog import AREAS, FAULTS, Fault, by_name  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
COPIED = ("manipdyn", "tests", "urdf", "scripts", "pyproject.toml")
SELF_TEST = "tests/unit/test_fault_harness.py"        # never run inside a faulty copy (it would recurse)
_IGNORE = shutil.ignore_patterns("__pycache__", "*.pyc", "*.nbi", "*.nbc", "*.egg-info", ".pytest_cache",
                                 "test-artifacts")
_FIRST_FAIL = re.compile(r"^(FAILED|ERROR) (\S+)", re.M)


class UsageError(Exception):
    """Bad usage: unknown fault, stale snippet, missing test path (exit code 2)."""


@dataclass
class Outcome:
    """What one fault run found: status "caught" / "missed" / "timeout" / "error", the first failing test,
    the phase that caught it, seconds."""
    name: str
    area: str
    file: str
    status: str
    caught_by: str
    phase: str            # "relevant", "rest" or "" (missed / error)
    seconds: float
    detail: str = ""


def check_faults(faults, root=ROOT):
    """Problems (list of str, each naming a fault) with the catalogue against the sources under root."""
    problems, seen = [], set()
    for f in faults:
        if f.name in seen:
            problems.append(f"fault {f.name!r}: duplicate name")
        seen.add(f.name)
        path = root / f.file
        if not path.is_file():
            problems.append(f"fault {f.name!r}: file {f.file} does not exist")
            continue
        n = path.read_text(encoding="utf-8").count(f.old)
        if n != 1:
            problems.append(f"fault {f.name!r}: snippet {f.old!r} occurs {n} times in {f.file} (expected once); "
                            f"update the fault to the current code")
        if f.old == f.new:
            problems.append(f"fault {f.name!r}: old and new snippets are the same")
        if f.area not in AREAS:
            problems.append(f"fault {f.name!r}: unknown area {f.area!r}")
        for t in f.relevant:
            if not (root / t.split("::")[0]).exists():
                problems.append(f"fault {f.name!r}: test path {t} does not exist")
    return problems


def make_copy(dest: Path, root=ROOT) -> Path:
    """Copy what the suite needs into dest (no caches, no build artefacts); returns dest."""
    for name in COPIED:
        src = root / name
        if src.is_dir():
            shutil.copytree(src, dest / name, ignore=_IGNORE)
        elif src.is_file():
            shutil.copy2(src, dest / name)
    for cache in dest.rglob("__pycache__"):          # belt and braces: no stale bytecode or numba index
        shutil.rmtree(cache, ignore_errors=True)
    return dest


def apply_fault(fault: Fault, copy_root: Path):
    """Replace the fault's snippet in the copy; UsageError unless it occurs exactly once."""
    path = copy_root / fault.file
    text = path.read_text(encoding="utf-8")
    if text.count(fault.old) != 1:
        raise UsageError(f"fault {fault.name!r}: snippet occurs {text.count(fault.old)} times in {fault.file}")
    path.write_text(text.replace(fault.old, fault.new), encoding="utf-8")


def _pytest(copy_root: Path, cache: Path, args, timeout):
    """Run pytest in the copy with its own PYTHONPATH and an empty numba cache: (returncode, output)."""
    env = dict(os.environ, PYTHONPATH=str(copy_root), NUMBA_CACHE_DIR=str(cache), PYTHONDONTWRITEBYTECODE="1",
               MPLBACKEND="Agg")
    cmd = [sys.executable, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", "-rfE",
           f"--ignore={SELF_TEST}", *args]
    try:
        p = subprocess.run(cmd, cwd=copy_root, env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired as exc:
        out = (exc.stdout or b"").decode() if isinstance(exc.stdout, bytes) else (exc.stdout or "")
        return None, out
    return p.returncode, p.stdout + p.stderr


def _first_failure(out: str) -> str:
    m = _FIRST_FAIL.search(out)
    return m.group(2) if m else "(pytest reported a failure; no test id found)"


REST_WORKERS = int(os.environ.get("PLANT_FAULTS_REST_WORKERS", "2"))   # pytest-xdist workers for the rest phase


def _rest_args(relevant):
    """pytest arguments for 'the suite without the relevant paths already run'."""
    args = ["tests"]
    for t in relevant:
        args.append(f"--deselect={t}" if "::" in t else f"--ignore={t}")
    return args


def _kernel_cache_folder(root=ROOT) -> str:
    """The numba cache folder name of the unfaulted kernel sources (manipdyn/_jit.py's key)."""
    sys.path.insert(0, str(root))
    try:
        from manipdyn._jit import source_hash
        return f"numba-{source_hash(root / 'manipdyn')[:16]}"
    finally:
        sys.path.remove(str(root))


def run_fault(fault: Fault, *, rest=True, timeout=3600.0, keep=False, root=ROOT, slot=None) -> Outcome:
    """Plant one fault in a fresh copy and run the tests; relevant paths first, then (if rest) the others.
    slot: a worker's folder, whose copy path and numba cache (kernels of the unfaulted sources) the worker's
    faults share (module docstring); None: a temporary folder and an empty cache."""
    t0 = time.perf_counter()
    tmp = Path(tempfile.mkdtemp(prefix=f"fault-{fault.name}-")) if slot is None else slot
    try:
        shutil.rmtree(tmp / "repo", ignore_errors=True)
        copy_root, cache = make_copy(tmp / "repo", root), tmp / "numba-cache"
        cache.mkdir(exist_ok=True)
        apply_fault(fault, copy_root)
        rest_args = _rest_args(fault.relevant) + (["-n", str(REST_WORKERS)] if REST_WORKERS > 1 else [])
        phases = [("relevant", list(fault.relevant))] + ([("rest", rest_args)] if rest else [])
        for phase, args in phases:
            left = timeout - (time.perf_counter() - t0)
            code, out = _pytest(copy_root, cache, args, max(left, 1.0))
            secs = time.perf_counter() - t0
            if code is None:                          # undecided: neither caught nor shown to be missed
                return Outcome(fault.name, fault.area, fault.file, "timeout", f"no failure within {timeout:.0f} s",
                               phase, secs, "the suite hung or ran past the timeout under this fault")
            # 1: a test failed; 2: collection broke under the fault; 4: ditto, when a node id was asked for
            if code in (1, 2) or (code == 4 and _FIRST_FAIL.search(out)):
                return Outcome(fault.name, fault.area, fault.file, "caught", _first_failure(out), phase, secs)
            if code not in (0, 5):                    # 5: nothing collected in this phase
                return Outcome(fault.name, fault.area, fault.file, "error", f"pytest exit code {code}", phase,
                               secs, out[-2000:])
        return Outcome(fault.name, fault.area, fault.file, "missed", "", "", time.perf_counter() - t0)
    finally:
        if keep:
            print(f"  kept copy of {fault.name} at {tmp}", file=sys.stderr)
        elif slot is None:
            shutil.rmtree(tmp, ignore_errors=True)
        else:                                         # keep only the unfaulted kernels' cache
            keep_folder = _kernel_cache_folder(root)
            for d in (tmp / "numba-cache").glob("numba-*"):
                if d.name != keep_folder:
                    shutil.rmtree(d, ignore_errors=True)


def rotation(k: int, seed=None, faults=FAULTS):
    """A deterministic handful: k faults from a fixed shuffle, window chosen by seed (default: day of year).

    Consecutive days take consecutive windows, so every fault comes round within ⌈n/k⌉ days."""
    order = list(faults)
    random.Random(20240601).shuffle(order)                 # fixed: mixes the areas across windows
    day = _dt.date.today().timetuple().tm_yday if seed is None else int(seed)
    start = (day * k) % len(order)
    return [order[(start + i) % len(order)] for i in range(min(k, len(order)))]


def write_report(outcomes, path: Path, meta: dict):
    """Markdown table (fault, area, caught by, seconds) with an 'N/N caught' line, and a JSON twin."""
    caught = sum(o.status == "caught" for o in outcomes)
    lines = ["# Planted-fault report", "",
             f"Generated by `python scripts/plant_faults.py {meta['argv']}` on {meta['date']} "
             f"(commit {meta['commit']}), {meta['jobs']} job(s), {meta['seconds']:.0f} s in all"
             + ("." if meta.get("complete", True) else
                f" so far: PARTIAL, {len(outcomes)} of {meta.get('planned')} faults run."), "",
             f"**{caught}/{len(outcomes)} caught**", ""]
    if "--no-rest" in meta["argv"].split():
        lines += ["Run with `--no-rest`: only each fault's relevant tests ran, so *missed* means missed by those "
                  "tests, not by the whole suite.", ""]
    lines += ["| fault | area | file | caught by | phase | seconds |", "|---|---|---|---|---|---:|"]
    for o in outcomes:
        by = f"`{o.caught_by}`" if o.status == "caught" else f"**{o.status.upper()}** {o.caught_by}".strip()
        lines.append(f"| {o.name} | {o.area} | {o.file} | {by} | {o.phase} | {o.seconds:.0f} |")
    missed = [o.name for o in outcomes if o.status != "caught"]
    lines += ["", f"{caught}/{len(outcomes)} caught" + (f"; missed: {', '.join(missed)}" if missed else ""), ""]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines), encoding="utf-8")
    path.with_suffix(".json").write_text(json.dumps({**meta, "caught": caught, "total": len(outcomes),
                                                     "faults": [asdict(o) for o in outcomes]}, indent=1) + "\n")


def _commit(root=ROOT):
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                              timeout=10).stdout.strip() or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _interrupt(signum, frame):  # noqa: ARG001
    raise KeyboardInterrupt(f"signal {signum}")


def _select(args):
    if args.only and args.rotate:
        raise UsageError("--only and --rotate are exclusive")
    if args.only:
        try:
            return by_name(args.only)
        except KeyError as exc:
            raise UsageError(str(exc.args[0])) from None
    if args.rotate:
        if args.rotate < 1:
            raise UsageError("--rotate needs K >= 1")
        return rotation(args.rotate, args.seed)
    return list(FAULTS)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--list", action="store_true", help="list the faults and exit")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="run only these faults")
    ap.add_argument("--rotate", type=int, metavar="K", help="run K faults chosen by the day of the year (or --seed)")
    ap.add_argument("--seed", type=int, help="window of --rotate (default: day of the year)")
    ap.add_argument("--jobs", type=int, default=1, help="faults run at once (default 1)")
    ap.add_argument("--no-rest", action="store_true", help="run only each fault's relevant tests")
    ap.add_argument("--timeout", type=float, default=3600.0,
                    help="seconds per fault; past it the fault is reported 'timeout' (not caught)")
    ap.add_argument("--report", type=Path, help="write a markdown report here (and a .json twin)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary copies (debugging)")
    args = ap.parse_args(argv)
    try:
        problems = check_faults(FAULTS)
        if problems:
            raise UsageError("stale or bad faults:\n  " + "\n  ".join(problems))
        if args.jobs < 1:
            raise UsageError("--jobs needs N >= 1")
        chosen = _select(args)
    except UsageError as exc:
        print(f"plant_faults: {exc}", file=sys.stderr)
        return 2
    if args.list:
        for f in chosen:
            print(f"{f.name:<42} {f.area:<12} {f.file:<36} {f.what}\n{'':<55}tests: {', '.join(f.relevant)}")
        print(f"{len(chosen)} faults")
        return 0
    t0 = time.perf_counter()
    print(f"planting {len(chosen)} fault(s), {args.jobs} at a time", flush=True)

    base = Path(tempfile.mkdtemp(prefix="plant-faults-"))
    slots = queue.Queue()
    for k in range(args.jobs):
        (base / f"worker{k}").mkdir()
        slots.put(base / f"worker{k}")

    def one(f):
        slot = slots.get()
        try:
            o = run_fault(f, rest=not args.no_rest, timeout=args.timeout, keep=args.keep, slot=slot)
        finally:
            slots.put(slot)
        print(f"{o.status:<7} {o.name:<42} {o.seconds:7.1f} s  {o.caught_by}", flush=True)
        if o.status == "error":
            print(o.detail, file=sys.stderr)
        return o

    meta = dict(argv=" ".join(sys.argv[1:] if argv is None else argv), date=_dt.date.today().isoformat(),
                commit=_commit(), jobs=args.jobs)
    done = {}

    def report(final):                         # rewritten after every fault: a long run leaves partial results
        if args.report:
            outs = [done[f.name] for f in chosen if f.name in done]
            write_report(outs, args.report, dict(meta, seconds=time.perf_counter() - t0,
                                                 complete=final, planned=len(chosen)))

    # SIGTERM stops like Ctrl-C: the running pytest is killed and the temporary copy removed (with --jobs 1)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            results = map(one, chosen) if args.jobs == 1 else pool.map(one, chosen)
            for f, o in zip(chosen, results):
                done[f.name] = o
                report(False)
    except KeyboardInterrupt:
        print(f"interrupted after {len(done)} of {len(chosen)} faults"
              + (f"; partial report in {args.report}" if args.report and done else ""), file=sys.stderr)
        return 130
    finally:
        if not args.keep:
            shutil.rmtree(base, ignore_errors=True)
    outcomes = [done[f.name] for f in chosen]
    report(True)
    secs = time.perf_counter() - t0
    caught = sum(o.status == "caught" for o in outcomes)
    print(f"{caught}/{len(outcomes)} caught in {secs:.0f} s", flush=True)
    if any(o.status == "error" for o in outcomes):
        return 2
    return 0 if caught == len(outcomes) else 1


if __name__ == "__main__":
    sys.exit(main())
