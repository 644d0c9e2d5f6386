"""Hostile mesh paths: a URDF must not make playback read a file outside its folder or a package root.

A marker file (random content) sits next to the URDF's folder, outside every root; the URDF names it through
every URI form we know. The exported HTML must not contain the marker (plain, or inside the embedded base64
command payloads), no file outside the roots may be opened (a spy on open), and the visual is skipped with a
GeometryWarning naming the link and the URI. A control case proves the detector sees the marker when the
same file is placed inside the folder.
"""
from __future__ import annotations

import base64
import builtins
import io
import json
import os
import re
import secrets
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import manipdyn as md
from manipdyn import viz
from manipdyn.errors import GeometryWarning
from manipdyn.viz.geometry import check_package_dirs, load_visuals, valid_package_name

REPO = Path(__file__).resolve().parents[2]


def robot_urdf(mesh_uri, name="hostile"):
    """A two-link arm whose 'arm' link draws the mesh ``mesh_uri`` (XML-escaped)."""
    from xml.sax.saxutils import quoteattr
    inertial = ('<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" '
                'iyz="0"/></inertial>')
    return (f'<?xml version="1.0"?>\n<robot name="{name}"><link name="base"/>'
            f'<link name="arm">{inertial}<visual><geometry><mesh filename={quoteattr(mesh_uri)}/></geometry>'
            f'</visual></link><joint name="j1" type="revolute"><parent link="base"/><child link="arm"/>'
            f'<origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>'
            f'<limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>\n')


def stl_text(marker):
    return (f"solid {marker}\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.1 0 0\nvertex 0 0.1 0\n"
            f"endloop\nendfacet\nendsolid {marker}\n")


@pytest.fixture
def world(tmp_path):
    """tmp/secret.stl (the marker, outside every root) and tmp/robot/ (a ROS package 'robot', the URDF's folder)
    holding meshes/ok.stl, a symlink to the secret, and a symlinked folder pointing at tmp/."""
    marker = "MARKER_" + secrets.token_hex(16)
    secret = tmp_path / "secret.stl"
    secret.write_text(stl_text(marker))
    robot = tmp_path / "robot"
    (robot / "meshes").mkdir(parents=True)
    (robot / "package.xml").write_text("<package><name>robot</name></package>\n")
    (robot / "meshes" / "ok.stl").write_text(stl_text("harmless"))
    (robot / "link.stl").symlink_to(secret)
    (robot / "meshes" / "up").symlink_to(tmp_path, target_is_directory=True)
    return dict(tmp=tmp_path, robot=robot, secret=secret, marker=marker)


# (id, URI template, package_dirs): {S} = absolute secret path, {T} = tmp folder, {TN} = its name
VARIANTS = [
    ("package-empty-name-absolute", "package://{S}", None),
    ("package-empty-name-relative", "package:///../secret.stl", None),
    ("package-dot", "package://./../secret.stl", None),
    ("package-dotdot", "package://../secret.stl", None),
    ("package-dotdot-deep", "package://../../secret.stl", None),
    ("package-climbs-out", "package://robot/../secret.stl", None),
    ("package-climbs-out-deep", "package://robot/meshes/../../secret.stl", None),
    ("package-absolute-inside", "package://robot/{S}", None),
    ("package-ancestor-without-package-xml", "package://{TN}/secret.stl", None),
    ("package-user-root-climbs-out", "package://meshes/../../secret.stl", {"meshes": "robot/meshes"}),
    ("package-symlink-inside-root", "package://robot/link.stl", None),
    ("package-symlinked-folder", "package://robot/meshes/up/secret.stl", None),
    ("package-percent-dotdot", "package://%2e%2e/secret.stl", None),
    ("package-backslash", "package://robot\\..\\..\\secret.stl", None),
    ("absolute-path", "{S}", None),
    ("file-uri-absolute", "file://{S}", None),
    ("file-uri-localhost", "file://localhost{S}", None),
    ("file-uri-host", "file://example.org{S}", None),
    ("file-uri-percent-dotdot", "file://{T}/robot/%2e%2e/secret.stl", None),
    ("file-uri-relative", "file://../secret.stl", None),
    ("relative-dotdot", "../secret.stl", None),
    ("relative-deep-dotdot", "meshes/../../secret.stl", None),
    ("relative-percent-dotdot", "%2e%2e/secret.stl", None),
    ("relative-symlink-file", "link.stl", None),
    ("relative-symlinked-folder", "meshes/up/secret.stl", None),
    ("http-uri", "http://127.0.0.1:9/secret.stl", None),
]


def payloads(page: str) -> list:
    """The page's text and the decoded bytes of every embedded command (base64 inside the JSON array)."""
    out = [page.encode()]
    m = re.search(r'<script type="application/json" id="manipdyn-commands">(.*?)</script>', page, re.S)
    assert m, "the commands array is missing"
    out += [base64.b64decode(b) for b in json.loads(m.group(1))]
    return out


class OpenSpy:
    """Records every path opened through open/io.open/os.open while active."""

    def __init__(self, monkeypatch):
        self.paths = []
        for mod, name in ((builtins, "open"), (io, "open"), (os, "open")):
            real = getattr(mod, name)
            monkeypatch.setattr(mod, name, self._wrap(real))

    def _wrap(self, real):
        def spy(file, *a, **kw):
            if isinstance(file, (str, bytes, os.PathLike)):
                self.paths.append(Path(os.fsdecode(file)))
            return real(file, *a, **kw)
        return spy

    def outside(self, tmp, allowed):
        """Opened paths (resolved) under ``tmp`` that are not inside one of the ``allowed`` folders/files."""
        bad = []
        for p in self.paths:
            r = p.resolve() if p.is_absolute() else (Path.cwd() / p).resolve()
            if r.is_relative_to(tmp) and not any(r == a or r.is_relative_to(a) for a in allowed):
                bad.append(r)
        return bad


def export(world, uri, package_dirs, monkeypatch):
    """(page text, caught warnings, opened paths outside the roots) of exporting the hostile robot."""
    urdf = world["robot"] / "r.urdf"
    urdf.write_text(robot_urdf(uri.format(S=world["secret"], T=world["tmp"], TN=world["tmp"].name)))
    dirs = {k: world["tmp"] / v for k, v in (package_dirs or {}).items()}
    model = md.load_urdf(urdf)
    t, Q = np.linspace(0, 1, 5), np.zeros((5, 1))
    out = world["tmp"] / "out.html"
    spy = OpenSpy(monkeypatch)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        viz.export_html(model, urdf, t, Q, out, package_dirs=dirs)
    monkeypatch.undo()
    allowed = [world["robot"].resolve(), out.resolve()] + [d.resolve() for d in dirs.values()]
    return out.read_text(), caught, spy.outside(world["tmp"].resolve(), allowed)


@pytest.mark.parametrize("uri,package_dirs", [v[1:] for v in VARIANTS], ids=[v[0] for v in VARIANTS])
def test_marker_outside_the_roots_is_never_read(world, uri, package_dirs, monkeypatch):
    page, caught, opened_outside = export(world, uri, package_dirs, monkeypatch)
    assert opened_outside == [], f"opened outside the roots: {opened_outside}"
    for blob in payloads(page):
        assert world["marker"].encode() not in blob
    geo = [w for w in caught if issubclass(w.category, GeometryWarning)]
    assert len(geo) == 1, [str(w.message) for w in caught]
    text = str(geo[0].message)
    assert "'arm'" in text and "skipped" in text
    shown = uri.format(S=world["secret"], T=world["tmp"], TN=world["tmp"].name)
    assert repr(shown) in text or shown in text, text


def test_marker_inside_the_folder_is_seen(world, monkeypatch):
    # control: the same file inside the URDF's folder is read and embedded, so the detector above can fail
    (world["robot"] / "meshes" / "inside.stl").write_bytes(world["secret"].read_bytes())
    page, caught, _ = export(world, "meshes/inside.stl", None, monkeypatch)
    assert not [w for w in caught if issubclass(w.category, GeometryWarning)]
    assert any(world["marker"].encode() in blob for blob in payloads(page))


@pytest.mark.parametrize("uri,package_dirs", [
    ("package://robot/meshes/ok.stl", None),                     # the URDF's ROS package (ancestor + package.xml)
    ("meshes/ok.stl", None),                                      # relative to the URDF
    ("package://robot/meshes/../meshes/ok.stl", None),            # climbs, but stays inside
    ("package://meshes/ok.stl", {"meshes": "robot/meshes"}),      # a root given by the caller
    ("package://outside/secret.stl", {"outside": "."}),           # the caller may widen the roots; a URDF may not
], ids=["ros-package", "relative", "dotdot-inside", "user-package-dir", "user-root-outside"])
def test_allowed_paths_are_read(world, uri, package_dirs, monkeypatch):
    page, caught, opened_outside = export(world, uri, package_dirs, monkeypatch)
    assert opened_outside == []
    assert not [w for w in caught if issubclass(w.category, GeometryWarning)], [str(w.message) for w in caught]
    assert len(load_visuals(world["robot"] / "r.urdf", {k: world["tmp"] / v for k, v in
                                                          (package_dirs or {}).items()})) == 1


@pytest.mark.parametrize("name", ["", ".", "..", "a/b", "a\\b", "%2e%2e", "a b", "a\x00b", "-x", "robot/.."])
def test_package_names_refused(name, tmp_path):
    assert not valid_package_name(name)
    with pytest.raises(md.InputError, match="package"):
        check_package_dirs({name: tmp_path})


def test_package_dir_must_be_a_folder(tmp_path):
    with pytest.raises(md.InputError, match="not a folder"):
        check_package_dirs({"pkg": tmp_path / "missing"})


def _cli(*args, cwd):
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    return subprocess.run([sys.executable, "-m", "manipdyn.cli", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=300)


def test_cli_package_dir_and_refusal(world):
    urdf = world["robot"] / "r.urdf"
    urdf.write_text(robot_urdf("package://meshes/../../secret.stl"))
    r = _cli("play", str(urdf), "--html", "a.html", "--package-dir", f"meshes={world['robot'] / 'meshes'}",
             cwd=world["tmp"])
    assert r.returncode == 0, r.stderr
    assert "warning:" in r.stderr and "'arm'" in r.stderr and "secret.stl" in r.stderr
    assert world["marker"] not in (world["tmp"] / "a.html").read_text()
    urdf.write_text(robot_urdf("package://meshes/ok.stl"))
    r = _cli("play", str(urdf), "--html", "b.html", "--package-dir", f"meshes={world['robot'] / 'meshes'}",
             cwd=world["tmp"])
    assert r.returncode == 0 and "warning" not in r.stderr, r.stderr
    for bad in ("meshes", "=x", "../x=" + str(world["tmp"]), f"m={world['tmp'] / 'missing'}"):
        r = _cli("play", str(urdf), "--html", "c.html", "--package-dir", bad, cwd=world["tmp"])
        assert r.returncode == 2 and "--package-dir" in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr)
