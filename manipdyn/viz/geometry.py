"""Visual geometry of a URDF, loaded only when a viewer asks for it (never by the dynamics path).

Each visual becomes (link, meshcat geometry, 4×4 placement in the link frame, rgba). Mesh files are resolved
relative to the URDF's folder or through ``package://<pkg>/...`` (the folder named <pkg> above the URDF, or an
installed example-robot-data); a path that leaves those roots is refused unless ``allow_outside=True``.
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, URDFError


@dataclass(frozen=True)
class Visual:
    link: str
    geometry: object          # a meshcat.geometry.Geometry
    placement: np.ndarray     # (4, 4) in the link frame (scale included for meshes)
    rgba: tuple


def _package_roots(urdf_path: Path, pkg: str):
    """Candidate folders for package://<pkg>: an ancestor named <pkg>, or installed example-robot-data."""
    roots = [p for p in urdf_path.resolve().parents if p.name == pkg]
    if pkg == "example-robot-data":
        try:
            from ..validation.zoo import robots_dir
            roots.append(robots_dir().parent)
        except Exception:          # not installed: only the ancestors
            pass
    return roots


def resolve_mesh(filename: str, urdf_path: Path, allow_outside=False) -> Path:
    """The mesh file a URDF names, checked to stay inside the URDF's folder or its package root."""
    if filename.startswith("package://"):
        pkg, _, rel = filename[len("package://"):].partition("/")
        for root in _package_roots(urdf_path, pkg):
            cand = (root / rel).resolve()
            if cand.is_file():
                if not (allow_outside or _inside(cand, root)):
                    break
                return cand
        raise URDFError(f"{urdf_path}: mesh {filename!r} not found under package {pkg!r} (or it escapes it)")
    path = filename[len("file://"):] if filename.startswith("file://") else filename
    root = urdf_path.resolve().parent
    cand = (root / path).resolve()
    if not (allow_outside or _inside(cand, root)):
        raise URDFError(f"{urdf_path}: mesh path {filename!r} leaves the URDF's folder (allow_outside=True to permit)")
    if not cand.is_file():
        raise URDFError(f"{urdf_path}: mesh file {filename!r} not found")
    return cand


def _inside(path: Path, root: Path) -> bool:
    return os.path.commonpath([str(path), str(root.resolve())]) == str(root.resolve())


def load_visuals(urdf_path, allow_outside=False):
    """Every <visual> of the URDF as Visual records (meshcat imported here, lazily)."""
    import meshcat.geometry as g
    import yourdfpy
    urdf_path = Path(urdf_path)
    robot = yourdfpy.URDF.load(str(urdf_path), build_scene_graph=False, load_meshes=False).robot
    out = []
    for link in robot.links:
        for vis in link.visuals:
            T = np.eye(4) if vis.origin is None else np.array(vis.origin, float)
            geom, S = _geometry(g, vis.geometry, urdf_path, allow_outside)
            if geom is None:
                continue
            rgba = (0.7, 0.7, 0.75, 1.0)
            if vis.material is not None and vis.material.color is not None:
                rgba = tuple(float(x) for x in vis.material.color.rgba)
            out.append(Visual(link.name, geom, T @ S, rgba))
    return out


def _geometry(g, geometry, urdf_path, allow_outside):
    """(meshcat geometry, 4×4 intrinsic transform) of a URDF geometry element."""
    S = np.eye(4)
    if geometry.box is not None:
        return g.Box(list(np.asarray(geometry.box.size, float))), S
    if geometry.sphere is not None:
        return g.Sphere(float(geometry.sphere.radius)), S
    if geometry.cylinder is not None:        # meshcat cylinders run along y, URDF ones along z
        S[:3, :3] = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])
        return g.Cylinder(float(geometry.cylinder.length), float(geometry.cylinder.radius)), S
    if geometry.mesh is not None:
        path = resolve_mesh(geometry.mesh.filename, urdf_path, allow_outside)
        loaders = {".stl": g.StlMeshGeometry, ".obj": g.ObjMeshGeometry, ".dae": g.DaeMeshGeometry}
        loader = loaders.get(path.suffix.lower())
        if loader is None:
            raise InputError(f"{urdf_path}: mesh {path.name}: format {path.suffix!r} not supported (stl, obj, dae)")
        if geometry.mesh.scale is not None:
            S[:3, :3] = np.diag(np.broadcast_to(np.asarray(geometry.mesh.scale, float), 3))
        return loader.from_file(str(path)), S
    return None, S
