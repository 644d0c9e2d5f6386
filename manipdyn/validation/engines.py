"""Other engines as referees: Pinocchio, MuJoCo, PyBullet and Drake on the same URDF and the same states.

Each engine loads the file its own way; an adapter maps its joint order to ours by joint name (1-dof joints: q
and v share the order; a continuous joint is one angle everywhere but in Pinocchio, whose (cos, sin) the
``Reference`` converts), sets the same gravity, and gives back, in our order (a free-flyer root, loaded with
``root_joint="free_flyer"``: each engine's floating base converted by ``FloatingBase`` — MuJoCo a free joint
added to the root body, qvel [linear (world); angular (body)]; Drake's floating body, v [angular (world); linear
(world)]; PyBullet's base, the root's inertial frame, M only: its inverse dynamics refuses a floating base):

- τ = ID(q, q̇, q̈): Pinocchio ``rnea``; MuJoCo ``mj_inverse`` (qfrc_inverse); PyBullet
  ``calculateInverseDynamics``; Drake ``CalcInverseDynamics`` with ``CalcForceElementsContribution``
  (gravity, joint damping) as the known forces.
- M(q): ``crba``; ``mj_fullM``; ``calculateMassMatrix``; ``CalcMassMatrix``.
- q̈ = FD(q, q̇, τ): ``aba``; ``mj_forward`` with qfrc_applied = τ and the constraint solver off (joint
  limits, contacts and mimic equalities are not dynamics of the tree); PyBullet has no forward-dynamics
  query, so q̈ = M⁻¹(τ − ID(q, q̇, 0)) from its own two queries; Drake's generalized-acceleration output
  port with τ on the applied-generalized-force input.

How each engine is made to keep the file's inertias (from their documentation, then checked by reading the
values back): MuJoCo reads a ``<mujoco><compiler .../></mujoco>`` element inside ``<robot>``; we add
``discardvisual="true" fusestatic="false" balanceinertia="false" inertiafromgeom="false"`` (URDF import
fuses static bodies by default, which would hide link names; ``balanceinertia`` would alter inertias that
break the triangle inequality; ``inertiafromgeom`` would recompute them from geoms). PyBullet recomputes
inertias from collision shapes unless ``URDF_USE_INERTIA_FROM_FILE`` is given: it is. Its gravity defaults
to zero: we set ours. Drake welds the root link to the world (fixed base). <visual> and <collision> are
removed before any engine reads the file: no engine then needs meshes, and none can derive inertia from them.

After import each adapter reads back every link's mass, CoM and inertia about the CoM in the link frame
(Pinocchio: per body, fixed links already merged) and the armature/damping it adds per dof. The comparison
includes our own joint dynamics (docs/design.md §3): the model's armature (in ``rnea`` and ``mass_matrix``) and
its damping (URDF ``<dynamics damping>``) wherever the engine applies damping (``applied_damping``); friction is
left out on both sides (MuJoCo's frictionloss is a constraint, off in these queries). ``explain`` diffs the
engine's parameters against the file's own numbers, link by link, and against our armature and damping, and names
the quirk; ``referee`` then rebuilds our model with the engine's parameters (``dataclasses.replace`` on
mass/com/inertia, the engine's armature and damping added analytically) and compares again: what remains is the
engine's precision.

An MJCF file (``robot_format``: root element ``<mujoco>``) is refereed as written: MuJoCo compiles the file (its
free joint, ball joints, armature and damping; joint springs, which the model holds as quirks, turned off), each
joint mapped by name — a ball's qpos (w, x, y, z) against our (x, y, z, w), its qvel the body-frame ω as ours;
Pinocchio reads it with ``buildModelFromMJCF`` (refused by name where it makes one body's joints a composite
joint); the PyBullet and Drake adapters load URDF and refuse, naming the ball joints (or the MJCF file). The
causes then compare the engine's bodies with the model's (``explain``; no per-link URDF ``<inertial>``).

Engines are imported here only, lazily, inside the adapters: ``import manipdyn`` loads none of them.
"""
from __future__ import annotations

import contextlib
import dataclasses
import importlib.util
import logging
import math
import re
import tempfile
import time
from pathlib import Path

import numpy as np

from ..dynamics.aba import aba
from ..dynamics.crba import mass_matrix
from ..dynamics.rnea import rnea
from ..errors import InputError, ManipdynError, MissingExtraError
from ..extras import install_command, require
from ..io.load import robot_format
from ..model import BALL, FREEFLYER, PRISMATIC, REVOLUTE
from ..joints import TYPE_NAMES
from ..spatial import combine_inertias, rpy_matrix
from .compare import random_states
from .measure import error

ENGINES = ("pinocchio", "mujoco", "pybullet", "drake")
MODULES = {"pinocchio": "pinocchio", "mujoco": "mujoco", "pybullet": "pybullet", "drake": "pydrake"}
PIP = {"pinocchio": "pin", "mujoco": "mujoco", "pybullet": "pybullet", "drake": "drake"}
EXTRA = {"pinocchio": "validate", "mujoco": "engines", "pybullet": "engines", "drake": "engines"}   # manipdyn[...]
TOL = 1e-9                    # a disagreement above this must carry a named cause
MUJOCO_COMPILER = ('<mujoco><compiler angle="radian" discardvisual="true" fusestatic="false" '
                   'balanceinertia="false" inertiafromgeom="false"/></mujoco>')


class EngineMissing(MissingExtraError):
    """The engine's Python package is not installed (the referee skips it with a note)."""


class EngineRefused(ManipdynError):
    """The engine would not load the file (its own message kept)."""


def parse_engines(text) -> list[str]:
    """'pinocchio,mujoco' -> ['pinocchio', 'mujoco']; InputError names an unknown engine."""
    names = [s.strip().lower() for s in str(text).split(",") if s.strip()]
    bad = [n for n in names if n not in ENGINES]
    if bad or not names:
        raise InputError(f"--against {text!r}: unknown engine {bad[0] if bad else '(none)'!r}; "
                         f"known: {', '.join(ENGINES)}")
    return list(dict.fromkeys(names))


def available(name) -> bool:
    """True when the engine's Python package can be imported (checked without importing it)."""
    return importlib.util.find_spec(MODULES[name]) is not None


# ---- the file's own numbers ---------------------------------------------------------------------------------

@dataclasses.dataclass
class LinkInertial:
    """A URDF link's <inertial> as written: mass, CoM and inertia about the CoM in the link frame."""
    present: bool              # False: the link has no <inertial>
    mass: float
    com: np.ndarray            # (3,)
    inertia: np.ndarray        # (3, 3) in the link frame (the inertial origin's rotation applied)
    rotated: bool              # the inertial origin has a non-zero rpy
    raw: np.ndarray            # (3, 3) as written, in the inertial frame


def urdf_inertials(path) -> dict:
    """{link name: LinkInertial} read from the file (lxml without entities or network, as the loader)."""
    from lxml import etree
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, remove_comments=True)
    root = etree.fromstring(Path(path).read_bytes(), parser)
    out = {}
    for link in root.findall("link"):
        e = link.find("inertial")
        if e is None:
            out[link.get("name")] = LinkInertial(False, 0.0, np.zeros(3), np.zeros((3, 3)), False, np.zeros((3, 3)))
            continue
        o, m, i = e.find("origin"), e.find("mass"), e.find("inertia")
        xyz = np.array((o.get("xyz", "0 0 0") if o is not None else "0 0 0").split(), float)
        rpy = np.array((o.get("rpy", "0 0 0") if o is not None else "0 0 0").split(), float)
        k = {a: float(i.get(a, 0.0)) for a in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")} if i is not None else {}
        raw = np.array([[k.get("ixx", 0), k.get("ixy", 0), k.get("ixz", 0)],
                        [k.get("ixy", 0), k.get("iyy", 0), k.get("iyz", 0)],
                        [k.get("ixz", 0), k.get("iyz", 0), k.get("izz", 0)]], float)
        R = rpy_matrix(rpy)
        out[link.get("name")] = LinkInertial(True, float(m.get("value")) if m is not None else 0.0, xyz,
                                             R @ raw @ R.T, bool(np.any(rpy != 0)), raw)
    return out


def stripped_urdf(path) -> str:
    """The file's text without <visual> and <collision> elements (no engine needs meshes for dynamics)."""
    text = Path(path).read_text(encoding="utf-8")
    text = re.sub(r"<(visual|collision)\b[^>]*/>", "", text)
    return re.sub(r"<(visual|collision)\b.*?</\1\s*>", "", text, flags=re.S)


# ---- adapters -----------------------------------------------------------------------------------------------

class Adapter:
    """One engine's model of the file, queried in our q order. Subclasses fill ``links``, ``armature``,
    ``damping`` and implement tau / mass / qdd for one state."""
    name = "?"
    merged = False             # True: ``links`` holds bodies with fixed links already merged (Pinocchio)
    precision = "double precision"

    def __init__(self, model, path):
        self.model, self.path = model, Path(path)
        self.mjcf = robot_format(path) == "mjcf"
        self.notes = []
        self.links = {}                          # link name -> (mass, com (3,), inertia about com (3, 3))
        self.armature = np.zeros(model.nv)       # added to M's diagonal by the engine
        self.damping = np.zeros(model.nv)        # viscous: the engine's τ includes + d q̇
        self.damping_in_id = True                # whether ID (as well as FD) includes the damping

    terms = ("tau", "M", "qdd")    # what the engine's queries give for this model (the rest: None, not compared)

    def session(self):
        """A context for a run of queries (MuJoCo: its warnings collected into the notes)."""
        return contextlib.nullcontext()

    def _perm(self, names, where):
        """Index in the engine's joint list of each of our moving joints (by name; a free-flyer root excluded)."""
        ours = self._one_dof()
        pos = {n: i for i, n in enumerate(names)}
        missing = [j for j in ours if j not in pos]
        if missing or len(names) != len(ours):
            raise EngineRefused(f"{self.name}: its moving joints {list(names)} are not ours "
                                f"{list(ours)} ({where})")
        return np.array([pos[j] for j in ours], int)

    def _one_dof(self):
        return self.model.joint_names[1:] if self.model.floating else self.model.joint_names

    def _urdf_only(self):
        """EngineRefused for what this adapter does not take: ball joints (named), an MJCF file."""
        balls = [self.model.joint_names[i] for i in range(self.model.njoints) if self.model.kind[i] == BALL]
        if balls:
            raise EngineRefused(f"{self.name}: ball joints ({', '.join(map(repr, balls))}): not supported by this "
                                f"adapter (it loads the URDF, which has no ball joint; refereed by pinocchio and "
                                f"mujoco)")
        if self.mjcf:
            raise EngineRefused(f"{self.name}: an MJCF file: this adapter loads URDF only (MJCF: pinocchio, mujoco)")


def _rotation_xyzw(quat):
    """Rotation matrix of our free flyer's quaternion (x, y, z, w), normalised."""
    x, y, z, w = np.asarray(quat, float) / np.linalg.norm(quat)
    return _quat_matrix((w, x, y, z))


class FloatingBase:
    """A free-flyer root as an engine holds it: its dof block is P_b v_b of ours (v_b = [linear; angular] in the
    body frame, docs/design.md §3), P_b orthogonal, and its acceleration P_b a_b + c(q, v). So, with the joints'
    permutation in P (nv_engine, nv): engine velocity P v, acceleration P a + c, our τ = Pᵀ f (f the engine's
    generalized force: power fᵀ P v), our M = Pᵀ M_e P, and for forward dynamics f = P τ, a = Pᵀ (q̈_e − c).

    ``layout``: "mujoco" — MuJoCo's free joint, qvel [linear (world); angular (body)]: P_b = diag(R, 1), c = [R (ω ×
    v); 0]; "drake" — Drake's quaternion floating joint, v [angular (world); linear (world)]: P_b = [[0, R], [R, 0]],
    c = [0; R (ω × v)]; "pybullet" — btMultiBody's base, which is the root link's *inertial* frame (Bullet's URDF
    import; orientation R_i, origin c in the link frame, PyBullet's getDynamicsInfo(-1) local inertial frame),
    [angular; linear] in that frame: P_b = [[0, R_iᵀ], [R_iᵀ, −R_iᵀ [c]×]] (v_c = v + ω × c), not orthogonal — M only
    (Pᵀ M P). R: the base's orientation in the world, ω, v its body-frame angular and linear velocity. (The linear
    rows' c: d/dt (R v) = R (v̇ + ω × v), where v̇ is our spatial acceleration's linear part.)"""

    def __init__(self, layout, base_v, joint_v, nv_engine, inertial=None):
        self.layout, self.base_v, self.joint_v, self.nv_engine = layout, base_v, np.asarray(joint_v, int), nv_engine
        self.inertial = inertial                 # pybullet: (R_i, c) of the base's inertial frame in the link frame

    def P(self, q):
        R, Z, I3 = _rotation_xyzw(q[3:7]), np.zeros((3, 3)), np.eye(3)
        if self.layout == "pybullet":
            Ri, c = self.inertial
            cx = np.array([[0, -c[2], c[1]], [c[2], 0, -c[0]], [-c[1], c[0], 0]])
            Pb = np.block([[Z, Ri.T], [Ri.T, -Ri.T @ cx]])
        else:
            Pb = np.block([[R, Z], [Z, I3]]) if self.layout == "mujoco" else np.block([[Z, R], [R, Z]])
        n = len(self.joint_v)
        P = np.zeros((self.nv_engine, 6 + n))
        P[self.base_v:self.base_v + 6, :6] = Pb
        P[self.joint_v, np.arange(6, 6 + n)] = 1.0
        return P

    def c(self, q, v):
        out = np.zeros(self.nv_engine)
        if self.layout == "pybullet":
            return out
        lin = _rotation_xyzw(q[3:7]) @ np.cross(v[3:6], v[:3])
        k = self.base_v + (0 if self.layout == "mujoco" else 3)
        out[k:k + 3] = lin
        return out


class PinocchioAdapter(Adapter):
    name, merged = "pinocchio", True

    def __init__(self, model, path):
        super().__init__(model, path)
        from .reference import Reference
        _import("pinocchio")                     # EngineMissing, not EngineRefused, when it is not installed
        try:
            self.ref = Reference(model, path)
        except Exception as exc:                 # bare parser errors, or a joint order unlike ours
            raise EngineRefused(f"pinocchio: {_one_line(exc)}") from exc
        pm = self.ref.pm
        self.armature = np.asarray(pm.armature, float).copy()
        for i, body in enumerate(model.body_names):   # per body, in our body frame; held in the frame of the
            Y = pm.inertias[i + 1]                     # body's name (an MJCF body's frame: offset from the joint's
            m, c, I = float(Y.mass), np.array(Y.lever), np.array(Y.inertia)     # anchor), where body_params reads it
            fr = model.frames.get(body)
            if fr is not None and fr.body == i:
                c, I = fr.R.T @ (c - fr.p), fr.R.T @ I @ fr.R
            self.links[body] = (m, c, I)

    def tau(self, q, v, a):
        P = _import("pinocchio")
        return P.rnea(self.ref.pm, self.ref.pd, self.ref.to_pin_q(q), v, a).copy()

    def mass(self, q):
        P = _import("pinocchio")
        M = P.crba(self.ref.pm, self.ref.pd, self.ref.to_pin_q(q)).copy()
        return np.triu(M) + np.triu(M, 1).T      # crba fills the upper triangle (whatever the binding does)

    def qdd(self, q, v, tau):
        P = _import("pinocchio")
        return P.aba(self.ref.pm, self.ref.pd, self.ref.to_pin_q(q), v, tau).copy()


_MJ_KIND = {0: FREEFLYER, 1: BALL, 2: PRISMATIC, 3: REVOLUTE}      # mjtJoint: free, ball, slide, hinge
_KIND_NAME = {FREEFLYER: "free", BALL: "ball", PRISMATIC: "slide", REVOLUTE: "hinge"}


class MujocoAdapter(Adapter):
    name = "mujoco"

    def __init__(self, model, path):
        super().__init__(model, path)
        mj = _import("mujoco")
        self.mj = mj
        if not self.mjcf:
            text = stripped_urdf(path)
            if "<mujoco" in text:
                self.notes.append("the file carries its own <mujoco> element: removed, ours used")
                text = re.sub(r"<mujoco\b.*?</mujoco\s*>", "", text, flags=re.S)
            text = re.sub(r"</robot\s*>\s*$", MUJOCO_COMPILER + "</robot>", text.rstrip())
        heard, before = [], mj.get_mju_user_warning()
        mj.set_mju_user_warning(heard.append)    # else MuJoCo appends its warnings to ./MUJOCO_LOG.TXT
        try:                                     # an MJCF file: MuJoCo compiles it as written (its includes too)
            m = mj.MjModel.from_xml_path(str(path)) if self.mjcf else self._compile(mj, text, model)
        except EngineRefused:
            raise
        except Exception as exc:
            raise EngineRefused(f"mujoco: {_one_line(exc)}") from exc
        finally:
            mj.set_mju_user_warning(before)
        self.notes += [f"mujoco warned: {_one_line(w)}" for w in list(dict.fromkeys(heard))[:5]]
        self.m, self.d = m, mj.MjData(m)
        m.opt.disableflags |= int(mj.mjtDisableBit.mjDSBL_CONSTRAINT) | int(mj.mjtDisableBit.mjDSBL_CONTACT)
        if np.any(m.jnt_stiffness):              # joint springs: read by manipdyn as quirks, not applied
            m.opt.disableflags |= int(mj.mjtDisableBit.mjDSBL_SPRING)
            self.notes.append("joint stiffness (springs) turned off: manipdyn reads it as a quirk, not applied")
        m.opt.gravity[:] = model.gravity
        free = [j for j in range(m.njnt) if m.jnt_type[j] == 0]                       # mjJNT_FREE
        if len(free) != int(model.floating):
            raise EngineRefused("mujoco: the model has free joints other than our free-flyer root")
        self._perm([m.joint(j).name for j in range(m.njnt) if m.jnt_type[j] != 0], "joint names")
        ours, ids = [model.joint_index(n) for n in self._one_dof()], [m.joint(n).id for n in self._one_dof()]
        for i, j in zip(ours, ids):
            theirs = _MJ_KIND[int(m.jnt_type[j])]
            if theirs != model.kind[i]:
                raise EngineRefused(f"mujoco: joint {model.joint_names[i]!r} is a {_KIND_NAME[theirs]} joint there, a "
                                    f"{_KIND_NAME[int(model.kind[i])]} joint here")
        # (our q index, its length, MuJoCo's qpos index) per joint; the dofs of each joint in our order
        self.qmap = [(int(model.idx_q[i]), int(model.nqs[i]), int(m.jnt_qposadr[j])) for i, j in zip(ours, ids)]
        iv = np.array([int(m.jnt_dofadr[j]) + k for i, j in zip(ours, ids) for k in range(model.nvs[i])], int)
        self.fb = None
        if model.floating:                        # qpos [x y z qw qx qy qz], qvel [linear (world); angular (body)]
            self.fq, fv = int(m.jnt_qposadr[free[0]]), int(m.jnt_dofadr[free[0]])
            self.fb = FloatingBase("mujoco", fv, iv, m.nv)
            iv = np.concatenate([np.arange(fv, fv + 6), iv])
        self.iv = iv
        self.armature, self.damping = m.dof_armature[self.iv].copy(), m.dof_damping[self.iv].copy()
        for b in range(1, m.nbody):              # an unnamed body: the MJCF reader's name for it
            R = _quat_matrix(m.body_iquat[b])
            self.links[m.body(b).name or f"body{b}"] = (float(m.body_mass[b]), m.body_ipos[b].copy(),
                                                        R @ np.diag(m.body_inertia[b]) @ R.T)

    @contextlib.contextmanager
    def session(self):
        heard, before = [], self.mj.get_mju_user_warning()
        self.mj.set_mju_user_warning(heard.append)          # not ./MUJOCO_LOG.TXT
        try:
            yield
        finally:
            self.mj.set_mju_user_warning(before)
            self.notes += [f"mujoco warned: {_one_line(w)}" for w in list(dict.fromkeys(heard))[:5]]

    @staticmethod
    def _compile(mj, text, model):
        """MuJoCo's model of the URDF text; a free-flyer root: its root body given a free joint (MjSpec), as
        MuJoCo's URDF import welds the root link to the world."""
        if not model.floating:
            return mj.MjModel.from_xml_string(text)
        spec = mj.MjSpec.from_string(text)
        root = spec.worldbody.first_body()
        if root is None or root.name != model.root_link or len(spec.worldbody.bodies) != 1:
            raise EngineRefused(f"mujoco: the free-flyer root {model.root_link!r} is not the one body MuJoCo's URDF "
                                f"import puts under the world")
        root.add_freejoint(name=model.joint_names[0])
        return spec.compile()

    def _set(self, q, v):
        for a, n, b in self.qmap:                # a ball's quaternion: ours (x, y, z, w), MuJoCo's (w, x, y, z)
            self.d.qpos[b:b + n] = q[a:a + n] if n == 1 else np.roll(q[a:a + n], 1)
        if self.fb is None:
            self.d.qvel[self.iv] = v
            return
        self.d.qpos[self.fq:self.fq + 7] = np.concatenate([q[:3], q[6:7], q[3:6]])   # (w, x, y, z) first
        self.d.qvel[:] = self.fb.P(q) @ v

    def tau(self, q, v, a):
        self._set(q, v)
        self.d.qacc[:] = 0
        if self.fb is None:
            self.d.qacc[self.iv] = a
        else:
            self.d.qacc[:] = self.fb.P(q) @ a + self.fb.c(q, v)
        self.mj.mj_inverse(self.m, self.d)
        if self.fb is not None:
            return self.fb.P(q).T @ self.d.qfrc_inverse
        return self.d.qfrc_inverse[self.iv].copy()

    def mass(self, q):
        self._set(q, np.zeros(self.model.nv))
        self.mj.mj_forward(self.m, self.d)
        M = np.zeros((self.m.nv, self.m.nv))
        if hasattr(self.d, "qM"):                # MuJoCo 3: mj_fullM(m, dst, qM)
            self.mj.mj_fullM(self.m, M, self.d.qM)
        else:                                    # MuJoCo 4: mj_fullM(m, d, dst)
            self.mj.mj_fullM(self.m, self.d, M)
        if self.fb is not None:
            P = self.fb.P(q)
            return P.T @ M @ P
        return M[np.ix_(self.iv, self.iv)]

    def qdd(self, q, v, tau):
        self._set(q, v)
        self.d.qfrc_applied[:] = 0
        if self.fb is not None:
            P = self.fb.P(q)
            self.d.qfrc_applied[:] = P @ tau
            self.mj.mj_forward(self.m, self.d)
            return P.T @ (self.d.qacc - self.fb.c(q, v))
        self.d.qfrc_applied[self.iv] = tau
        self.mj.mj_forward(self.m, self.d)
        return self.d.qacc[self.iv].copy()


class PybulletAdapter(Adapter):
    name = "pybullet"
    damping_in_id = False

    def __init__(self, model, path):
        super().__init__(model, path)
        p = _import("pybullet")
        self._urdf_only()
        self.p = p
        self.cid = p.connect(p.DIRECT)
        try:
            with tempfile.TemporaryDirectory() as tmp:
                f = Path(tmp) / self.path.name
                f.write_text(stripped_urdf(path), encoding="utf-8")
                self.body = p.loadURDF(str(f), useFixedBase=not model.floating,
                                       flags=p.URDF_USE_INERTIA_FROM_FILE, physicsClientId=self.cid)
        except Exception as exc:
            p.disconnect(self.cid)
            raise EngineRefused(f"pybullet: {_one_line(exc)}") from exc
        p.setGravity(*model.gravity, physicsClientId=self.cid)
        info = [p.getJointInfo(self.body, j, physicsClientId=self.cid) for j in
                range(p.getNumJoints(self.body, physicsClientId=self.cid))]
        dofs = sorted((i[3], i[1].decode()) for i in info if i[3] >= 0)   # (qIndex, name)
        self.ix = self._perm([n for _, n in dofs], "joint names")
        jd = {i[1].decode(): i[6] for i in info}
        d = np.array([jd[j] for j in self._one_dof()], float)
        if np.any(d):      # getJointInfo's jointDamping acts in stepSimulation, not in the queries used here
            listed = ", ".join(f"{j} {x:g}" for j, x in zip(self._one_dof(), d) if x)
            self.notes.append(f"joint damping from <dynamics> ({listed}) acts only when stepping, not in "
                              "calculateInverseDynamics: not compared")
        for i in info:
            dyn = p.getDynamicsInfo(self.body, i[0], physicsClientId=self.cid)
            R = np.array(p.getMatrixFromQuaternion(dyn[4]), float).reshape(3, 3)
            self.links[i[12].decode()] = (float(dyn[0]), np.array(dyn[3], float), R @ np.diag(dyn[2]) @ R.T)
        self.fb = None
        if model.floating:
            # calculateMassMatrix (flags=0) takes the joints' positions and gives the base's 6 dofs first,
            # [angular; linear] in the base's inertial frame (btMultiBody's base); calculateInverseDynamics of a
            # floating base fails with flags=0 ("Inverse Dynamics computations failed") and corrupts the heap with
            # flags=1 (PyBullet 3.2.7, measured; bullet3 issues 3149, 3264): τ and q̈ are not asked for
            dyn = p.getDynamicsInfo(self.body, -1, physicsClientId=self.cid)
            R = np.array(p.getMatrixFromQuaternion(dyn[4]), float).reshape(3, 3)
            root = p.getBodyInfo(self.body, physicsClientId=self.cid)[0].decode()
            self.links[root] = (float(dyn[0]), np.array(dyn[3], float), R @ np.diag(dyn[2]) @ R.T)
            self.fb = FloatingBase("pybullet", 0, 6 + self.ix, 6 + len(self.ix), (R, np.array(dyn[3], float)))
            self.terms = ("M",)
            self.notes.append("floating base: M only — PyBullet's calculateInverseDynamics refuses a floating base "
                              "(flags=0) or corrupts the heap (flags=1), so τ and q̈ are not compared")

    def _ours_to_engine(self, x):
        y = np.zeros(len(self.ix))
        y[self.ix] = x[7:] if self.fb is not None and len(x) == self.model.nq else x
        return y.tolist()

    def tau(self, q, v, a):
        t = self.p.calculateInverseDynamics(self.body, self._ours_to_engine(q), self._ours_to_engine(v),
                                            self._ours_to_engine(a), physicsClientId=self.cid)
        return np.array(t, float)[self.ix]

    def mass(self, q):
        M = np.array(self.p.calculateMassMatrix(self.body, self._ours_to_engine(q), physicsClientId=self.cid))
        if self.fb is not None:
            P = self.fb.P(q)
            return P.T @ M @ P
        return M[np.ix_(self.ix, self.ix)]

    def qdd(self, q, v, tau):
        return np.linalg.solve(self.mass(q), tau - self.tau(q, v, np.zeros(self.model.nv)))

    def __del__(self):
        try:
            self.p.disconnect(self.cid)
        except Exception:
            pass


class DrakeAdapter(Adapter):
    name = "drake"

    def __init__(self, model, path):
        super().__init__(model, path)
        _import("pydrake")
        self._urdf_only()
        from pydrake.multibody.parsing import Parser
        from pydrake.multibody.plant import MultibodyPlant
        from pydrake.multibody.tree import MultibodyForces
        self.Forces = MultibodyForces
        plant = MultibodyPlant(0.0)
        heard = _Heard()                         # Drake's parser warns through Python logging ("drake")
        log, propagate = logging.getLogger("drake"), logging.getLogger("drake").propagate
        log.addHandler(heard)
        log.propagate = False                    # kept in the notes instead of printed
        try:
            Parser(plant).AddModelsFromString(stripped_urdf(path), "urdf")
            if model.root_link != "world" and not model.floating:     # a free-flyer root: Drake's free body
                plant.WeldFrames(plant.world_frame(), plant.GetFrameByName(model.root_link))
            plant.Finalize()
        except Exception as exc:
            raise EngineRefused(f"drake: {_one_line(exc)}") from exc
        finally:
            log.removeHandler(heard)
            log.propagate = propagate
        self.notes += [f"drake warned: {_one_line(w, 600)}" for w in heard.messages[:5]]
        self.plant, self.ctx = plant, plant.CreateDefaultContext()
        plant.mutable_gravity_field().set_gravity_vector(model.gravity)
        names, starts = [], []
        for j in plant.GetJointIndices():
            jt = plant.get_joint(j)
            if jt.num_velocities() == 1:
                names.append(jt.name())
                starts.append(jt.velocity_start())
        order = np.argsort(starts)
        self.ix = self._perm([names[k] for k in order], "joint names")
        self.fb = None
        if model.floating:                        # q [qw qx qy qz x y z], v [angular (world); linear (world)]
            base = plant.GetBodyByName(model.root_link)
            if not base.is_floating_base_body() or plant.num_velocities() != model.nv:
                raise EngineRefused(f"drake: {model.root_link!r} is not Drake's one floating body")
            self.fq, fv = base.floating_positions_start(), base.floating_velocities_start_in_v()
            jv = np.array(starts, int)[order][self.ix]
            self.iq = np.array([plant.GetJointByName(n).position_start() for n in self._one_dof()], int)
            self.fb = FloatingBase("drake", fv, jv, plant.num_velocities())
            self.ix = np.concatenate([np.arange(fv, fv + 6), jv])
        self.damping = np.array([0.0] * (6 * int(model.floating)) +
                                [plant.GetJointByName(j).default_damping() for j in self._one_dof()], float)
        refl = np.zeros(plant.num_velocities())
        for k in range(plant.num_actuators()):
            act = plant.get_joint_actuator(plant.GetJointActuatorIndices()[k])
            refl[act.joint().velocity_start()] += act.default_reflected_inertia()
        self.armature = refl[self.ix]
        from pydrake.multibody.tree import BodyIndex
        for b in range(plant.num_bodies()):
            body = plant.get_body(BodyIndex(b))
            M = body.default_spatial_inertia()
            m, c = float(M.get_mass()), np.array(M.get_com(), float)
            Io = np.array(M.CalcRotationalInertia().CopyToFullMatrix3())
            Ic = Io - m * (float(c @ c) * np.eye(3) - np.outer(c, c)) if m > 0 else Io
            self.links[body.name()] = (m, c, Ic)
        self.tau_port = plant.get_applied_generalized_force_input_port()
        self.fd_port_refused = False
        if plant.num_actuators():
            plant.get_actuation_input_port().FixValue(self.ctx, np.zeros(plant.num_actuated_dofs()))

    def _set(self, q, v):
        if self.fb is not None:
            x = np.zeros(self.plant.num_positions())
            x[self.fq:self.fq + 7] = np.concatenate([q[6:7], q[3:6], q[:3]])   # (w, x, y, z), then position
            x[self.iq] = q[7:]
            self.plant.SetPositions(self.ctx, x)
            self.plant.SetVelocities(self.ctx, self.fb.P(q) @ v)
            return
        x = np.zeros(self.plant.num_velocities())
        x[self.ix] = q
        self.plant.SetPositions(self.ctx, x)
        x[self.ix] = v
        self.plant.SetVelocities(self.ctx, x)

    def tau(self, q, v, a):
        self._set(q, v)
        f = self.Forces(self.plant)
        self.plant.CalcForceElementsContribution(self.ctx, f)
        if self.fb is not None:
            vd = self.fb.P(q) @ a + self.fb.c(q, v)
            return self.fb.P(q).T @ np.asarray(self.plant.CalcInverseDynamics(self.ctx, vd, f))
        vd = np.zeros(self.model.nv)
        vd[self.ix] = a
        return np.asarray(self.plant.CalcInverseDynamics(self.ctx, vd, f))[self.ix]

    def mass(self, q):
        self._set(q, np.zeros(self.model.nv))
        M = np.asarray(self.plant.CalcMassMatrix(self.ctx))
        if self.fb is not None:
            P = self.fb.P(q)
            return P.T @ M @ P
        return M[np.ix_(self.ix, self.ix)]

    def qdd(self, q, v, tau):
        self._set(q, v)
        t = np.zeros(self.model.nv)
        t[self.ix] = tau
        if self.fb is not None:
            t = self.fb.P(q) @ tau
        if not self.fd_port_refused:
            try:
                self.tau_port.FixValue(self.ctx, t)
                vd = np.asarray(self.plant.get_generalized_acceleration_output_port().Eval(self.ctx))
                if self.fb is not None:
                    return self.fb.P(q).T @ (vd - self.fb.c(q, v))
                return vd[self.ix]
            except RuntimeError as exc:          # e.g. mimic couplers: constraints need a discrete plant
                self.fd_port_refused = True
                self.notes.append(f"forward-dynamics port refused ({_one_line(exc)[:160]}); q̈ from Drake's "
                                  "own M and inverse dynamics instead: M⁻¹(τ − ID(q, q̇, 0))")
        return np.linalg.solve(self.mass(q), tau - self.tau(q, v, np.zeros(self.model.nv)))


ADAPTERS = {"pinocchio": PinocchioAdapter, "mujoco": MujocoAdapter, "pybullet": PybulletAdapter,
            "drake": DrakeAdapter}


def load_engine(name, model, path) -> Adapter:
    """The engine's model of ``path``; EngineMissing when not installed, EngineRefused when it will not load."""
    if not available(name):
        raise EngineMissing(f"{name} is not installed (pip install {PIP[name]}, or "
                            f"{install_command(EXTRA[name])})", name=MODULES[name])
    return ADAPTERS[name](model, path)


def _import(module):
    """An engine's module (pinocchio, mujoco, pybullet, pydrake); EngineMissing names its extra."""
    name = next(e for e, m in MODULES.items() if m == module)
    try:
        return require(module, EXTRA[name], f"manipdyn validate --against {name}")
    except MissingExtraError as exc:
        raise EngineMissing(str(exc), name=module) from exc


class _Heard(logging.Handler):
    """Keeps the warnings an engine logs while it parses."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


def _quat_matrix(qwxyz):
    w, x, y, z = (float(t) for t in qwxyz)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _one_line(exc, limit=300) -> str:
    return " | ".join(s.strip() for s in str(exc).splitlines() if s.strip())[:limit] or type(exc).__name__



# ---- explaining a disagreement -------------------------------------------------------------------------------

def _differs(x, y, floor=1e-12) -> bool:
    """x and y differ beyond round-off: relative 1e-9 of the larger, plus an absolute floor."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    return bool(np.max(np.abs(x - y)) > 1e-9 * max(np.max(np.abs(x)), np.max(np.abs(y))) + floor)


def _same_moments(I, J) -> bool:
    """Same principal moments to 1e-9 (relative to the largest) and close axes (matrices within 1e-5)."""
    scale = max(np.max(np.abs(J)), 1e-300)
    return bool(np.max(np.abs(np.linalg.eigvalsh(I) - np.linalg.eigvalsh(J))) <= 1e-9 * scale
                and np.max(np.abs(I - J)) <= 1e-5 * scale)


def _triangle_broken(I) -> bool:
    lam = np.linalg.eigvalsh(I)
    return bool(lam[0] + lam[1] < lam[2] - 1e-9 * max(np.sum(np.abs(lam)), 1e-300))


def body_params(model, links) -> tuple:
    """(mass (nb,), com (nb, 3), inertia (nb, 3, 3)) of our bodies built from per-link (m, c, I_c) in link
    frames: each link present in ``links`` placed by model.frames and merged into its body."""
    parts = [[] for _ in range(model.njoints)]
    for name, fr in model.frames.items():
        if fr.body >= 0 and name in links:
            m, c, I = links[name]
            parts[fr.body].append((m, fr.p + fr.R @ c, fr.R @ I @ fr.R.T))
    out = [combine_inertias(p) if p else (0.0, np.zeros(3), np.zeros((3, 3))) for p in parts]
    return (np.array([o[0] for o in out], float), np.array([o[1] for o in out], float).reshape(-1, 3),
            np.array([o[2] for o in out], float).reshape(-1, 3, 3))


def explain(model, adapter, inertials) -> list:
    """Named causes [{"link", "kind", "text"}] of every difference between the engine's read-back
    parameters and ours: per link against the file's own numbers, per body against our model, per dof
    for armature and damping. Empty when the engine holds the same parameters."""
    causes, e = [], adapter.name
    em, ec, eI = body_params(model, adapter.links)
    if not adapter.merged:
        for name, fr in model.frames.items():
            if fr.body < 0:
                continue
            f = inertials.get(name)
            if f is None:
                continue
            if name not in adapter.links:
                if f.mass > 0:
                    causes.append(dict(link=name, kind="missing link", text=f"{e} has no link {name!r} "
                                       f"({f.mass:g} kg in the file)"))
                continue
            m, c, I = adapter.links[name]
            causes += _link_causes(e, name, f, m, c, I)
    for i, body in enumerate(model.body_names):       # what the link view cannot see (and merged engines)
        if not (_differs(em[i], model.mass[i]) or _differs(eI[i], model.inertia[i], 1e-15)
                or (model.mass[i] > 0 and _differs(ec[i], model.com[i]))):
            continue
        links = (body,) + tuple(model.merged.get(body, ()))
        if any(c["link"] in links for c in causes):
            continue
        quirks = [q for ln in links if ln in inertials for q in _file_quirks(inertials[ln], ln)]
        causes.append(dict(link=body, kind="body parameters", text=(
            f"{e}: body {body!r} (links {', '.join(links)}) has mass {em[i]:.6g} kg, inertia trace "
            f"{np.trace(eI[i]):.6g}; ours {model.mass[i]:.6g} kg, {np.trace(model.inertia[i]):.6g}"
            + (f" — the file's {'; '.join(quirks)}" if quirks else ""))))
    for j, name in enumerate(model.joint_names):    # ours: model.armature, model.damping (per dof, docs/design.md §3)
        if model.kind[j] == FREEFLYER:                 # a free-flyer root: no armature or damping of its own
            continue
        k = slice(model.idx_v[j], model.idx_v[j] + model.nvs[j])     # a ball: its three dofs
        a, d = adapter.armature[k], adapter.damping[k]
        if _differs(a, model.armature[k]):
            causes.append(dict(link=name, kind="armature", text=f"{e} adds armature {_g(a)} kg m² to joint {name!r} "
                               f"(M's diagonal); ours {_g(model.armature[k])}"))
        if np.any(d) and _differs(d, model.damping[k]):
            causes.append(dict(link=name, kind="damping", text=f"{e} applies joint damping {_g(d)} N m s/rad to "
                               f"joint {name!r} (from <dynamics>); ours {_g(model.damping[k])}"))
    return causes


def _g(x) -> str:
    """A joint's per-dof values: one number when they are one (a 1-dof joint, a ball's three equal entries)."""
    x = np.asarray(x, float)
    return f"{x[0]:g}" if np.all(x == x[0]) else "[" + ", ".join(f"{t:g}" for t in x) + "]"


def applied_damping(model, adapter):
    """Our damping (nv,) where the engine applies damping in its queries (its read-back damping is nonzero), else 0:
    what our side of a comparison adds, as the engine does (τ += d q̇ in ID if ``damping_in_id``, and in FD)."""
    return np.where(adapter.damping != 0, model.damping, 0.0)


def precision_causes(model, adapter, inertials, floor=1e-13, k=3) -> list:
    """The links whose read-back parameters differ from the file's by more than ``floor`` (relative) but
    below the quirk threshold: the engine re-expressed them (e.g. principal axes by an iterative
    diagonalisation) with less than double precision. The k worst, named."""
    worst = []
    for name, fr in model.frames.items():
        f = inertials.get(name)
        if fr.body < 0 or f is None or name not in adapter.links or adapter.merged:
            continue
        m, c, I = adapter.links[name]
        rel = max(abs(m - f.mass) / max(abs(f.mass), 1e-300) if f.mass else abs(m),
                  np.max(np.abs(c - f.com)) / max(np.max(np.abs(f.com)), 1e-3) if f.mass else 0.0,
                  np.max(np.abs(I - f.inertia)) / max(np.max(np.abs(f.inertia)), 1e-300) if np.any(f.inertia)
                  else float(np.max(np.abs(I))))
        if rel > floor:
            worst.append((rel, name))
    return [dict(link=n, kind="precision", text=f"link {n!r}: {adapter.name} holds its mass/CoM/inertia to "
                 f"{rel:.1e} (relative) of the file's: round-off of its own re-expression of the inertia "
                 f"(principal axes), not a modelling difference") for rel, n in sorted(worst, reverse=True)[:k]]


def refusal_causes(reason, inertials) -> list:
    """The links an engine's refusal names (quoted in its message), with what is unusual in their <inertial>."""
    out = []
    for name in dict.fromkeys(re.findall(r"'([^']+)'", reason)):
        f = inertials.get(name)
        if f is None:
            continue
        quirks = _file_quirks(f, name)
        lam = np.linalg.eigvalsh(f.inertia)
        if f.present and lam[0] <= 0:
            quirks.append(f"link {name!r}'s inertia has a principal moment ≤ 0 (eigenvalues {lam.tolist()})")
        if f.present and f.mass == 0 and not np.any(f.inertia):
            quirks.append(f"link {name!r} has zero mass and zero inertia")
        out += [dict(link=name, kind="refused", text=q) for q in quirks]
    return out


def _file_quirks(f, name) -> list:
    """What is unusual in a link's <inertial> (short phrases)."""
    out = []
    if not f.present:
        out.append(f"link {name!r} has no <inertial>")
    elif f.mass == 0 and np.any(f.inertia):
        out.append(f"link {name!r} has zero mass but a non-zero inertia")
    elif f.present and np.any(f.inertia) and _triangle_broken(f.inertia):
        out.append(f"link {name!r}'s inertia violates the triangle inequality")
    if f.rotated:
        out.append(f"link {name!r}'s inertial frame is rotated (rpy ≠ 0)")
    return out


def _link_causes(e, name, f, m, c, I) -> list:
    """The engine's (m, c, I) of one link against the file's LinkInertial f: named quirks."""
    out = []
    dm, dc, dI = _differs(m, f.mass), f.mass > 0 and _differs(c, f.com), _differs(I, f.inertia, 1e-15)
    if not (dm or dc or dI):
        return out
    said = f"{e} holds {m:.6g} kg, inertia diag {np.round(np.diag(I), 9).tolist()}"
    if not f.present:
        out.append(dict(link=name, kind="no <inertial>", text=f"link {name!r} has no <inertial>: {said} "
                        f"(ours and the file: 0 kg)"))
    elif f.mass == 0 and np.any(f.inertia):
        how = "drops the inertia" if not np.any(np.abs(I) > 1e-300) else "changes it"
        out.append(dict(link=name, kind="zero mass with inertia", text=f"link {name!r} has zero mass and a "
                        f"non-zero inertia: {e} {how} ({said}; ours keeps the file's inertia)"))
    elif dI and _triangle_broken(f.inertia):
        out.append(dict(link=name, kind="triangle inequality", text=f"link {name!r}'s inertia violates the "
                        f"triangle inequality: {e} alters it ({said})"))
    elif dI and f.rotated and not _differs(I, f.raw, 1e-15):
        out.append(dict(link=name, kind="rotated inertial frame", text=f"link {name!r}'s inertial frame is "
                        f"rotated: {e} ignores the rotation (holds the inertia as written, unrotated)"))
    elif dI and not (dm or dc) and _same_moments(I, f.inertia):
        rel = np.max(np.abs(I - f.inertia)) / np.max(np.abs(f.inertia))
        out.append(dict(link=name, kind="precision", text=f"link {name!r}: {e} holds the inertia to {rel:.1e} "
                        f"(relative) of the file's, its principal moments to round-off: the principal axes of "
                        f"its re-expression (an iterative diagonalisation that stops at a tolerance) are off, "
                        f"not a modelling difference"))
    else:
        what = [w for w, d in (("mass", dm), ("CoM", dc), ("inertia", dI)) if d]
        out.append(dict(link=name, kind=" and ".join(what), text=f"link {name!r}: {e}'s {' and '.join(what)} "
                        f"differ(s) from the file ({said}; file {f.mass:.6g} kg)"))
    return out


def neutralised(model, adapter):
    """Our model rebuilt with the engine's masses, CoMs and inertias (dataclasses.replace)."""
    m, c, I = body_params(model, adapter.links)
    return dataclasses.replace(model, mass=m, com=c, inertia=I, notes=model.notes + (
        f"parameters read back from {adapter.name}",))


# ---- the referee run ------------------------------------------------------------------------------------------

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


# ---- reporting ------------------------------------------------------------------------------------------------

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
