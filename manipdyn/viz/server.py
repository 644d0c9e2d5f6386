"""A meshcat server that listens on loopback only.

meshcat 0.3.2's ZMQWebSocketBridge calls its tornado app's ``listen(port)`` without an address, so the web
server binds every interface whatever ``host`` says. This bridge passes address="127.0.0.1" to ``listen``;
its ZMQ socket binds tcp://127.0.0.1 as well. Run as ``python -m manipdyn.viz.server`` (it prints
zmq_url= and web_url= lines, as meshcat's own server does); ``start()`` does that in a subprocess.
"""
from __future__ import annotations

import subprocess
import sys

LOOPBACK = "127.0.0.1"


def _bridge_class():
    from meshcat.servers.zmqserver import ZMQWebSocketBridge

    class LoopbackBridge(ZMQWebSocketBridge):
        def make_app(self):
            app = super().make_app()
            listen = app.listen
            app.listen = lambda port, **kw: listen(port, address=LOOPBACK, **kw)
            return app

    return LoopbackBridge


def main():
    bridge = _bridge_class()(host=LOOPBACK)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    bridge.run()


def start():
    """(process, zmq_url, web_url) of a loopback-only meshcat server in a subprocess."""
    proc = subprocess.Popen([sys.executable, "-u", "-m", "manipdyn.viz.server"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, start_new_session=True)
    urls = {}
    while len(urls) < 2:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"meshcat server exited: {proc.stderr.read()}")
        key, _, val = line.strip().partition("=")
        if key in ("zmq_url", "web_url"):
            urls[key] = val
    return proc, urls["zmq_url"], urls["web_url"]


if __name__ == "__main__":
    main()
