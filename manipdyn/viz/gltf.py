"""A small glTF 2.0 reader: a ``.glb`` or ``.gltf`` (+ ``.bin`` buffers) as triangles, for playback.

Written here with numpy alone, no new dependency: the part of glTF a visual needs (a JSON document, binary
buffers, accessors, a node tree) is simple, and a general glTF library would add an untrusted-input surface
(extensions, image decoders, network URIs) whose work and file access we could not bound. A URDF's meshes
are hostile input (docs/design.md §9), so:

- buffers come only from the GLB's BIN chunk, a ``data:application/octet-stream;base64,`` (or
  ``application/gltf-buffer``) URI, or a file resolved (symlinks too) **inside the mesh file's own folder**:
  no absolute path, no URI scheme, no ``..`` or symlink that leaves the folder;
- the file and its buffers together are at most ``max_bytes``; the JSON is parsed with a size limit
  (NaN/Infinity and over-deep nesting refused); every count, offset, stride and index is checked against
  its buffer view and buffer before anything is read; the triangles are at most ``max_triangles``;
- the node tree is walked iteratively, each node at most once (a cycle or a node shared by two parents is
  refused), so the work is linear in the document;
- compressed or quantized data (Draco, meshopt, KHR_mesh_quantization) and sparse accessors are refused by
  name; primitives that are not TRIANGLES (mode 4) are skipped with a note.

What is read: the default scene (``scene``, else scene 0), its nodes with their transforms (``matrix``,
column-major, or ``translation`` · ``rotation`` (x, y, z, w) · ``scale``), each mesh primitive's
``POSITION`` (FLOAT VEC3) and ``indices`` (UNSIGNED_BYTE/SHORT/INT SCALAR, or none), honouring the buffer
view's ``byteOffset``/``byteStride`` and the accessor's ``byteOffset``; and the first primitive's
``pbrMetallicRoughness.baseColorFactor``. Any refusal raises GltfError with the reason.

Axes: glTF is y-up (+Y up, +Z forward, metres), a URDF link z-up. The triangles returned here are in the
file's own frame; viz/geometry.py turns them +90° about x, (x, y, z) → (x, -z, y), before the URDF's scale
and origin apply. That is what the tools that read glTF in robot descriptions do now: RViz since
ros2/rviz#1482 (2025; before it, assimp passed glTF vertices through unturned, and TRI's glTF robots lay on
their side, ros2/rviz#1229), Drake with its meshcat and Blender's importer (as that pull request reports).
urdfdom only passes the file name on; meshcat draws stl/obj/dae only. Pinocchio reads meshes through assimp
(hpp-fcl/coal), which as far as we know keeps glTF vertices unturned (not checked against its source): a file
authored for such a reader lies on its side here (turn its <origin> by -90° about x).
"""
from __future__ import annotations

import base64
import binascii
import json
import re
import stat
import struct
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import unquote

import numpy as np

MAX_JSON_BYTES = 16 << 20          # the JSON document of one glTF
MAX_TRIANGLES = 1_000_000          # per file: 50 MB of binary STL, under geometry.MAX_MESH_BYTES
MAX_BYTES = 64 << 20               # file + buffers, default (geometry passes its own limit)
MAX_ELEMENTS_PER_TRIANGLE = 8      # accessor elements read (positions + indices, all accessors) per triangle allowed
MAX_NOTES = 5                      # notes on skipped primitives kept (then a count)

_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
_DATA_URI = re.compile(r"data:application/(?:octet-stream|gltf-buffer);base64,", re.I)
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.\-]*:")
_COMPONENT = {5121: np.dtype("<u1"), 5123: np.dtype("<u2"), 5125: np.dtype("<u4"), 5126: np.dtype("<f4")}
_COMPONENT_NAME = {5120: "BYTE", 5121: "UNSIGNED_BYTE", 5122: "SHORT", 5123: "UNSIGNED_SHORT",
                   5125: "UNSIGNED_INT", 5126: "FLOAT"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_REFUSED_EXTENSIONS = {
    "KHR_draco_mesh_compression": "Draco-compressed meshes",
    "EXT_meshopt_compression": "meshopt-compressed buffers",
    "KHR_meshopt_compression": "meshopt-compressed buffers",
    "KHR_mesh_quantization": "quantized vertex data",
}
_MODES = {0: "POINTS", 1: "LINES", 2: "LINE_LOOP", 3: "LINE_STRIP", 4: "TRIANGLES", 5: "TRIANGLE_STRIP",
          6: "TRIANGLE_FAN"}


class GltfError(Exception):
    """A glTF file that is refused; the message says why."""


@dataclass
class Gltf:
    """What a glTF file draws: triangles (N, 3, 3) float32 in the file's frame (metres), the first primitive's
    base colour (4 floats in [0, 1]) or None, notes on what was skipped, and the bytes read (file + buffers)."""
    triangles: np.ndarray
    rgba: tuple | None = None
    notes: list = field(default_factory=list)
    bytes_read: int = 0


def read_gltf(path, max_bytes=None, max_triangles=None) -> Gltf:
    """The triangles of the default scene of a .glb or .gltf file; GltfError says why a file is refused.

    ``max_bytes`` bounds the file and its buffers together (default MAX_BYTES), ``max_triangles`` the
    triangles drawn, every instance counted (default MAX_TRIANGLES)."""
    try:
        return _Reader(Path(path), MAX_BYTES if max_bytes is None else max_bytes,
                       MAX_TRIANGLES if max_triangles is None else max_triangles).read()
    except GltfError:
        raise
    except (ValueError, TypeError, KeyError, IndexError, OverflowError, AttributeError, struct.error) as exc:
        raise GltfError(f"malformed glTF ({type(exc).__name__}: {exc})") from None


def binary_stl(triangles) -> bytes:
    """A binary STL of triangles (N, 3, 3): 80-byte header, count, then normal, 3 vertices, 0 per triangle."""
    tri = np.asarray(triangles, dtype=np.float64).reshape(-1, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n = np.divide(n, norm, out=np.zeros_like(n), where=norm > 0)
    rec = np.zeros(len(tri), dtype=[("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"], rec["v"] = n, tri
    header = b"manipdyn: converted from glTF".ljust(80, b" ")
    return header + struct.pack("<I", len(tri)) + rec.tobytes()


class _Reader:
    def __init__(self, path: Path, max_bytes: int, max_triangles: int):
        self.path, self.max_bytes, self.max_triangles = path, max_bytes, max_triangles
        self.root = path.resolve().parent
        self.bytes_read = 0
        self.bin = None                 # the GLB's BIN chunk
        self.buffers = {}               # index -> bytes, loaded when an accessor needs them
        self.accessors = {}             # index -> array, each accessor read once
        self.elements = 0               # accessor elements read, at most MAX_ELEMENTS_PER_TRIANGLE * max_triangles
        self.notes = []

    # ------------------------------------------------------------------ files and buffers
    def _read_file(self, path: Path, what: str) -> bytes:
        try:
            info = path.stat()
        except OSError:
            raise GltfError(f"{what} not found") from None
        if not stat.S_ISREG(info.st_mode):
            raise GltfError(f"{what} is not a regular file")
        room = self.max_bytes - self.bytes_read
        if info.st_size > room:
            raise GltfError(f"{what}: {info.st_size} bytes, more than the {room} left of the {self.max_bytes} "
                            f"a glTF and its buffers may have")
        with open(path, "rb") as fh:
            data = fh.read(room + 1)
        if len(data) > room:
            raise GltfError(f"{what}: more than the {self.max_bytes} bytes a glTF and its buffers may have")
        self.bytes_read += len(data)
        return data

    def read(self) -> Gltf:
        data = self._read_file(self.path, f"glTF file {self.path.name!r}")
        if data[:4] == b"glTF":
            doc = self._glb(data)
        elif self.path.suffix.lower() == ".glb":
            raise GltfError(f"not a GLB file (magic {data[:4]!r}, expected b'glTF')")
        else:
            doc = self._json(data.removeprefix(b"\xef\xbb\xbf"))
        return self._document(doc)

    def _glb(self, data: bytes):
        if len(data) < 20:
            raise GltfError(f"GLB truncated: {len(data)} bytes, less than a header and a chunk header")
        _, version, length = struct.unpack_from("<III", data, 0)
        if version != 2:
            raise GltfError(f"GLB version {version} (only glTF 2 is read)")
        if length != len(data):
            raise GltfError(f"GLB header says {length} bytes, the file has {len(data)} (truncated or padded)")
        chunks, at = [], 12
        while at < length:
            if at + 8 > length:
                raise GltfError(f"GLB chunk header at byte {at} runs past the end ({length} bytes)")
            size, kind = struct.unpack_from("<II", data, at)
            if at + 8 + size > length:
                raise GltfError(f"GLB chunk at byte {at} says {size} bytes, past the end ({length} bytes)")
            chunks.append((kind, data[at + 8:at + 8 + size]))
            at += 8 + size
        if not chunks or chunks[0][0] != _JSON_CHUNK:
            raise GltfError("GLB: the first chunk is not JSON")
        if len(chunks) > 1 and chunks[1][0] == _BIN_CHUNK:
            self.bin = chunks[1][1]
        return self._json(chunks[0][1])

    def _json(self, text: bytes):
        if len(text) > MAX_JSON_BYTES:
            raise GltfError(f"JSON of {len(text)} bytes, more than the {MAX_JSON_BYTES} read")

        def no_constant(name):
            raise GltfError(f"JSON holds {name} (not a JSON number)")
        try:
            doc = json.loads(text.decode("utf-8"), parse_constant=no_constant)
        except UnicodeDecodeError:
            raise GltfError("the JSON is not UTF-8") from None
        except RecursionError:
            raise GltfError("the JSON is nested too deeply") from None
        except ValueError as exc:           # json.JSONDecodeError, over-long integers
            raise GltfError(f"not JSON ({exc})") from None
        if not isinstance(doc, dict):
            raise GltfError("the JSON document is not an object")
        version = _obj(doc.get("asset"), "asset").get("version")
        if not isinstance(version, str) or not version.startswith("2."):
            raise GltfError(f"asset.version {version!r} (only glTF 2.x is read)")
        return doc

    def _buffer(self, k: int) -> bytes:
        if k in self.buffers:
            return self.buffers[k]
        buf = _item(self.doc, "buffers", k)
        length = _int(buf, "byteLength", f"buffer {k}", lo=1)
        uri = buf.get("uri")
        if uri is None:
            if self.bin is None or k != 0:
                raise GltfError(f"buffer {k} has no uri and the file has no GLB BIN chunk for it")
            data = self.bin
        elif not isinstance(uri, str):
            raise GltfError(f"buffer {k}: uri {uri!r} is not a string")
        elif uri[:5].lower() == "data:":
            m = _DATA_URI.match(uri)
            if not m:
                raise GltfError(f"buffer {k}: data URI {uri[:40]!r} is not application/octet-stream;base64")
            if (len(uri) - m.end()) * 3 // 4 > self.max_bytes - self.bytes_read:
                raise GltfError(f"buffer {k}: data URI larger than the {self.max_bytes} bytes a glTF may have")
            try:
                data = base64.b64decode(uri[m.end():], validate=True)
            except (binascii.Error, ValueError):
                raise GltfError(f"buffer {k}: data URI is not valid base64") from None
            self.bytes_read += len(data)
        else:
            data = self._read_file(self._inside(uri, k), f"buffer {k} {uri!r}")
        if len(data) < length:
            raise GltfError(f"buffer {k}: {len(data)} bytes, less than its byteLength {length} (truncated)")
        self.buffers[k] = data[:length]
        return self.buffers[k]

    def _inside(self, uri: str, k: int) -> Path:
        """The buffer file a relative URI names, resolved and checked to lie inside the glTF file's folder."""
        rel = unquote(uri)
        if (_SCHEME.match(uri) or _SCHEME.match(rel) or rel.startswith(("/", "\\")) or "\\" in rel
                or "\x00" in rel or not rel):
            raise GltfError(f"buffer {k}: uri {uri!r} refused (only a relative path inside the glTF's folder "
                            f"{str(self.root)!r}, or a base64 data URI)")
        try:
            cand = (self.root / rel).resolve()
        except (OSError, RuntimeError, ValueError):
            cand = None
        if cand is None or not cand.is_relative_to(self.root):
            raise GltfError(f"buffer {k}: uri {uri!r} leaves the glTF's folder {str(self.root)!r}")
        return cand

    # ------------------------------------------------------------------ accessors
    def _accessor(self, k, what, types, components):
        """Accessor k as an (count, width) array; ``types``/``components`` are the allowed type and
        componentType values."""
        where = f"accessor {k} ({what})"
        if k in self.accessors and self.accessors[k][0] == (types, components):
            return self.accessors[k][1]
        acc = _item(self.doc, "accessors", k)
        if "sparse" in acc:
            raise GltfError(f"{where} is sparse (sparse accessors are not read)")
        ctype, atype = acc.get("componentType"), acc.get("type")
        if atype not in types or ctype not in components:
            quant = "KHR_mesh_quantization" in (self.doc.get("extensionsUsed") or [])
            raise GltfError(f"{where} is {_COMPONENT_NAME.get(ctype, ctype)} {atype}, expected "
                            f"{'/'.join(_COMPONENT_NAME[c] for c in components)} {'/'.join(types)}"
                            + (" (KHR_mesh_quantization: quantized vertex data is not read)" if quant else ""))
        count = _int(acc, "count", where, lo=1)
        if count > 3 * self.max_triangles:
            raise GltfError(f"{where}: count {count}, more than the {3 * self.max_triangles} vertices of the "
                            f"{self.max_triangles} triangles a glTF file may draw")
        self.elements += count
        if self.elements > MAX_ELEMENTS_PER_TRIANGLE * self.max_triangles:
            raise GltfError(f"accessors of more than {MAX_ELEMENTS_PER_TRIANGLE * self.max_triangles} elements "
                            f"in all ({MAX_ELEMENTS_PER_TRIANGLE} per triangle of the {self.max_triangles} a glTF "
                            f"file may draw)")
        if "bufferView" not in acc:
            raise GltfError(f"{where} has no bufferView (an all-zero accessor draws nothing)")
        bv_k = _int(acc, "bufferView", where)
        view = _item(self.doc, "bufferViews", bv_k)
        _refuse_extensions(view, f"bufferView {bv_k}")
        dt, width = _COMPONENT[ctype], _WIDTH[atype]
        elem = dt.itemsize * width
        buf = self._buffer(_int(view, "buffer", f"bufferView {bv_k}"))
        v_off = _int(view, "byteOffset", f"bufferView {bv_k}", default=0)
        v_len = _int(view, "byteLength", f"bufferView {bv_k}", lo=1)
        if v_off + v_len > len(buf):
            raise GltfError(f"bufferView {bv_k}: bytes {v_off}..{v_off + v_len} lie past its buffer "
                            f"({len(buf)} bytes)")
        stride = _int(view, "byteStride", f"bufferView {bv_k}", default=0) or elem
        if stride < elem or stride % dt.itemsize:
            raise GltfError(f"bufferView {bv_k}: byteStride {stride} is shorter than an element ({elem} bytes) "
                            f"or not a multiple of its component size")
        a_off = _int(acc, "byteOffset", where, default=0)
        end = a_off + stride * (count - 1) + elem
        if end > v_len:
            raise GltfError(f"{where}: {count} elements from byte {a_off} with stride {stride} end at byte "
                            f"{end}, past its bufferView {bv_k} ({v_len} bytes)")
        out = np.ndarray((count, width), dtype=dt, buffer=buf, offset=v_off + a_off,
                         strides=(stride, dt.itemsize)).copy()
        self.accessors[k] = ((types, components), out)
        return out

    # ------------------------------------------------------------------ document
    def _document(self, doc) -> Gltf:
        self.doc = doc
        for name in doc.get("extensionsRequired") or []:
            if name in _REFUSED_EXTENSIONS:
                raise GltfError(f"extension {name} required ({_REFUSED_EXTENSIONS[name]} are not read)")
        scenes = doc.get("scenes")
        if not isinstance(scenes, list) or not scenes:
            raise GltfError("the file has no scene")
        s = _int(doc, "scene", "the document", default=0)
        roots = _obj(_item(doc, "scenes", s), f"scene {s}").get("nodes", [])
        if not isinstance(roots, list):
            raise GltfError(f"scene {s}: nodes is not a list")
        out, rgba, ntri, cache = [], None, 0, {}
        seen, stack = set(), [(n, np.eye(4)) for n in reversed(roots)]
        while stack:
            n, parent = stack.pop()
            if isinstance(n, bool) or not isinstance(n, int):
                raise GltfError(f"node index {n!r} is not an integer")
            if n in seen:
                raise GltfError(f"node {n} is reached twice (a cycle, or a node with two parents)")
            seen.add(n)
            node = _item(doc, "nodes", n)
            M = parent @ _local(node, n)
            if "mesh" in node:
                m = _int(node, "mesh", f"node {n}")
                for p, prim in enumerate(_list(_item(doc, "meshes", m), "primitives", f"mesh {m}")):
                    if (m, p) not in cache:
                        cache[m, p] = self._primitive(m, p, _obj(prim, f"mesh {m} primitive {p}"))
                    tri = cache[m, p]
                    if tri is None:
                        continue
                    ntri += len(tri)
                    if ntri > self.max_triangles:
                        raise GltfError(f"more than the {self.max_triangles} triangles a glTF file may draw")
                    world = (tri.reshape(-1, 3) @ M[:3, :3].T + M[:3, 3]).astype(np.float32)
                    if not np.all(np.isfinite(world)):
                        raise GltfError(f"mesh {m} primitive {p} under node {n} has non-finite positions")
                    out.append(world.reshape(-1, 3, 3))
                    if rgba is None:
                        rgba = self._color(prim, m, p)
            children = node.get("children", [])
            if not isinstance(children, list):
                raise GltfError(f"node {n}: children is not a list")
            stack.extend((c, M) for c in reversed(children))
        if not out:
            raise GltfError("no triangles to draw" + (f" ({'; '.join(self.notes)})" if self.notes else ""))
        notes = self.notes[:MAX_NOTES] + ([f"... and {len(self.notes) - MAX_NOTES} more skipped primitives"]
                                          if len(self.notes) > MAX_NOTES else [])
        return Gltf(np.concatenate(out), rgba, notes, self.bytes_read)

    def _primitive(self, m, p, prim):
        """Primitive p of mesh m as (N, 3, 3) float64 triangles in the mesh frame, or None (with a note)."""
        where = f"mesh {m} primitive {p}"
        _refuse_extensions(prim, where)
        mode = _int(prim, "mode", where, default=4)
        if mode != 4:
            self.notes.append(f"{where} skipped: mode {mode} ({_MODES.get(mode, 'unknown')}), "
                              f"only TRIANGLES (4) are drawn")
            return None
        attrs = _obj(prim.get("attributes"), f"{where} attributes")
        if "POSITION" not in attrs:
            raise GltfError(f"{where} has no POSITION")
        pos = self._accessor(_int(attrs, "POSITION", where), f"{where} POSITION", ("VEC3",), (5126,))
        pos = pos.astype(np.float64)
        if not np.all(np.isfinite(pos)):
            bad = pos[~np.all(np.isfinite(pos), axis=1)][0]
            raise GltfError(f"{where} POSITION has non-finite values ({bad.tolist()})")
        if "indices" in prim:
            idx = self._accessor(_int(prim, "indices", where), f"{where} indices", ("SCALAR",),
                                 (5121, 5123, 5125))[:, 0].astype(np.int64)
            if len(idx) and idx.max() >= len(pos):
                raise GltfError(f"{where}: index {int(idx.max())} out of range ({len(pos)} positions)")
        else:
            idx = np.arange(len(pos))
        if len(idx) % 3:
            raise GltfError(f"{where}: {len(idx)} vertices is not a whole number of triangles")
        if len(idx) // 3 > self.max_triangles:
            raise GltfError(f"{where}: {len(idx) // 3} triangles, more than the {self.max_triangles} a glTF "
                            f"file may draw")
        return pos[idx].reshape(-1, 3, 3)

    def _color(self, prim, m, p):
        """The base colour of the primitive's material (rgba in [0, 1]) or None; a bad one is a note."""
        if "material" not in prim:
            return None
        mat = _item(self.doc, "materials", _int(prim, "material", f"mesh {m} primitive {p}"))
        pbr = mat.get("pbrMetallicRoughness") or {}
        c = pbr.get("baseColorFactor") if isinstance(pbr, dict) else None
        if c is None:
            return None
        if (not isinstance(c, list) or len(c) != 4 or not all(_real(x) for x in c)
                or not all(0 <= x <= 1 for x in c)):
            self.notes.append(f"baseColorFactor {c!r} ignored (4 numbers in [0, 1] expected)")
            return None
        return tuple(float(x) for x in c)


# ---------------------------------------------------------------------- JSON helpers
def _real(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and np.isfinite(x)


def _obj(x, where) -> dict:
    if not isinstance(x, dict):
        raise GltfError(f"{where} is missing or not an object")
    return x


def _list(obj, key, where) -> list:
    x = obj.get(key)
    if not isinstance(x, list):
        raise GltfError(f"{where}: {key} is missing or not a list")
    return x


def _item(doc, key, k) -> dict:
    """doc[key][k], checked: a list, an integer index in range, an object."""
    items = doc.get(key)
    if not isinstance(items, list) or isinstance(k, bool) or not isinstance(k, int) or not 0 <= k < len(items):
        n = len(items) if isinstance(items, list) else 0
        raise GltfError(f"{key}[{k!r}] does not exist ({n} {key})")
    return _obj(items[k], f"{key}[{k}]")


def _int(obj, key, where, default=None, lo=0) -> int:
    v = obj.get(key, default)
    if v is None:
        raise GltfError(f"{where} has no {key}")
    if isinstance(v, bool) or not isinstance(v, int) or v < lo:
        raise GltfError(f"{where}: {key} = {v!r} is not an integer >= {lo}")
    return v


def _refuse_extensions(obj, where):
    for name in obj.get("extensions") or {}:
        if name in _REFUSED_EXTENSIONS:
            raise GltfError(f"{where} uses {name} ({_REFUSED_EXTENSIONS[name]} are not read)")


def _numbers(node, key, n, where):
    v = node.get(key)
    if not isinstance(v, list) or len(v) != n or not all(_real(x) for x in v):
        raise GltfError(f"{where}: {key} {v!r} is not {n} finite numbers")
    return np.array(v, dtype=float)


def quaternion_matrix(x, y, z, w) -> np.ndarray:
    """The rotation of a unit quaternion given as glTF stores it: (x, y, z, w)."""
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _local(node, n) -> np.ndarray:
    """The node's transform to its parent: ``matrix`` (column-major) or T · R · S."""
    where = f"node {n}"
    if "matrix" in node:
        return _numbers(node, "matrix", 16, where).reshape(4, 4).T
    M = np.eye(4)
    if "rotation" in node:
        q = _numbers(node, "rotation", 4, where)
        norm = np.linalg.norm(q)
        if not 0.5 < norm < 2:
            raise GltfError(f"{where}: rotation {q.tolist()} is not a unit quaternion")
        M[:3, :3] = quaternion_matrix(*(q / norm))
    if "scale" in node:
        M[:3, :3] = M[:3, :3] * _numbers(node, "scale", 3, where)
    if "translation" in node:
        M[:3, 3] = _numbers(node, "translation", 3, where)
    return M
