"""Visual geometry of a URDF, loaded only when a viewer asks for it (never by the dynamics path).

Each <visual> becomes (link, meshcat geometry, 4×4 placement in the link frame, rgba). A URDF is untrusted, so
its mesh files resolve only inside a root:

- a relative path, an absolute path or a ``file://`` URI: the URDF's own folder;
- ``package://<pkg>/<path>``: the folder the caller maps <pkg> to (``package_dirs={"pkg": dir}``, the CLI's
  ``--package-dir pkg=dir``), the installed example-robot-data (for <pkg> = example-robot-data), or an ancestor
  folder of the URDF named <pkg> that is a ROS package (holds a package.xml) or lies inside example-robot-data.

A package name must be a plain name (no empty name, no ``.``/``..``, no path separator). A path is resolved
(symlinks too) and only then checked to lie inside its root. Nothing the URDF says widens the roots. A visual
whose file is refused, missing, too large or of an unknown format, or whose numbers are bad (sizes ≤ 0 or
non-finite, a scale that is not 3 finite non-zero numbers, an rgba outside [0, 1]), is skipped with a
GeometryWarning naming the link and the value: nothing outside the roots is ever opened.

glTF 2.0 meshes (.gltf + .bin, .glb) are converted here to binary STL by viz/gltf.py (the bundled meshcat
viewer draws only stl, obj and dae); their buffers are read only inside the mesh file's own folder. Without a
URDF <material>, the first primitive's baseColorFactor colours the visual. glTF is y-up: its vertices are
turned into the z-up frame of a URDF link (GLTF_TO_URDF) before the URDF's scale and origin apply.
"""
from __future__ import annotations

import re
import stat
import warnings
from dataclasses import dataclass
from pathlib import Path
from urllib.parse import unquote, urlsplit

import numpy as np

from ..errors import GeometryWarning, InputError, URDFError
from ..extras import require
from ..spatial import rpy_matrix
from .gltf import GltfError, binary_stl, read_gltf

MAX_URDF_BYTES = 64 << 20        # a URDF larger than this is refused (the loader reads it whole)
MAX_MESH_BYTES = 64 << 20        # one mesh file (example-robot-data's largest: 29 MB)
MAX_MESH_TOTAL = 512 << 20       # all meshes of one URDF together
MESH_FORMATS = {".stl": "stl", ".obj": "obj", ".dae": "dae", ".gltf": "gltf", ".glb": "gltf"}
DEFAULT_RGBA = (0.7, 0.7, 0.75, 1.0)
# glTF is y-up (its spec), a URDF link z-up: a .gltf/.glb's vertices are turned +90° about x, (x, y, z) → (x, -z, y),
# as RViz (ros2/rviz#1482), Drake and Blender's importer do; see viz/gltf.py
GLTF_TO_URDF = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
_PACKAGE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]*\Z")
_NUMBER = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?\Z")   # plain ASCII decimal


@dataclass(frozen=True)
class Visual:
    link: str
    geometry: object          # a meshcat.geometry.Geometry
    placement: np.ndarray     # (4, 4) in the link frame (scale included for meshes)
    rgba: tuple               # 4 floats in [0, 1]


class _Skip(Exception):
    """A visual that is not drawn; the message says why (it becomes a GeometryWarning)."""


def meshcat_module(name="meshcat"):
    """meshcat (or one of its modules, or its umsgpack), imported on first use; MissingExtraError names the
    viz extra when it is not installed."""
    return require(name, "viz", "manipdyn play (3-D playback, HTML export)")


def valid_package_name(pkg) -> bool:
    """True for a plain package name: not empty, not '.' or '..', no path separator or other punctuation."""
    return isinstance(pkg, str) and pkg not in (".", "..") and bool(_PACKAGE_NAME.match(pkg))


def check_package_dirs(package_dirs) -> dict:
    """{name: resolved folder} of the caller's package roots; InputError names a bad name or folder."""
    out = {}
    for name, folder in (package_dirs or {}).items():
        if not valid_package_name(name):
            raise InputError(f"package_dirs: {name!r} is not a package name (letters, digits, _ . -)")
        try:
            path = Path(folder).resolve()
        except (OSError, RuntimeError, ValueError, TypeError):
            raise InputError(f"package_dirs[{name!r}]: {folder!r} is not a folder") from None
        if not path.is_dir():
            raise InputError(f"package_dirs[{name!r}]: {str(folder)!r} is not a folder")
        out[name] = path
    return out


def parse_package_dirs(items) -> dict:
    """{name: folder} from the CLI's repeated ``--package-dir NAME=DIR``; InputError names a bad item."""
    out = {}
    for item in items:
        name, sep, folder = item.partition("=")
        if not sep or not folder:
            raise InputError(f"--package-dir {item!r}: expected NAME=DIR")
        out[name] = folder
    try:
        check_package_dirs(out)
    except InputError as exc:
        raise InputError(f"--package-dir: {exc}") from None
    return out


def _installed_share():
    """example-robot-data's share folder (parent of robots/), or None when it is not installed."""
    try:
        from ..validation.zoo import robots_dir
        return robots_dir().parent.resolve()
    except Exception:          # not installed: no installed package roots
        return None


def package_roots(urdf_path: Path, pkg: str, package_dirs=None) -> list:
    """Folders (resolved) where package://<pkg>/ may point: the caller's, the installed one, a package ancestor."""
    if not valid_package_name(pkg):
        return []
    dirs = check_package_dirs(package_dirs)
    roots = [dirs[pkg]] if pkg in dirs else []
    share = _installed_share()
    if share is not None and pkg == "example-robot-data":
        roots.append(share)
    for p in Path(urdf_path).resolve().parents:
        if p.name == pkg and ((p / "package.xml").is_file()
                              or (share is not None and p.is_relative_to(share / "robots"))):
            roots.append(p)
    return roots


def _resolve_inside(root: Path, rel: str):
    """root/rel with symlinks resolved, or None when it leaves root (or cannot be resolved)."""
    try:
        cand = (root / rel).resolve()
    except (OSError, RuntimeError, ValueError):      # loops, over-long names
        return None
    return cand if cand.is_relative_to(root) else None


def resolve_mesh(filename: str, urdf_path, package_dirs=None) -> Path:
    """The mesh file a URDF names, resolved and checked to lie inside the URDF's folder or its package root.

    Raises URDFError (naming the URI) when the name is refused, leaves its root, or names no file."""
    urdf_path = Path(urdf_path)
    if not isinstance(filename, str) or not filename or "\x00" in filename:
        raise URDFError(f"{urdf_path}: mesh filename {filename!r} is empty or not a path")
    if filename.startswith("package://"):
        pkg, _, rel = filename[len("package://"):].partition("/")
        if not valid_package_name(pkg):
            raise URDFError(f"{urdf_path}: mesh {filename!r}: package name {pkg!r} refused "
                            f"(empty, '.', '..' or not a plain name)")
        roots = package_roots(urdf_path, pkg, package_dirs)
        if not roots:
            raise URDFError(f"{urdf_path}: mesh {filename!r}: package {pkg!r} is unknown "
                            f"(give its folder with package_dirs / --package-dir {pkg}=DIR)")
        for root in roots:
            cand = _resolve_inside(root, rel)
            if cand is not None and cand.is_file():
                return cand
        raise URDFError(f"{urdf_path}: mesh {filename!r} not found inside package {pkg!r} "
                        f"({', '.join(map(str, roots))}) or it leaves the package")
    if filename.startswith("file://"):
        parts = urlsplit(filename)
        if parts.netloc not in ("", "localhost"):
            raise URDFError(f"{urdf_path}: mesh {filename!r}: file URI with a host is refused")
        path = unquote(parts.path)
    elif re.match(r"[A-Za-z][A-Za-z0-9+.\-]*://", filename):
        raise URDFError(f"{urdf_path}: mesh {filename!r}: only package://, file:// and paths are read")
    else:
        path = filename
    root = urdf_path.resolve().parent
    cand = _resolve_inside(root, path)
    if cand is None:
        raise URDFError(f"{urdf_path}: mesh path {filename!r} leaves the URDF's folder {str(root)!r} "
                        f"(meshes elsewhere: package://<pkg>/... with --package-dir <pkg>=DIR)")
    if not cand.is_file():
        raise URDFError(f"{urdf_path}: mesh file {filename!r} not found")
    return cand


def load_visuals(urdf_path, package_dirs=None):
    """Every drawable <visual> of the URDF as Visual records; the others are skipped with a GeometryWarning.

    The XML is read with the loaders' hardened parser (io/safe_xml.py); meshcat is imported here, lazily."""
    from ..io.safe_xml import parse_xml
    urdf_path = Path(urdf_path)
    package_dirs = check_package_dirs(package_dirs)
    try:
        size = urdf_path.stat().st_size
    except OSError:
        raise URDFError(f"{urdf_path}: no such URDF file") from None
    if size > MAX_URDF_BYTES:
        raise URDFError(f"{urdf_path}: {size} bytes, more than the {MAX_URDF_BYTES} a URDF may have")
    root = parse_xml(urdf_path.read_bytes(), str(urdf_path))
    materials = {}
    for m in root.findall("material"):
        rgba = _material_rgba(m, {})
        if m.get("name") and rgba is not None:
            materials[m.get("name")] = rgba
    out, budget = [], [MAX_MESH_TOTAL]
    for link in root.findall("link"):
        for k, vis in enumerate(link.findall("visual")):
            notes = []
            try:
                out.append(_visual(link.get("name"), vis, urdf_path, package_dirs, materials, budget, notes))
            except _Skip as why:
                warnings.warn(f"{urdf_path}: link {link.get('name')!r}: visual {k} skipped: {why}",
                              GeometryWarning, stacklevel=2)
            for note in notes:                  # drawn, but part of it is not
                warnings.warn(f"{urdf_path}: link {link.get('name')!r}: visual {k}: {note}",
                              GeometryWarning, stacklevel=2)
    return out


def _visual(link, vis, urdf_path, package_dirs, materials, budget, notes=None) -> Visual:
    """One <visual> element as a Visual; _Skip says why it cannot be drawn."""
    g = meshcat_module("meshcat.geometry")
    T = np.eye(4)
    origin = vis.find("origin")
    if origin is not None:
        T[:3, :3] = rpy_matrix(_numbers(origin, "rpy", 3, "0 0 0"))
        T[:3, 3] = _numbers(origin, "xyz", 3, "0 0 0")
    given = _material_rgba(vis.find("material"), materials) if vis.find("material") is not None else None
    rgba = given or DEFAULT_RGBA
    geometry = vis.find("geometry")
    shapes = [] if geometry is None else [e for e in geometry if e.tag in ("box", "sphere", "cylinder", "mesh")]
    if len(shapes) != 1:
        raise _Skip(f"<geometry> needs exactly one of box, sphere, cylinder, mesh (found {len(shapes)})")
    shape, S = shapes[0], np.eye(4)
    if shape.tag == "box":
        return Visual(link, g.Box(list(_numbers(shape, "size", 3, None, positive=True))), T, rgba)
    if shape.tag == "sphere":
        return Visual(link, g.Sphere(float(_numbers(shape, "radius", 1, None, positive=True)[0])), T, rgba)
    if shape.tag == "cylinder":              # meshcat cylinders run along y, URDF ones along z
        r = _numbers(shape, "radius", 1, None, positive=True)[0]
        L = _numbers(shape, "length", 1, None, positive=True)[0]
        S[:3, :3] = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
        return Visual(link, g.Cylinder(float(L), float(r)), T @ S, rgba)
    scale = _numbers(shape, "scale", 3, "1 1 1")
    if np.any(scale == 0):
        raise _Skip(f"<mesh scale={shape.get('scale')!r}> has a zero factor")
    S[:3, :3] = np.diag(scale)
    mesh, file_rgba = _mesh(shape.get("filename"), urdf_path, package_dirs, budget, notes)
    return Visual(link, mesh, T @ S, given or file_rgba or DEFAULT_RGBA)


def _numbers(e, key, n, default, positive=False) -> np.ndarray:
    """Attribute ``key`` of element e as n finite plain-decimal numbers (> 0 if ``positive``): (n,)."""
    text = e.get(key, default)
    if text is None:
        raise _Skip(f"<{e.tag}> has no {key} attribute")
    words = text.split()
    if len(words) != n or not all(_NUMBER.match(w) for w in words):
        raise _Skip(f"<{e.tag} {key}={text!r}> is not {n} plain number(s)")
    x = np.array([float(w) for w in words])
    if not np.all(np.isfinite(x)) or (positive and np.any(x <= 0)):
        raise _Skip(f"<{e.tag} {key}={text!r}> must be finite{' and > 0' if positive else ''}")
    return x


def _material_rgba(mat, materials):
    """rgba (4 floats in [0, 1]) of a <material>: its own <color>, else the named robot-level material."""
    color = mat.find("color")
    if color is None:
        return materials.get(mat.get("name"))
    rgba = _numbers(color, "rgba", 4, None)
    if np.any(rgba < 0) or np.any(rgba > 1):
        raise _Skip(f"<color rgba={color.get('rgba')!r}> must lie in [0, 1]")
    return tuple(float(x) for x in rgba)


def _mesh(filename, urdf_path, package_dirs, budget, notes=None):
    """(meshcat geometry, the file's own rgba or None) of a mesh file: resolved, confined, bounded in size,
    then read once; a glTF is converted to binary STL (its notes on skipped parts go to ``notes``)."""
    g, umsgpack = meshcat_module("meshcat.geometry"), meshcat_module("umsgpack")
    try:
        path = resolve_mesh(filename, urdf_path, package_dirs)
    except URDFError as exc:
        raise _Skip(str(exc).removeprefix(f"{urdf_path}: ")) from None
    fmt = MESH_FORMATS.get(path.suffix.lower())
    if fmt is None:
        raise _Skip(f"mesh {filename!r}: format {path.suffix!r} not supported (stl, obj, dae, gltf, glb)")
    if fmt == "gltf":
        return _gltf_mesh(filename, path, budget, notes)
    info = path.stat()
    if not stat.S_ISREG(info.st_mode) or info.st_size > min(MAX_MESH_BYTES, budget[0]):
        raise _Skip(f"mesh {filename!r}: {info.st_size} bytes, more than the {MAX_MESH_BYTES} a mesh may "
                    f"have (or than the {MAX_MESH_TOTAL} of all meshes)")
    with open(path, "rb") as fh:
        data = fh.read(MAX_MESH_BYTES + 1)[:MAX_MESH_BYTES]
    budget[0] -= len(data)
    if fmt == "stl":
        return g.MeshGeometry(umsgpack.Ext(g.threejs_type(np.uint8)[1], data), "stl"), None  # as from_file
    try:
        return g.MeshGeometry(data.decode("utf-8"), fmt), None
    except UnicodeDecodeError:
        raise _Skip(f"mesh {filename!r}: a .{fmt} file must be UTF-8 text") from None



def _gltf_mesh(filename, path, budget, notes):
    """A .gltf/.glb as a binary-STL meshcat geometry and its base colour; the larger of the bytes read (file
    and buffers) and the STL written counts against the budget of all meshes."""
    g, umsgpack = meshcat_module("meshcat.geometry"), meshcat_module("umsgpack")
    try:
        got = read_gltf(path, max_bytes=min(MAX_MESH_BYTES, budget[0]))
    except GltfError as exc:
        raise _Skip(f"mesh {filename!r}: {exc}") from None
    data = binary_stl(got.triangles @ GLTF_TO_URDF.T)
    cost = max(got.bytes_read, len(data))
    if cost > budget[0]:
        raise _Skip(f"mesh {filename!r}: its STL of {len(data)} bytes exceeds the {MAX_MESH_TOTAL} of all meshes")
    budget[0] -= cost
    if notes is not None:
        notes += [f"mesh {filename!r}: {note}" for note in got.notes]
    return g.MeshGeometry(umsgpack.Ext(g.threejs_type(np.uint8)[1], data), "stl"), got.rgba
