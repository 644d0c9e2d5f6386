"""A model's scene as meshcat commands: bodies, visuals (or default capsules), frames, closure markers, camera,
and a trajectory as a meshcat animation with the real time base. The same commands go to a live server or
into one self-contained HTML file.

Names from the URDF never reach the page unescaped: scene-tree node names keep only [A-Za-z0-9_.-] (others
become "_", made unique), the page title is HTML-escaped, data inside <script> is JSON with "<", ">" and "&"
escaped, and the page carries a Content-Security-Policy that runs only its own scripts (by nonce) and fetches
nothing from the network. Work is bounded: at most MAX_FRAMES animation frames (fewer for many bodies, see
max_frames), at most MAX_SAMPLES trajectory samples.
"""
from __future__ import annotations

import base64
import html as _html
import json
import math
import os
import re
import secrets
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..configuration import difference, integrate, neutral, normalize
from ..dynamics.forward_kinematics import forward_kinematics
from ..errors import InputError
from ..joints import BALL, HELICAL, PRISMATIC, REVOLUTE
from .geometry import load_visuals, meshcat_module

ROOT = "manipdyn"
CLOSURE_TOL = 1e-6       # closure gaps above this (m) show the warning marker
MAX_FRAMES = 3000        # animation frames at most: 100 s at 30 fps; longer motions are resampled at lower fps
MAX_KEYS = 200_000       # body transforms in one animation at most (frames × bodies)
MAX_SAMPLES = 1_000_000  # trajectory samples accepted at most
MAX_FPS = 240.0
_UNSAFE = re.compile(r"[^A-Za-z0-9_.\-]")


class PlaybackWarning(UserWarning):
    """Playback changed what it was asked for (fewer frames than asked, to bound the work)."""


def _T(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


@dataclass
class Scene:
    """Commands to draw ``model`` and every body node's transform per animation frame, in world coordinates
    (the root node /manipdyn is the world frame; the camera aims at the motion: see view())."""
    model: object
    commands: list = field(default_factory=list)
    nodes: dict = field(default_factory=dict)        # body index (-1 base) -> node path
    frames: dict = field(default_factory=dict)       # filled by animate: node path -> (F, 4, 4)
    times: np.ndarray = None
    t0: float = 0.0                                  # trajectory time of animation frame 0
    fps: float = 30.0
    notes: list = field(default_factory=list)        # what playback changed (frame cap), in words
    view: dict = None                                # camera and ground (see view())
    plots: dict = None                               # time series shown beside the robot (see viz/plots.py)


def node_name(name) -> str:
    """A scene-tree node name from a URDF name: only [A-Za-z0-9_.-] kept (others -> "_"), never '', '.', '..'."""
    s = _UNSAFE.sub("_", str(name))[:100]
    return s if s.strip(".") else "_" + s


def body_nodes(model) -> dict:
    """Node path of every body (-1: the base), unique even when sanitised names collide."""
    out, used = {}, set()
    for b in range(-1, model.njoints):
        base = node_name(model.root_link if b < 0 else model.body_names[b])
        name, k = base, 1
        while name in used:
            name, k = f"{base}_{k}", k + 1
        used.add(name)
        out[b] = f"/{ROOT}/{name}"
    return out


def body_path(model, b):
    """Node path of body b (-1: the base)."""
    return body_nodes(model)[b]


def build(model, urdf_path=None, Q_extent=None, show_frames=False, package_dirs=None) -> Scene:
    """Scene of the model: URDF visuals if any, else a mechanism drawing (a cylinder along every joint axis,
    tubes from each joint to the next, a base plate and pedestal), the ground under the base, the camera
    framing the motion (see view()), optional triads.

    Mesh files resolve only inside the URDF's folder or a package root (``package_dirs={"pkg": dir}``, see
    viz/geometry.py); a visual that cannot be drawn is skipped with a GeometryWarning."""
    g = meshcat_module("meshcat.geometry")
    sc = Scene(model)
    Q = neutral(model)[None] if Q_extent is None else np.atleast_2d(Q_extent)
    sc.nodes = body_nodes(model)
    visuals = load_visuals(urdf_path, package_dirs) if urdf_path is not None else []
    visuals = [v for v in visuals if v.link in model.frames]      # links a reduction removed are not drawn
    drawn = {model.frame(v.link).body for v in visuals}          # bodies with a visual (merged links too)
    rt, rj = _radii(model, Q)
    parts = []                                                    # (node path, geometry, 4×4 in the body, rgba)
    for k, v in enumerate(visuals):
        fr = model.frame(v.link)
        parts.append((f"{sc.nodes[fr.body]}/{node_name(v.link)}_visual{k}", v.geometry,
                      _T(fr.R, fr.p) @ v.placement, v.rgba))
    parts += _mechanism(g, model, sc.nodes, drawn, rt, rj)
    placed = [(model.frame(v.link).body, _corners(v.geometry, _T(model.frame(v.link).R, model.frame(v.link).p)
                                                  @ v.placement)) for v in visuals]
    base_low = _base_low(model, visuals, rj)
    sc.view = view(model, Q, placed, rt, rj, base_low=base_low)
    if sc.view["pedestal"] > 1e-9:                  # the base stands on a column down to the ground
        h = sc.view["pedestal"]
        parts.append((f"{sc.nodes[-1]}/pedestal", g.Cylinder(float(h), float(1.3 * rj)),
                      _T(_Y_TO_Z, [0, 0, base_low - 0.5 * h]), BASE_RGBA))
    for path, geom, T, rgba in parts:
        _add(sc, path, geom, T, rgba)
    for c in model.constraints:                     # shown only when the loop is open (gap > CLOSURE_TOL)
        _add(sc, gap_node(sc, c), g.Sphere(2.0 * rj), _T(np.eye(3), c.pc), (1.0, 0.0, 0.0, 0.7))
    if show_frames:
        from meshcat.commands import SetObject
        from meshcat.path import Path as MPath
        for b in range(model.njoints):
            sc.commands.append(SetObject(g.triad(3 * rj), path=MPath(tuple(f"{sc.nodes[b]}/frame".strip("/").split("/")))))
    sc.commands += ground_commands(sc.view) + camera_commands(sc.view)
    return sc


LINK_RGBA = (0.62, 0.67, 0.76, 1.0)       # tubes of links drawn without a URDF visual
JOINT_RGBA = (0.96, 0.56, 0.12, 1.0)      # joint housings along the joint axes
BASE_RGBA = (0.28, 0.30, 0.34, 1.0)       # base plate and pedestal
CLOSURE_RGBA = (0.20, 0.72, 0.35, 1.0)    # pins at loop closures of links drawn without a visual
_Y_TO_Z = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])    # meshcat cylinders run along y; this turns y to z


def _add(sc, path, geom, T, rgba):
    g = meshcat_module("meshcat.geometry")
    from meshcat.commands import SetObject, SetTransform
    from meshcat.path import Path as MPath
    color = int(rgba[0] * 255) << 16 | int(rgba[1] * 255) << 8 | int(rgba[2] * 255)
    mat = g.MeshLambertMaterial(color=color, opacity=float(rgba[3]), transparent=rgba[3] < 1)
    sc.commands.append(SetObject(geom, mat, MPath(tuple(path.strip("/").split("/")))))
    sc.commands.append(SetTransform(T, MPath(tuple(path.strip("/").split("/")))))


def _radii(model, Q):
    """(tube radius, joint-housing radius) of the mechanism drawing: a fixed share of the motion's size,
    at most a share of the typical link length (so short links still read as links)."""
    size = _size(model, Q)
    lengths = [float(np.linalg.norm(p)) for p in model.p0 if np.linalg.norm(p) > 1e-9]
    lengths += [float(np.linalg.norm(f.p)) for f in model.frames.values() if np.linalg.norm(f.p) > 1e-9]
    typical = float(np.median(lengths)) if lengths else size
    rj = min(0.06 * size, 0.35 * typical)
    return 0.75 * rj, rj


def _axis_frame(axis):
    """Rotation whose y column is ``axis`` (meshcat cylinders run along y)."""
    y = np.asarray(axis, float) / np.linalg.norm(axis)
    x = np.cross(y, [0, 0, 1.0]) if abs(y[2]) < 0.9 else np.cross(y, [1.0, 0, 0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, y, np.cross(x, y)])


def _mechanism(g, model, nodes, drawn, rt, rj):
    """Shapes that read as a mechanism for the bodies without a URDF visual: a housing along each joint
    axis (revolute: cylinder; prismatic: box), a tube from the joint to every child joint, tool frame and
    closure point it carries, a pin at each closure; the base: a plate and tubes to its children. Sizes
    taper by 10 % per joint away from the base (at most to 55 %)."""
    parts = []
    depth = np.zeros(model.njoints, int)
    for b in range(model.njoints):
        depth[b] = depth[model.parent[b]] + 1 if model.parent[b] >= 0 else 0
    rt0, rj0 = rt, rj
    for b in range(-1, model.njoints):
        if b in drawn:
            continue
        taper = 1.0 if b < 0 else max(0.55, 1.0 - 0.1 * depth[b])   # links thin out towards the tool
        rt, rj = taper * rt0, taper * rj0
        ends = [model.p0[c] for c in range(model.njoints) if model.parent[c] == b]
        ends += [f.p for f in model.frames.values() if f.body == b and not any(np.allclose(f.p, e) for e in ends)]
        loops = [c for c in model.constraints if c.type != "coupling"]    # a coupling has no place to draw
        ends += [c.pp for c in loops if c.parent == b] + [c.pc for c in loops if c.child == b]
        if b < 0:
            if not model.floating:
                parts.append((f"{nodes[-1]}/base_plate", g.Cylinder(float(1.2 * rj), float(1.8 * rj)),
                              _T(_Y_TO_Z, [0, 0, -0.6 * rj]), BASE_RGBA))
        elif model.kind[b] == REVOLUTE or model.kind[b] == HELICAL:
            parts.append((f"{nodes[b]}/joint", g.Cylinder(float(2.6 * rj), float(rj)), _T(_axis_frame(model.axis[b]),
                                                                                             np.zeros(3)), JOINT_RGBA))
        elif model.kind[b] == PRISMATIC:
            parts.append((f"{nodes[b]}/joint", g.Box([1.6 * rj, 3.0 * rj, 1.6 * rj]),
                          _T(_axis_frame(model.axis[b]), np.zeros(3)), JOINT_RGBA))
        elif model.kind[b] == BALL:                 # a ball joint: a sphere about its centre
            parts.append((f"{nodes[b]}/joint", g.Sphere(float(1.3 * rj)), np.eye(4), JOINT_RGBA))
        else:                                       # a free flyer's or planar joint's body: a hub
            parts.append((f"{nodes[b]}/joint", g.Sphere(float(1.5 * rj)), np.eye(4), BASE_RGBA))
        for k, e in enumerate(e for e in ends if np.linalg.norm(e) > 1e-9):
            geom, T = _segment(g, np.zeros(3), np.asarray(e, float), (1.3 if b < 0 else 1.0) * rt)
            parts.append((f"{nodes[b]}/link{k}", geom, T, BASE_RGBA if b < 0 else LINK_RGBA))
        for c in loops:                             # the pin of a cut joint, drawn once (on the parent side)
            if c.parent == b and c.type == "revolute":
                parts.append((f"{nodes[b]}/{node_name(c.name)}_pin", g.Cylinder(float(2.2 * rj), float(0.8 * rj)),
                              _T(_axis_frame(c.axis_p), c.pp), CLOSURE_RGBA))
            elif c.parent == b:
                parts.append((f"{nodes[b]}/{node_name(c.name)}_pin", g.Sphere(float(rj)), _T(np.eye(3), c.pp),
                              CLOSURE_RGBA))
    return parts


def _corners(geom, T):
    """Corners (8, 3) of a primitive visual's box in the link frame (T: its 4×4 placement, meshcat axes);
    a mesh (extent unknown without parsing it): its origin only."""
    kind = type(geom).__name__
    if kind == "Box":
        h = 0.5 * np.asarray(geom.lengths, float)
    elif kind == "Sphere":
        h = np.full(3, float(geom.radius))
    elif kind == "Cylinder":                        # meshcat cylinders run along y
        h = np.array([geom.radiusTop, 0.5 * geom.height, geom.radiusTop], float)
    else:
        return T[:3, 3][None]
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    return (signs * h) @ T[:3, :3].T + T[:3, 3]


def _base_low(model, visuals, rj):
    """Lowest z of the base's own drawing (its visuals, else the base plate): where the ground goes."""
    lows = [0.0]
    for v in visuals:
        fr = model.frame(v.link)
        if fr.body < 0:
            lows.append(float(_corners(v.geometry, _T(fr.R, fr.p) @ v.placement)[:, 2].min()))
    if all(model.frame(v.link).body >= 0 for v in visuals):
        lows.append(-1.2 * rj)                       # the base plate drawn by _mechanism
    return min(lows)


def gap_node(sc, c):
    """Node path of closure c's gap-warning marker."""
    return f"{sc.nodes[c.child]}/{node_name(c.name)}_gap_warning"


def _segment(g, a, b, r):
    """A cylinder (meshcat: along y) from a to b: (geometry, 4×4)."""
    d = b - a
    return g.Cylinder(float(np.linalg.norm(d)), float(r)), _T(_axis_frame(d), (a + b) / 2)


def _points(model, Q):
    """World positions of body origins, CoMs, named frames and closure points over the states Q: (K, 3)."""
    R, p = forward_kinematics(model, np.asarray(Q, float))
    pts = [p.reshape(-1, 3), np.zeros((1, 3)), (p + np.einsum("bnij,bj->bni", R, model.com)).reshape(-1, 3)]
    for f in model.frames.values():
        if f.body >= 0:
            pts.append(p[f.body] + np.einsum("nij,j->ni", R[f.body], f.p))
    for c in model.constraints:
        if c.child >= 0:
            pts.append(p[c.child] + np.einsum("nij,j->ni", R[c.child], c.pc))
    return np.concatenate(pts)


def _size(model, Q):
    pts = _points(model, Q)
    return max(float(np.linalg.norm(pts.max(0) - pts.min(0))), 0.05)


ELEVATION = math.radians(24.0)   # the camera looks down this much
AZIMUTH = math.radians(35.0)     # first azimuth tried (from +x towards +y; a three-quarter view)
AZIMUTH_STEP = 15.0              # degrees between the azimuths tried
FOV = 40.0                       # vertical field of view, degrees (meshcat's 75 distorts a near robot)
ASPECT_LIVE = 1.6                # width / height assumed for the live viewer (the page refits to its pane)
ASPECT_PAGE = 1.3                # width / height of the page's 3-D pane, typically (to choose the direction)
MARGIN = 1.03                    # distance added so the drawing does not touch the border
FIT_FRAMES = 60                  # motion samples used to fit the camera


def view(model, Q, visuals, rt, rj, base_low=0.0) -> dict:
    """Where the camera and the ground go for a motion Q (F, nq); visuals: [(body, corners (K, 3) in the
    body frame)], the boxes of the drawn primitives (a mesh: its origin).

    The camera aims at the centre of the bounding box of everything drawn over the whole motion (body
    origins, frames, closure points, the visuals' boxes; ``pad`` covers the rest), from the broad side of that box,
    turned AZIMUTH round and ELEVATION up; its distance fits the drawing (see fit_distance). The ground sits
    under the base (fixed base: at the bottom of the base drawing, or, when the motion reaches lower, below
    its lowest point with a pedestal under the base; free flyer: under the lowest point of the motion).
    Returns a dict: centre (3,), back (3,) unit vector from centre to camera, points (K, 3) to fit relative
    to the centre, pad (m), ground_z, ground (half-size, cell, centre xy), pedestal (m), axes (m)."""
    Q = np.atleast_2d(Q)
    Q = Q[np.unique(np.linspace(0, len(Q) - 1, min(len(Q), FIT_FRAMES)).round().astype(int))]
    pts = [_points(model, Q)]
    R, p = forward_kinematics(model, np.asarray(Q, float))
    for body, c in visuals:
        pts.append(c if body < 0 else (p[body][:, None] + np.einsum("nij,kj->nki", R[body], c)).reshape(-1, 3))
    meshes = any(len(c) == 1 for _, c in visuals)
    pad = 1.6 * rj if meshes or not visuals else 0.5 * rj     # housings reach 1.6 rj from their joint
    pts = np.concatenate(pts)
    lowest = float(pts[:, 2].min()) - pad
    pedestal = 0.0
    if model.floating:
        ground_z = lowest
    elif lowest < base_low - pad:                   # a motion below the base: the base stands on a pedestal
        ground_z, pedestal = lowest, base_low - lowest
        pts = np.vstack([pts, [[0.0, 0.0, ground_z]]])
    else:
        ground_z = base_low
    lo, hi = pts.min(0), pts.max(0)
    centre = 0.5 * (lo + hi)
    ext = hi - lo
    base_pts = [c for body, c in visuals if body < 0]
    front = None
    if min(ext[0], ext[1]) < 0.25 * max(ext):       # planar: look from the side of the moving links
        i = int(np.argmin(ext[:2]))
        side = float(p[..., i].mean()) - (float(np.concatenate(base_pts)[:, i].mean()) if base_pts else 0.0)
        if abs(side) > 1e-9:
            front = np.sign(side) * np.eye(3)[i]
    back = _best_direction(model, Q, pts - centre, pad, ext, front)
    half = 0.6 * max(ext[0], ext[1], 0.3 * ext[2], 4 * rj)
    cell = _nice(2 * half / 12)
    half = cell * math.ceil(half / cell)
    return dict(centre=centre, back=back, points=_hull_sample(pts - centre), pad=float(pad),
                ground_z=float(ground_z), ground=(float(half), float(cell), centre[:2].tolist()),
                pedestal=float(pedestal), axes=float(max(0.12 * max(ext), 2 * rj)))


def _best_direction(model, Q, P, pad, ext, front=None):
    """The camera direction (unit, centre to camera) that shows the robot largest: ELEVATION up (less for a
    planar mechanism), all round in AZIMUTH_STEP steps; each is scored by the drawn length of the links
    (segments between joint origins projected on the image plane) over its fitted distance squared
    (coverage grows with both), averaged over the frames plus the worst frame. ``front``: only directions
    on its side (a planar mechanism seen from the side of its moving links, not through its base)."""
    _, p = forward_kinematics(model, np.asarray(Q, float))
    seg = np.stack([p[b] - (p[model.parent[b]] if model.parent[b] >= 0 else 0.0) for b in range(model.njoints)])
    planar = min(ext[0], ext[1]) < 0.25 * max(ext)             # a planar mechanism: seen nearer face-on
    el = 0.6 * ELEVATION if planar else ELEVATION
    best = None
    for az in np.radians(np.arange(0.0, 360.0, AZIMUTH_STEP)) + AZIMUTH:
        back = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
        if front is not None and back @ front < 0.3:
            continue
        d = fit_distance(P, back, pad, ASPECT_PAGE)
        shown = np.linalg.norm(seg - np.einsum("bfi,i->bf", seg, back)[..., None] * back, axis=2).sum(0) / d**2
        score = float(shown.mean() + shown.min())
        if best is None or score > best[0] * (1 + 1e-9):
            best = (score, back)
    return best[1]


def _nice(x):
    """1, 2 or 5 × 10^k nearest above x."""
    k = 10.0 ** math.floor(math.log10(x))
    return next(m * k for m in (1, 2, 5, 10) if m * k >= x * 0.999)


def _hull_sample(P, n=200):
    """At most n of the points that matter for framing: the extreme ones along many directions."""
    if len(P) <= n:
        return P
    rng = np.random.default_rng(0)
    D = rng.normal(size=(n, 3))
    idx = np.unique(np.argmax(P @ D.T, axis=0))
    return P[idx]


def fit_distance(points, back, pad, aspect):
    """Camera distance from the centre so every point (relative to the centre) plus ``pad`` lies inside a
    FOV-degree (vertical) view of the given width/height aspect, looking along −back with z up."""
    f = -np.asarray(back, float)
    right = np.cross(f, [0, 0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, f)
    tv = math.tan(math.radians(FOV) / 2)
    th = tv * aspect
    P = np.asarray(points, float)
    depth = P @ np.asarray(back, float)
    d = np.maximum((np.abs(P @ right) + pad) / th, (np.abs(P @ up) + pad) / tv) + depth
    return MARGIN * float(max(d.max(), 1e-3))


def camera_commands(v, aspect=ASPECT_LIVE):
    """Aim meshcat's camera at the motion. Its orbit controls always aim at the world origin, so the robot
    (/manipdyn), the ground and the world axes are all shifted by −centre (the motion's bounding-box centre
    lands on the orbit centre; robot and ground stay together), and the camera sits fit_distance away along
    ``back`` (given in the rotated camera frame, whose y is the world's z)."""
    meshcat_module("meshcat")
    from meshcat.commands import SetProperty, SetTransform
    from meshcat.path import Path as MPath
    o = fit_distance(v["points"], v["back"], v["pad"], aspect) * np.asarray(v["back"])
    return [SetTransform(_T(np.eye(3), -np.asarray(v["centre"])), MPath((ROOT,))),
            SetProperty("fov", FOV, MPath(("Cameras", "default", "rotated", "<object>"))),
            SetProperty("position", [float(o[0]), float(o[2]), float(-o[1])],
                        MPath(("Cameras", "default", "rotated", "<object>")))]


def ground_commands(v):
    """The ground under the base: a plate with a grid sized to the motion (/ground, outside the robot's node);
    meshcat's own 20 m grid hidden, its world axes shrunk to ``v["axes"]`` at the origin."""
    g = meshcat_module("meshcat.geometry")
    from meshcat.commands import SetObject, SetProperty, SetTransform
    from meshcat.path import Path as MPath
    half, cell, (cx, cy) = v["ground"]
    shift = -np.asarray(v["centre"], float)
    z = v["ground_z"]
    n = int(round(2 * half / cell))
    ticks = -half + cell * np.arange(n + 1)
    seg = [[[cx + s, cy - half, 0], [cx + s, cy + half, 0]] for s in ticks]
    seg += [[[cx - half, cy + s, 0], [cx + half, cy + s, 0]] for s in ticks]
    pos = np.array(seg, float).reshape(-1, 3).T
    lines = g.LineSegments(g.PointsGeometry(pos.astype(np.float32)), g.LineBasicMaterial(color=0x7d838c))
    plate = g.Box([2 * half, 2 * half, 0.002 * half])
    s = v["axes"] / 0.5                                              # meshcat's axes are 0.5 m long
    return [SetProperty("visible", False, MPath(("Grid",))),
            SetTransform(_T(s * np.eye(3), shift), MPath(("Axes",))),
            SetTransform(_T(np.eye(3), shift), MPath(("ground",))),
            SetObject(plate, g.MeshLambertMaterial(color=0xe4e6ea), MPath(("ground", "plate"))),
            SetTransform(_T(np.eye(3), [cx, cy, z - 0.0015 * half]), MPath(("ground", "plate"))),
            SetObject(lines, path=MPath(("ground", "grid"))),
            SetTransform(_T(np.eye(3), [0, 0, z + 0.0005 * half]), MPath(("ground", "grid")))]


def check_trajectory(model, t, Q):
    """(t (T,), Q (T, nq)) as float arrays, checked: 1 ≤ T ≤ MAX_SAMPLES, finite, times increasing, finite span."""
    t, Q = np.asarray(t, dtype=float), np.asarray(Q, dtype=float)
    if Q.ndim == 1 and t.ndim == 1 and model.nq != 1 and Q.shape == (model.nq,):
        Q = Q[None]
    Q = Q.reshape(-1, 1) if Q.ndim == 1 and model.nq == 1 else Q
    if t.ndim != 1 or not 1 <= len(t) <= MAX_SAMPLES:
        raise InputError(f"playback of {model.name!r}: t must be 1-D with 1 to {MAX_SAMPLES} samples, "
                         f"got shape {t.shape}")
    if Q.shape != (len(t), model.nq):
        raise InputError(f"playback of {model.name!r}: q has shape {Q.shape}, expected ({len(t)}, {model.nq})")
    if not np.all(np.isfinite(t)):
        raise InputError(f"playback of {model.name!r}: t has non-finite values (first at sample "
                         f"{int(np.argmin(np.isfinite(t)))})")
    if not np.all(np.isfinite(Q)):
        k = int(np.argmin(np.all(np.isfinite(Q), axis=1)))
        raise InputError(f"playback of {model.name!r}: q has non-finite values (first at sample {k}: {Q[k]})")
    if np.any(np.diff(t) <= 0):
        raise InputError(f"playback of {model.name!r}: times must increase (sample "
                         f"{int(np.argmax(np.diff(t) <= 0)) + 1})")
    if not math.isfinite(float(t[-1]) - float(t[0])):
        raise InputError(f"playback of {model.name!r}: time span {t[0]:g} .. {t[-1]:g} is not finite")
    return t, Q


def max_frames(model) -> int:
    """Frame cap of a model's animation: MAX_FRAMES, fewer when frames × bodies would pass MAX_KEYS."""
    return max(2, min(MAX_FRAMES, MAX_KEYS // max(model.nq, 1)))


def frame_times(span, fps, cap):
    """(times (F,), fps, note) of the animation frames over [0, span]: every 1/fps, or, when that would
    give more than ``cap`` frames, ``cap`` frames evenly spaced (fps lowered; the note says so)."""
    if not (isinstance(fps, (int, float, np.floating, np.integer)) and 0 < fps <= MAX_FPS):
        raise InputError(f"playback: fps must be a number in (0, {MAX_FPS:g}], got {fps!r}")
    n = math.floor(span * fps + 1e-9) + 1
    if n <= cap:
        return np.arange(n) / float(fps), float(fps), None
    low = (cap - 1) / span
    note = (f"{span:.6g} s at {fps:g} fps would be {n} frames; resampled to {cap} frames at {low:.4g} fps "
            f"(the frame cap)")
    return np.linspace(0.0, span, cap), low, note


def animate(sc: Scene, t, Q, fps=30.0):
    """Append the animation (real time base: frame k at time k/fps, q interpolated in t by ``interpolate``) and
    keep every body's world transform per frame in ``sc.frames`` (for checking against forward kinematics).

    At most max_frames(model) frames (MAX_FRAMES = 3000): a longer motion is resampled at a lower fps, said
    in ``sc.notes`` and by a PlaybackWarning. Raises InputError for non-finite, unordered or oversized input."""
    meshcat_module("meshcat")
    from meshcat.animation import Animation
    from meshcat.commands import SetAnimation
    t, Q = check_trajectory(sc.model, t, Q)
    times, fps, note = frame_times(float(t[-1]) - float(t[0]), fps, max_frames(sc.model))
    if note:
        sc.notes.append(note)
        warnings.warn(f"playback of {sc.model.name!r}: {note}", PlaybackWarning, stacklevel=2)
    Qf = interpolate(sc.model, t - t[0], Q, times)
    R, p = forward_kinematics(sc.model, Qf)
    anim = Animation(default_framerate=fps)
    gaps = _closure_gaps(sc.model, Qf)
    for k in range(len(times)):
        with anim.at_frame(_Recorder(), k) as frame:
            for b in range(sc.model.njoints):
                frame[sc.nodes[b]].set_transform(_T(R[b, k], p[b, k]))
            for c, gap in zip(sc.model.constraints, gaps):
                frame[gap_node(sc, c)].set_property("visible", "boolean", bool(gap[k] > CLOSURE_TOL))
    sc.frames = {sc.nodes[b]: np.array([_T(R[b, k], p[b, k]) for k in range(len(times))]) for b in range(sc.model.njoints)}
    sc.times, sc.fps, sc.gaps, sc.t0 = times, fps, gaps, float(t[0])
    sc.commands.append(SetAnimation(anim, play=True, repetitions=1))
    return sc


def interpolate(model, t, Q, times):
    """q (F, nq) at ``times`` (F,) of the samples t (T,), Q (T, nq): every entry linearly in t, except each
    quaternion (free flyer, ball joint), normalised, which turns along the shorter great arc between its two
    neighbouring samples at a constant rate (slerp: the rotation part of q_k ⊕ s (q_{k+1} ⊖ q_k), s the fraction of the
    interval): it stays unit, and q and −q (the same rotation) are interpolated alike."""
    Qf = np.column_stack([np.interp(times, t, Q[:, i]) for i in range(model.nq)])
    if not model.quat_q.size or len(t) < 2:
        return Qf
    Q = normalize(model, Q)                  # samples read from a file may be off unit norm (InputError if zero)
    k = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
    s = np.clip((times - t[k]) / (t[k + 1] - t[k]), 0.0, 1.0)
    turned = integrate(model, Q[k], s[:, None] * difference(model, Q[k], Q[k + 1]))
    quats = (model.quat_q[:, None] + np.arange(4)).ravel()
    Qf[:, quats] = turned[:, quats]
    return Qf


class _Recorder:
    """Stand-in visualizer for Animation.at_frame, which only reads its root path."""
    def __init__(self):
        meshcat_module("meshcat")
        from meshcat.path import Path as MPath
        self.path = MPath()


def _closure_gaps(model, Q):
    """|p_A − p_B| of every closure per frame: (n_closures, F)."""
    if not model.constraints:
        return []
    from ..constraints import closure_terms
    Phi = closure_terms(model, Q)[0]
    out, k = [], 0
    for c in model.constraints:
        out.append(np.abs(Phi[:, k]) if c.type == "coupling" else np.linalg.norm(Phi[:, k:k + 3], axis=1))
        k += c.n_rows
    return out


PLAY_SCRIPT = """
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
JSON.parse(document.getElementById("manipdyn-commands").textContent).forEach(function (b64) {
  var s = atob(b64), bytes = new Uint8Array(s.length);
  for (var i = 0; i < s.length; i++) bytes[i] = s.charCodeAt(i);
  viewer.handle_command_bytearray(bytes);
});
"""
# The page runs only its own scripts (nonce) and loads nothing: no network, no file, no inline handler.
CSP = ("default-src 'none'; script-src 'nonce-{nonce}'; style-src 'unsafe-inline'; img-src data: blob:; "
       "connect-src data: blob:; worker-src blob:; base-uri 'none'; form-action 'none'")


def json_for_script(obj) -> str:
    """JSON text safe inside a <script> element: "<", ">", "&" escaped (non-ASCII too)."""
    text = json.dumps(obj, ensure_ascii=True)
    return text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def default_speed(span):
    """Playback speed the page starts at: slow motion for short motions (at least about a second)."""
    return 0.25 if span < 0.4 else 0.5 if span < 0.8 else 1.0


def page_data(sc: Scene) -> dict:
    """What the page's player needs besides the commands: time base, camera fit, plots."""
    v = sc.view
    span = float(sc.times[-1]) if sc.times is not None else 0.0
    return dict(t0=float(sc.t0), duration=span, fps=float(sc.fps), speed=default_speed(span), closure_tol=CLOSURE_TOL,
                view=dict(back=[float(x) for x in v["back"]], points=np.round(v["points"], 5).tolist(),
                          pad=float(v["pad"]), fov=FOV, margin=MARGIN),
                plots=sc.plots or dict(t=[float(sc.t0)], groups=[], marks=[], notes=[]))


def html(sc: Scene) -> str:
    """One self-contained HTML page (viz/page.py): meshcat's viewer script inlined, every command embedded
    (msgpack, base64, in a JSON array), the player and plot data in the last script; the title is
    HTML-escaped and every name goes through json_for_script."""
    meshcat = meshcat_module("meshcat")
    umsgpack = meshcat_module("umsgpack")

    from .page import document
    js_path = os.path.join(os.path.dirname(meshcat.__file__), "viewer", "dist", "main.min.js")
    with open(js_path, encoding="utf-8") as fh:
        js = re.sub(r"</(script)", r"<\\/\1", fh.read(), flags=re.IGNORECASE)
    cmds = [base64.b64encode(umsgpack.packb(c.lower())).decode("ascii") for c in sc.commands]
    nonce = secrets.token_urlsafe(18)
    return document(_html.escape("manipdyn: " + str(sc.model.name)), CSP.format(nonce=nonce), nonce,
                    json_for_script(cmds), json_for_script(page_data(sc)), js, PLAY_SCRIPT)
