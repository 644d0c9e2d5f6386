"""Engine adapters: Pinocchio, MuJoCo, PyBullet and Drake each loading one URDF (or MJCF) file and answering τ, M
and q̈ in our joint order, plus the engine names, their packages and ``load_engine``.

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
removed before any engine reads the file (``referee_urdf.stripped_urdf``): no engine then needs meshes, and none
can derive inertia from them.

After import each adapter reads back every link's mass, CoM and inertia about the CoM in the link frame
(``links``; Pinocchio: per body, fixed links already merged) and the armature/damping it adds per dof
(``armature``, ``damping``): what causes.py compares with the file and our model.

An MJCF file (``robot_format``: root element ``<mujoco>``) is taken as written: MuJoCo compiles the file (its
free joint, ball joints, armature and damping; joint springs, which the model holds as quirks, turned off), each
joint mapped by name — a ball's qpos (w, x, y, z) against our (x, y, z, w), its qvel the body-frame ω as ours;
Pinocchio reads it with ``buildModelFromMJCF`` (refused by name where it makes one body's joints a composite
joint); the PyBullet and Drake adapters load URDF and refuse, naming the ball joints (or the MJCF file).

Engines are imported here only (and in referee_zoo.py), lazily, inside the adapters: ``import manipdyn`` loads
none of them.
"""
from __future__ import annotations

import contextlib
import importlib.util
import logging
import re
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError, ManipdynError, MissingExtraError
from ..extras import install_command, require
from ..io.load import robot_format
from ..joints import BALL, FREEFLYER, PRISMATIC, REVOLUTE
from .referee_urdf import stripped_urdf

ENGINES = ("pinocchio", "mujoco", "pybullet", "drake")
MODULES = {"pinocchio": "pinocchio", "mujoco": "mujoco", "pybullet": "pybullet", "drake": "pydrake"}
PIP = {"pinocchio": "pin", "mujoco": "mujoco", "pybullet": "pybullet", "drake": "drake"}
EXTRA = {"pinocchio": "validate", "mujoco": "engines", "pybullet": "engines", "drake": "engines"}   # manipdyn[...]
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
