"""A minimal W3C WebDriver client (standard library only) for headless Chromium through chromedriver.

One browser session serves many pages (the slow part of a screenshot is starting Chromium), scripts run in
the page (WebDriver's execute bypasses the page's CSP, which only governs the page's own scripts), and
screenshots come back as arrays. chromedriver listens on loopback; the session and the driver are closed
by ``close()`` (or a context manager).
"""
from __future__ import annotations

import base64
import io
import json
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.request
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
HAVE_BROWSER = Path(CHROMIUM).exists() and Path(CHROMEDRIVER).exists()
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--hide-scrollbars"]


def _free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Browser:
    """Headless Chromium driven through chromedriver (W3C WebDriver over HTTP on 127.0.0.1)."""

    def __init__(self, width=1000, height=640):
        self.port = _free_port()
        self.profile = tempfile.TemporaryDirectory()
        self.driver = subprocess.Popen([CHROMEDRIVER, f"--port={self.port}", "--allowed-ips=127.0.0.1"],
                                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        self.base = f"http://127.0.0.1:{self.port}"
        for _ in range(100):
            try:
                self._call("GET", "/status")
                break
            except OSError:
                time.sleep(0.05)
        caps = {"capabilities": {"alwaysMatch": {"browserName": "chrome", "goog:chromeOptions": {
            "binary": CHROMIUM, "args": FLAGS + [f"--window-size={width},{height}",
                                                 f"--user-data-dir={self.profile.name}"]}}}}
        self.session = self._call("POST", "/session", caps)["sessionId"]

    def _call(self, method, path, body=None, timeout=120):
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(self.base + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return json.loads(r.read() or b"{}").get("value")

    def _s(self, method, path, body=None):
        return self._call(method, f"/session/{self.session}{path}", body)

    def open(self, url, ready="return typeof viewer !== 'undefined' && !!window.manipdyn", timeout=30):
        """Load a page and wait until ``ready`` (a script returning true) holds."""
        self._s("POST", "/url", {"url": url})
        t0 = time.time()
        while not self.run(ready):
            if time.time() - t0 > timeout:
                raise TimeoutError(f"{url}: not ready after {timeout} s")
            time.sleep(0.05)

    def run(self, script, *args):
        """Run a script in the page (a function body: ``return ...``); its result."""
        return self._s("POST", "/execute/sync", {"script": script, "args": list(args)})

    def frames(self, n=3):
        """Wait for n animation frames of the page (the viewer renders on requestAnimationFrame)."""
        return self._s("POST", "/execute/async", {
            "script": "var done = arguments[arguments.length - 1], k = %d;"
                      "function f() { if (--k <= 0) done(true); else requestAnimationFrame(f); }"
                      "requestAnimationFrame(f);" % n, "args": []})

    def shot(self, out=None):
        """Screenshot of the viewport as an (H, W, 3) int array (and a PNG at ``out``)."""
        from PIL import Image
        png = base64.b64decode(self._s("GET", "/screenshot"))
        if out is not None:
            Path(out).parent.mkdir(parents=True, exist_ok=True)
            Path(out).write_bytes(png)
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=int)

    def close(self):
        try:
            self._call("DELETE", f"/session/{self.session}", timeout=30)
        except OSError:
            pass
        self.driver.terminate()
        try:
            self.driver.wait(10)
        except subprocess.TimeoutExpired:
            self.driver.kill()
        self.profile.cleanup()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
