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
from .spatial import skew
from .joints import (BALL, COORDS, FREEFLYER, HELICAL, IN_MODEL, NQ, NV, OMEGA_AT, PLANAR, PRISMATIC, QUAT_AT, RATES,
                     REVOLUTE, TYPE_NAMES, UNIT_AT, UNIT_LEN, motion_subspace)

__all__ = ["Model", "KernelForm", "Frame", "Constraint", "Quirk", "QUIRK_KINDS", "MimicModel", "check_gravity", "REVOLUTE", "PRISMATIC",
           "FREEFLYER", "BALL", "HELICAL", "PLANAR", "QUAT_TOL",
           "JOINT_DYNAMICS", "FRICTION_EPS", "check_joint_dynamics", "with_joint_dynamics"]

JOINT_DYNAMICS = ("armature", "damping", "friction")   # the per-velocity joint parameters of a Model
FRICTION_EPS = 1e-3      # rad/s (m/s): the Coulomb friction's regularisation, friction ⊙ tanh(q̇ / FRICTION_EPS)
QUAT_TOL = 1e-8          # | ‖quat‖ − 1 | accepted in a free flyer's or ball joint's q, and for a planar joint's
#                          (cos θ, sin θ) (integrate's output: ~1e-16)


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


# What the loader reports about a file (Model.quirks), one kind per engine difference or data flaw:
QUIRK_KINDS = {
    "zero_mass_inertia": "mass 0 but a nonzero rotational inertia (kept or dropped: load_urdf zero_mass_inertia=)",
    "point_mass": "an <inertial> with <mass> but no <inertia>: a point mass at its <origin> (Pinocchio 4.1's reading)",
    "non_psd_inertia": "a body's inertia is not positive semi-definite: loaded as written (load_urdf "
                       "non_psd_inertia=\"keep\"; the default refuses it)",
    "no_inertial": "a link carried by a moving joint has no <inertial> (a massless body unless fixed links add mass)",
    "triangle": "principal moments violate the triangle inequality I1 + I2 >= I3",
    "rotated_root_inertial": "the root link's <inertial><origin rpy> is not zero",
    "free_root": "the root body carries mass and the tree's shape says it is a free body (legs, or a heavy body "
                 "with a hanging appendage, or no joint at all): load with root_joint=\"free_flyer\"",
    "mimic": "a <mimic> joint (honoured with mimic=True, else loaded as an independent joint)",
    "version": "<robot version> that urdfdom 6 (Pinocchio 4.1's reader) refuses; manipdyn loads the file",
    "xml_version": "an XML declaration whose version is not 1.x (<?xml version=\"0.0\"?>): read as XML 1.0, as "
                   "urdfdom (Pinocchio), MuJoCo, PyBullet and Drake ignore it",
    "xml_text": "whitespace before the XML declaration, or NUL bytes (a C string's terminator) after the document: "
                "removed before parsing, as urdfdom (Pinocchio), MuJoCo and PyBullet read such files",
    "inverted_limits": "a joint <limit> with lower > upper: read as no position limit (PyBullet's reading; urdfdom "
                       "keeps the numbers); limits never enter the dynamics (load_urdf strict=True refuses it)",
    "unknown_element": "an element manipdyn does not read (reported, never dropped in silence)",
    "joint_dynamics": "an MJCF joint's stiffness, springref or springdamper is nonzero: read, not applied yet (its "
                      "armature, damping and frictionloss are applied: Model.armature, damping, friction)",
    "free_armature": "an MJCF free joint's armature: applied as Pinocchio applies model.armature, armature ⊙ v̇ with v "
                     "the body-frame twist; MuJoCo adds it to d/dt of its world-frame linear velocity, so its τ differs "
                     "by armature · R (ω × v_lin) on the linear rows (M and the energy are the same)",
    "joint_ref": "an MJCF joint's ref (MuJoCo's qpos0) is nonzero: folded into the joint's placement, so q is MuJoCo's "
                 "qpos and q = 0 is not the pose drawn in the file",
    "passive_force": "an MJCF element that adds passive forces manipdyn does not apply (a body's gravcomp, a tendon's "
                     "stiffness or damping, <option> fluid density, viscosity or wind); MuJoCo's mj_rne leaves them out "
                     "too",
    "equality_softness": "an MJCF equality's solref, solimp or a weld's torquescale: MuJoCo's constraint softness (or "
                         "the scale of its rows), not a model parameter; manipdyn's closures are rigid",
    "inactive_equality": "an MJCF equality with active=\"false\": not read as a closure (MuJoCo starts with it off)",
}


@dataclass(frozen=True)
class Quirk:
    """One thing the loader noticed in a file: kind (a key of QUIRK_KINDS), the link, joint or element it
    concerns, and a detail sentence."""
    kind: str
    name: str
    detail: str

    def as_dict(self) -> dict:
        return {"kind": self.kind, "name": self.name, "detail": self.detail}


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
    kernel: "KernelForm" = field(init=False, repr=False)  # what the compiled kernels read (KernelForm below)
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


# -- the kernel form: everything derived from a Model for the compiled kernels, built once --------------------

@dataclass(frozen=True, eq=False, slots=True)
class KernelForm:
    """What the compiled kernels (and the one-state fast paths) read of a Model, derived once when the model is
    built (``Model.kernel``): the Model holds the description, this holds the same numbers laid out for the
    kernels, as MuJoCo's mjModel holds its arrays or Pinocchio's Model its derived tree data. Read-only.

    The kernels take the whole model as two arrays, ``I`` and ``F`` (each array argument of a compiled call
    costs ~30 ns of dispatch, so 13 named arrays would cost a one-state call ~0.4 µs more); ``dynamics.core.unpack``
    turns them back into the named views of ``core.ModelArrays`` inside every kernel, and is the only reader of
    the layout below.
    """
    q_shape: tuple             # (nq,): one configuration
    v_shape: tuple             # (nv,): one velocity, acceleration or torque
    arrays: tuple              # (I, F), the two below, as the kernels take them
    I: np.ndarray              # (5, nb) int64, rows: parent, kind, idx_q, idx_v, nv_j (joints in q order)
    F: np.ndarray              # (4 nb + 1 + m + ⌈nv/9⌉, 3, 3) float64, blocks of 3×3: [0, nb) R0; [nb, 2nb) inertia
    #                            about the CoM; [2nb, 3nb) rows (axis, p0, com); [3nb, 4nb) mass in [·, 0, 0], pitch
    #                            in [·, 0, 1]; 4nb: −g
    #                            in row 0; then m = max(2, 2⌈nv/3⌉) blocks holding S (nv, 6) row by row ([linear;
    #                            angular], joints.motion_subspace); then the armature (nv,) (Model.armature)
    config: tuple              # (kind (nb,), continuous (nb,) bool, idx_q (nb,), idx_v (nb,)): configuration kernels
    joint_index: MappingProxyType  # joint name -> index in q order (O(1) lookups on large models)
    frame_rows: MappingProxyType   # frame name -> (body, X (4, 3) = [R; p]: the frame in its body)
    one_state_rows: MappingProxyType  # (frame name, reference) -> X (5, 3) = [R; p; (body, 0, local)]
    wrench_rows: MappingProxyType  # (frame name, "local" | "world") -> P (13,) = [R (9, row by row: the frame's
    #                                axes into the body's, identity for "world"); origin in the body (3); body]
    closure_ints: np.ndarray   # (nc, 3) int64 [parent body, child body, number of orientation pairs (−1: coupling)]
    closure_floats: np.ndarray  # (nc, 24) [pp (3), pc (3), a_1..a_3 (9), b_1..b_3 (9)]; a coupling: [ratio, 0, ...]
    closure_labels: tuple      # (m,) the name of every closure row ("<closure>.x|y|z|r1|r2|r3|c")
    result_shapes: tuple       # one state's result of a route (dynamics/route.py), by route.SHAPES: (nv,), (nv, nv),
    #                            (nv, 10 nb) (the regressor)
    lane_arrays: tuple         # (I, F) of the same model in z-aligned body frames (``z_aligned``): what the lane
    #                            kernels take (a batch's route; the GPU)
    lane_turns: np.ndarray     # (nb, 3, 3) C_i: body i's z-aligned frame in its own (x_body = C_i x_lane); a
    #                            wrench's rows are turned with it as they are laid out (state.wrench_rows(lanes=True))
    lane_frame_rows: MappingProxyType   # frame_rows in those frames

    @classmethod
    def of(cls, model) -> "KernelForm":
        """The kernel form of a Model (called once, by Model.__post_init__)."""
        nb = model.njoints
        I = np.zeros((5, nb), np.int64)
        if nb:
            I[:] = np.vstack([model.parent, model.kind, model.idx_q, model.idx_v, model.nvs])
        F = _floats(model, model.R0, model.inertia, model.axis, model.p0, model.com)
        config = (np.array(model.kind, np.int64), np.array(model.continuous, np.bool_),
                  np.array(model.idx_q, np.int64), np.array(model.idx_v, np.int64))
        frame_rows, one_state, wrench = {}, {}, {}
        for name, fr in model.frames.items():
            R, p = np.asarray(fr.R, float), np.asarray(fr.p, float)
            X = np.ascontiguousarray(np.vstack([R, p]))
            frame_rows[name] = (int(fr.body), X)
            for reference in ("local_world_aligned", "local"):
                one_state[name, reference] = np.vstack([X, [float(fr.body), 0.0, float(reference == "local")]])
            for axes in ("local", "world"):
                wrench[name, axes] = np.concatenate([(R if axes == "local" else np.eye(3)).ravel(), p, [float(fr.body)]])
        ints, floats, labels = _closure_form(model.constraints)
        *turned, turn = z_aligned(model)
        Fz = _floats(model, *turned)
        lane_frames = {}
        for name, (b, X) in frame_rows.items():
            C = turn[b] if b >= 0 else np.eye(3)             # the frame in the body's z-aligned frame: Cᵀ R, Cᵀ p
            lane_frames[name] = (b, np.ascontiguousarray(np.vstack([C.T @ X[:3], C.T @ X[3]])))
        arrays = [I, F, Fz, *config, ints, floats, *(x for _, x in frame_rows.values()), *one_state.values(),
                  *wrench.values(), turn, *(x for _, x in lane_frames.values())]
        for a in arrays:
            a.setflags(write=False)
        return cls((model.nq,), (model.nv,), (I, F), I, F, config,
                   MappingProxyType({name: i for i, name in enumerate(model.joint_names)}),
                   MappingProxyType(frame_rows), MappingProxyType(one_state), MappingProxyType(wrench),
                   ints, floats, labels,
                   ((model.nv,), (model.nv, model.nv), (model.nv, 10 * nb)),
                   (I, Fz), turn, MappingProxyType(lane_frames))


def _floats(model, R0, inertia, axis, p0, com):
    """F, the kernels' float array (KernelForm's layout), of the model with these joint frames, inertias, axes,
    origins and centres of mass (the model's own, or ``z_aligned``'s)."""
    nb = model.njoints
    S = np.concatenate([motion_subspace(int(k), a, h) for k, a, h in zip(model.kind, axis, model.pitch)]) if nb \
        else np.zeros((0, 6))
    m = max(2, 2 * ((model.nv + 2) // 3))             # even: 9 m numbers reshape into (3 m / 2, 6) ⊇ S
    F = np.zeros((4 * nb + 1 + m + (model.nv + 8) // 9, 3, 3))     # then armature (nv,) in whole blocks
    F[:nb], F[nb:2 * nb] = R0, inertia
    F[2 * nb:3 * nb, 0], F[2 * nb:3 * nb, 1], F[2 * nb:3 * nb, 2] = axis, p0, com
    F[3 * nb:4 * nb, 0, 0] = model.mass
    F[3 * nb:4 * nb, 0, 1] = model.pitch
    F[4 * nb, 0] = -np.asarray(model.gravity, float)
    F[4 * nb + 1:4 * nb + 1 + m].reshape(-1, 6)[:model.nv] = S
    F[4 * nb + 1 + m:].reshape(-1)[:model.nv] = model.armature
    return F


def z_turn(k) -> np.ndarray:
    """C, the rotation that turns e_z into the unit vector k (C e_z = k): the identity for k = e_z, a half turn
    about x for k = −e_z, else the shortest turn, about u = e_z × k / |e_z × k|, by Rodrigues with cos = k_z and
    sin = |e_z × k| taken from k itself (``spatial.axis_angle`` takes an angle, whose sin and cos would round: this
    way a turn onto a coordinate axis is exact)."""
    k = np.asarray(k, float)
    c, s = k[2], np.hypot(k[0], k[1])
    if s == 0.0:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    u = np.array([-k[1] / s, k[0] / s, 0.0])
    return c * np.eye(3) + s * skew(u) + (1.0 - c) * np.outer(u, u)


def z_aligned(model):
    """The model's joint frames, inertias, axes, origins and centres of mass with every 1-dof joint's body frame
    turned so that its joint axis is z (the chapter's z'_i, docs/design.md §4c): body i's frame becomes C_i
    (``z_turn`` of its axis; the identity for a ball or free joint), so R^{i−1}_i = R0'_i Rot(z, q),
    R0'_i = C_λᵀ R0_i C_i, p0'_i = C_λᵀ p0_i, c'_i = C_iᵀ c_i, I'_i = C_iᵀ I_i C_i, axis' = e_z. τ, M, q̈ and world
    placements are the same numbers: only what is written in a body's own axes changes.
    Returns (R0', I', axis', p0', c', C), each (nb, 3, 3) or (nb, 3)."""
    nb = model.njoints
    C = np.array([z_turn(model.axis[i]) if model.nvs[i] == 1 else np.eye(3) for i in range(nb)]).reshape(nb, 3, 3)
    Cp = np.array([C[j] if j >= 0 else np.eye(3) for j in model.parent]).reshape(nb, 3, 3)
    Ct = np.swapaxes(C, 1, 2)
    R0 = np.swapaxes(Cp, 1, 2) @ np.asarray(model.R0, float) @ C
    J = Ct @ np.asarray(model.inertia, float) @ C
    axis = np.where(np.asarray(model.nvs)[:, None] == 1, [0.0, 0.0, 1.0], model.axis)   # C e_z = k: exactly z
    p0 = np.einsum("nji,nj->ni", Cp, np.asarray(model.p0, float))
    com = np.einsum("nji,nj->ni", C, np.asarray(model.com, float))
    return R0, 0.5 * (J + np.swapaxes(J, 1, 2)), axis.reshape(nb, 3), p0, com, C


def perpendicular_pair(e):
    """Two unit vectors completing e (3,) to a right-handed orthonormal basis."""
    t = np.eye(3)[np.argmin(np.abs(e))]
    n1 = np.cross(e, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(e, n1)


def orientation_pairs(c):
    """(a, b) direction pairs of a closure's orientation rows, a in the parent body frame, b in the child's
    (constraints/closures.py: Φ = a·b)."""
    if c.type == "revolute":
        n1, n2 = perpendicular_pair(c.axis_p)
        return [(n1, c.axis_c), (n2, c.axis_c)]
    if c.type == "fixed":
        A, B = c.Rp, c.Rc
        return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]
    return []


def _closure_form(constraints):
    """(ints (nc, 3), floats (nc, 24), row labels) of KernelForm for a tuple of Constraint."""
    nc = len(constraints)
    ints, floats, labels = np.zeros((nc, 3), np.int64), np.zeros((nc, 24)), []
    for k, c in enumerate(constraints):
        if c.type == "coupling":
            ints[k], floats[k, 0] = (c.parent, c.child, -1), c.ratio
            labels.append(f"{c.name}.c")
            continue
        pairs = orientation_pairs(c)
        ints[k] = c.parent, c.child, len(pairs)
        floats[k, :3], floats[k, 3:6] = c.pp, c.pc
        for m, (a, b) in enumerate(pairs):
            floats[k, 6 + 3 * m:9 + 3 * m], floats[k, 15 + 3 * m:18 + 3 * m] = a, b
        labels += [f"{c.name}.{x}" for x in ("x", "y", "z")] + [f"{c.name}.r{m + 1}" for m in range(len(pairs))]
    return ints, floats, tuple(labels)
