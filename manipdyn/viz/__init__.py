"""Browser 3D playback in meshcat: live (loopback-only server) or as one self-contained HTML file.

Imported on demand: ``import manipdyn`` never loads meshcat or any geometry. A URDF is untrusted: mesh files
are read only inside the URDF's folder or a package root (``package_dirs``, see geometry.py), names are
escaped for the page (scene.py), the animation has at most MAX_FRAMES frames, and the live server binds
loopback only and dies with its parent (server.py).
"""
from __future__ import annotations

import atexit
from pathlib import Path

import numpy as np

from ..errors import ConstraintError, GeometryWarning, InputError, SingularError  # noqa: F401 (re-exported)
from ..io.trajectory import read_trajectory_file
from ..joints import BALL, FREEFLYER, PLANAR, REVOLUTE
from . import scene as _scene
from .scene import MAX_FRAMES, PlaybackWarning  # noqa: F401 (re-exported)

ASSEMBLY_STARTS = 24                 # starting guesses tried when a frame does not assemble from the last one


def read_trajectory(path, model):
    """(t (T,), q (T, nv)) from a CSV (header t, q_<joint>...; other columns ignored) or an NPZ (t, q,
    joint_names). A closed chain may give only its actuated joints (completed later by assembly).
    The file is read strictly (manipdyn.io.trajectory): any flaw raises InputError naming the file."""
    t, names, q = read_trajectory_file(path)
    return t, _to_model_order(model, names, q, Path(path))


def _to_model_order(model, names, q, source):
    """Columns named by joint (a free flyer's by model.q_names: root_joint.x … root_joint.qw) -> (T, nq)."""
    unknown = [n for n in names if n not in model.q_names]
    if unknown:
        raise InputError(f"{source}: joints {unknown} are not moving joints of {model.name!r} "
                         f"(q entries: {', '.join(model.q_names[:20])})")
    full = np.full((q.shape[0], model.nq), np.nan)
    for k, n in enumerate(names):
        full[:, model.q_names.index(n)] = q[:, k]
    missing = [j for j in model.q_names if j not in names]
    if missing and not (model.constraints and set(model.actuated) <= set(names)):
        raise InputError(f"{source}: no column q_<joint> for {missing}")
    return full


def complete(model, Q, guess=None):
    """Fill the passive coordinates (NaN) of a closed chain by assembly, frame after frame: Q (T, nq).

    Each frame starts from the previous one (the first from ``guess``, default the middle of the joint
    ranges, a free flyer and ball joints at their neutral pose); a frame that does not assemble from there is
    retried from ASSEMBLY_STARTS guesses spread over the joint ranges. A free flyer whose columns are missing stays at
    the guess's pose (closures inside the robot do not place it). Raises ConstraintError naming the frame
    and the actuated values when none assembles."""
    Q = np.array(Q, dtype=float)
    if not np.isnan(Q).any():
        return Q
    known = ~np.isnan(Q[0])
    if np.any(np.isnan(Q[:, known])) or not np.all(np.isfinite(Q[~np.isnan(Q)])):
        raise InputError(f"complete({model.name!r}): the given coordinates must be finite in every frame")
    fixed = [j for i, j in enumerate(model.joint_names)       # joints whose whole q block is given
             if known[model.idx_q[i]:model.idx_q[i] + model.nqs[i]].all()]
    out = Q.copy()
    g = _mid_range(model) if guess is None else np.array(guess, dtype=float)
    for k in range(len(Q)):
        out[k] = g = _assemble_frame(model, Q[k], known, fixed, g, k)
    return out


def _mid_range(model):
    """Middle of every joint's range (±π where a range is unbounded or wider than a turn), a free flyer at
    its neutral pose: (nq,)."""
    lo, hi = _ranges(model)
    return _one_dof_q(model, 0.5 * (lo + hi))


def _one_dof_q(model, x):
    """A configuration (nq,) with the 1-dof joints at x (njoints,), a free flyer and ball joints neutral."""
    from ..configuration import neutral
    q = neutral(model)
    one = np.flatnonzero(model.nqs == 1)
    q[model.idx_q[one]] = x[one]
    return q


def _ranges(model):
    """(lo (njoints,), hi (njoints,)) joint ranges clipped to [−π, π] (a turn covers every revolute pose;
    a free flyer's entry is unused)."""
    lo = np.clip(np.where(np.isfinite(model.lower), model.lower, -np.pi), -np.pi, np.pi)
    hi = np.clip(np.where(np.isfinite(model.upper), model.upper, np.pi), -np.pi, np.pi)
    return lo, np.maximum(hi, lo)


def _assemble_frame(model, q_known, known, fixed, g, k):
    """One frame assembled: the given coordinates held, the others found from g, else from spread starts."""
    from ..constraints import assemble
    lo, hi = _ranges(model)
    rng = np.random.default_rng(k)
    starts = [g, _mid_range(model)] + [_one_dof_q(model, lo + (hi - lo) * rng.random(model.njoints))
                                       for _ in range(ASSEMBLY_STARTS)]
    err = None
    for s in starts:
        s = np.array(s, dtype=float)
        s[known] = q_known[known]
        try:
            return assemble(model, s, fixed=fixed).q
        except (ConstraintError, SingularError) as exc:
            err = exc
    given = ", ".join(f"{model.q_names[i]} = {q_known[i]:.6g}" for i in np.flatnonzero(known))
    raise ConstraintError(f"{model.name!r}: the loop closures cannot be assembled at frame {k} ({given}) from "
                          f"{len(starts)} starting guesses; last: {err}")


def scene_for(model, urdf_path, t, Q, show_frames=False, fps=None, package_dirs=None, plots=True, **signals):
    """The animated scene (meshcat commands) of a trajectory t (T,), Q (T, nq), with the plot data of the
    page (sc.plots, see viz/plots.py: q, q̇, τ, closure gaps; ``signals`` passes V, A, tau, tau_names,
    marks when they are known, else rates come from finite differences and torques from rnea or the
    constrained inverse dynamics).

    fps: animation frames per second (default: 30, more for short motions so that slow motion stays
    smooth). Meshes resolve only inside the URDF's folder or a package root (``package_dirs={"pkg": dir}``
    adds roots); at most MAX_FRAMES frames (``sc.notes`` says when fps was lowered). Raises InputError for a
    non-finite, unordered or oversized trajectory."""
    t, Q = _scene.check_trajectory(model, t, Q)
    sc = _scene.build(model, urdf_path, Q_extent=Q, show_frames=show_frames, package_dirs=package_dirs)
    sc = _scene.animate(sc, t, Q, auto_fps(float(t[-1] - t[0])) if fps is None else fps)
    if plots:
        from .plots import signals as _signals
        sc.plots = _signals(model, t, Q, **signals)
    return sc


def auto_fps(span):
    """Animation fps for a motion lasting ``span`` s: 30 frames per second of playback at the page's
    starting speed (scene.default_speed), so a 0.25 s motion gets 120 fps."""
    return float(min(_scene.MAX_FPS, 30.0 / _scene.default_speed(span)))


def export_html(model, urdf_path, t, Q, out, **kw):
    """Write the animation as one self-contained HTML file (plays offline; out.html#t=1.5 opens paused at
    1.5 s). Keywords as scene_for (show_frames, fps, package_dirs, V, A, tau, tau_names, marks)."""
    sc = scene_for(model, urdf_path, t, Q, **kw)
    Path(out).write_text(_scene.html(sc), encoding="utf-8")
    return sc


class LiveViewer:
    """A meshcat viewer on a loopback-only server started for it (see viz/server.py). The server stops with
    close(), at interpreter exit, and on its own when this process dies (it watches its stdin pipe)."""

    def __init__(self):
        from .server import start
        meshcat = _scene.meshcat_module("meshcat")          # before the server starts
        self.proc, self.zmq_url, self.url = start()
        atexit.register(self.close)
        self.vis = meshcat.Visualizer(zmq_url=self.zmq_url)

    def show(self, sc):
        for cmd in sc.commands:
            self.vis.window.send(cmd)

    def close(self):
        """Stop the server (idempotent): SIGTERM, then SIGKILL after 3 s; close the pipes and the ZMQ socket."""
        from .server import stop
        stop(self.proc)
        atexit.unregister(self.close)
        window = getattr(getattr(self, "vis", None), "window", None)
        if window is not None and hasattr(window, "zmq_socket"):
            window.zmq_socket.close(linger=0)


def serve(sc, out=print) -> int:
    """Play a scene on a live loopback server until Ctrl-C, SIGTERM or SIGHUP (each stops it and returns 0);
    the server stops with this process whatever ends it."""
    import signal
    import time

    def stop(signum, frame):
        raise KeyboardInterrupt(signal.Signals(signum).name)

    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):   # SIGINT too: a shell that starts a command in
        signal.signal(sig, stop)                                 # the background makes it ignore Ctrl-C
    live = None
    try:
        live = LiveViewer()
        live.show(sc)
        out(f"playing on {live.url} (loopback only; zmq {live.zmq_url}); Ctrl-C to stop", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        return 0
    finally:
        if live is not None:
            live.close()


def demo(model, urdf_path):
    """Built-in demo motion (t, q): see demo_motion."""
    m = demo_motion(model, urdf_path)
    return m["t"], m["Q"]


SPM_FPS = 240.0          # the SPM's 0.25 s: 61 frames (60 frames per second at the page's 0.25×)


def demo_motion(model, urdf_path) -> dict:
    """Built-in demo motion: {"t", "Q"} and what is known beside it ("V", "A", "tau", "tau_names",
    "marks", "fps": keywords of scene_for).

    The AAU arm follows the chapter's path over t ∈ [0, 2π] s with the torques of the 5 kg payload (Figs.
    3–4); the SPM runs the Fig. 7 scenario over its singularity-free span (validation/fig7.SPAN) at 240
    fps with the actuator torques of the generic route (external moment included) and the time at which
    a leg becomes singular marked; any other model swings every joint smoothly for 4 s (a serial arm ±0.5 rad
    around a pose that keeps it above its base, see _upright_centre; other trees ±0.8 rad around the middle
    of the ranges), except that a closed chain's actuated joints free to turn a full turn
    (a crank) turn once; a closed chain's passive joints are completed by assembly."""
    name = Path(urdf_path).name if urdf_path else ""
    if name == "aau_arm.urdf":
        from ..examples.aau_arm import chapter_example
        traj, tau = chapter_example(model, samples=126)
        return dict(t=traj.t, Q=traj.q, V=traj.v, A=traj.a, tau=tau, tau_names=list(model.joint_names))
    if name == "spm.urdf" and set(model.actuated) == {"leg1_theta", "leg2_theta", "leg3_theta"}:
        return _spm_demo(model)
    t = np.linspace(0.0, 4.0, 121)
    lo, hi = _ranges(model)
    mid, amp = 0.5 * (lo + hi), np.minimum(0.4 * (hi - lo), 0.8)
    wave = np.sin(2 * np.pi * np.outer(t, 0.25 + 0.05 * np.arange(model.njoints)))
    if model.nq == model.njoints and not model.constraints:
        mid, amp = _upright_centre(model, lo, hi, wave)
    swing = mid + amp * wave
    if model.constraints:
        turn = (hi - lo >= 2 * np.pi - 1e-9) & (model.kind == REVOLUTE)   # a crank turns once
        swing[:, turn] = lo[turn] + np.pi + 2 * np.pi * t[:, None] / t[-1]
    Q = swing
    if model.nq != model.njoints:           # a free flyer stays at the origin; a ball joint turns ±0.8 rad
        from ..configuration import integrate, neutral        # about (1, 1, 0)/√2; a planar joint turns ±0.8 rad
        turn = np.zeros((len(t), model.nv))                   # and slides ±0.2 m; 1-dof joints swing
        for j in np.flatnonzero(model.kind == BALL):
            turn[:, model.idx_v[j]:model.idx_v[j] + 3] = 0.8 * np.outer(wave[:, j], [1.0, 1.0, 0.0]) / np.sqrt(2.0)
        for j in np.flatnonzero(model.kind == PLANAR):
            turn[:, model.idx_v[j]:model.idx_v[j] + 3] = np.outer(wave[:, j], [0.2, 0.0, 0.8])
        Q = integrate(model, np.tile(neutral(model), (len(t), 1)), turn)
        one = np.flatnonzero(model.nqs == 1)
        Q[:, model.idx_q[one]] = swing[:, one]
    if model.constraints:                   # passive joints (1-dof and ball) completed by assembly
        for i in range(model.njoints):
            if model.kind[i] != FREEFLYER and model.joint_names[i] not in model.actuated:
                Q[:, model.idx_q[i]:model.idx_q[i] + model.nqs[i]] = np.nan
        return dict(t=t, Q=complete(model, Q))
    return dict(t=t, Q=Q)


def _upright_centre(model, lo, hi, wave, tries=48):
    """(centre (nv,), amplitude (nv,)) of a serial arm's demo swing: ±0.5 rad (less for short ranges)
    around the pose, among the middle of the ranges and ``tries`` seeded random poses within them, whose
    motion stays above the base best and, after that, is the most compact (it frames best)."""
    from ..dynamics.forward_kinematics import forward_kinematics
    amp = np.minimum(0.3 * (hi - lo), 0.5)
    rng = np.random.default_rng(0)
    cands = [0.5 * (lo + hi)] + [lo + amp + (hi - lo - 2 * amp) * rng.random(model.nv) for _ in range(tries)]
    best = None
    for c in cands:
        p = forward_kinematics(model, c + amp * wave[::6])[1]              # (nb, F, 3) body origins
        below = min(float(p[..., 2].min()), 0.0)
        score = 10.0 * below - float(np.linalg.norm(p.reshape(-1, 3).max(0) - p.reshape(-1, 3).min(0)))
        if best is None or score > best[0]:
            best = (score, c)
    return best[1], amp


def _spm_demo(model):
    """The Fig. 7 scenario on urdf/spm.urdf: actuators from the chapter's formulation, the tree completed
    through the closures, actuator torques by the generic route (examples/spm_routes.py)."""
    from ..examples import spm as chapter
    from ..examples import spm_params as P
    from ..examples.spm_routes import generic_torques
    from ..examples.spm_urdf import tree_guess
    from ..validation.fig7 import SPAN
    t = np.arange(round((SPAN[1] - SPAN[0]) * SPM_FPS) + 1) / SPM_FPS + SPAN[0]
    f = chapter.fig7(t)
    th, thd, thdd = f.q[:, :3], f.qd[:, :3], f.qdd[:, :3]
    start = tree_guess(model, chapter.platform_rotation(f.q[0, 3:]), th[0])
    tau, Q, V, A, _ = generic_torques(model, start, th, thd, thdd, P.MOMENT)
    leg, ts = chapter.singular_time(t_max=SPAN[1] + 0.1, dt=1e-3)
    marks = [] if leg is None else [(ts, f"leg {leg} singular")]
    return dict(t=t, Q=Q, V=V, A=A, tau=tau, tau_names=list(model.actuated), marks=marks, fps=SPM_FPS)
