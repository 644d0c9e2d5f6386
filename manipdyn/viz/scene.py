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

from ..configuration import neutral, normalize
from ..dynamics.core import forward_kinematics
from ..errors import InputError
from .geometry import load_visuals

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
    """Commands to draw ``model`` and every body node's transform per animation frame, relative to the
    root node /manipdyn (which sits at −centre: see camera_commands)."""
    model: object
    commands: list = field(default_factory=list)
    nodes: dict = field(default_factory=dict)        # body index (-1 base) -> node path
    frames: dict = field(default_factory=dict)       # filled by animate: node path -> (F, 4, 4)
    times: np.ndarray = None
    fps: float = 30.0
    notes: list = field(default_factory=list)        # what playback changed (frame cap), in words


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
    """Scene of the model: URDF visuals if any (else capsules between joint origins), optional triads.

    Mesh files resolve only inside the URDF's folder or a package root (``package_dirs={"pkg": dir}``, see
    viz/geometry.py); a visual that cannot be drawn is skipped with a GeometryWarning."""
    import meshcat.geometry as g
    from meshcat.commands import SetObject, SetTransform
    from meshcat.path import Path as MPath
    sc = Scene(model)
    Q = neutral(model)[None] if Q_extent is None else np.atleast_2d(Q_extent)
    size = _size(model, Q)
    sc.nodes = body_nodes(model)
    visuals = load_visuals(urdf_path, package_dirs) if urdf_path is not None else []
    visuals = [v for v in visuals if v.link in model.frames]      # links a reduction removed are not drawn
    drawn = {v.link for v in visuals}

    def add(path, geom, T, rgba):
        color = int(rgba[0] * 255) << 16 | int(rgba[1] * 255) << 8 | int(rgba[2] * 255)
        mat = g.MeshLambertMaterial(color=color, opacity=float(rgba[3]), transparent=rgba[3] < 1)
        sc.commands.append(SetObject(geom, mat, MPath(tuple(path.strip("/").split("/")))))
        sc.commands.append(SetTransform(T, MPath(tuple(path.strip("/").split("/")))))

    for k, v in enumerate(visuals):
        fr = model.frame(v.link)
        add(f"{sc.nodes[fr.body]}/{node_name(v.link)}_visual{k}", v.geometry, _T(fr.R, fr.p) @ v.placement, v.rgba)
    r = 0.015 * size
    for b in range(model.njoints):                       # default capsules for links without a visual
        if model.body_names[b] in drawn:
            continue
        ends = [model.p0[c] for c in range(model.njoints) if model.parent[c] == b]
        ends += [f.p for f in model.frames.values() if f.body == b and np.linalg.norm(f.p) > 1e-9
                 and f.name not in drawn]
        add(f"{sc.nodes[b]}/joint_sphere", g.Sphere(1.6 * r), np.eye(4), (0.9, 0.55, 0.1, 1.0))
        for k, e in enumerate(e for e in ends if np.linalg.norm(e) > 1e-9):
            add(f"{sc.nodes[b]}/capsule{k}", *_segment(g, np.zeros(3), np.asarray(e), r), (0.6, 0.65, 0.75, 1.0))
    if model.root_link not in drawn:
        ends = [model.p0[c] for c in range(model.njoints) if model.parent[c] < 0]
        for k, e in enumerate(ends):
            if np.linalg.norm(e) > 1e-9:
                add(f"{sc.nodes[-1]}/capsule{k}", *_segment(g, np.zeros(3), np.asarray(e), 1.3 * r), (0.3, 0.3, 0.3, 1.0))
    for c in model.constraints:                     # both sides of every cut joint, and a warning marker
        add(f"{sc.nodes[c.parent]}/{node_name(c.name)}_parent_side", g.Sphere(1.2 * r), _T(np.eye(3), c.pp),
            (0.1, 0.8, 0.2, 1.0))
        add(f"{sc.nodes[c.child]}/{node_name(c.name)}_child_side", g.Sphere(0.9 * r), _T(np.eye(3), c.pc),
            (0.1, 0.4, 0.9, 1.0))
        add(gap_node(sc, c), g.Sphere(2.5 * r), _T(np.eye(3), c.pc), (1.0, 0.0, 0.0, 0.7))
    if show_frames:
        for b in range(model.njoints):
            sc.commands.append(SetObject(g.triad(4 * r), path=MPath(tuple(f"{sc.nodes[b]}/frame".strip("/").split("/")))))
    sc.commands += camera_commands(model, Q, size)
    return sc


def gap_node(sc, c):
    """Node path of closure c's gap-warning marker."""
    return f"{sc.nodes[c.child]}/{node_name(c.name)}_gap_warning"


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
    """Append the animation (real time base: frame k at time k/fps, q interpolated linearly in t) and keep
    every body's world transform per frame in ``sc.frames`` (for checking against forward kinematics).

    At most max_frames(model) frames (MAX_FRAMES = 3000): a longer motion is resampled at a lower fps, said
    in ``sc.notes`` and by a PlaybackWarning. Raises InputError for non-finite, unordered or oversized input."""
    from meshcat.animation import Animation
    from meshcat.commands import SetAnimation
    t, Q = check_trajectory(sc.model, t, Q)
    times, fps, note = frame_times(float(t[-1]) - float(t[0]), fps, max_frames(sc.model))
    if note:
        sc.notes.append(note)
        warnings.warn(f"playback of {sc.model.name!r}: {note}", PlaybackWarning, stacklevel=2)
    Qf = np.column_stack([np.interp(times, t - t[0], Q[:, i]) for i in range(sc.model.nq)])
    if sc.model.floating:                                    # a free flyer's quaternion: normalised lerp
        Qf = normalize(sc.model, Qf)
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
        out.append(np.abs(Phi[:, k]) if c.type == "coupling" else np.linalg.norm(Phi[:, k:k + 3], axis=1))
        k += c.n_rows
    return out


SEEK_SCRIPT = """
// open at a given time with file.html#t=1.5 (the animation is paused there)
window.addEventListener("load", function () {
  var m = /t=([0-9.]+)/.exec(window.location.hash);
  if (!m) return;
  setTimeout(function () { viewer.animator.pause(); viewer.animator.seek(parseFloat(m[1])); }, 1000);
});
"""
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


def html(sc: Scene) -> str:
    """One self-contained HTML page: meshcat's viewer script inlined, every command embedded (msgpack,
    base64, in a JSON array); the title is HTML-escaped."""
    import meshcat
    import umsgpack
    js_path = os.path.join(os.path.dirname(meshcat.__file__), "viewer", "dist", "main.min.js")
    with open(js_path, encoding="utf-8") as fh:
        js = re.sub(r"</(script)", r"<\\/\1", fh.read(), flags=re.IGNORECASE)
    cmds = [base64.b64encode(umsgpack.packb(c.lower())).decode("ascii") for c in sc.commands]
    nonce = secrets.token_urlsafe(18)
    return ("<!DOCTYPE html>\n<html><head><meta charset=utf-8>"
            f'<meta http-equiv="Content-Security-Policy" content="{CSP.format(nonce=nonce)}">'
            f"<title>{_html.escape('manipdyn: ' + str(sc.model.name))}</title>"
            "<style>body{margin:0}#meshcat-pane{width:100vw;height:100vh;overflow:hidden}</style></head>"
            '<body><div id="meshcat-pane"></div>'
            f'<script type="application/json" id="manipdyn-commands">{json_for_script(cmds)}</script>'
            f'<script nonce="{nonce}">{js}</script>'
            f'<script nonce="{nonce}">{PLAY_SCRIPT}{SEEK_SCRIPT}</script></body></html>\n')
