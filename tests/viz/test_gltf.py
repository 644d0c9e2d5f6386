"""glTF 2.0 meshes (manipdyn/viz/gltf.py): small files written by hand (tests/gltf_files.py) read back as the
triangles they describe — vertices moved by transforms computed here independently (Rodrigues, not a
quaternion formula), a cube's volume and area — and a URDF that names a .glb draws it in the exported page,
turned from glTF's y-up into the link's z-up."""
from __future__ import annotations

import base64
import json
import re
import struct
import warnings

import numpy as np
import pytest
from conftest import assert_close
from gltf_files import CUBE_F, CUBE_V, U8, U16, U32, Builder, robot_with_mesh, volume_area

import manipdyn as md
from manipdyn import viz
from manipdyn.errors import GeometryWarning
from manipdyn.viz.geometry import DEFAULT_RGBA, MESH_FORMATS, load_visuals
from manipdyn.viz.gltf import binary_stl, read_gltf

CUBE = CUBE_V[CUBE_F]                       # (12, 3, 3): the cube's triangles in its own frame


def rodrigues(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def moved(tri, M):
    """Triangles (N, 3, 3) under the 4×4 transform M."""
    return tri @ M[:3, :3].T + M[:3, 3]


def write(tmp_path, b, form, name="cube"):
    """The builder's file in ``form`` ('glb', 'gltf' + .bin, or 'data' for an embedded buffer); its path."""
    if form == "glb":
        (tmp_path / f"{name}.glb").write_bytes(b.glb())
        return tmp_path / f"{name}.glb"
    js, bn = b.gltf(None if form == "data" else f"{name}.bin")
    (tmp_path / f"{name}.gltf").write_bytes(js)
    if form == "gltf":
        (tmp_path / f"{name}.bin").write_bytes(bn)
    return tmp_path / f"{name}.gltf"


@pytest.mark.parametrize("form", ["glb", "gltf", "data"])
def test_cube_volume_area_and_vertices(form, tmp_path):
    b = Builder()
    b.cube(translation=[1.0, -2.0, 0.5])
    got = read_gltf(write(tmp_path, b, form))
    vol, area = volume_area(got.triangles)
    print(f"\n{form}: {len(got.triangles)} triangles, volume {vol!r}, area {area!r}, {got.bytes_read} bytes read")
    assert got.triangles.shape == (12, 3, 3) and got.triangles.dtype == np.float32 and not got.notes
    assert_close(vol, 1.0, 1e-12, "volume")          # outward winding kept: +1 (measured exact)
    assert_close(area, 6.0, 1e-12, "area")
    M = np.eye(4)
    M[:3, 3] = [1.0, -2.0, 0.5]
    assert_close(got.triangles, moved(CUBE, M), 0, "vertices")


@pytest.mark.parametrize("ctype", [U8, U16, U32, None], ids=["u8", "u16", "u32", "unindexed"])
def test_index_types_give_the_same_triangles(ctype, tmp_path):
    b = Builder()
    b.cube(ctype)
    got = read_gltf(write(tmp_path, b, "glb"))
    assert_close(got.triangles, CUBE, 0, "triangles")


def test_node_hierarchy_trs_and_matrix(tmp_path):
    # root (T·R·S) → child (matrix, column-major) → grandchild (rotation only) drawing the cube, and a second
    # root drawing it with a scale: each instance moved by the product of its ancestors' transforms
    axis, angle = [1.0, 2.0, 3.0], 0.7
    k = np.array(axis) / np.linalg.norm(axis)
    A = np.eye(4)
    A[:3, :3] = rodrigues(axis, angle) @ np.diag([1.0, 2.0, 0.5])
    A[:3, 3] = [0.3, -0.2, 1.1]
    B = np.eye(4)
    B[:3, :3] = rodrigues([0, 1, 0], -1.2) * 1.5
    B[:3, 3] = [-1.0, 0.25, 2.0]
    C = np.eye(4)
    C[:3, :3] = rodrigues([0, 0, 1], np.pi / 2)
    b = Builder()
    mesh = b.mesh({"attributes": {"POSITION": b.positions(CUBE_V)}, "indices": b.indices(CUBE_F)})
    grand = b.node(mesh=mesh, rotation=[0.0, 0.0, np.sin(np.pi / 4), np.cos(np.pi / 4)])
    child = b.node(matrix=B.T.ravel().tolist(), children=[grand])
    b.node(root=True, translation=A[:3, 3].tolist(), scale=[1.0, 2.0, 0.5], children=[child],
           rotation=(np.r_[k * np.sin(angle / 2), np.cos(angle / 2)]).tolist())
    b.node(root=True, mesh=mesh, scale=[2.0, 3.0, 4.0])
    got = read_gltf(write(tmp_path, b, "gltf"))
    want = np.concatenate([moved(CUBE, A @ B @ C), moved(CUBE, np.diag([2.0, 3.0, 4.0, 1.0]))])
    err = np.abs(got.triangles - want).max()
    print(f"\nhierarchy: max vertex error {err:.2e} (float32 vertices)")
    assert_close(got.triangles, want, 1e-5, "vertices")     # float32 storage; measured 1.2e-7
    vol = volume_area(got.triangles[:12])[0]
    assert_close(vol, np.linalg.det(A[:3, :3] @ B[:3, :3]), 1e-5, "volume of the nested instance")


@pytest.mark.parametrize("stride,offset,lead", [(24, 0, 0), (24, 12, 8), (32, 4, 4)])
def test_interleaved_buffer_views(stride, offset, lead, tmp_path):
    # positions interleaved with another attribute (byteStride), the accessor starting inside each element
    # (accessor byteOffset) and the view not at the buffer's start (bufferView byteOffset)
    b = Builder()
    b.view(b"\x01" * 20, lead=lead)                   # something else first in the buffer
    pos = b.positions(CUBE_V, stride=stride, offset=offset)
    b.node(root=True, mesh=b.mesh({"attributes": {"POSITION": pos}, "indices": b.indices(CUBE_F, U8)}))
    assert b.doc["bufferViews"][-2]["byteStride"] == stride and b.doc["bufferViews"][-2]["byteOffset"] > 0
    got = read_gltf(write(tmp_path, b, "glb"))
    assert_close(got.triangles, CUBE, 0, "triangles")


def test_non_triangle_primitives_are_skipped_with_a_note(tmp_path):
    b = Builder()
    lines = {"attributes": {"POSITION": b.positions(CUBE_V)}, "mode": 1}
    tris = {"attributes": {"POSITION": b.positions(CUBE_V)}, "indices": b.indices(CUBE_F)}
    b.node(root=True, mesh=b.mesh(lines, tris))
    got = read_gltf(write(tmp_path, b, "glb"))
    assert len(got.triangles) == 12 and len(got.notes) == 1 and "mode 1 (LINES)" in got.notes[0]
    b.doc["meshes"][0]["primitives"] = [dict(lines, mode=m) for m in (0, 1, 2, 3, 5, 6, 0)] + [tris]
    got = read_gltf(write(tmp_path, b, "glb"))          # at most 5 notes, then a count
    assert len(got.triangles) == 12 and len(got.notes) == 6 and got.notes[-1] == "... and 2 more skipped primitives"
    assert "mode 5 (TRIANGLE_STRIP)" in got.notes[4]
    # load_visuals draws the visual and warns about the skipped primitives, naming the link
    path = robot_with_mesh(tmp_path, "cube.glb")
    with pytest.warns(GeometryWarning, match=r"link 'arm': visual 0: mesh 'cube.glb': mesh 0 primitive 0 skipped"):
        assert len(load_visuals(path)) == 1


def test_binary_stl_layout():
    tri = moved(CUBE, np.diag([1.0, 2.0, 3.0, 1.0]))
    data = binary_stl(tri)
    assert len(data) == 84 + 50 * 12 and struct.unpack_from("<I", data, 80) == (12,)
    rec = np.frombuffer(data, dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")], offset=84)
    assert_close(rec["v"], tri, 0, "vertices")
    # each normal is the unit outward normal: along ±x, ±y or ±z and pointing away from the centre
    assert_close(np.linalg.norm(rec["n"], axis=1), np.ones(12), 1e-7, "|n|")
    assert np.all(np.einsum("ij,ij->i", rec["n"].astype(float), tri.mean(axis=1)) > 0)


def test_urdf_with_glb_loads_and_its_page_is_written(tmp_path):
    assert MESH_FORMATS[".glb"] == MESH_FORMATS[".gltf"] == "gltf"
    (tmp_path / "meshes").mkdir()
    b = Builder()
    b.cube(translation=[0.0, 0.2, 0.0], scale=[0.1, 0.2, 0.3])        # 0.2 m up (+y) in the y-up file
    b.doc["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.1, 0.2, 1.0]}}]
    b.doc["meshes"][0]["primitives"][0]["material"] = 0
    (tmp_path / "meshes" / "arm.glb").write_bytes(b.glb())
    path = robot_with_mesh(tmp_path, "meshes/arm.glb")
    with warnings.catch_warnings():
        warnings.simplefilter("error", GeometryWarning)
        (vis,) = load_visuals(path)
    assert vis.link == "arm" and vis.rgba == (0.9, 0.1, 0.2, 1.0)
    assert vis.geometry.mesh_format == "stl"
    # a URDF <material> wins over the file's colour
    path = robot_with_mesh(tmp_path, "meshes/arm.glb", '<material name="m"><color rgba="0 1 0 1"/></material>')
    assert load_visuals(path)[0].rgba == (0.0, 1.0, 0.0, 1.0)
    b.doc.pop("materials")
    b.doc["meshes"][0]["primitives"][0].pop("material")
    (tmp_path / "meshes" / "arm.glb").write_bytes(b.glb())
    assert load_visuals(robot_with_mesh(tmp_path, "meshes/arm.glb"))[0].rgba == DEFAULT_RGBA
    # the page carries the converted STL: the cube's 12 triangles, scaled and lifted as the file says, turned from
    # glTF's y-up into the link's z-up: file (x, y, z) is link (x, -z, y), so "up" stays up
    model = md.load_urdf(path)
    page = tmp_path / "g.html"
    with warnings.catch_warnings():
        warnings.simplefilter("error", GeometryWarning)
        viz.export_html(model, path, np.linspace(0, 1, 5), np.zeros((5, 1)), page)
    m = re.search(r'<script type="application/json" id="manipdyn-commands">(.*?)</script>', page.read_text(), re.S)
    blobs = [base64.b64decode(x) for x in json.loads(m.group(1))]
    hits = [blob for blob in blobs if b"manipdyn: converted from glTF" in blob]
    assert len(hits) == 1
    blob = hits[0]
    at = blob.index(b"manipdyn: converted from glTF")
    assert struct.unpack_from("<I", blob, at + 80) == (12,)
    rec = np.frombuffer(blob, dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")], count=12,
                        offset=at + 84)
    v = CUBE * [0.1, 0.2, 0.3]
    want = np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1) + [0.0, 0.0, 0.2]
    assert_close(rec["v"], want, 1e-7, "vertices in the page")
    assert_close(rec["v"].reshape(-1, 3).max(axis=0), [0.05, 0.15, 0.3], 1e-7, "upper corner in the link frame")
    assert_close(volume_area(rec["v"])[0], 0.006, 1e-9, "volume (a rotation keeps the winding)")



def test_viewer_parses_the_converted_stl(tmp_path):
    # in headless Chromium the bundled meshcat viewer turns the page's STL into the cube's 36 vertices, in the
    # link frame (glTF's +y up is the link's +z)
    from browser import HAVE_BROWSER, Browser
    if not HAVE_BROWSER:
        pytest.skip("Debian's chromium and chromium-driver are not installed")
    (tmp_path / "meshes").mkdir()
    b = Builder()
    b.cube(translation=[0.0, 0.2, 0.0], scale=[0.1, 0.2, 0.3])
    (tmp_path / "meshes" / "arm.glb").write_bytes(b.glb())
    path = robot_with_mesh(tmp_path, "meshes/arm.glb")
    page = tmp_path / "g.html"
    viz.export_html(md.load_urdf(path), path, np.linspace(0, 1, 5), np.zeros((5, 1)), page)
    found = []
    with Browser(800, 600) as br:
        br.open(f"file://{page}")
        for _ in range(20):                      # the viewer parses mesh files as they arrive
            br.frames(3)
            found = br.run("""var out = [];
                viewer.scene_tree.find(['manipdyn']).object.traverse(function (o) {
                  if (o.isMesh && o.geometry.attributes.position && o.geometry.attributes.position.count === 36)
                    out.push(Array.from(o.geometry.attributes.position.array)); });
                return out;""")
            if found:
                break
    assert len(found) == 1, f"{len(found)} meshes of 36 vertices in the viewer"
    v = CUBE * [0.1, 0.2, 0.3]
    want = np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1) + [0.0, 0.0, 0.2]
    assert_close(np.array(found[0]).reshape(12, 3, 3), want, 1e-7, "vertices the viewer drew")
