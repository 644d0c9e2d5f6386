"""Trajectory files (play --traj) are untrusted: every flawed CSV or NPZ raises InputError naming the file
(and the line, column or array at fault), never a raw numpy/zip/unicode exception; NPZ is never unpickled."""
import os
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn.io import trajectory
from manipdyn.io.trajectory import MAX_TRAJECTORY_BYTES
from manipdyn.viz import read_trajectory

ROOT = Path(__file__).resolve().parents[2]
AAU = ROOT / "urdf" / "aau_arm.urdf"
JOINTS = ["joint1", "joint2", "joint3", "joint4", "joint5"]
HEAD = "t," + ",".join(f"q_{j}" for j in JOINTS)


@pytest.fixture(scope="module")
def model():
    return md.load_urdf(AAU)


def rows(*lines):
    """CSV text: the full AAU header, then the given lines."""
    return "\n".join([HEAD, *lines]) + "\n"


GOOD = "0,1,2,3,4,5"

CSV = [   # id, file content (str = UTF-8 text, bytes = raw), fragment of the message
    ("empty", b"", "empty file"),
    ("blank-lines-only", "\n\n\n", "no header"),
    ("header-only", HEAD + "\n", "header only, no data rows"),
    ("first-column-not-t", "time,q_joint1\n0,1\n", "first CSV column must be 't'"),
    ("no-t-column", ",".join(f"q_{j}" for j in JOINTS) + "\n1,2,3,4,5\n", "first CSV column must be 't'"),
    ("row-too-long", rows(GOOD, "1,1,2,3,4,5,6"), "line 3 has 7 cells, the header has 6"),
    ("row-too-short", rows(GOOD, "1,1,2"), "line 3 has 3 cells"),
    ("text-cell", rows(GOOD, "1,1,2,abc,4,5"), "line 3, column 'q_joint3': 'abc' is not a number"),
    ("empty-cell", rows("0,1,,3,4,5"), "line 2, column 'q_joint2': '' is not a number"),
    ("underscore-digits", rows("0,1_0,2,3,4,5"), "'1_0' is not a number"),
    ("non-ascii-digit", rows("0,\u0663,2,3,4,5"), "is not a number"),
    ("hex-float", rows("0,0x1p3,2,3,4,5"), "'0x1p3' is not a number"),
    ("nan-cell", rows("0,nan,2,3,4,5"), "column 'q_joint1': 'nan' is a non-finite number"),
    ("inf-time", rows("-inf,1,2,3,4,5"), "column 't': '-inf' is a non-finite number"),
    ("equal-times", rows(GOOD, "0,1,2,3,4,5"), "times must increase strictly; frame 1"),
    ("decreasing-times", rows(GOOD, "1,1,2,3,4,5", "0.5,1,2,3,4,5"), "frame 2 has t = 0.5"),
    ("duplicate-column", HEAD + ",q_joint1\n" + GOOD + ",1\n", "'q_joint1' appears twice"),
    ("duplicate-t", HEAD + ",t\n" + GOOD + ",0\n", "'t' appears twice"),
    ("joint-without-name", HEAD + ",q_\n" + GOOD + ",0\n", "'q_' without a joint name"),
    ("unknown-joint", rows().replace("q_joint5", "q_elbow") + GOOD + "\n", "elbow"),
    ("missing-joints", "t,q_joint1\n0,0\n", "no column q_<joint>"),
    ("no-joint-columns", "t,x\n0,0\n", "no column q_<joint>"),
    ("binary", bytes(range(256)) * 4, "binary file (NUL byte at offset 0)"),
    ("latin-1", (HEAD + "\n0,1,2,3,4,5 \xe9\n").encode("latin-1"), "not UTF-8 text"),
    ("open-quote", rows('0,"1,2,3,4,5'), "not a valid CSV file"),
]


@pytest.mark.parametrize("content,fragment", [c[1:] for c in CSV], ids=[c[0] for c in CSV])
def test_bad_csv(tmp_path, model, content, fragment):
    path = tmp_path / "traj.csv"
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(md.InputError, match="^" + re.escape(str(path))) as info:
        read_trajectory(path, model)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def save_npz(path, **arrays):
    np.savez(path, **arrays)
    return path


T2 = np.array([0.0, 1.0])
Q2 = np.zeros((2, 5))
NAMES = np.array(JOINTS)

NPZ = [   # id, arrays, fragment
    ("pickled-names", dict(t=T2, q=Q2, joint_names=np.array(JOINTS, dtype=object)),
     "array 'joint_names' holds Python objects (pickled data)"),
    ("pickled-q", dict(t=T2, q=Q2.astype(object), joint_names=NAMES), "array 'q' holds Python objects"),
    ("missing-arrays", dict(t=T2), "missing q, joint_names"),
    ("q-wrong-width", dict(t=T2, q=np.zeros((2, 4)), joint_names=NAMES), "q has shape (2, 4), expected"),
    ("q-wrong-length", dict(t=T2, q=np.zeros((3, 5)), joint_names=NAMES), "q has shape (3, 5)"),
    ("q-1d", dict(t=T2, q=np.zeros(5), joint_names=NAMES), "q has shape (5,)"),
    ("q-3d", dict(t=T2, q=np.zeros((2, 5, 1)), joint_names=NAMES), "q has shape (2, 5, 1)"),
    ("t-2d", dict(t=T2[:, None], q=Q2, joint_names=NAMES), "t must be 1-D"),
    ("t-empty", dict(t=np.zeros(0), q=np.zeros((0, 5)), joint_names=NAMES), "no frames"),
    ("names-numeric", dict(t=T2, q=Q2, joint_names=np.arange(5)), "joint_names must be a 1-D array of strings"),
    ("names-2d", dict(t=T2, q=Q2, joint_names=NAMES[None]), "joint_names must be a 1-D array of strings"),
    ("names-duplicate", dict(t=T2, q=Q2, joint_names=np.array(JOINTS[:4] + ["joint1"])), "more than once"),
    ("names-unknown", dict(t=T2, q=Q2, joint_names=np.array(JOINTS[:4] + ["elbow"])), "elbow"),
    ("q-complex", dict(t=T2, q=Q2 + 1j, joint_names=NAMES), "array 'q' must hold real numbers"),
    ("q-nan", dict(t=T2, q=np.where(np.eye(2, 5) > 0, np.nan, 0.0), joint_names=NAMES),
     "q[0, 0] = nan is a non-finite number"),
    ("t-not-increasing", dict(t=np.array([1.0, 1.0]), q=Q2, joint_names=NAMES), "times must increase"),
]


@pytest.mark.parametrize("arrays,fragment", [c[1:] for c in NPZ], ids=[c[0] for c in NPZ])
def test_bad_npz(tmp_path, model, arrays, fragment):
    path = save_npz(tmp_path / "traj.npz", **arrays)
    with pytest.raises(md.InputError, match="^" + re.escape(str(path))) as info:
        read_trajectory(path, model)
    assert fragment in str(info.value) and "\n" not in str(info.value)


def _zip_member_garbage(path):
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("t.npy", b"\x93NUMPY garbage")
        zf.writestr("q.npy", b"")
        zf.writestr("joint_names.npy", b"")


def _truncated(path):
    save_npz(path, t=T2, q=Q2, joint_names=NAMES)
    data = path.read_bytes()
    path.write_bytes(data[:len(data) // 2])


def _huge(path):
    with open(path, "wb") as fh:      # sparse: no data written
        fh.truncate(MAX_TRAJECTORY_BYTES + 1)


FILES = [   # id, file name, how to make it, fragment
    ("npz-not-a-zip", "traj.npz", lambda p: p.write_text("t,q\n"), "not an NPZ file"),
    ("npz-truncated", "traj.npz", _truncated, "not an NPZ file"),
    ("npz-members-not-npy", "traj.npz", _zip_member_garbage, "array 't' cannot be read"),
    ("csv-over-size-limit", "traj.csv", _huge, f"more than the limit of {MAX_TRAJECTORY_BYTES} bytes"),
    ("npz-over-size-limit", "traj.npz", _huge, "more than the limit"),
    ("unknown-suffix", "traj.txt", lambda p: p.write_text(rows(GOOD)), "unknown trajectory format '.txt'"),
    ("no-suffix", "traj", lambda p: p.write_text(rows(GOOD)), "'(no suffix)'"),
    ("a-directory", "traj.csv", lambda p: p.mkdir(), "not a regular file"),
    ("missing", "traj.csv", lambda p: None, "no such trajectory file"),
]


@pytest.mark.parametrize("name,make,fragment", [c[1:] for c in FILES], ids=[c[0] for c in FILES])
def test_bad_file(tmp_path, model, name, make, fragment):
    path = tmp_path / name
    make(path)
    with pytest.raises(md.InputError, match="^" + re.escape(str(path))) as info:
        read_trajectory(path, model)
    assert fragment in str(info.value)


def test_npz_zip_bomb_refused_before_unpacking(tmp_path, model, monkeypatch):
    """The limit applies to the arrays' unpacked size, read from the zip directory, not only to the file."""
    monkeypatch.setattr(trajectory, "MAX_TRAJECTORY_BYTES", 100_000)
    path = tmp_path / "bomb.npz"
    np.savez_compressed(path, t=np.arange(20_000.0), q=np.zeros((20_000, 5)), joint_names=NAMES)
    assert path.stat().st_size < 100_000         # small on disk, 960 kB unpacked
    with pytest.raises(md.InputError, match="unpack to"):
        read_trajectory(path, model)


def test_lenient_csv_reads_exactly(tmp_path, model):
    """BOM, CRLF, spaces, a blank line, an ignored text column and columns out of order read exactly."""
    text = ("\ufefft , q_joint3,note,q_joint1,q_joint2,q_joint4,q_joint5\r\n"
            " 0 , 0.25 ,first,-1,2.5e-1,+3,.5\r\n\r\n"
            "1.5,-0.0,x y,1E2,0,0,1.\r\n")
    path = tmp_path / "ok.csv"
    path.write_bytes(text.encode("utf-8"))
    t, Q = read_trajectory(path, model)
    assert t.tolist() == [0.0, 1.5]
    assert Q.tolist() == [[-1.0, 0.25, 0.25, 3.0, 0.5], [100.0, 0.0, -0.0, 0.0, 1.0]]


def test_npz_with_byte_names_and_integer_times(tmp_path, model):
    path = save_npz(tmp_path / "ok.npz", t=np.array([0, 2]), q=np.arange(10.0).reshape(2, 5)[:, ::-1],
                    joint_names=np.array(JOINTS[::-1], dtype="S"))
    t, Q = read_trajectory(path, model)
    assert t.dtype == float and t.tolist() == [0.0, 2.0]
    assert Q.tolist() == np.arange(10.0).reshape(2, 5).tolist()


# ---- the same refusals through `manipdyn play` (exit 2, one line, no traceback) ------------------------

CLI = [   # id, file name, content (bytes), fragment
    ("pickled-npz", "p.npz", None, "holds Python objects"),
    ("empty-csv", "e.csv", b"", "empty file"),
    ("ragged-csv", "r.csv", rows(GOOD, "1,2").encode(), "line 3 has 2 cells"),
    ("unknown-suffix", "t.json", b"{}", "unknown trajectory format"),
]


@pytest.mark.parametrize("name,content,fragment", [c[1:] for c in CLI], ids=[c[0] for c in CLI])
def test_play_refuses_bad_trajectory(tmp_path, name, content, fragment):
    path = tmp_path / name
    if content is None:
        save_npz(path, t=T2, q=Q2, joint_names=np.array(JOINTS, dtype=object))
    else:
        path.write_bytes(content)
    out = tmp_path / "o.html"
    r = subprocess.run([sys.executable, "-m", "manipdyn.cli", "play", str(AAU), "--traj", str(path),
                        "--html", str(out)], capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"manipdyn play: error: {path}: ") and fragment in lines[0]
    assert not out.exists()
