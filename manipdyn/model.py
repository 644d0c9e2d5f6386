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

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from types import MappingProxyType

from .errors import InputError
from .joints import FREE_COORDS, FREE_RATES, FREEFLYER, NQ, NV, PRISMATIC, REVOLUTE, TYPE_NAMES

__all__ = ["Model", "Frame", "Constraint", "Quirk", "QUIRK_KINDS", "MimicModel", "check_gravity", "REVOLUTE", "PRISMATIC",
           "FREEFLYER", "QUAT_TOL"]

QUAT_TOL = 1e-8          # | ‖quat‖ − 1 | accepted in a free flyer's q (integrate's output: ~1e-16)


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
    "no_inertial": "a link carried by a moving joint has no <inertial> (a massless body unless fixed links add mass)",
    "triangle": "principal moments violate the triangle inequality I1 + I2 >= I3",
    "rotated_root_inertial": "the root link's <inertial><origin rpy> is not zero",
    "free_root": "the root body carries mass and the tree's shape says it is a free body (legs, or a heavy body "
                 "with a hanging appendage, or no joint at all): load with root_joint=\"free_flyer\"",
    "mimic": "a <mimic> joint (honoured with mimic=True, else loaded as an independent joint)",
    "version": "<robot version> that urdfdom 6 (Pinocchio 4.1's reader) refuses; manipdyn loads the file",
    "unknown_element": "an element manipdyn does not read (reported, never dropped in silence)",
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
    kind: np.ndarray       # (nb,) int, joints.REVOLUTE, PRISMATIC or FREEFLYER
    continuous: np.ndarray  # (nb,) bool, revolute joint without limits (Pinocchio: nq = 2)
    axis: np.ndarray       # (nb, 3) unit joint axis in body i's frame (free flyer: unused, zeros)
    R0: np.ndarray         # (nb, 3, 3) joint i's frame in its parent body's frame, at q = 0
    p0: np.ndarray         # (nb, 3) joint i's origin in its parent body's frame
    mass: np.ndarray       # (nb,) merged body mass, kg
    com: np.ndarray        # (nb, 3) merged centre of mass in the body frame, m
    inertia: np.ndarray    # (nb, 3, 3) merged inertia about the CoM, body axes, kg m²
    lower: np.ndarray      # (nb,) joint lower limit (-inf if none; free flyer: -inf)
    upper: np.ndarray      # (nb,) joint upper limit (+inf if none; free flyer: +inf)
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

    def __post_init__(self):
        if not (isinstance(self.gravity, np.ndarray) and self.gravity.dtype == np.float64):
            raise InputError(f"model {self.name!r}: gravity must be a float array (3,), not {self.gravity!r}")
        check_gravity(self.gravity, f"model {self.name!r}")
        for key in ("frames", "merged", "locked"):            # constant, like every array below
            object.__setattr__(self, key, MappingProxyType(dict(getattr(self, key))))
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)
        free = [self.joint_names[i] for i in range(self.njoints) if self.kind[i] == FREEFLYER and self.parent[i] >= 0]
        if free:
            raise InputError(f"model {self.name!r}: a free flyer must be the root joint; {free[0]!r} is not")

    @property
    def njoints(self) -> int:
        """nb, the number of joints (= moving bodies)."""
        return len(self.joint_names)

    @cached_property
    def nqs(self) -> np.ndarray:
        """(nb,) configuration size of each joint (``joints.NQ``)."""
        return _frozen([NQ[int(k)] for k in self.kind])

    @cached_property
    def nvs(self) -> np.ndarray:
        """(nb,) velocity size of each joint (``joints.NV``)."""
        return _frozen([NV[int(k)] for k in self.kind])

    @cached_property
    def idx_q(self) -> np.ndarray:
        """(nb,) index of joint i's first entry in q."""
        return _frozen(np.concatenate([[0], np.cumsum(self.nqs)[:-1]]) if self.njoints else [])

    @cached_property
    def idx_v(self) -> np.ndarray:
        """(nb,) index of joint i's first entry in v (and in a, τ)."""
        return _frozen(np.concatenate([[0], np.cumsum(self.nvs)[:-1]]) if self.njoints else [])

    @cached_property
    def nq(self) -> int:
        """Size of q (cached: the fast paths read it on every call)."""
        return int(np.sum(self.nqs))

    @cached_property
    def nv(self) -> int:
        """Size of v, a and τ."""
        return int(np.sum(self.nvs))

    @cached_property
    def state_shapes(self) -> tuple:
        """((nq,), (nv,)): the shapes of one state, read by the single-state fast paths on every call."""
        return (self.nq,), (self.nv,)

    @cached_property
    def q_names(self) -> tuple:
        """(nq,) a name for every entry of q: the joint's name, or "root_joint.qx" for a free flyer's."""
        return _dof_names(self, FREE_COORDS)

    @cached_property
    def v_names(self) -> tuple:
        """(nv,) a name for every entry of v, a and τ: the joint's name, or "root_joint.wx" for a free
        flyer's."""
        return _dof_names(self, FREE_RATES)

    @cached_property
    def v_joint(self) -> np.ndarray:
        """(nv,) the joint each entry of v belongs to."""
        return _frozen(np.repeat(np.arange(self.njoints), self.nvs))

    @property
    def floating(self) -> bool:
        """True when the root joint is a free flyer (nq ≠ nv)."""
        return bool(self.njoints and self.kind[0] == FREEFLYER)

    def frame(self, name: str) -> Frame:
        """The frame of a link (merged links included); InputError names the unknown frame."""
        try:
            return self.frames[name]
        except (KeyError, TypeError):
            known = sorted(self.frames)
            raise InputError(f"model {self.name!r} has no link or frame named {name!r}; "
                             f"known: {', '.join(known[:50])}{' ...' if len(known) > 50 else ''}") from None

    @cached_property
    def _joint_position(self) -> dict:
        """joint name -> index in q (built once: lookups stay O(1) on large models)."""
        return {name: i for i, name in enumerate(self.joint_names)}

    def joint_index(self, name: str) -> int:
        """Index of a moving joint in q; InputError names the unknown joint."""
        try:
            return self._joint_position[name]
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
            if self.kind[i] == FREEFLYER:      # the root body moves freely: q = [x y z qx qy qz qw]
                par, how = "world", "q = [x y z qx qy qz qw], v = [linear; angular] (body frame)"
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
    the mimic joints' entries removed (Pinocchio's order). The public ``rnea``, ``mass_matrix``,
    ``gravity_torques``, ``aba`` and ``forward_dynamics`` take it in place of a Model; for every other function
    (kinematics, playback) use ``full`` at ``full_state(q, v, a)``.
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


def _dof_names(model, free_names) -> tuple:
    out = []
    for i, j in enumerate(model.joint_names):
        out += [f"{j}.{c}" for c in free_names] if model.kind[i] == FREEFLYER else [j]
    return tuple(out)
