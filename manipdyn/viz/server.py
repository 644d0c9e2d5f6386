"""A meshcat server that listens on loopback only and dies with the process that started it.

meshcat 0.3.2's ZMQWebSocketBridge calls its tornado app's ``listen(port)`` without an address, so the web
server binds every interface whatever ``host`` says. This bridge passes address="127.0.0.1" to ``listen``;
its ZMQ socket binds tcp://127.0.0.1 as well. Run as ``python -m manipdyn.viz.server PARENT_PID [--death-signal]`` (it prints
zmq_url= and web_url= lines, as meshcat's own server does); ``start()`` does that in a subprocess.

Lifetime: the server stays in its parent's session and process group, ignores SIGINT (the parent handles
Ctrl-C and stops it), and exits as soon as its parent is gone, however the parent ends (normal exit,
exception, signal, even SIGKILL): a thread waits for end-of-file on stdin, a pipe only the parent holds, and
on Linux the kernel also sends it SIGTERM when the parent dies (prctl PR_SET_PDEATHSIG).
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import threading

LOOPBACK = "127.0.0.1"
PR_SET_PDEATHSIG = 1
STOP_TIMEOUT = 3.0       # seconds between SIGTERM and SIGKILL in stop()


def _bridge_class():
    from .geometry import meshcat_module
    ZMQWebSocketBridge = meshcat_module("meshcat.servers.zmqserver").ZMQWebSocketBridge

    class LoopbackBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kw: listen(port, address=LOOPBACK, **kw)
            return app

    return LoopbackBridge


def _die_with_parent(parent_pid: int, death_signal: bool):
    """Exit when the parent is gone: end-of-file on the stdin pipe, and (Linux, when the parent started us
    from its main thread: the signal follows the thread) a kernel death signal."""
    if death_signal and sys.platform.startswith("linux"):
        import ctypes
        try:
            ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
        except (OSError, AttributeError):     # no prctl: the stdin watch below still works
            pass
    if os.getppid() != parent_pid:            # the parent died before prctl took effect
        os._exit(0)

    def watch():
        while sys.stdin.buffer.read(4096):
            pass
        os._exit(0)

    threading.Thread(target=watch, name="parent-watch", daemon=True).start()


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if argv:
        _die_with_parent(int(argv[0]), "--death-signal" in argv[1:])
    bridge = _bridge_class()(host=LOOPBACK)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    devnull = os.open(os.devnull, os.O_WRONLY)        # nobody reads stdout any more: never block on it
    os.dup2(devnull, 1)
    bridge.run()


def start():
    """(process, zmq_url, web_url) of a loopback-only meshcat server in a subprocess that dies with us."""
    err = tempfile.TemporaryFile()
    args = [str(os.getpid())] + (["--death-signal"] if threading.current_thread() is threading.main_thread() else [])
    proc = subprocess.Popen([sys.executable, "-u", "-m", "manipdyn.viz.server", *args],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, text=True)
    urls = {}
    try:
        while len(urls) < 2:
            line = proc.stdout.readline()
            if not line:
                err.seek(0)
                raise RuntimeError(f"meshcat server exited: {err.read().decode(errors='replace')[-2000:]}")
            key, _, val = line.strip().partition("=")
            if key in ("zmq_url", "web_url"):
                urls[key] = val
    except BaseException:
        stop(proc)
        raise
    finally:
        err.close()
    return proc, urls["zmq_url"], urls["web_url"]


def stop(proc):
    """Stop a server process (idempotent): SIGTERM, SIGKILL after STOP_TIMEOUT s, reap it, close its pipes."""
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(STOP_TIMEOUT)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for pipe in (proc.stdin, proc.stdout):
        if pipe is not None:
            try:
                pipe.close()
            except OSError:
                pass


if __name__ == "__main__":
    main()
