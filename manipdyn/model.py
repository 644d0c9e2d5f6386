"""The Model: a frozen set of arrays built once from a URDF, read by every algorithm.

Conventions owned here:
- One *body* per moving joint; body i is the child link of joint i, and its frame is that link's frame
  (the joint frame after the joint's motion), so joint i turns or slides along ``axis[i]`` expressed in
  body i's own frame. Links attached by fixed joints are merged into the body they hang from.
- q order: depth-first from the root link, children of a link visited in the order of their joint
  names (as Pinocchio's URDF reader does), fixed joints skipped; ``parent[i] < i``.
- nq == nv: a continuous joint is one angle. SI units; gravity in the base frame, default [0, 0, -9.81].
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .errors import InputError
from .spatial import axis_angle

REVOLUTE, PRISMATIC = 0, 1


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
    """A loop closure between two bodies (URDF ``<constraint>``), frames given in each body's frame.

    type "revolute": the frames share their origin and their axis (5 equations); "spherical": the origin
    (3); "fixed": origin and orientation (6). Axes are unit vectors in the body frames.
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

    @property
    def n_rows(self) -> int:
        return {"revolute": 5, "spherical": 3, "fixed": 6}[self.type]


@dataclass(frozen=True, eq=False)
class Model:
    """Kinematic tree with merged rigid bodies; immutable (arrays are read-only)."""
    name: str
    root_link: str
    joint_names: tuple     # (nv,) q order
    body_names: tuple      # (nv,) child link of each joint (the body's frame)
    parent: np.ndarray     # (nv,) int, parent body, -1 = fixed base; parent[i] < i
    kind: np.ndarray       # (nv,) int, REVOLUTE or PRISMATIC
    continuous: np.ndarray  # (nv,) bool, revolute joint without limits (Pinocchio: nq = 2)
    axis: np.ndarray       # (nv, 3) unit joint axis in body i's frame
    R0: np.ndarray         # (nv, 3, 3) joint i's frame in its parent body's frame, at q = 0
    p0: np.ndarray         # (nv, 3) joint i's origin in its parent body's frame
    mass: np.ndarray       # (nv,) merged body mass, kg
    com: np.ndarray        # (nv, 3) merged centre of mass in the body frame, m
    inertia: np.ndarray    # (nv, 3, 3) merged inertia about the CoM, body axes, kg m²
    lower: np.ndarray      # (nv,) joint lower limit (-inf if none)
    upper: np.ndarray      # (nv,) joint upper limit (+inf if none)
    effort: np.ndarray     # (nv,) effort limit (inf if none)
    velocity: np.ndarray   # (nv,) velocity limit (inf if none)
    gravity: np.ndarray    # (3,) gravity acceleration in the base frame, m/s²
    frames: dict           # link name -> Frame, every link including merged ones
    merged: dict           # body link name (or root link) -> tuple of links merged into it
    mimic: tuple           # ((joint, mimicked joint, multiplier, offset), ...) loaded as independent
    source: str = ""       # file the model was loaded from
    notes: tuple = ()      # what the loader did that a user should know (warnings included)
    constraints: tuple = field(default=())  # (Constraint, ...) loop closures; empty for a tree
    actuated: tuple = field(default=())     # joint names with a URDF <transmission>, q order
    locked: dict = field(default_factory=dict)  # joint -> value held fixed by reduce() (not in q)

    def __post_init__(self):
        if not (isinstance(self.gravity, np.ndarray) and self.gravity.dtype == np.float64):
            raise InputError(f"model {self.name!r}: gravity must be a float array (3,), not {self.gravity!r}")
        check_gravity(self.gravity, f"model {self.name!r}")
        for value in vars(self).values():
            if isinstance(value, np.ndarray):
                value.setflags(write=False)

    @property
    def nv(self) -> int:
        return len(self.joint_names)

    nq = nv

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

    def joint_transforms(self, Q: np.ndarray):
        """Placement of body i in its parent body for a batch Q (N, nv): (R (nv, N, 3, 3), p (nv, N, 3)).

        Revolute: R = R0 Rot(axis, q), p = p0. Prismatic: R = R0, p = p0 + R0 axis d (Eqs. 8-12: p^{i-1}_i
        evaluated at the current d_i).
        """
        N = Q.shape[0]
        R, p = np.empty((self.nv, N, 3, 3)), np.empty((self.nv, N, 3))
        for i in range(self.nv):
            if self.kind[i] == REVOLUTE:
                R[i] = self.R0[i] @ axis_angle(self.axis[i], Q[:, i])
                p[i] = self.p0[i]
            else:
                R[i] = self.R0[i]
                p[i] = self.p0[i] + Q[:, i, None] * (self.R0[i] @ self.axis[i])
        return R, p

    def summary(self) -> str:
        """What the loader built: joints in q order, bodies, merges, massless links, mimics, notes."""
        kinds = {REVOLUTE: "revolute", PRISMATIC: "prismatic"}
        lines = [f"model {self.name!r} from {self.source or '<memory>'}: nq = nv = {self.nv}, "
                 f"root link {self.root_link!r}, gravity {self.gravity.tolist()}",
                 "joints in q order:"]
        for i, j in enumerate(self.joint_names):
            kind = "continuous" if self.continuous[i] else kinds[int(self.kind[i])]
            par = self.body_names[self.parent[i]] if self.parent[i] >= 0 else self.root_link
            lines.append(f"  q[{i}] {j:<28} {kind:<10} axis {np.round(self.axis[i], 4).tolist()} "
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
            lines.append(f"closure {c.name!r} ({c.type}, {c.n_rows} equations): {c.parent_link} <-> {c.child_link}")
        if self.actuated:
            lines.append(f"actuated joints (<transmission>): {', '.join(self.actuated)}")
        if self.locked:
            lines.append("locked joints: " + ", ".join(f"{j} = {v:g}" for j, v in self.locked.items()))
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)

    def __repr__(self) -> str:
        return f"Model({self.name!r}, nv={self.nv}, joints={list(self.joint_names)})"
