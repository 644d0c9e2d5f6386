"""manipdyn validate DIR --against ENGINES --jobs N: a folder's URDFs refereed in worker processes, one summary
table, one JSON file per URDF; the same rows as the in-process sweep, in the same order. --scheduler ADDRESS:
the same sweep on a Dask cluster's workers (a LocalCluster here), the same per-file JSON."""
from __future__ import annotations

import json
import shutil

import pytest

from conftest import AAU, ROOT

from manipdyn.cli import main
from manipdyn.validation.referee_zoo import sweep, urdf_files

BAD = """<robot name="bad"><link name="a"/><joint name="j" type="revolute"><parent link="a"/><child link="b"/>
</joint><link name="b"/></robot>"""


@pytest.fixture
def folder(tmp_path):
    d = tmp_path / "in"
    (d / "sub").mkdir(parents=True)
    shutil.copy(AAU, d / "aau_arm.urdf")
    shutil.copy(ROOT / "urdf" / "fourbar.urdf", d / "sub" / 'four bar "&<x>.urdf')     # a hostile file name
    (d / "bad.urdf").write_text(BAD)
    (d / "notes.txt").write_text("not a URDF")
    return d


def test_folder_sweep_in_two_jobs(folder, tmp_path, capsys):
    out = tmp_path / "json"
    code = main(["validate", str(folder), "--against", "pinocchio", "--jobs", "2", "--states", "2",
                 "--json", str(out)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert "| pinocchio | 2 | 1 |" in text and "manipdyn loads 2 of 3 files." in text
    files = sorted(p.name for p in out.iterdir())
    assert files == ["0000_aau_arm.urdf.json", "0001_bad.urdf.json", "0002_sub_four_bar____x_.urdf.json",
                     "summary.json"]
    rows = json.loads((out / "summary.json").read_text())
    assert [r["file"] for r in rows] == ["aau_arm.urdf", "bad.urdf", 'sub/four bar "&<x>.urdf']
    assert "needs <limit" in rows[1]["manipdyn"] and rows[1]["engines"]["pinocchio"]["status"] == "refused"
    # the worker processes give the rows the in-process sweep gives (same seeds, same order)
    here = sweep(["pinocchio"], n_states=2, seed=0, paths=urdf_files([folder]), root=folder)
    assert json.loads(json.dumps(here, default=float)) == rows
    assert all(r["engines"]["pinocchio"]["worst"] < 1e-13 for r in rows if r["manipdyn"] == "loaded")  # measured 5e-16


def test_folder_sweep_on_a_dask_cluster(folder, tmp_path, capsys):
    distributed = pytest.importorskip("distributed")
    on_cluster, here = tmp_path / "cluster", tmp_path / "here"
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as c:
        code = main(["validate", str(folder), "--against", "pinocchio", "--scheduler", c.scheduler_address,
                     "--states", "2", "--json", str(on_cluster)])
    text = capsys.readouterr().out
    assert code == 0, text
    assert f"the Dask scheduler at {c.scheduler_address}" in text and "manipdyn loads 2 of 3 files." in text
    assert main(["validate", str(folder), "--against", "pinocchio", "--jobs", "1", "--states", "2",
                 "--json", str(here)]) == 0
    names = sorted(p.name for p in here.iterdir())
    assert names == sorted(p.name for p in on_cluster.iterdir()) and len(names) == 4
    for name in names:                                    # the same rows, in the same files
        assert json.loads((on_cluster / name).read_text()) == json.loads((here / name).read_text()), name


def test_an_unreachable_scheduler_is_one_line_exit_2(folder, capsys, monkeypatch):
    pytest.importorskip("distributed")
    from manipdyn.validation import referee_zoo
    monkeypatch.setattr(referee_zoo, "SCHEDULER_TIMEOUT", 1)
    assert main(["validate", str(folder), "--against", "pinocchio", "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("manipdyn validate: error: --scheduler tcp://127.0.0.1:9: no Dask scheduler answered")
    assert "Traceback" not in "\n".join(err)


@pytest.mark.parametrize("argv, fragment", [
    (["validate", "{d}", "--scheduler", "tcp://h:1"], "--scheduler needs --against"),
    (["validate", "{d}", "--against", "pinocchio", "--scheduler", "tcp://h:1", "--jobs", "2"], "and no --jobs"),
    (["validate", "{d}", "--against", "pinocchio", "--scheduler", "tcp://h :1"], "expected a scheduler address"),
    (["validate", "{d}", "--jobs", "2"], "--jobs needs --against"),
    (["validate", "{d}/empty", "--against", "pinocchio"], "holds no *.urdf"),
    (["validate", "{d}", "--against", "pinocchio", "--jobs", "2", "--json", "{d}/aau_arm.urdf"], "is a file"),
    (["validate", "{d}", "--states", "2"], "is a directory"),          # without --against: files only, as before
    (["validate", "{d}", "--against", "pinocchio", "--jobs", "0"], "--jobs"),
])
def test_sweep_bad_input_exit_2(folder, capsys, argv, fragment):
    (folder / "empty").mkdir()
    assert main([a.format(d=folder) for a in argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert fragment in err[-1] and err[-1].startswith("manipdyn validate: error:"), err


# -- a --scheduler address where something else answers: probed before anything is sent, bounded reads ---------

def _serve(reply, seen):
    """A loopback TCP server on 127.0.0.1 (a thread) that sends ``reply`` to each client as it connects and records
    in ``seen`` what the client sends; its port."""
    import socket
    import threading
    srv = socket.create_server(("127.0.0.1", 0))
    srv.settimeout(10)

    def run():
        try:
            conn, _ = srv.accept()
        except OSError:
            return
        with conn:
            conn.sendall(reply)
            conn.settimeout(2)
            try:
                seen.append(conn.recv(1 << 16))
            except OSError:
                seen.append(b"")
        srv.close()
    threading.Thread(target=run, daemon=True).start()
    return srv.getsockname()[1]


def _one_line_exit_2(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "Traceback" not in "\n".join(err) and "MemoryError" not in "\n".join(err)
    return err[-1]


def test_an_http_server_is_not_taken_for_a_scheduler(folder, capsys, monkeypatch):
    """An HTTP server waits for a request: nothing comes back, nothing is sent to it (Dask's client would send its
    handshake and read the "HTTP/1.1 400" reply as a 3.07 EiB frame)."""
    pytest.importorskip("distributed")
    import http.server
    import threading
    from manipdyn.validation import referee_zoo
    monkeypatch.setattr(referee_zoo, "SCHEDULER_TIMEOUT", 1)
    requests = []

    class Handler(http.server.BaseHTTPRequestHandler):
        timeout = 2                                     # (a client that sends no line: dropped, not waited for)

        def handle_one_request(self):
            requests.append(self.rfile.read(1))
            super().handle_one_request()
    srv = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    srv.block_on_close = False
    threading.Thread(target=srv.serve_forever, daemon=True).start()
    try:
        address = f"tcp://127.0.0.1:{srv.server_address[1]}"
        line = _one_line_exit_2(["validate", str(folder), "--against", "pinocchio", "--scheduler", address], capsys)
    finally:
        srv.shutdown()
        srv.server_close()
    assert line == (f"manipdyn validate: error: --scheduler {address}: no Dask scheduler answered there (no Dask "
                    f"handshake came back in 1 s: a service that is not a Dask scheduler, or none)")
    assert requests in ([], [b""])                        # the server never read a byte from us


@pytest.mark.parametrize("reply, fragment", [
    ((3 << 30).to_bytes(8, "little"), "announced a first message of 3 GiB, not a Dask handshake (at most 64 KiB)"),
    (b"HTTP/1.1 400 Bad Request\r\n\r\n", "announced a first message of 3.07 EiB"),
    ((5).to_bytes(8, "little") + b"hello", "sent something other than a Dask handshake"),
    ((50).to_bytes(8, "little") + b"short", "no Dask scheduler answered there (no Dask handshake came back in 1 s"),
])
def test_a_hostile_first_message_is_refused_unread(folder, capsys, monkeypatch, reply, fragment):
    pytest.importorskip("distributed")
    from manipdyn.validation import referee_zoo
    monkeypatch.setattr(referee_zoo, "SCHEDULER_TIMEOUT", 1)
    seen = []
    port = _serve(reply, seen)
    line = _one_line_exit_2(["validate", str(folder), "--against", "pinocchio", "--scheduler",
                             f"tcp://127.0.0.1:{port}"], capsys)
    assert line.startswith(f"manipdyn validate: error: --scheduler tcp://127.0.0.1:{port}: ") and fragment in line
    assert seen in ([], [b""])                            # nothing was sent to the service


def test_dask_reads_are_bounded_while_the_cluster_is_used():
    """Past the probe, a message announced longer than REPLY_BYTES raises OSError before Dask allocates it; the
    bound is lifted afterwards."""
    import asyncio
    tcp = pytest.importorskip("distributed.comm.tcp")
    from manipdyn.validation import referee_zoo
    original = tcp.read_bytes_rw
    with referee_zoo._bounded_reads("tcp://x:1"):
        assert tcp.read_bytes_rw is not original
        with pytest.raises(OSError, match=r"a message from tcp://x:1 announced 3.07 EiB, more than the 256 MiB"):
            asyncio.run(tcp.read_bytes_rw(None, int.from_bytes(b"HTTP/1.1", "little")))
    assert tcp.read_bytes_rw is original
