"""Trajectory files (CSV or NPZ) read strictly: every refusal names the file, and the row, column or array.

A trajectory file is untrusted data. CSV: UTF-8 text, header ``t,q_<joint>,...`` (other columns are kept
out of the result and not parsed), one row per time, every cell of ``t`` and ``q_*`` a plain decimal number
(``1``, ``-0.5``, ``2.5e-3``; not ``nan``, ``inf``, ``1_0``), times strictly increasing. NPZ: a zip of
``.npy`` arrays ``t`` (T,), ``q`` (T, n) and ``joint_names`` (n,) of strings, read with
``allow_pickle=False`` (an object array is refused, never unpickled). Either format is at most
``MAX_TRAJECTORY_BYTES`` on disk and, for NPZ, once decompressed.
"""
from __future__ import annotations

import csv
import io
import re
import zipfile
from pathlib import Path

import numpy as np

from ..errors import InputError

MAX_TRAJECTORY_BYTES = 64 * 2**20     # 64 MiB: ~100 000 frames of a 30-joint arm as CSV
_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")   # ASCII digits only
_NONFINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


def read_trajectory_file(path):
    """(t (T,), joint names [n], q (T, n)) from a .csv or .npz trajectory file; InputError on any flaw."""
    path = Path(path)
    _check_file(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        t, names, q = _read_npz(path)
    elif suffix == ".csv":
        t, names, q = _read_csv(path)
    else:
        raise InputError(f"{path}: unknown trajectory format {path.suffix or '(no suffix)'!r}: "
                         "expected .csv or .npz")
    _check_times(path, t)
    return t, names, q


def _check_file(path):
    """An existing regular file of at most MAX_TRAJECTORY_BYTES."""
    if not path.exists():
        raise InputError(f"{path}: no such trajectory file")
    if not path.is_file():
        raise InputError(f"{path}: not a regular file (a trajectory must be a .csv or .npz file)")
    size = path.stat().st_size
    if size == 0:
        raise InputError(f"{path}: empty file")
    if size > MAX_TRAJECTORY_BYTES:
        raise InputError(f"{path}: {size} bytes, more than the limit of {MAX_TRAJECTORY_BYTES} bytes "
                         f"({MAX_TRAJECTORY_BYTES // 2**20} MiB) for a trajectory file")


def _check_times(path, t):
    """At least one frame; times strictly increasing (names the first row at fault)."""
    if len(t) == 0:
        raise InputError(f"{path}: no frames (t is empty)")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(f"{path}: times must increase strictly; frame {k} has t = {float(t[k])!r} after "
                         f"t = {float(t[k - 1])!r}")


def _read_csv(path):
    """The t and q_<joint> columns of a CSV, cell by cell (line numbers are the file's, header = 1)."""
    text = _decode(path)
    rows = csv.reader(io.StringIO(text, newline=""), strict=True)
    try:
        head = [h.strip() for h in next(rows, [])]
        if not any(head):
            raise InputError(f"{path}: no header on line 1 (expected t,q_<joint>,...)")
        if head[0] != "t":
            raise InputError(f"{path}: the first CSV column must be 't', not {head[0][:40]!r}")
        _check_header(path, head)
        cols = [i for i, h in enumerate(head) if h.startswith("q_")]
        data = []
        for row in rows:
            if not row or row == [""]:
                continue                                  # blank line
            if len(row) != len(head):
                raise InputError(f"{path}: line {rows.line_num} has {len(row)} cells, the header has "
                                 f"{len(head)}")
            data.append([_number(path, rows.line_num, head[i], row[i]) for i in [0] + cols])
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file (line {rows.line_num}: {exc})") from None
    if not data:
        raise InputError(f"{path}: header only, no data rows")
    arr = np.array(data, dtype=float).reshape(len(data), 1 + len(cols))
    return arr[:, 0], [head[i][2:] for i in cols], arr[:, 1:]


def _decode(path):
    """The file's text (UTF-8, an optional BOM); a binary file is refused."""
    raw = path.read_bytes()
    nul = raw.find(b"\0")
    if nul >= 0:
        raise InputError(f"{path}: a binary file (NUL byte at offset {nul}), not a CSV text file")
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(f"{path}: not UTF-8 text (byte {exc.start}); a trajectory CSV is a text file") from None


def _check_header(path, head):
    """No duplicate or empty column names; every q_ column names a joint."""
    seen = set()
    for k, h in enumerate(head, 1):
        if h in seen:
            raise InputError(f"{path}: column {h[:40]!r} appears twice in the header (column {k})")
        if h == "q_":
            raise InputError(f"{path}: column {k} is 'q_' without a joint name")
        seen.add(h)


def _number(path, line, column, cell):
    """One cell as a finite float (plain decimal only)."""
    s = cell.strip()
    if _NUMBER.fullmatch(s):
        return float(s)
    what = "is a non-finite number" if _NONFINITE.fullmatch(s) else "is not a number"
    raise InputError(f"{path}: line {line}, column {column!r}: {s[:40]!r} {what}")


def _read_npz(path):
    """The arrays t, q and joint_names of an NPZ, without unpickling and within the size limit."""
    if not zipfile.is_zipfile(path):
        raise InputError(f"{path}: not an NPZ file (an NPZ is a zip archive of .npy arrays)")
    try:
        with zipfile.ZipFile(path) as zf:
            unpacked = sum(info.file_size for info in zf.infolist())
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise InputError(f"{path}: damaged NPZ (zip) file: {exc}") from None
    if unpacked > MAX_TRAJECTORY_BYTES:
        raise InputError(f"{path}: its arrays unpack to {unpacked} bytes, more than the limit of "
                         f"{MAX_TRAJECTORY_BYTES} bytes for a trajectory file")
    with np.load(path, allow_pickle=False) as data:
        missing = [k for k in ("t", "q", "joint_names") if k not in data.files]
        if missing:
            raise InputError(f"{path}: NPZ needs arrays t, q and joint_names (missing {', '.join(missing)}; "
                             f"found {', '.join(data.files) or 'none'})")
        t, q, names = (_array(path, data, k) for k in ("t", "q", "joint_names"))
    return _check_npz_arrays(path, t, q, names)


def _array(path, data, key):
    """One array of an open NPZ; object (pickled) arrays and damaged members are refused."""
    try:
        return data[key]
    except ValueError as exc:
        if "pickle" in str(exc) or "Object arrays" in str(exc):
            raise InputError(f"{path}: array {key!r} holds Python objects (pickled data), which manipdyn "
                             "refuses to load; save strings as np.array(names, dtype=str)") from None
        raise InputError(f"{path}: array {key!r} cannot be read: {exc}") from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise InputError(f"{path}: array {key!r} cannot be read: {exc}") from None


def _check_npz_arrays(path, t, q, names):
    """t (T,) and q (T, n) real and finite, joint_names (n,) distinct strings."""
    if names.ndim != 1 or names.dtype.kind not in "US":
        raise InputError(f"{path}: joint_names must be a 1-D array of strings, got dtype {names.dtype} "
                         f"shape {names.shape}")
    names = [n.decode("utf-8", "replace") if isinstance(n, bytes) else str(n) for n in names.tolist()]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"{path}: joint_names lists {dup} more than once")
    for key, a in (("t", t), ("q", q)):
        if a.dtype.kind not in "iuf":
            raise InputError(f"{path}: array {key!r} must hold real numbers, got dtype {a.dtype}")
    if t.ndim != 1:
        raise InputError(f"{path}: t must be 1-D (T,), got shape {t.shape}")
    if q.shape != (len(t), len(names)):
        raise InputError(f"{path}: q has shape {q.shape}, expected (len(t), len(joint_names)) = "
                         f"({len(t)}, {len(names)})")
    t, q = t.astype(float), q.astype(float)
    for key, a in (("t", t), ("q", q)):
        bad = np.argwhere(~np.isfinite(a))
        if bad.size:
            at = ", ".join(map(str, bad[0]))
            raise InputError(f"{path}: {key}[{at}] = {a[tuple(bad[0])]} is a non-finite number")
    return t, names, q
