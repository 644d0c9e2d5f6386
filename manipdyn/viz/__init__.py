"""Browser 3D playback in meshcat: live (loopback-only server) or as one self-contained HTML file.

Imported on demand: ``import manipdyn`` never loads meshcat or any geometry.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io.trajectory import read_trajectory_file
from . import scene as _scene


def read_trajectory(path, model):
    """(t (T,), q (T, nv)) from a CSV (header t, q_<joint>...; other columns ignored) or an NPZ (t, q,
    joint_names). A closed chain may give only its actuated joints (completed later by assembly).
    The file is read strictly (manipdyn.io.trajectory): any flaw raises InputError naming the file."""
    t, names, q = read_trajectory_file(path)
    return t, _to_model_order(model, names, q, Path(path))


def _to_model_order(model, names, q, source):
    unknown = [n for n in names if n not in model.joint_names]
    if unknown:
        raise InputError(f"{source}: joints {unknown} are not moving joints of {model.name!r}")
    full = np.full((q.shape[0], model.nv), np.nan)
    for k, n in enumerate(names):
        full[:, model.joint_index(n)] = q[:, k]
    missing = [j for j in model.joint_names if j not in names]
    if missing and not (model.constraints and set(model.actuated) <= set(names)):
        raise InputError(f"{source}: no column q_<joint> for {missing}")
    return full


def complete(model, Q, guess=None):
    """Fill the passive coordinates (NaN) of a closed chain by assembly, frame after frame."""
    from ..constraints import assemble
    if not np.isnan(Q).any():
        return Q
    out, g = Q.copy(), np.zeros(model.nv) if guess is None else np.array(guess, float)
    known = ~np.isnan(Q[0])
    for k in range(len(Q)):
        g[known] = Q[k, known]
        g = assemble(model, g, fixed=[model.joint_names[i] for i in np.flatnonzero(known)]).q
        out[k] = g
    return out


def scene_for(model, urdf_path, t, Q, show_frames=False, fps=30.0):
    """The animated scene (meshcat commands) of a trajectory."""
    sc = _scene.build(model, urdf_path, Q_extent=Q, show_frames=show_frames)
    return _scene.animate(sc, t, Q, fps)


def export_html(model, urdf_path, t, Q, out, **kw):
    """Write the animation as one self-contained HTML file (plays offline; out.html#t=1.5 opens at 1.5 s)."""
    sc = scene_for(model, urdf_path, t, Q, **kw)
    Path(out).write_text(_scene.html(sc), encoding="utf-8")
    return sc


class LiveViewer:
    """A meshcat viewer on a loopback-only server started for it (see viz/server.py)."""

    def __init__(self):
        import meshcat
        from .server import start
        self.proc, self.zmq_url, self.url = start()
        self.vis = meshcat.Visualizer(zmq_url=self.zmq_url)

    def show(self, sc):
        for cmd in sc.commands:
            self.vis.window.send(cmd)

    def close(self):
        self.proc.kill()
        self.proc.wait()


def demo(model, urdf_path):
    """Built-in demo motion (t, q): the AAU arm on the chapter's path, the SPM under the Fig. 7 scenario,
    any other model swinging every joint smoothly within its limits for 4 s."""
    name = Path(urdf_path).name if urdf_path else ""
    if name == "aau_arm.urdf":
        from ..examples.aau_arm import chapter_example
        traj, _ = chapter_example(model, samples=126)
        return traj.t, traj.q
    if name == "spm.urdf":
        from ..examples import spm as chapter
        from ..examples.spm_urdf import tree_guess
        t = np.linspace(0.0, 0.25, 51)
        f = chapter.fig7(t)
        Q = np.full((len(t), model.nv), np.nan)
        Q[:, [model.joint_index(j) for j in model.actuated]] = f.q[:, :3]
        return t, complete(model, Q, tree_guess(model, chapter.platform_rotation(f.q[0, 3:]), f.q[0, :3]))
    t = np.linspace(0.0, 4.0, 121)
    lo = np.where(np.isfinite(model.lower), model.lower, -np.pi)
    hi = np.where(np.isfinite(model.upper), model.upper, np.pi)
    mid, amp = 0.5 * (lo + hi), 0.4 * (hi - lo)
    Q = mid + amp * np.sin(2 * np.pi * np.outer(t, 0.25 + 0.05 * np.arange(model.nv)))
    if model.constraints:
        Q[:, [i for i in range(model.nv) if model.joint_names[i] not in model.actuated]] = np.nan
        return t, complete(model, Q)
    return t, Q
