"""Small glTF 2.0 files written by hand for the tests (tests/viz/test_gltf.py, tests/robustness/test_viz_files.py).

Independent of manipdyn/viz/gltf.py: the bytes follow the glTF 2.0 specification directly."""
from __future__ import annotations

import base64
import json
import struct

import numpy as np

FLOAT, U8, U16, U32 = 5126, 5121, 5123, 5125
_NP = {FLOAT: "<f4", U8: "<u1", U16: "<u2", U32: "<u4"}

# a unit cube centred on the origin: 8 corners, 12 outward-facing (counter-clockwise) triangles
CUBE_V = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
CUBE_F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                   [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])


def volume_area(tri):
    """(signed volume, area) of a closed triangle surface (N, 3, 3), by the divergence theorem."""
    tri = np.asarray(tri, dtype=float)
    c = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    return np.einsum("ij,ij->", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])) / 6, np.linalg.norm(c, axis=1).sum() / 2


class Builder:
    """A glTF document and its one binary buffer, built piece by piece; ``glb()`` or ``gltf()`` writes it."""

    def __init__(self):
        self.bin = bytearray()
        self.doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": []}], "nodes": [],
                    "meshes": [], "accessors": [], "bufferViews": [], "buffers": [{"byteLength": 0}]}

    def view(self, data: bytes, stride=None, lead=0) -> int:
        """A buffer view over ``data``, starting 4-aligned after ``lead`` bytes of filler; its index."""
        self.bin += b"\0" * (-len(self.bin) % 4) + b"\xab" * lead
        bv = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            bv["byteStride"] = stride
        self.bin += data
        self.doc["buffers"][0]["byteLength"] = len(self.bin)
        self.doc["bufferViews"].append(bv)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, view, ctype, kind, count, offset=0) -> int:
        acc = {"bufferView": view, "componentType": ctype, "type": kind, "count": count}
        if offset:
            acc["byteOffset"] = offset
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def positions(self, P, stride=None, offset=0) -> int:
        """A FLOAT VEC3 accessor of P (n, 3); with ``stride`` each vertex is followed by filler (another
        attribute interleaved) and the accessor starts ``offset`` bytes into each element."""
        P = np.asarray(P, dtype="<f4")
        if stride is None:
            return self.accessor(self.view(P.tobytes()), FLOAT, "VEC3", len(P))
        rows = bytearray()
        for p in P:
            rows += b"\x7f" * offset + p.tobytes() + b"\x7f" * (stride - offset - 12)   # filler: NaN-ish bytes
        return self.accessor(self.view(bytes(rows), stride=stride), FLOAT, "VEC3", len(P), offset=offset)

    def indices(self, I, ctype=U16) -> int:
        I = np.asarray(I).ravel().astype(_NP[ctype])
        return self.accessor(self.view(I.tobytes()), ctype, "SCALAR", len(I))

    def mesh(self, *prims) -> int:
        self.doc["meshes"].append({"primitives": list(prims)})
        return len(self.doc["meshes"]) - 1

    def node(self, root=False, **kw) -> int:
        self.doc["nodes"].append(kw)
        k = len(self.doc["nodes"]) - 1
        if root:
            self.doc["scenes"][0]["nodes"].append(k)
        return k

    def cube(self, ctype=U16, root=True, **node) -> int:
        """A node drawing the unit cube (indexed with ``ctype``, or unindexed for None); its index."""
        if ctype is None:
            prim = {"attributes": {"POSITION": self.positions(CUBE_V[CUBE_F].reshape(-1, 3))}}
        else:
            prim = {"attributes": {"POSITION": self.positions(CUBE_V)}, "indices": self.indices(CUBE_F, ctype)}
        return self.node(root=root, mesh=self.mesh(prim), **node)

    def json_bytes(self) -> bytes:
        return json.dumps(self.doc).encode()

    def glb(self, version=2) -> bytes:
        """The binary GLB: header, JSON chunk (space-padded), BIN chunk (zero-padded)."""
        self.doc["buffers"][0].pop("uri", None)
        js = self.json_bytes()
        js += b" " * (-len(js) % 4)
        bn = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(bn), 0x004E4942) + bn
        return struct.pack("<III", 0x46546C67, version, 12 + len(body)) + body

    def gltf(self, uri="cube.bin") -> tuple:
        """(JSON text bytes, buffer bytes) with the buffer at ``uri``; uri=None embeds it as a data URI."""
        if uri is None:
            uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()
        self.doc["buffers"][0]["uri"] = uri
        return self.json_bytes(), bytes(self.bin)


def robot_with_mesh(folder, mesh_uri, material=""):
    """folder/r.urdf: a one-joint arm whose 'arm' link draws ``mesh_uri``; its path."""
    path = folder / "r.urdf"
    path.write_text(
        '<?xml version="1.0"?>\n<robot name="g"><link name="base"/><link name="arm"><inertial><mass value="1"/>'
        '<inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>'
        f'<visual><geometry><mesh filename="{mesh_uri}"/></geometry>{material}</visual></link>'
        '<joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/>'
        '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>\n')
    return path
