"""The engines referee: Pinocchio, MuJoCo, PyBullet and Drake against manipdyn on the same file and the same
seeded random states (``referee``), and its report (``RefereeReport``, ``format_referee``).

Each engine is loaded by its adapter (adapters.py) and asked τ = ID(q, q̇, q̈), M(q) and q̈ = FD(q, q̇, τ) in our
joint order; the errors are the worst over the states (docs/design.md §3; q̈ as err/cond(M)). The comparison
includes our own joint dynamics (docs/design.md §3): the model's armature (in ``rnea`` and ``mass_matrix``) and
its damping (URDF ``<dynamics damping>``) wherever the engine applies damping (``applied_damping``); friction is
left out on both sides (MuJoCo's frictionloss is a constraint, off in these queries). A disagreement above
``TOL`` must carry a named cause (causes.py: the engine's parameters against the file's own numbers, link by
link, and against our armature and damping); ``referee`` then rebuilds our model with the engine's parameters
(``dataclasses.replace`` on mass/com/inertia, the engine's armature and damping added analytically) and compares
again: what remains is the engine's precision.
"""
from __future__ import annotations

import dataclasses
import math
import time

import numpy as np

from ..dynamics.aba import aba
from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import rnea
from ..errors import InputError, ManipdynError
from ..io.load import robot_format
from ..joints import FREEFLYER, TYPE_NAMES
from .adapters import ENGINES, EngineMissing, EngineRefused, _KIND_NAME, _one_line, load_engine
from .causes import applied_damping, explain, neutralised, precision_causes, refusal_causes
from .compare import random_states
from .measure import error
from .referee_urdf import urdf_inertials

TOL = 1e-9                    # a disagreement above this must carry a named cause


@dataclasses.dataclass
class EngineResult:
    """One engine against manipdyn: worst errors (docs/design.md §3; q̈ as err/cond(M)), raw and neutralised."""
    engine: str
    status: str                       # "ok", "missing", "refused"
    reason: str = ""
    err: dict = dataclasses.field(default_factory=dict)        # "tau", "M", "qdd" -> float or None
    neutral: dict = dataclasses.field(default_factory=dict)    # the same with the quirks neutralised
    causes: list = dataclasses.field(default_factory=list)
    notes: list = dataclasses.field(default_factory=list)
    precision: str = ""
    seconds: float = 0.0

    @property
    def worst(self):
        vals = [v for v in self.err.values() if v is not None]
        return max(vals) if vals else None

    @property
    def worst_neutral(self):
        vals = [v for v in self.neutral.values() if v is not None]
        return max(vals) if vals else None

    @property
    def explained(self) -> bool:
        """Agrees (≤ TOL), or every disagreement carries a cause and vanishes once neutralised."""
        if self.status != "ok":
            return True
        if self.worst is None or self.worst <= TOL:
            return True
        return bool(self.causes) and self.worst_neutral is not None and self.worst_neutral <= TOL


@dataclasses.dataclass
class RefereeReport:
    name: str
    source: str
    nv: int
    n_states: int
    seed: int
    engines: list
    notes: list = dataclasses.field(default_factory=list)

    @property
    def explained(self) -> bool:
        return all(r.explained for r in self.engines)

    def as_dict(self) -> dict:
        d = dataclasses.asdict(self)
        for r, rd in zip(self.engines, d["engines"]):
            rd["explained"] = r.explained
        d["explained"] = self.explained
        return d


def referee(model, path, engines=ENGINES, *, n_states=100, seed=0) -> RefereeReport:
    """Every engine against manipdyn on the same seeded random states: τ, M, q̈, causes, neutralised."""
    if np.any(model.kind[1:] == FREEFLYER) or (np.any(model.kind == FREEFLYER) and not model.floating):
        raise InputError(f"{path}: the engines referee compares fixed-base models and a free-flyer root only")
    other = [f"{n} ({TYPE_NAMES[int(k)]})" for n, k in zip(model.joint_names, model.kind) if k not in _KIND_NAME]
    if other:
        raise InputError(f"{path}: the engines referee compares revolute, prismatic, ball and free-flyer joints "
                         f"(what every engine has), not {', '.join(other[:5])}; validate --against pinocchio compares "
                         f"every kind")
    rng = np.random.default_rng(seed)
    Q, V, A = random_states(model, n_states, rng)
    T = rng.normal(0.0, 5.0, V.shape)
    ours = None if model.nv == 0 else _our_terms(model, Q, V, A, T, np.zeros(model.nv), np.zeros(model.nv))
    mjcf = robot_format(path) == "mjcf"
    inertials = {} if mjcf else urdf_inertials(path)
    rep = RefereeReport(model.name, str(path), model.nv, n_states, seed, [])
    if mjcf:
        rep.notes.append("an MJCF file: each engine's bodies are compared with the model's (no per-link URDF "
                         "<inertial> to diff against)")
    if model.nv == 0:
        rep.notes.append("no moving joint: nothing to compare")
        return rep
    if model.constraints:
        rep.notes.append(f"{len(model.constraints)} loop closure(s) (<constraint>) not compared: the engines "
                         "load the open tree, and so do the terms here")
    if ours["qdd"] is None:
        rep.notes.append(f"manipdyn forward dynamics: {ours['why']} (q̈ not compared)")
    for name in engines:
        t0 = time.perf_counter()
        try:
            with _quiet():
                ad = load_engine(name, model, path)
        except EngineMissing as exc:
            rep.engines.append(EngineResult(name, "missing", str(exc)))
            continue
        except EngineRefused as exc:
            rep.engines.append(EngineResult(name, "refused", str(exc), causes=refusal_causes(str(exc), inertials)))
            continue
        res = EngineResult(name, "ok", precision=ad.precision)
        with _quiet():
            theirs = _engine_terms(ad, Q, V, A, T)
        res.notes = list(ad.notes)
        res.err = _errors(theirs, _our_terms(model, Q, V, A, T, np.zeros(model.nv), applied_damping(model, ad),
                                             ad.damping_in_id))      # our armature (in M) and damping
        res.causes = explain(model, ad, inertials)
        if (res.worst or 0) > TOL and not res.causes:
            res.causes = precision_causes(model, ad, inertials)
        if theirs.get("why"):
            res.notes.append(f"{name} forward dynamics: {theirs['why']}")
        nm = neutralised(model, ad)
        res.neutral = _errors(theirs, _our_terms(nm, Q, V, A, T, ad.armature - model.armature, ad.damping,
                                                 ad.damping_in_id))
        res.seconds = time.perf_counter() - t0
        rep.engines.append(res)
        del ad
    return rep


def _our_terms(model, Q, V, A, T, arm, damp, damp_in_id=True):
    """Our τ, M, q̈ on the states (the model's armature in τ and M, as ``rnea`` and ``mass_matrix`` hold it), with
    arm added to M's diagonal and damp as the engine applies damping (zeros: rnea, mass_matrix, aba alone)."""
    tau = rnea(model, Q, V, A) + arm * A + (damp * V if damp_in_id else 0.0)
    M = mass_matrix(model, Q) + np.diag(arm)
    out = dict(tau=tau, M=M, qdd=None, why="", cond=np.linalg.cond(M))
    try:
        if np.any(arm) or np.any(damp):
            h = rnea(model, Q, V, np.zeros_like(V)) + damp * V
            out["qdd"] = np.linalg.solve(M, (T - h)[..., None])[..., 0]
        else:
            out["qdd"] = aba(model, Q, V, T)
        if not np.all(np.isfinite(out["qdd"])):
            out["qdd"], out["why"] = None, "non-finite q̈"
    except (ManipdynError, np.linalg.LinAlgError) as exc:
        out["qdd"], out["why"] = None, _one_line(exc)
    return out


def _engine_terms(ad, Q, V, A, T):
    with ad.session():
        return _engine_queries(ad, Q, V, A, T)


def _engine_queries(ad, Q, V, A, T):
    out = dict(tau=np.array([ad.tau(q, v, a) for q, v, a in zip(Q, V, A)]) if "tau" in ad.terms else None,
               M=np.array([ad.mass(q) for q in Q]), qdd=None, why="")
    if "qdd" not in ad.terms:
        out["why"] = "not asked of this engine for this model (see its notes)"
        return out
    try:
        out["qdd"] = np.array([ad.qdd(q, v, t) for q, v, t in zip(Q, V, T)])
        if not np.all(np.isfinite(out["qdd"])):
            out["qdd"], out["why"] = None, "non-finite q̈ (singular mass matrix)"
    except Exception as exc:                     # an engine's refusal, kept as its message
        out["qdd"], out["why"] = None, _one_line(exc)
    return out


def _errors(theirs, ours) -> dict:
    """Worst error measure over the states; q̈ as err/cond(M) (docs/design.md §3), None when either side has none."""
    err = {}
    for k in ("tau", "M"):
        if theirs[k] is None:                    # the engine cannot give it for this model (its notes say why)
            err[k] = None
            continue
        err[k] = max(error(x, y) for x, y in zip(theirs[k], ours[k])) if np.all(np.isfinite(theirs[k])) \
            else math.inf
    if theirs["qdd"] is None or ours["qdd"] is None:
        err["qdd"] = None
    else:
        err["qdd"] = max(error(x, y) / c for x, y, c in zip(theirs["qdd"], ours["qdd"], ours["cond"]))
    return err


class _quiet:
    """Silence C-level stdout/stderr (PyBullet prints its build time and warnings there)."""

    def __enter__(self):
        import os
        import sys
        for s in (sys.stdout, sys.stderr):
            try:
                s.flush()
            except Exception:
                pass
        self.os, self.saved = os, []
        try:
            null = os.open(os.devnull, os.O_WRONLY)
            for fd in (1, 2):
                self.saved.append((fd, os.dup(fd)))
                os.dup2(null, fd)
            os.close(null)
        except OSError:
            self.saved = []
        return self

    def __exit__(self, *exc):
        for fd, old in self.saved:
            self.os.dup2(old, fd)
            self.os.close(old)
        return False


def _fmt(x):
    return "-" if x is None else f"{x:.1e}"


def format_referee(rep: RefereeReport) -> str:
    """One table: engine, status, worst τ / M / q̈ errors, the same neutralised, and the named causes."""
    lines = [f"{rep.name}  ({rep.source})  nv={rep.nv}  states={rep.n_states}  seed={rep.seed}",
             f"  {'engine':<10} {'status':<8} {'tau':>8} {'M':>8} {'qdd/κ':>8}   "
             f"{'neutralised: tau':>16} {'M':>8} {'qdd/κ':>8}  verdict"]
    for r in rep.engines:
        if r.status != "ok":
            lines.append(f"  {r.engine:<10} {r.status:<8} {r.reason}")
            continue
        verdict = ("agrees" if (r.worst or 0) <= TOL else "explained" if r.explained else "UNEXPLAINED")
        e, n = r.err, r.neutral
        lines.append(f"  {r.engine:<10} {r.status:<8} {_fmt(e['tau']):>8} {_fmt(e['M']):>8} {_fmt(e['qdd']):>8}   "
                     f"{_fmt(n['tau']):>16} {_fmt(n['M']):>8} {_fmt(n['qdd']):>8}  {verdict}")
    for r in rep.engines:
        for c in r.causes:
            lines.append(f"  cause [{r.engine}] {c['kind']}: {c['text']}")
        for note in r.notes:
            lines.append(f"  note [{r.engine}] {note}")
    lines += [f"  note: {n}" for n in rep.notes]
    lines.append(f"  => {'every disagreement above %g has a named cause' % TOL if rep.explained else 'UNEXPLAINED'}")
    return "\n".join(lines)
