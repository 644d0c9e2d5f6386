"""Browser playback: exported HTML and the live server render in headless Chromium; transforms are the
model's forward kinematics; the live server listens on loopback only."""
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT, assert_close

import manipdyn as md
from manipdyn import viz

ART = ROOT / "test-artifacts"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(CHROMIUM is None and not Path("/usr/bin/chromium").exists(),
                                reason="Debian's chromium is not installed (.ci/run installs it)")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--window-size=800,600", "--virtual-time-budget=6000"]


def shoot(url, out):
    """Screenshot of a page (file:// or http://127.0.0.1) as an (H, W, 3) array."""
    from PIL import Image
    ART.mkdir(exist_ok=True)
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run([CHROMIUM or "/usr/bin/chromium", *FLAGS, f"--user-data-dir={profile}",
                        f"--screenshot={out}", url], capture_output=True, timeout=120, check=True)
    return np.asarray(Image.open(out).convert("RGB"), dtype=int)


HIDE = ('<script nonce="{}">window.addEventListener("load", function () { setTimeout(function () {'
        ' viewer.set_property(["manipdyn"], "visible", false); }, 1500); });</script></body>')


def hidden_copy(page):
    """The page with the robot hidden after load (the script carries the page's nonce: CSP runs only those)."""
    import re
    nonce = re.search(r'<script nonce="([^"]+)">', page).group(1)
    return page.replace("</body>", HIDE.replace("{}", nonce))


@pytest.mark.parametrize("name,times", [("aau_arm", (0.5, 5.0)), ("spm", (0.0, 0.2))])
def test_exported_html_renders_the_motion(name, times, tmp_path):
    path = ROOT / "urdf" / f"{name}.urdf"
    model = md.load_urdf(path)
    t, Q = viz.demo(model, path)
    page = tmp_path / f"{name}.html"
    sc = viz.export_html(model, path, t, Q, page)
    hidden = tmp_path / f"{name}_hidden.html"
    hidden.write_text(hidden_copy(page.read_text()))
    a = shoot(f"file://{page}#t={times[0]}", ART / f"{name}_t{times[0]}.png")
    b = shoot(f"file://{page}#t={times[1]}", ART / f"{name}_t{times[1]}.png")
    empty = shoot(f"file://{hidden}#t={times[0]}", ART / f"{name}_hidden.png")
    drawn = np.abs(a - empty).sum(axis=2) > 30                      # pixels where the robot is
    moved = np.abs(a - b).sum(axis=2) > 30
    print(f"\n{name}: robot pixels {drawn.sum()}, pixels that change between t = {times[0]} and {times[1]} s: "
          f"{moved.sum()}")
    assert drawn.sum() > 300 and moved.sum() > 100
    # the animation's transforms are the model's forward kinematics at the frame times
    for k in (0, len(sc.times) // 2, len(sc.times) - 1):
        q = np.array([np.interp(sc.times[k], t - t[0], Q[:, i]) for i in range(model.nv)])
        for body in model.body_names:
            R, p = md.frame_placement(model, q, body)
            assert_close(sc.frames[f"/manipdyn/{body}"][k][:3, :3], R, 1e-14, "R")  # measured 0
            assert_close(sc.frames[f"/manipdyn/{body}"][k][:3, 3], p, 1e-14, "p")  # measured 0
    if model.constraints:                                           # closed chain: consistent at every frame
        assert max(g.max() for g in sc.gaps) < 1e-6


def _listening(port):
    """Local addresses of TCP sockets in LISTEN state on ``port`` (from /proc/net/tcp and tcp6)."""
    out = []
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        for line in Path(table).read_text().splitlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, p = local.split(":")
            if state == "0A" and int(p, 16) == port:
                out.append(addr)
    return out


def test_live_server_binds_loopback_only():
    path = ROOT / "urdf" / "aau_arm.urdf"
    model = md.load_urdf(path)
    live = viz.LiveViewer()
    try:
        web_port = int(live.url.split(":")[2].split("/")[0])
        zmq_port = int(live.zmq_url.rsplit(":", 1)[1])
        for port in (web_port, zmq_port):
            addrs = _listening(port)
            assert addrs and all(a == "0100007F" for a in addrs), f"port {port} listens on {addrs}"
        assert live.url.startswith("http://127.0.0.1:")
        t, Q = viz.demo(model, path)
        live.show(viz.scene_for(model, path, t, Q))
        time.sleep(0.5)
        a = shoot(live.url, ART / "live.png")
        from meshcat.commands import SetProperty
        from meshcat.path import Path as MPath
        live.vis.window.send(SetProperty("visible", False, MPath(("manipdyn",))))
        time.sleep(0.5)
        empty = shoot(live.url, ART / "live_empty.png")
        assert (np.abs(a - empty).sum(axis=2) > 30).sum() > 300
    finally:
        live.close()


def test_trajectory_files_and_errors(tmp_path):
    from manipdyn.examples import aau_arm as ex
    model = md.load_urdf(ROOT / "urdf" / "aau_arm.urdf")
    traj, tau = ex.chapter_example(model, samples=21)
    ex.write_csv(tmp_path / "a.csv", model, traj, tau)
    t, Q = viz.read_trajectory(tmp_path / "a.csv", model)
    assert_close(Q, traj.q, 1e-15, "CSV q")  # measured 0
    np.savez(tmp_path / "a.npz", t=traj.t, q=traj.q, joint_names=np.array(model.joint_names))
    assert_close(viz.read_trajectory(tmp_path / "a.npz", model)[1], traj.q, 0, "NPZ q")
    (tmp_path / "bad.csv").write_text("t,q_joint1\n0,0\n1,nan\n")
    with pytest.raises(md.InputError, match="no column q_<joint>|non-finite"):
        viz.read_trajectory(tmp_path / "bad.csv", model)
    (tmp_path / "bad2.csv").write_text("t,q_elbow\n0,0\n")
    with pytest.raises(md.InputError, match="elbow"):
        viz.read_trajectory(tmp_path / "bad2.csv", model)


def test_mesh_paths_cannot_escape(tmp_path):
    from manipdyn.viz.geometry import resolve_mesh
    urdf = tmp_path / "robot" / "r.urdf"
    urdf.parent.mkdir()
    (tmp_path / "secret.stl").write_text("solid x\nendsolid x\n")
    with pytest.raises(md.URDFError, match="leaves the URDF's folder"):
        resolve_mesh("../secret.stl", urdf)
    # a root given by the caller is the only way to read it
    assert resolve_mesh("package://outside/secret.stl", urdf, {"outside": tmp_path}).name == "secret.stl"


def test_ur5_meshes_through_package_paths(tmp_path):
    # a real vendor URDF: DAE meshes resolved through package://example-robot-data/..., drawn in Chromium
    from manipdyn.validation import robots_dir
    from manipdyn.viz.geometry import load_visuals
    path = robots_dir() / "ur_description/urdf/ur5_robot.urdf"
    assert len(load_visuals(path)) >= 6
    model = md.load_urdf(path)
    t, Q = viz.demo(model, path)
    page = tmp_path / "ur5.html"
    viz.export_html(model, path, t, Q, page)
    hidden = tmp_path / "ur5_hidden.html"
    hidden.write_text(hidden_copy(page.read_text()))
    a = shoot(f"file://{page}#t=1.0", ART / "ur5_t1.0.png")
    empty = shoot(f"file://{hidden}#t=1.0", ART / "ur5_hidden.png")
    assert (np.abs(a - empty).sum(axis=2) > 30).sum() > 300
