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
import struct
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


# ---------------------------------------------------------------------------------------------- glTF buffers
# A .gltf names its buffers by URI: they are read only inside the mesh file's own folder (robot/meshes/ here).
# The secret buffer (tmp/secret.bin, outside every root) holds a valid cube, so a reader that followed the URI
# would draw it; robot/stray.bin lies inside the URDF's folder but outside the mesh's folder: refused as well.
GLTF_URIS = [
    ("dotdot", "../../secret.bin"),
    ("dotdot-to-urdf-folder", "../stray.bin"),
    ("dotdot-percent", "%2e%2e/%2e%2e/secret.bin"),
    ("dotdot-backslash", "..\\..\\secret.bin"),
    ("absolute", "{S}"),
    ("file-uri", "file://{S}"),
    ("http-uri", "http://127.0.0.1:9/secret.bin"),
    ("symlink-file", "link.bin"),
    ("symlinked-folder", "up/secret.bin"),
    ("data-uri-not-octet-stream", "data:text/plain;base64,AAAA"),
]


@pytest.fixture
def gltf_world(world):
    from gltf_files import Builder
    b = Builder()
    b.cube()
    _, cube = b.gltf()
    secret = world["tmp"] / "secret.bin"
    secret.write_bytes(cube)
    (world["robot"] / "stray.bin").write_bytes(cube)
    (world["robot"] / "meshes" / "link.bin").symlink_to(secret)
    return dict(world, builder=b, cube=cube, secret_bin=secret)


def gltf_export(gltf_world, uri, monkeypatch):
    b = gltf_world["builder"]
    js, _ = b.gltf(uri.format(S=gltf_world["secret_bin"]))
    (gltf_world["robot"] / "meshes" / "arm.gltf").write_bytes(js)
    return export(gltf_world, "meshes/arm.gltf", None, monkeypatch)


@pytest.mark.parametrize("uri", [u for _, u in GLTF_URIS], ids=[i for i, _ in GLTF_URIS])
def test_gltf_buffer_outside_the_mesh_folder_is_never_read(gltf_world, uri, monkeypatch):
    page, caught, opened_outside = gltf_export(gltf_world, uri, monkeypatch)
    assert opened_outside == [], f"opened outside the roots: {opened_outside}"
    assert b"converted from glTF" not in b"".join(payloads(page))
    geo = [str(w.message) for w in caught if issubclass(w.category, GeometryWarning)]
    assert len(geo) == 1 and "'arm'" in geo[0] and "skipped" in geo[0], geo
    shown = uri.format(S=gltf_world["secret_bin"])
    assert repr(shown[:40]) in geo[0] or repr(shown) in geo[0], geo[0]


def test_gltf_buffer_inside_the_mesh_folder_is_read(gltf_world, monkeypatch):
    # control: the same buffer beside the .gltf is read and the cube is drawn (so the cases above can fail)
    (gltf_world["robot"] / "meshes" / "cube.bin").write_bytes(gltf_world["cube"])
    page, caught, opened_outside = gltf_export(gltf_world, "cube.bin", monkeypatch)
    assert opened_outside == [] and not [w for w in caught if issubclass(w.category, GeometryWarning)]
    assert b"converted from glTF" in b"".join(payloads(page))


# ------------------------------------------------------------------------------------- malformed glTF files
def _with(edit, form="glb"):
    """A case: apply ``edit`` to the builder of a cube (it may return the file's bytes itself)."""
    def make(b):
        out = edit(b)
        if isinstance(out, bytes):
            return out
        return b.glb() if form == "glb" else b.gltf(None)[0]
    return make


def _deep_json(b):
    return b'{"asset": {"version": "2.0"}, "x": ' + b"[" * 200000 + b"]" * 200000 + b"}"


def _glb_chunk_past_end(b):
    data = bytearray(b.glb())
    struct.pack_into("<I", data, 12, 10 ** 6)
    return bytes(data)


def _instances(b):
    mesh = b.doc["nodes"][0]["mesh"]
    for _ in range(200):
        b.node(root=True, mesh=mesh)


def _many_accessors(b):
    # three distinct accessors of 2900 positions each over one view, one triangle each: few triangles, but
    # 8700 elements read, more than the 8 per allowed triangle (8000)
    view = b.view(np.zeros((2900, 3), "<f4").tobytes())
    for _ in range(3):
        pos = b.accessor(view, 5126, "VEC3", 2900)
        b.node(root=True, mesh=b.mesh({"attributes": {"POSITION": pos}, "indices": b.indices([0, 1, 2])}))


def _set(path, value):
    def edit(b):
        obj = b.doc
        for key in path[:-1]:
            obj = obj[key]
        obj[path[-1]] = value
    return edit


def _positions(P):
    def edit(b):
        b.doc["accessors"][0]["bufferView"] = b.view(np.asarray(P, "<f4").tobytes())
    return edit


BAD_GLTF = {   # id: (file bytes from the cube's builder, text the warning must quote)
    "glb-truncated": (lambda b: b.glb()[:-10], "truncated"),
    "glb-header-only": (lambda b: b.glb()[:12], "truncated"),
    "glb-wrong-magic": (lambda b: b"glTX" + b.glb()[4:], "magic"),
    "glb-version-1": (lambda b: b.glb(version=1), "version 1"),
    "glb-chunk-past-end": (_glb_chunk_past_end, "past the end"),
    "json-not-json": (lambda b: b"{not json", "not JSON"),
    "json-array": (lambda b: b"[1, 2]", "not an object"),
    "json-nan": (_with(_set(["nodes", 0, "translation"], [float("nan"), 0, 0]), "gltf"), "NaN"),
    "json-deep": (_deep_json, "nested too deeply"),
    "asset-version-1": (_with(_set(["asset", "version"], "1.0")), "asset.version"),
    "no-scene": (_with(_set(["scenes"], [])), "no scene"),
    "accessor-count-past-view": (_with(_set(["accessors", 0, "count"], 9)), "past its bufferView"),
    "accessor-offset-huge": (_with(_set(["accessors", 0, "byteOffset"], 2 ** 62)), "past its bufferView"),
    "accessor-count-huge": (_with(_set(["accessors", 0, "count"], 10 ** 15)), "count 1000000000000000"),
    "view-past-buffer": (_with(_set(["bufferViews", 0, "byteLength"], 10 ** 9)), "past its buffer"),
    "view-stride-short": (_with(_set(["bufferViews", 0, "byteStride"], 4)), "byteStride 4"),
    "buffer-longer-than-data": (_with(_set(["buffers", 0, "byteLength"], 10 ** 6)), "truncated"),
    "index-out-of-range": (_with(lambda b: b.doc["accessors"][1].update(bufferView=b.view(
        np.array([0, 1, 8] * 12, "<u2").tobytes()))), "index 8 out of range"),
    "index-count-not-triangles": (_with(_set(["accessors", 1, "count"], 35)), "whole number of triangles"),
    "index-type-float": (_with(_set(["accessors", 1, "componentType"], 5126)), "FLOAT SCALAR"),
    "node-cycle": (_with(lambda b: [b.node(children=[0]), _set(["nodes", 0, "children"], [1])(b)]),
                   "reached twice"),
    "node-self-cycle": (_with(_set(["nodes", 0, "children"], [0])), "reached twice"),
    "node-shared-child": (_with(lambda b: [b.node(root=True, children=[0])]), "reached twice"),
    "node-index-missing": (_with(_set(["scenes", 0, "nodes"], [7])), "nodes[7] does not exist"),
    "node-index-bool": (_with(_set(["nodes", 0, "mesh"], True)), "mesh = True"),
    "triangle-budget": (_with(_instances), "more than the 1000 triangles"),
    "accessor-element-budget": (_with(_many_accessors), "accessors of more than 8000 elements"),
    "positions-nan": (_with(_positions(np.where(np.arange(24).reshape(8, 3) == 5, np.nan, 0.5))), "non-finite"),
    "positions-inf": (_with(_positions(np.full((8, 3), np.inf))), "non-finite"),
    "positions-overflow-by-matrix": (_with(_set(["nodes", 0, "matrix"], [1e300, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0,
                                                                         0, 0, 0, 1])), "non-finite positions"),
    "rotation-not-unit": (_with(_set(["nodes", 0, "rotation"], [0, 0, 0, 0])), "not a unit quaternion"),
    "matrix-short": (_with(_set(["nodes", 0, "matrix"], [1, 0, 0])), "not 16 finite numbers"),
    "sparse-accessor": (_with(_set(["accessors", 0, "sparse"], {"count": 1})), "sparse"),
    "draco": (_with(_set(["meshes", 0, "primitives", 0, "extensions"], {"KHR_draco_mesh_compression": {}})),
              "KHR_draco_mesh_compression"),
    "meshopt": (_with(_set(["bufferViews", 0, "extensions"], {"EXT_meshopt_compression": {}})),
                "EXT_meshopt_compression"),
    "quantization-required": (_with(_set(["extensionsRequired"], ["KHR_mesh_quantization"])),
                              "KHR_mesh_quantization"),
    "quantized-positions": (_with(lambda b: [_set(["extensionsUsed"], ["KHR_mesh_quantization"])(b),
                                             _set(["accessors", 0, "componentType"], 5123)(b)]),
                            "KHR_mesh_quantization"),
    "lines-only": (_with(_set(["meshes", 0, "primitives", 0, "mode"], 1)), "mode 1 (LINES)"),
    "data-uri-bad-base64": (lambda b: b.gltf(None)[0].replace(b";base64,", b";base64,!!"), "base64"),
    "bin-missing": (lambda b: b.gltf("missing.bin")[0], "not found"),
}


@pytest.mark.parametrize("make,quoted", list(BAD_GLTF.values()), ids=list(BAD_GLTF))
def test_bad_gltf_is_skipped_with_a_warning(make, quoted, tmp_path, monkeypatch):
    from gltf_files import Builder, robot_with_mesh

    from manipdyn.viz import gltf
    monkeypatch.setattr(gltf, "MAX_TRIANGLES", 1000)
    b = Builder()
    b.cube()
    data = make(b)
    name = "arm.glb" if data[:4] in (b"glTF", b"glTX") else "arm.gltf"
    (tmp_path / name).write_bytes(data)
    path = robot_with_mesh(tmp_path, name)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert load_visuals(path) == []
    texts = [str(w.message) for w in caught if issubclass(w.category, GeometryWarning)]
    assert len(texts) == 1 and "link 'arm'" in texts[0] and name in texts[0] and quoted in texts[0], texts


def test_gltf_larger_than_the_mesh_limit(tmp_path, monkeypatch):
    # the .gltf is small, its buffer is not: the file and its buffers count together against the limit
    from gltf_files import Builder, robot_with_mesh

    from manipdyn.viz import geometry
    b = Builder()
    b.cube()
    js, bn = b.gltf("cube.bin")
    (tmp_path / "arm.gltf").write_bytes(js)
    (tmp_path / "cube.bin").write_bytes(bn)
    monkeypatch.setattr(geometry, "MAX_MESH_BYTES", len(js) + len(bn) - 1)
    with pytest.warns(GeometryWarning, match=r"buffer 0 'cube.bin': \d+ bytes, more than"):
        assert load_visuals(robot_with_mesh(tmp_path, "arm.gltf")) == []
    monkeypatch.setattr(geometry, "MAX_MESH_BYTES", len(js) + len(bn))
    assert len(load_visuals(robot_with_mesh(tmp_path, "arm.gltf"))) == 1
