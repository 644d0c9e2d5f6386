"""The engines referee over many URDFs: every file example-robot-data ships (``--zoo``), or the *.urdf files of
folders and files given (``manipdyn validate DIR --against ... --jobs N``), fixed base, root welded.

For each file: does manipdyn load it (or why not), does each engine load it (or why not), each engine's worst
error against manipdyn and the named causes, and whether the disagreement vanishes once neutralised. The
markdown summary is docs/referee/zoo.md (``manipdyn validate --zoo --against mujoco,pybullet --markdown``).
"""
from __future__ import annotations

import multiprocessing
import os
import re
import tempfile
import warnings
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from pathlib import Path

from ..errors import InputError, ManipdynError
from ..extras import require
from .adapters import ADAPTERS, EngineMissing, EngineRefused, _import, _one_line, available
from .referee import _quiet, referee
from .referee_urdf import stripped_urdf
from .zoo import robots_dir


def zoo_urdfs() -> list[Path]:
    """Every .urdf file under example-robot-data's robots/ folder, sorted."""
    return sorted(robots_dir().rglob("*.urdf"))


MAX_FILES = 10_000        # URDF files one sweep takes (a folder is searched no further)
MAX_JOBS = 64             # worker processes


def urdf_files(items, limit=MAX_FILES) -> list[Path]:
    """The files given and the *.urdf files under the folders given (sorted per folder, symlinked folders not
    followed), at most ``limit``; InputError names a missing path, an empty folder or too many files."""
    out = []
    for item in map(Path, items):
        if item.is_dir():
            found = []
            for top, dirs, files in os.walk(item, followlinks=False):
                dirs.sort()
                found += [Path(top) / f for f in sorted(files) if f.lower().endswith(".urdf")
                          and (Path(top) / f).is_file()]
                if len(out) + len(found) > limit:
                    raise InputError(f"{item}: more than {limit} URDF files; give fewer folders or files")
            if not found:
                raise InputError(f"{item}: folder holds no *.urdf file")
            out += found
        elif item.is_file():
            out.append(item)
        else:
            raise InputError(f"{item}: no such URDF file or folder")
        if len(out) > limit:
            raise InputError(f"more than {limit} URDF files; give fewer folders or files")
    return out


def json_name(k, row) -> str:
    """A safe file name for row k's JSON (the URDF's path with every other character than [A-Za-z0-9._-]
    replaced: names on disk are untrusted)."""
    return f"{k:04d}_{re.sub(r'[^A-Za-z0-9._-]', '_', row['file'])[-120:]}.json"


def engine_loads(name, path) -> tuple:
    """(True, "") when the engine loads the file at all (fixed base), else (False, its message); None if
    the engine is not installed. Used when manipdyn itself refuses the file."""
    if not available(name):
        return None
    try:
        with _quiet(), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            _load_only(name, path)
        return True, ""
    except Exception as exc:
        return False, _one_line(exc)


def _load_only(name, path):
    text = stripped_urdf(path)
    if name == "pinocchio":
        _import("pinocchio").buildModelFromUrdf(str(path))
    elif name == "mujoco":
        import re

        from .adapters import MUJOCO_COMPILER
        mujoco = _import("mujoco")
        text = re.sub(r"<mujoco\b.*?</mujoco\s*>", "", text, flags=re.S)
        before = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(lambda msg: None)      # no ./MUJOCO_LOG.TXT
        try:
            mujoco.MjModel.from_xml_string(re.sub(r"</robot\s*>\s*$", MUJOCO_COMPILER + "</robot>", text.rstrip()))
        finally:
            mujoco.set_mju_user_warning(before)
    elif name == "pybullet":
        p = _import("pybullet")
        cid = p.connect(p.DIRECT)
        try:
            with tempfile.TemporaryDirectory() as tmp:
                f = Path(tmp) / Path(path).name
                f.write_text(text, encoding="utf-8")
                p.loadURDF(str(f), useFixedBase=True, flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=cid)
        finally:
            p.disconnect(cid)
    elif name == "drake":
        _import("pydrake")
        from pydrake.multibody.parsing import Parser
        from pydrake.multibody.plant import MultibodyPlant
        plant = MultibodyPlant(0.0)
        Parser(plant).AddModelsFromString(text, "urdf")
        plant.Finalize()


def sweep(engines, *, n_states=20, seed=0, paths=None, progress=None, jobs=1, root=None, scheduler=None) -> list[dict]:
    """One row per file, in the order given: {"file", "nv", "manipdyn": "loaded" | why, "engines": {name: result
    dict}}; ``jobs`` > 1 runs the files in that many worker processes (spawned: each compiles its kernels);
    ``scheduler`` (an address) sends them to a Dask cluster's workers instead (the Dask extra), the same rows.
    File names in rows and messages are shown relative to ``root`` (default: example-robot-data's robots/)."""
    root = Path(root) if root is not None else robots_dir()
    paths = list(paths if paths is not None else zoo_urdfs())
    jobs = max(1, min(int(jobs), MAX_JOBS, len(paths) or 1))
    work = [(p, tuple(engines), n_states, seed, root) for p in paths]
    rows = []
    if scheduler is not None:
        for row in _on_cluster(scheduler, work):
            rows.append(row)
            if progress is not None:
                progress(row)
        return rows
    if jobs == 1:
        results = map(_row_of, work)
        for row in results:
            rows.append(row)
            if progress is not None:
                progress(row)
        return rows
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        for row in pool.map(_row_of, work):
            rows.append(row)
            if progress is not None:
                progress(row)
    return rows


SCHEDULER_TIMEOUT = 10    # seconds to reach a Dask scheduler, and for its first message
HANDSHAKE_BYTES = 1 << 16     # the most a scheduler's first message may announce (its handshake: ~100 bytes)
REPLY_BYTES = 1 << 28         # the most any later message from the cluster may announce (a row: a few kB)


def _size(n):
    """n bytes in words: '3.07 EiB'."""
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if n < 1024 or unit == "EiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{n} B"
        n /= 1024


def probe_scheduler(address, timeout=None):
    """Raise InputError (one line) unless a Dask scheduler answers at ``address`` — before anything is sent there.

    A Dask scheduler writes its handshake as soon as a client connects: 8 bytes giving the length of what follows,
    then a msgpack map naming the pickle protocol. Dask's own client first writes its handshake and then trusts
    the length it reads, so another service (an HTTP server answers "HTTP/1.1 400…", read as 3.07 EiB) ends in a
    MemoryError, and a hostile one could announce a few gigabytes that Dask then allocates. Here the first message
    is read by hand, its length bounded (``HANDSHAKE_BYTES``), its content checked. Addresses of another scheme
    than tcp:// (tls://, ws://, inproc://, ucx://) are not probed; every TCP or TLS read then stays bounded by
    ``_bounded_reads``."""
    import socket
    import struct

    from distributed.comm.addressing import parse_address, parse_host_port
    timeout = SCHEDULER_TIMEOUT if timeout is None else timeout
    try:
        scheme, loc = parse_address(address)
        if scheme != "tcp":
            return
        host, port = parse_host_port(loc)
    except (ValueError, TypeError) as exc:
        raise InputError(f"--scheduler {address}: not a Dask address ({_one_line(exc)})") from None
    head = f"--scheduler {address}:"
    try:
        with socket.create_connection((host, port), timeout=timeout) as sock:
            sock.settimeout(timeout)
            header = _read_exactly(sock, 8)
            (n,) = struct.unpack("<Q", header)
            if n > HANDSHAKE_BYTES:
                raise InputError(f"{head} the service there announced a first message of {_size(n)}, not a Dask "
                                 f"handshake (at most {_size(HANDSHAKE_BYTES)}): nothing was sent to it")
            body = _read_exactly(sock, n)
    except TimeoutError:
        raise InputError(f"{head} no Dask scheduler answered there (no Dask handshake came back in {timeout:g} s: "
                         f"a service that is not a Dask scheduler, or none)") from None
    except OSError as exc:
        raise InputError(f"{head} no Dask scheduler answered there ({_one_line(exc)})") from None
    if b"pickle-protocol" not in body:
        raise InputError(f"{head} the service there sent something other than a Dask handshake: nothing was sent "
                         f"to it")


def _read_exactly(sock, n):
    """n bytes from the socket (OSError if it closes first)."""
    out = bytearray()
    while len(out) < n:
        chunk = sock.recv(min(n - len(out), 1 << 16))
        if not chunk:
            raise OSError(f"the connection closed after {len(out)} of {n} bytes")
        out += chunk
    return bytes(out)


@contextmanager
def _bounded_reads(address):
    """While it lasts, a message of more than ``REPLY_BYTES`` read by Dask's TCP (and TLS) comms raises OSError
    before anything is allocated: Dask allocates whatever length a peer announces (distributed.comm.tcp reads
    through its module's ``read_bytes_rw``, which this wraps)."""
    try:
        from distributed.comm import tcp
        unbounded = tcp.read_bytes_rw
    except (ImportError, AttributeError):      # another layout of distributed: the probe alone
        yield
        return

    async def bounded(stream, n):
        if n > REPLY_BYTES:
            raise OSError(f"a message from {address} announced {_size(n)}, more than the {_size(REPLY_BYTES)} "
                          f"allowed")
        return await unbounded(stream, n)
    tcp.read_bytes_rw = bounded
    try:
        yield
    finally:
        tcp.read_bytes_rw = unbounded


def _on_cluster(address, work):
    """The rows of ``work`` computed by the workers of the Dask scheduler at ``address``, in order: the scheduler
    probed first (``probe_scheduler``), every message from the cluster bounded (``_bounded_reads``)."""
    distributed = require("distributed", "dask", "manipdyn validate --scheduler")
    probe_scheduler(address)
    with _bounded_reads(address):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                client = distributed.Client(address, timeout=SCHEDULER_TIMEOUT)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise InputError(f"--scheduler {address}: no Dask scheduler answered there ({_one_line(exc)})") from None
        with client:
            try:
                for future in client.map(_row_of, work, pure=False):
                    yield future.result()
            except OSError as exc:             # a bounded read refused, a connection lost (CommClosedError)
                raise InputError(f"--scheduler {address}: {_one_line(exc)}") from None


def _row_of(item) -> dict:
    """One file's row (a worker's task): manipdyn's load, then each engine; any failure kept in the row."""
    path, engines, n_states, seed, root = item
    from ..io.urdf import load_urdf

    def shown(text):                     # messages without the sweep's folder
        return str(text).replace(f"{root}/", "")
    row = {"file": str(Path(path).relative_to(root)) if Path(path).is_relative_to(root) else str(path),
           "nv": None, "manipdyn": "loaded", "engines": {}}
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_urdf(path)
        row["nv"] = model.nv
    except Exception as exc:             # ManipdynError: refused; anything else: our bug, named as such
        why = _one_line(exc, 600) if isinstance(exc, ManipdynError) else \
            f"internal error: {type(exc).__name__}: {_one_line(exc, 600)}"
        row["manipdyn"] = shown(why)
        for e in engines:
            ok = engine_loads(e, path)
            row["engines"][e] = {"status": "missing" if ok is None else "loaded only" if ok[0] else "refused",
                                 "reason": "" if ok is None or ok[0] else shown(ok[1])}
        return row
    rep = referee(model, path, engines, n_states=n_states, seed=seed)
    for r in rep.engines:
        row["engines"][r.engine] = {"status": r.status, "reason": shown(r.reason), "err": r.err,
                                    "neutral": r.neutral, "worst": r.worst, "worst_neutral": r.worst_neutral,
                                    "causes": r.causes, "notes": r.notes, "explained": r.explained}
    row["notes"] = rep.notes
    return row


def _e(x):
    return "-" if x is None else f"{x:.1e}"


def markdown(rows, engines, n_states, seed, *, title="example-robot-data", command=None) -> str:
    """The summary: per engine loaded/refused counts, worst errors, causes; then one line per file."""
    command = command or (f"manipdyn validate --zoo --against {','.join(engines)} --states {n_states} "
                          f"--seed {seed} --markdown docs/referee/zoo.md")
    out = [f"# Engines referee over {title} ({len(rows)} URDF files, fixed base)", "",
           f"Generated by `{command}`. Errors: the measure of docs/design.md §3 over τ "
           "(inverse dynamics), M and q̈ (forward dynamics, err/cond(M)), worst over the states; 'neutralised': "
           "the same after rebuilding manipdyn's model with the engine's own read-back masses, CoMs, inertias, "
           "armature and damping. A disagreement above 1e-9 must carry a named cause.", "", "## Summary", "",
           "| engine | loaded | refused | worst τ | worst M | worst q̈/κ | worst neutralised (τ, M, q̈/κ) "
           "| files > 1e-9 | all explained |",
           "|---|---|---|---|---|---|---|---|---|"]
    loaded_by_us = [r for r in rows if r["manipdyn"] == "loaded"]
    for e in engines:
        res = [r["engines"].get(e, {}) for r in rows]
        ok = [x for x in res if x.get("status") == "ok"]
        refused = [x for x in res if x.get("status") == "refused"]
        w = {k: max((x["err"][k] for x in ok if x["err"].get(k) is not None), default=None)
             for k in ("tau", "M", "qdd")}
        wn = max((x["worst_neutral"] for x in ok if x.get("worst_neutral") is not None), default=None)
        above = sum(1 for x in ok if (x.get("worst") or 0) > 1e-9)
        expl = all(x.get("explained") for x in ok)
        out.append(f"| {e} | {len(ok) + sum(1 for x in res if x.get('status') == 'loaded only')} | {len(refused)} "
                   f"| {_e(w['tau'])} | {_e(w['M'])} | {_e(w['qdd'])} | {_e(wn)} | {above} | {'yes' if expl else 'NO'} |")
    out += ["", f"manipdyn loads {len(loaded_by_us)} of {len(rows)} files."]
    refused_us = [r for r in rows if r["manipdyn"] != "loaded"]
    for r in refused_us:
        others = [e for e, x in r["engines"].items() if x.get("status") in ("ok", "loaded only")]
        out.append(f"- manipdyn refuses `{r['file']}` ({len(others)} other engine(s) load it: "
                   f"{', '.join(others) or 'none'}): {r['manipdyn']}")
    out += ["", "## Causes named", ""]
    kinds = {}
    for r in rows:
        for e, x in r["engines"].items():
            for c in x.get("causes", []):
                kinds.setdefault((e, c["kind"]), []).append(f"{Path(r['file']).stem}:{c['link']}")
    for (e, k), where in sorted(kinds.items()):
        out.append(f"- **{e}: {k}** ({len(where)}): {', '.join(where[:12])}{' ...' if len(where) > 12 else ''}")
    out += ["", "## Per file", "", "| file | nv | manipdyn | " + " | ".join(engines) + " |",
            "|---|---|---|" + "---|" * len(engines)]
    for r in rows:
        cells = []
        for e in engines:
            x = r["engines"].get(e, {})
            if x.get("status") == "ok":
                cells.append(f"{_e(x['worst'])} → {_e(x['worst_neutral'])}"
                             + (f" ({len(x['causes'])} causes)" if x["causes"] else "")
                             + ("" if x["explained"] else " **UNEXPLAINED**"))
            else:
                cells.append(f"{x.get('status', '-')}: {x.get('reason', '')[:80]}".rstrip(": "))
        out.append(f"| `{r['file']}` | {r['nv'] if r['nv'] is not None else '-'} | "
                   f"{'loaded' if r['manipdyn'] == 'loaded' else 'refused: ' + r['manipdyn'][:80]} | "
                   + " | ".join(c.replace("|", "/") for c in cells) + " |")
    refusals = {}
    for r in rows:
        for e, x in r["engines"].items():
            if x.get("status") == "refused":
                why = "; ".join(c["text"] for c in x.get("causes", [])[:2])
                refusals.setdefault(e, []).append(f"`{Path(r['file']).name}`: {x['reason'][:200]}"
                                                  + (f" — the file: {why}" if why else ""))
    if refusals:
        out += ["", "## Refusals", ""]
        for e, items in refusals.items():
            out.append(f"### {e}")
            out += [f"- {i}" for i in items]
    return "\n".join(out) + "\n"


__all__ = ["zoo_urdfs", "urdf_files", "json_name", "engine_loads", "sweep", "markdown", "ADAPTERS", "EngineMissing", "EngineRefused"]
