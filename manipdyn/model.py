"""The Model: a frozen set of arrays built once from a URDF, read by every algorithm.

Conventions owned here:
- One *body* per joint; body i is the child link of joint i, and its frame is that link's frame (the
  joint frame after the joint's motion), so joint i turns or slides along ``axis[i]`` expressed in body
  i's own frame. Links attached by fixed joints are merged into the body they hang from. The joint types
  (nq, nv, X_J(q), S, integrate/difference) are described once, in ``manipdyn.joints``.
- q order: depth-first from the root link, children of a link visited in the order of their joint
  names (as Pinocchio's URDF reader does), fixed joints skipped; ``parent[i] < i``. Joint i owns
  q[idx_q[i]:idx_q[i] + nqs[i]] and v[idx_v[i]:idx_v[i] + nvs[i]].
- nq = nv for revolute (continuous: one angle) and prismatic joints; a free-flyer root (7 q, 6 v) makes
  nq = nv + 1. SI units; gravity in the base frame, default [0, 0, -9.81].
"""
from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np

from types import MappingProxyType

from .errors import InputError
from .joints import (BALL, COORDS, FREEFLYER, HELICAL, IN_MODEL, NQ, NV, OMEGA_AT, PLANAR, QUAT_AT, RATES, TYPE_NAMES,
                     QUAT_TOL, UNIT_AT, UNIT_LEN)
from .kernel_form import KernelForm
from .quirks import QUIRK_KINDS

__all__ = ["Model", "Frame", "Constraint", "MimicModel", "check_gravity", "QUAT_TOL",
           "JOINT_DYNAMICS", "FRICTION_EPS", "check_joint_dynamics", "with_joint_dynamics"]

JOINT_DYNAMICS = ("armature", "damping", "friction")   # the per-velocity joint parameters of a Model
FRICTION_EPS = 1e-3      # rad/s (m/s): the Coulomb friction's regularisation, friction ⊙ tanh(q̇ / FRICTION_EPS)


def check_joint_dynamics(x, key, nv, where, names=None) -> np.ndarray:
    """A joint-dynamics array (``JOINT_DYNAMICS``: armature, damping, friction) as a new float array (nv,): None
    gives zeros; InputError naming ``key``, the joint and the value for a wrong shape, a non-finite or a negative
    entry."""
    if x is None:
        return np.zeros(nv)
    try:
        a = np.array(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(f"{where}: {key} must be {nv} real numbers (one per velocity), not {x!r}") from None
    if a.shape != (nv,):
        raise InputError(f"{where}: {key} has shape {a.shape}; expected ({nv},), one entry per velocity")
    bad = np.flatnonzero(~(np.isfinite(a) & (a >= 0.0)))
    if bad.size:
        k = int(bad[0])
        who = f" (joint {names[k]!r})" if names is not None else ""
        raise InputError(f"{where}: {key}[{k}]{who} = {float(a[k])!r}: must be finite and >= 0")
    return a


def with_joint_dynamics(model, joint_dynamics, where=None):
    """The model with some joints' armature, damping and friction set (the loaders' ``joint_dynamics=`` keyword):
    ``{joint name: {"armature": x, "damping": x, "friction": x}}``, any subset of the keys; x a number (every velocity
    of the joint) or one per velocity (a free flyer's six). None or {} returns the model. InputError names an
    unknown joint or key and a bad value (``check_joint_dynamics``)."""
    if not joint_dynamics:
        return model
    where = where or model.source or model.name
    if not isinstance(joint_dynamics, dict):
        raise InputError(f"{where}: joint_dynamics must be a dict {{joint name: dict(armature=, damping=, "
                         f"friction=)}}, not {joint_dynamics!r}")
    arrays = {key: np.array(getattr(model, key)) for key in JOINT_DYNAMICS}
    for joint, values in joint_dynamics.items():
        i = model.joint_index(joint) if isinstance(joint, str) else model.joint_index(repr(joint))
        if not isinstance(values, dict):
            raise InputError(f"{where}: joint_dynamics[{joint!r}] must be a dict of {', '.join(JOINT_DYNAMICS)}, "
                             f"not {values!r}")
        for key, x in values.items():
            if key not in JOINT_DYNAMICS:
                raise InputError(f"{where}: joint_dynamics[{joint!r}]: unknown key {key!r}; known: "
                                 f"{', '.join(JOINT_DYNAMICS)}")
            n, a = int(model.nvs[i]), int(model.idx_v[i])
            x = np.broadcast_to(x, (n,)) if np.ndim(x) == 0 else x
            arrays[key][a:a + n] = check_joint_dynamics(x, f"joint_dynamics[{joint!r}][{key!r}]", n, where)
    from dataclasses import replace
    return replace(model, **arrays)


def check_gravity(gravity, where="gravity") -> np.ndarray:
    """gravity as a float array (3,), finite; InputError otherwise (a NaN here makes every result NaN)."""
    try:
        g = np.asarray(gravity)
    except (TypeError, ValueError):
        g = None
    if g is None or g.dtype.kind not in "fiu" or g.shape != (3,) or not np.all(np.isfinite(g)):
        raise InputError(f"{where}: gravity must be 3 finite real numbers (m/s², base frame), not {gravity!r}")
    return g.astype(float)


@dataclass(frozen=True, eq=False)
class Frame:
    """A named frame rigidly attached to a body: x_body = R x_frame + p. body = -1 is the fixed base."""
    name: str
    body: int
    R: np.ndarray          # (3, 3) frame axes in the body frame
    p: np.ndarray          # (3,)   frame origin in the body frame


@dataclass(frozen=True, eq=False)
class Constraint:
    """A loop closure between two bodies (URDF ``<constraint>``, URDF+ ``<loop>``/``<coupling>``), frames given
    in each body's frame.

    type "revolute": the frames share their origin and their axis (5 equations); "spherical": the origin
    (3); "fixed": origin and orientation (6). Axes are unit vectors in the body frames. "coupling" (URDF+
    gear): 1 equation between joint coordinates, ratio · Σ q (joints from the bodies' common ancestor down to
    the parent body) − Σ q (same, down to the child body) = 0 — the velocity ratio child/parent is ``ratio``
    (generalized_rbda's rule); frames and axes are unused (identity, zeros).
    """
    name: str
    type: str
    parent: int            # body index of the parent link (-1 = fixed base)
    parent_link: str
    Rp: np.ndarray         # (3, 3) closure frame on the parent, in the parent body's frame
    pp: np.ndarray         # (3,)
    axis_p: np.ndarray     # (3,) closure axis in the parent body's frame
    child: int             # body index of the child link
    child_link: str
    Rc: np.ndarray         # (3, 3) closure frame on the child, in the child body's frame
    pc: np.ndarray         # (3,)
    axis_c: np.ndarray     # (3,) closure axis in the child body's frame
    ratio: float = 0.0     # coupling only: velocity ratio child / parent
    source: str = "constraint"  # the URDF element it came from (constraint, loop, loop_constraint, coupling, ...)

    @property
    def n_rows(self) -> int:
        return {"revolute": 5, "spherical": 3, "fixed": 6, "coupling": 1}[self.type]


def _rebuild(cls, kw):
    """A model from its constructor's arguments (``Model.__reduce__``)."""
    return cls(**kw)


@dataclass(frozen=True, eq=False)
class Model:
    """Kinematic tree with merged rigid bodies; immutable (arrays are read-only, mappings are proxies).

    nb = number of joints = number of moving bodies (``njoints``); arrays indexed by joint have nb rows.
    """
    name: str
    root_link: str
    joint_names: tuple     # (nb,) joints in q order
    body_names: tuple      # (nb,) child link of each joint (the body's frame)
    parent: np.ndarray     # (nb,) int, parent body, -1 = fixed base; parent[i] < i
    kind: np.ndarray       # (nb,) int, the joint's kind: a code of joints.IN_MODEL (REVOLUTE, PRISMATIC, FREEFLYER,
    #                        BALL, HELICAL, PLANAR)
    continuous: np.ndarray  # (nb,) bool, revolute joint without limits (Pinocchio: nq = 2)
    axis: np.ndarray       # (nb, 3) unit joint axis in body i's frame (a planar joint's: the plane's normal; free
    #                        flyer, ball: unused, zeros)
    R0: np.ndarray         # (nb, 3, 3) joint i's frame in its parent body's frame, at q = 0
    p0: np.ndarray         # (nb, 3) joint i's origin in its parent body's frame
    mass: np.ndarray       # (nb,) merged body mass, kg
    com: np.ndarray        # (nb, 3) merged centre of mass in the body frame, m
    inertia: np.ndarray    # (nb, 3, 3) merged inertia about the CoM, body axes, kg m²
    lower: np.ndarray      # (nb,) joint lower limit (-inf if none; free flyer, ball: -inf)
    upper: np.ndarray      # (nb,) joint upper limit (+inf if none; free flyer, ball: +inf)
    effort: np.ndarray     # (nb,) effort limit (inf if none)
    velocity: np.ndarray   # (nb,) velocity limit (inf if none)
    gravity: np.ndarray    # (3,) gravity acceleration in the base frame, m/s²
    frames: dict           # link name -> Frame, every link including merged ones (read-only mapping)
    merged: dict           # body link name (or root link) -> tuple of links merged into it (read-only)
    mimic: tuple           # ((joint, mimicked joint, multiplier, offset), ...) loaded as independent
    source: str = ""       # file the model was loaded from
    notes: tuple = ()      # what the loader did that a user should know (warnings included)
    constraints: tuple = field(default=())  # (Constraint, ...) loop closures; empty for a tree
    actuated: tuple = field(default=())     # joint names with a URDF <transmission>, q order
    locked: dict = field(default_factory=dict)  # joint -> value held fixed by reduce() (not in q): a float,
    #                                             a free flyer's pose (x y z qx qy qz qw) as a tuple
    quirks: tuple = field(default=())       # (Quirk, ...) what the loader noticed, in QUIRK_KINDS order
    # joint dynamics, one entry per velocity (model.v_names order), ≥ 0, finite; None = zeros (JOINT_DYNAMICS):
    armature: np.ndarray = None  # (nv,) rotor inertia reflected to the joint, kg m² (kg): M + diag(armature),
    #                              τ = rnea + armature ⊙ q̈ (Pinocchio's model.armature, MuJoCo's armature)
    damping: np.ndarray = None   # (nv,) viscous damping, N m s/rad (N s/m): τ_joint −= damping ⊙ q̇
    friction: np.ndarray = None  # (nv,) Coulomb friction, N m (N): τ_joint −= friction ⊙ tanh(q̇ / FRICTION_EPS)
    pitch: np.ndarray = None     # (nb,) a helical joint's pitch, m/rad (p_J = pitch θ axis); 0 for every other kind

    def __post_init__(self):
        if not (isinstance(self.gravity, np.ndarray) and self.gravity.dtype == np.float64):
            raise InputError(f"model {self.name!r}: gravity must be a float array (3,), not {self.gravity!r}")
        check_gravity(self.gravity, f"model {self.name!r}")
        for key in ("frames", "merged", "locked"):            # constant, like every array below
            object.__setattr__(self, key, MappingProxyType(dict(getattr(self, key))))
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        odd = [i for i in range(self.njoints) if int(self.kind[i]) not in IN_MODEL]
        if odd:
            k = int(self.kind[odd[0]])
            what = f"a {TYPE_NAMES[k]} joint (the loaders expand it)" if 0 <= k < len(TYPE_NAMES) else f"kind {k}"
            raise InputError(f"model {self.name!r}: joint {self.joint_names[odd[0]]!r} is {what}; a Model holds "
                             f"{', '.join(TYPE_NAMES[c] for c in IN_MODEL)} joints (manipdyn.joints)")
        pitch = np.zeros(self.njoints) if self.pitch is None else np.array(self.pitch, float).reshape(-1)
        if pitch.shape != (self.njoints,) and not np.any(pitch):   # a model replaced with other joints, no helical
            pitch = np.zeros(self.njoints)
        if pitch.shape != (self.njoints,) or not np.all(np.isfinite(pitch)) or np.any(pitch[self.kind != HELICAL]):
            raise InputError(f"model {self.name!r}: pitch must be {self.njoints} finite numbers, 0 but for helical "
                             f"joints, not {self.pitch!r}")
        pitch.setflags(write=False)
        object.__setattr__(self, "pitch", pitch)
        free = [self.joint_names[i] for i in range(self.njoints) if self.kind[i] == FREEFLYER and self.parent[i] >= 0]
        if free:
            raise InputError(f"model {self.name!r}: a free flyer hangs from the base (a free body); {free[0]!r} has a "
                             f"parent body")
        for c in self.constraints:                            # a coupling row sums joint angles and displacements
            a, b = (c.parent, c.child) if c.type == "coupling" else (-1, -1)
            while a != b:
                if a < b:
                    a, b = b, a
                if NV[int(self.kind[a])] != 1:
                    raise InputError(f"model {self.name!r}: coupling {c.name!r}: joint {self.joint_names[a]!r} on "
                                     f"its loop is a {TYPE_NAMES[int(self.kind[a])]} joint; a coupling relates "
                                     f"joints of one coordinate only")
                a = self.parent[a]
        nqs, nvs = _frozen([NQ[int(k)] for k in self.kind]), _frozen([NV[int(k)] for k in self.kind])
        derived = dict(nqs=nqs, nvs=nvs, idx_q=_frozen(np.concatenate([[0], np.cumsum(nqs)[:-1]]) if len(nqs) else []),
                       idx_v=_frozen(np.concatenate([[0], np.cumsum(nvs)[:-1]]) if len(nvs) else []),
                       nq=int(np.sum(nqs)), nv=int(np.sum(nvs)), v_joint=_frozen(np.repeat(np.arange(len(nvs)), nvs)),
                       q_names=_dof_names(self, COORDS), v_names=_dof_names(self, RATES))
        qi, vi = derived["idx_q"], derived["idx_v"]
        rot = [i for i in range(len(nqs)) if QUAT_AT[int(self.kind[i])] >= 0]
        derived.update(quat_q=_frozen([qi[i] + QUAT_AT[int(self.kind[i])] for i in rot]),
                       quat_v=_frozen([vi[i] + OMEGA_AT[int(self.kind[i])] for i in rot]),
                       unit_q=_frozen([(qi[i] + UNIT_AT[int(k)], UNIT_LEN[int(k)]) for i, k in enumerate(self.kind)
                                       if UNIT_LEN[int(k)]]).reshape(-1, 2))
        for key, value in derived.items():
            object.__setattr__(self, key, value)
        for key in JOINT_DYNAMICS:                           # (nv,) each, zeros when not given
            value = check_joint_dynamics(getattr(self, key), key, self.nv, f"model {self.name!r}", self.v_names)
            value.setflags(write=False)
            object.__setattr__(self, key, value)
        object.__setattr__(self, "passive", bool(np.any(self.damping) or np.any(self.friction)))
        object.__setattr__(self, "kernel", KernelForm.of(self))

    # -- derived once, in __post_init__ (the model is immutable: nothing is added later) --
    nqs: np.ndarray = field(init=False, repr=False)     # (nb,) configuration size of each joint (joints.NQ)
    nvs: np.ndarray = field(init=False, repr=False)     # (nb,) velocity size of each joint (joints.NV)
    idx_q: np.ndarray = field(init=False, repr=False)   # (nb,) index of joint i's first entry in q
    idx_v: np.ndarray = field(init=False, repr=False)   # (nb,) index of joint i's first entry in v (and a, τ)
    nq: int = field(init=False, repr=False)             # size of q
    nv: int = field(init=False, repr=False)             # size of v, a and τ
    q_names: tuple = field(init=False, repr=False)      # (nq,) the joint's name, or "root_joint.qx" for a free flyer's
    v_names: tuple = field(init=False, repr=False)      # (nv,) the joint's name, or "root_joint.wx" for a free flyer's
    v_joint: np.ndarray = field(init=False, repr=False)  # (nv,) the joint each entry of v belongs to
    quat_q: np.ndarray = field(init=False, repr=False)  # (k,) q index of every unit quaternion's qx (free flyer, ball)
    quat_v: np.ndarray = field(init=False, repr=False)  # (k,) v index of the matching body-frame ω's wx
    unit_q: np.ndarray = field(init=False, repr=False)  # (u, 2) [start, length] in q of every block of unit norm: a
    #                                                     quaternion (4), a planar joint's (cos θ, sin θ) (2)
    kernel: "KernelForm" = field(init=False, repr=False)  # what the compiled kernels read (kernel_form.py)
    passive: bool = field(init=False, repr=False)       # a damping or friction entry is nonzero (joint torques)

    def __reduce__(self):
        """Pickle the description only (what the constructor takes); the derived data, ``kernel`` included, is
        built again on loading: a model travels to worker processes (``--jobs``, a Dask cluster) as it was loaded."""
        kw = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        kw.update({key: dict(kw[key]) for key in ("frames", "merged", "locked")})
        return _rebuild, (type(self), kw)

    @property
    def njoints(self) -> int:
        """nb, the number of joints (= moving bodies)."""
        return len(self.joint_names)

    @property
    def state_shapes(self) -> tuple:
        """((nq,), (nv,)): the shapes of one state."""
        return self.kernel.q_shape, self.kernel.v_shape

    @property
    def floating(self) -> bool:
        """True when the root joint (joint 0) is a free flyer: a floating-base robot. Further free bodies (MJCF
        objects beside a robot) are free flyers hanging from the base too, without making the model floating."""
        return bool(self.njoints and self.kind[0] == FREEFLYER)

    def frame(self, name: str) -> Frame:
        """The frame of a link (merged links included); InputError names the unknown frame."""
        try:
            return self.frames[name]
        except (KeyError, TypeError):
            known = sorted(self.frames)
            raise InputError(f"model {self.name!r} has no link or frame named {name!r}; "
                             f"known: {', '.join(known[:50])}{' ...' if len(known) > 50 else ''}") from None

    def joint_index(self, name: str) -> int:
        """Index of a moving joint in q; InputError names the unknown joint."""
        try:
            return self.kernel.joint_index[name]
        except (KeyError, TypeError):
            raise InputError(f"model {self.name!r} has no moving joint named {name!r}; "
                             f"q order: {', '.join(self.joint_names[:50])}"
                             f"{' ...' if self.nv > 50 else ''}") from None

    def summary(self) -> str:
        """What the loader built: joints in q order, bodies, merges, massless links, mimics, notes."""
        sizes = f"nq = nv = {self.nv}" if self.nq == self.nv else f"nq = {self.nq}, nv = {self.nv}"
        lines = [f"model {self.name!r} from {self.source or '<memory>'}: {sizes}, "
                 f"root link {self.root_link!r}, gravity {self.gravity.tolist()}",
                 "joints in q order:"]
        for i, j in enumerate(self.joint_names):
            kind = "continuous" if self.continuous[i] else TYPE_NAMES[int(self.kind[i])]
            par = self.body_names[self.parent[i]] if self.parent[i] >= 0 else self.root_link
            how = f"axis {np.round(self.axis[i], 4).tolist()}"
            if self.kind[i] == FREEFLYER:      # a free body: q = [x y z qx qy qz qw]
                par = "world" if self.body_names[i] == self.root_link else par    # root_joint="free_flyer"
                how = "q = [x y z qx qy qz qw], v = [linear; angular] (body frame)"
            elif self.kind[i] == BALL:
                how = "q = [qx qy qz qw], v = angular velocity (body frame)"
            elif self.kind[i] == HELICAL:
                how += f", pitch {self.pitch[i]:.6g} m/rad"
            elif self.kind[i] == PLANAR:
                how = f"normal {np.round(self.axis[i], 4).tolist()}, q = [x y cos sin], v = [vx vy wz] (body frame)"
            lines.append(f"  q[{self.idx_q[i]}] {j:<28} {kind:<10} {how} "
                         f"{par} -> {self.body_names[i]}  mass {self.mass[i]:.6g} kg")
        for body, links in self.merged.items():
            if links:
                lines.append(f"merged into {body!r} (fixed joints): {', '.join(links)}")
        massless = [b for b, m in zip(self.body_names, self.mass) if m == 0.0]
        if massless:
            lines.append(f"massless bodies: {', '.join(massless)}")
        for j, src, mult, off in self.mimic:
            lines.append(f"mimic joint {j!r} (= {mult} * {src} + {off}) loaded as an independent joint")
        for c in self.constraints:
            how = f", ratio {c.ratio:g}" if c.type == "coupling" else ""
            lines.append(f"closure {c.name!r} ({c.type}{how}, {c.n_rows} equation(s), from <{c.source}>): "
                         f"{c.parent_link} <-> {c.child_link}")
        if self.actuated:
            lines.append(f"actuated joints (<transmission>): {', '.join(self.actuated)}")
        if self.locked:
            lines.append("locked joints: " + ", ".join(
                f"{j} = {v:g}" if np.ndim(v) == 0 else f"{j} = {np.round(v, 6).tolist()}" for j, v in self.locked.items()))
        for key in JOINT_DYNAMICS:
            if np.any(getattr(self, key)):
                lines.append(f"{key}: " + ", ".join(f"{n} {x:g}" for n, x in zip(self.v_names, getattr(self, key))
                                                     if x))
        lines += [f"note: {n}" for n in self.notes]
        for kind in QUIRK_KINDS:
            names = [q.name for q in self.quirks if q.kind == kind]
            if names:
                lines.append(f"quirk {kind}: {', '.join(names[:50])}{' ...' if len(names) > 50 else ''}")
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"Model({self.name!r}, nq={self.nq}, nv={self.nv}, joints={list(self.joint_names)})"


@dataclass(frozen=True, eq=False)
class MimicModel:
    """A tree whose <mimic> joints follow their targets: q_mimic = multiplier · q_target + offset, no coordinate
    of their own (``load_urdf(..., mimic=True)``; Pinocchio 4.1's ``buildModelFromUrdf(path, mimic=True)``).

    The one linear map (``manipdyn.dynamics.mimic`` applies it): q_full = Gq q + q_off, v_full = G v,
    a_full = G a, τ = Gᵀ τ_full, M = Gᵀ M_full G. Independent coordinates keep the full model's q order with
    the mimic joints' entries removed (Pinocchio's order). The calls listed in
    ``manipdyn.dynamics.mimic.TAKES_MIMIC`` take it in place of a Model; every other function refuses it (use
    ``full`` at ``full_state(q, v, a)``).
    """
    full: Model            # the tree with every joint moving (mimic joints as independent joints)
    G: np.ndarray          # (full.nv, nv) v_full = G v
    Gq: np.ndarray         # (full.nq, nq) q_full = Gq q + q_offset
    q_offset: np.ndarray   # (full.nq,)
    joint_names: tuple     # (k,) the independent joints, q order
    mimic: tuple           # ((joint, target joint, multiplier, offset), ...) as in the URDF

    def __post_init__(self):
        for value in (self.G, self.Gq, self.q_offset):
            value.setflags(write=False)

    @property
    def nq(self) -> int:
        return self.Gq.shape[1]

    @property
    def nv(self) -> int:
        return self.G.shape[1]

    @property
    def name(self) -> str:
        return self.full.name

    @property
    def quirks(self) -> tuple:
        return self.full.quirks

    @property
    def source(self) -> str:
        return self.full.source

    def full_state(self, q, v=None, a=None):
        """(q_full, v_full, a_full) = (Gq q + q_offset, G v, G a) of ``full`` from independent coordinates, each
        (n,) or (N, n); v, a None stay None. InputError names a wrong shape or a non-finite entry."""
        q = self.check("q", q, self.nq)
        out = [q @ self.Gq.T + self.q_offset]
        for name, x in (("v", v), ("a", a)):
            if x is not None and (np.ndim(x) != q.ndim or np.shape(x)[:-1] != q.shape[:-1]):
                raise InputError(f"{name} has shape {np.shape(x)}; q has {q.shape}: one state or the same batch")
            out.append(None if x is None else self.check(name, x, self.nv) @ self.G.T)
        return tuple(out)

    def check(self, name, x, n) -> np.ndarray:
        """x as float (n,) or (N, n), finite; InputError naming ``name`` otherwise."""
        if x is None:
            raise InputError(f"{name} is None; expected an array of real numbers")
        try:
            x = np.asarray(x, dtype=float)
        except (TypeError, ValueError):
            raise InputError(f"{name} must be real numbers, not {x!r}") from None
        if x.ndim not in (1, 2) or x.shape[-1] != n:
            raise InputError(f"{name} has shape {x.shape}; expected ({n},) or (N, {n}) for {self.name!r} "
                             f"(independent coordinates: {', '.join(self.joint_names)})")
        if not np.all(np.isfinite(x)):
            raise InputError(f"{name} has non-finite entries")
        return x

    def summary(self) -> str:
        full = self.full.summary().replace(") loaded as an independent joint", ") honoured: no coordinate of its own")
        lines = [full, f"mimic joints honoured: nq = {self.nq}, nv = {self.nv} independent "
                       f"coordinates ({', '.join(self.joint_names)})"]
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"MimicModel({self.name!r}, nq={self.nq}, nv={self.nv}, mimic={[m[0] for m in self.mimic]})"


def _frozen(x) -> np.ndarray:
    a = np.asarray(x, dtype=np.int64)
    a.setflags(write=False)
    return a


def _dof_names(model, names) -> tuple:
    """q_names (names = joints.COORDS) or v_names (joints.RATES): a 1-dof joint's name, "joint.qx" etc. else."""
    out = []
    for i, j in enumerate(model.joint_names):
        out += [f"{j}.{c}" for c in names[int(model.kind[i])]] or [j]
    return tuple(out)
