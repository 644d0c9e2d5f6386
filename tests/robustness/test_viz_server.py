"""The live meshcat server of `manipdyn play` listens on loopback only and dies with the CLI.

`manipdyn play urdf/aau_arm.urdf` runs as a subprocess; once it prints its URLs, both ports (web and ZMQ)
must listen on 127.0.0.1 only. Then the CLI gets SIGTERM, SIGINT, SIGHUP or SIGKILL: within 5 s both ports
must be free and the server process gone (a zombie left to init counts as gone: it holds no socket).
"""
from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FREE_WITHIN = 5.0      # seconds (measured 0.2–0.4 s)


def listening(port):
    """Local addresses (hex, as /proc shows them) of TCP sockets in LISTEN state on ``port``."""
    out = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            f = line.split()
            addr, p = f[1].rsplit(":", 1)
            if f[3] == "0A" and int(p, 16) == port:
                out.append(addr)
    return out


def alive(pid):
    """True while process ``pid`` exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


def start_play(tmp_path, ignore_sigint=False):
    """(CLI process, web port, ZMQ port, server pid) of a live `manipdyn play` of the AAU arm (a short
    trajectory file instead of the built-in demo, which takes ~20 s to compute). ignore_sigint starts it
    as a shell starts a background command (SIGINT ignored, so Python installs no Ctrl-C handler of its
    own): Ctrl-C must stop it all the same."""
    import manipdyn as md
    names = md.load_urdf(REPO / "urdf" / "aau_arm.urdf").joint_names
    traj = tmp_path / "swing.csv"
    traj.write_text("t," + ",".join(f"q_{n}" for n in names) + "\n"
                    + "".join(f"{k * 0.1}," + ",".join([str(0.1 * k)] * len(names)) + "\n" for k in range(11)))
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, "-m", "manipdyn.cli", "play", str(REPO / "urdf" / "aau_arm.urdf"),
                             "--traj", str(traj)],
                            cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=(lambda: signal.signal(signal.SIGINT, signal.SIG_IGN)) if ignore_sigint else None)
    deadline = time.time() + 300
    line = ""
    while not line.startswith("playing on") and time.time() < deadline:
        line = proc.stdout.readline()
        if not line and proc.poll() is not None:
            pytest.fail(f"manipdyn play exited {proc.returncode}: {proc.stderr.read()[-2000:]}")
    m = re.search(r"http://127\.0\.0\.1:(\d+)/.*zmq tcp://127\.0\.0\.1:(\d+)", line)
    assert m, line
    children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
    servers = [int(c) for c in children if b"manipdyn.viz.server" in Path(f"/proc/{c}/cmdline").read_bytes()]
    assert len(servers) == 1, children
    return proc, int(m.group(1)), int(m.group(2)), servers[0]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT, signal.SIGHUP, signal.SIGKILL],
                         ids=["SIGTERM", "SIGINT", "SIGHUP", "SIGKILL"])
def test_server_dies_with_the_cli(sig, tmp_path):
    proc, web, zmq, server = start_play(tmp_path, ignore_sigint=sig == signal.SIGINT)
    try:
        for port in (web, zmq):                       # loopback only: 127.0.0.1 in /proc's byte order
            addrs = listening(port)
            assert addrs and all(a == "0100007F" for a in addrs), f"port {port} listens on {addrs}"
        t0 = time.time()
        proc.send_signal(sig)
        while (listening(web) or listening(zmq) or alive(server)) and time.time() - t0 < FREE_WITHIN:
            time.sleep(0.02)
        elapsed = time.time() - t0
        print(f"\n{sig.name}: ports free and server gone after {elapsed:.2f} s")
        assert not listening(web) and not listening(zmq), f"ports still listening {elapsed:.1f} s after {sig.name}"
        assert not alive(server), f"server {server} still running after {sig.name}"
        rc = proc.wait(FREE_WITHIN)
        assert rc == (-signal.SIGKILL if sig == signal.SIGKILL else 0)
        assert "Traceback" not in proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        if alive(server):
            os.kill(server, signal.SIGKILL)


def test_live_viewer_close_and_exit_free_the_ports():
    # the API: close() is idempotent and a process that exits without close() takes its server along
    code = ("import sys; from manipdyn import viz; v = viz.LiveViewer(); print(v.url, v.zmq_url, v.proc.pid, "
            "flush=True); v.close(); v.close(); w = viz.LiveViewer(); print(w.url, w.zmq_url, w.proc.pid, flush=True)")
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(REPO)},
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    lines = [l.split() for l in r.stdout.splitlines() if len(l.split()) == 3]
    assert len(lines) == 2
    deadline = time.time() + FREE_WITHIN
    for url, zurl, pid in lines:
        ports = [int(url.split(":")[2].split("/")[0]), int(zurl.rsplit(":", 1)[1])]
        while (any(listening(p) for p in ports) or alive(int(pid))) and time.time() < deadline:
            time.sleep(0.02)
        assert not any(listening(p) for p in ports) and not alive(int(pid))
