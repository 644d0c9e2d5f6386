"""A model's scene as meshcat commands: bodies, visuals (or default capsules), frames, closure markers, camera,
and a trajectory as a meshcat animation with the real time base. The same commands go to a live server or
into one self-contained HTML file.
"""
from __future__ import annotations

import base64
import os
from dataclasses import dataclass, field

import numpy as np

from ..dynamics.kinematics import placements
from .geometry import load_visuals

ROOT = "manipdyn"
CLOSURE_TOL = 1e-6       # closure gaps above this (m) show the warning marker


def _T(R, p):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


@dataclass
class Scene:
    """Commands to draw ``model`` and every body node's transform per animation frame, relative to the
    root node /manipdyn (which sits at −centre: see camera_commands)."""
    model: object
    commands: list = field(default_factory=list)
    nodes: dict = field(default_factory=dict)        # body index (-1 base) -> node path
    frames: dict = field(default_factory=dict)       # filled by animate: node path -> (F, 4, 4)
    times: np.ndarray = None
    fps: float = 30.0


def body_path(model, b):
    return f"/{ROOT}/{model.root_link if b < 0 else model.body_names[b]}"


def build(model, urdf_path=None, Q_extent=None, show_frames=False, allow_outside=False) -> Scene:
    """Scene of the model: URDF visuals if any (else capsules between joint origins), optional triads."""
    import meshcat.geometry as g
    from meshcat.commands import SetObject, SetTransform
    from meshcat.path import Path as MPath
    sc = Scene(model)
    Q = np.zeros((1, model.nv)) if Q_extent is None else np.atleast_2d(Q_extent)
    size = _size(model, Q)
    sc.nodes = {b: body_path(model, b) for b in range(-1, model.nv)}
    visuals = load_visuals(urdf_path, allow_outside) if urdf_path is not None else []
    drawn = {v.link for v in visuals}

    def add(path, geom, T, rgba):
        color = int(rgba[0] * 255) << 16 | int(rgba[1] * 255) << 8 | int(rgba[2] * 255)
        mat = g.MeshLambertMaterial(color=color, opacity=float(rgba[3]), transparent=rgba[3] < 1)
        sc.commands.append(SetObject(geom, mat, MPath(tuple(path.strip("/").split("/")))))
        sc.commands.append(SetTransform(T, MPath(tuple(path.strip("/").split("/")))))

    for k, v in enumerate(visuals):
        fr = model.frame(v.link)
        add(f"{sc.nodes[fr.body]}/{v.link}_visual{k}", v.geometry, _T(fr.R, fr.p) @ v.placement, v.rgba)
    r = 0.015 * size
    for b in range(model.nv):                       # default capsules for links without a visual
        if model.body_names[b] in drawn:
            continue
        ends = [model.p0[c] for c in range(model.nv) if model.parent[c] == b]
        ends += [f.p for f in model.frames.values() if f.body == b and np.linalg.norm(f.p) > 1e-9
                 and f.name not in drawn]
        add(f"{sc.nodes[b]}/joint_sphere", g.Sphere(1.6 * r), np.eye(4), (0.9, 0.55, 0.1, 1.0))
        for k, e in enumerate(e for e in ends if np.linalg.norm(e) > 1e-9):
            add(f"{sc.nodes[b]}/capsule{k}", *_segment(g, np.zeros(3), np.asarray(e), r), (0.6, 0.65, 0.75, 1.0))
    if model.root_link not in drawn:
        ends = [model.p0[c] for c in range(model.nv) if model.parent[c] < 0]
        for k, e in enumerate(ends):
            if np.linalg.norm(e) > 1e-9:
                add(f"{sc.nodes[-1]}/capsule{k}", *_segment(g, np.zeros(3), np.asarray(e), 1.3 * r), (0.3, 0.3, 0.3, 1.0))
    for c in model.constraints:                     # both sides of every cut joint, and a warning marker
        add(f"{sc.nodes[c.parent]}/{c.name}_parent_side", g.Sphere(1.2 * r), _T(np.eye(3), c.pp), (0.1, 0.8, 0.2, 1.0))
        add(f"{sc.nodes[c.child]}/{c.name}_child_side", g.Sphere(0.9 * r), _T(np.eye(3), c.pc), (0.1, 0.4, 0.9, 1.0))
        add(f"{sc.nodes[c.child]}/{c.name}_gap_warning", g.Sphere(2.5 * r), _T(np.eye(3), c.pc), (1.0, 0.0, 0.0, 0.7))
    if show_frames:
        for b in range(model.nv):
            sc.commands.append(SetObject(g.triad(4 * r), path=MPath(tuple(f"{sc.nodes[b]}/frame".strip("/").split("/")))))
    sc.commands += camera_commands(model, Q, size)
    return sc


def _segment(g, a, b, r):
    """A cylinder (meshcat: along y) from a to b: (geometry, 4×4)."""
    d = b - a
    L = np.linalg.norm(d)
    y = d / L
    x = np.cross(y, [0, 0, 1.0]) if abs(y[2]) < 0.9 else np.cross(y, [1.0, 0, 0])
    x /= np.linalg.norm(x)
    return g.Cylinder(float(L), float(r)), _T(np.column_stack([x, y, np.cross(x, y)]), (a + b) / 2)


def _points(model, Q):
    """World positions of body origins, CoMs, named frames and closure points over the states Q: (K, 3)."""
    R, p = placements(model, Q)
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


def camera_commands(model, Q, size=None):
    """Frame the robot whatever its size: meshcat's camera orbits the world origin, so the robot's root
    node is shifted by −(centre of its bounding box over the motion), and the camera placed 0.6 × size
    + 0.15 m away (the grid stays at the origin)."""
    from meshcat.commands import SetProperty, SetTransform
    from meshcat.path import Path as MPath
    pts = _points(model, Q)
    centre = 0.5 * (pts.max(0) + pts.min(0))
    d = 0.6 * (size or _size(model, Q)) + 0.15
    return [SetTransform(_T(np.eye(3), -centre), MPath((ROOT,))),
            SetProperty("position", [0.9 * d, 0.6 * d, 0.9 * d], MPath(("Cameras", "default", "rotated", "<object>")))]


def animate(sc: Scene, t, Q, fps=30.0):
    """Append the animation (real time base: frame k at time k/fps, q interpolated linearly in t) and keep
    every body's world transform per frame in ``sc.frames`` (for checking against forward kinematics)."""
    from meshcat.animation import Animation
    from meshcat.commands import SetAnimation
    t, Q = np.asarray(t, float), np.atleast_2d(np.asarray(Q, float))
    times = np.arange(0.0, t[-1] - t[0] + 1e-12, 1.0 / fps)
    Qf = np.column_stack([np.interp(times, t - t[0], Q[:, i]) for i in range(sc.model.nv)])
    R, p = placements(sc.model, Qf)
    anim = Animation(default_framerate=fps)
    gaps = _closure_gaps(sc.model, Qf)
    for k in range(len(times)):
        with anim.at_frame(_Recorder(), k) as frame:
            for b in range(sc.model.nv):
                frame[sc.nodes[b]].set_transform(_T(R[b, k], p[b, k]))
            for c, gap in zip(sc.model.constraints, gaps):
                frame[f"{sc.nodes[c.child]}/{c.name}_gap_warning"].set_property("visible", "boolean",
                                                                                 bool(gap[k] > CLOSURE_TOL))
    sc.frames = {sc.nodes[b]: np.array([_T(R[b, k], p[b, k]) for k in range(len(times))]) for b in range(sc.model.nv)}
    sc.times, sc.fps, sc.gaps = times, fps, gaps
    sc.commands.append(SetAnimation(anim, play=True, repetitions=1))
    return sc


class _Recorder:
    """Stand-in visualizer for Animation.at_frame, which only reads its root path."""
    def __init__(self):
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
        out.append(np.linalg.norm(Phi[:, k:k + 3], axis=1))
        k += c.n_rows
    return out


SEEK_SCRIPT = """
<script>
// open at a given time with file.html#t=1.5 (the animation is paused there)
window.addEventListener("load", function () {
  var m = /t=([0-9.]+)/.exec(window.location.hash);
  if (!m) return;
  setTimeout(function () { viewer.animator.pause(); viewer.animator.seek(parseFloat(m[1])); }, 1000);
});
</script>
"""


def html(sc: Scene) -> str:
    """One self-contained HTML page: meshcat's viewer script inlined, every command embedded."""
    import meshcat
    import umsgpack
    js_path = os.path.join(os.path.dirname(meshcat.__file__), "viewer", "dist", "main.min.js")
    with open(js_path, encoding="utf-8") as fh:
        js = fh.read()
    cmds = "".join(
        'fetch("data:application/octet-binary;base64,{}").then(r => r.arrayBuffer())'
        '.then(b => viewer.handle_command_bytearray(new Uint8Array(b)));\n'.format(
            base64.b64encode(umsgpack.packb(c.lower())).decode()) for c in sc.commands)
    return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8><title>manipdyn: " + sc.model.name +
            "</title><style>body{margin:0}#meshcat-pane{width:100vw;height:100vh;overflow:hidden}</style></head>"
            '<body><div id="meshcat-pane"></div><script>' + js + "</script><script>\n"
            'var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));\n' + cmds +
            "</script>" + SEEK_SCRIPT + "</body></html>\n")
