"""Pinocchio as the referee: building its model, and converting our conventions to its conventions.

This is the one place where manipdyn's conventions meet Pinocchio's:
- q: Pinocchio stores a continuous joint as (cos q, sin q) (nq = 2); ``to_pin_q`` maps our angle
  (``from_pin_q`` back: atan2). A free-flyer root is the same in both, [x y z qx qy qz qw], v = [linear;
  angular] in the body frame: its block is copied. A floating model's reference is
  ``buildModelFromUrdf(path, pin.JointModelFreeFlyer())``, whose joint 1 is "root_joint" as ours.
- spatial vectors: Pinocchio's are [linear; angular]; data.v[i], data.a[i] in joint i's frame, with
  data.a the *spatial* acceleration (classical linear acceleration = a.linear + ω × v.linear).
- rnea fills data.a_gf (with gravity), never data.a: the gravity-free one comes from forwardKinematics.
- fext is per joint, in the joint's frame, about the joint origin.
Pinocchio is imported lazily: ``import manipdyn`` never loads it.
"""
from __future__ import annotations

import numpy as np

from ..errors import ManipdynError
from ..joints import HELICAL, PLANAR
from ..extras import require


def pin():
    """The pinocchio module, imported on first use (MissingExtraError without the validate extra)."""
    return require("pinocchio", "validate", "manipdyn validate")


class Reference:
    """A Pinocchio model of the same URDF, checked to have our joint order."""

    def __init__(self, model, urdf_path):
        from ..io.load import robot_format
        P = pin()
        self.model = model
        added = model.floating and model.body_names[0] == model.root_link   # root_joint="free_flyer" (a file's
        free = added or any(np.ndim(v) == 1 and len(v) == 7 for v in model.locked.values())   # floating joint
        root = (P.JointModelFreeFlyer(),) if free else ()       # is in the file); a locked free flyer: its pose (7,)
        odd = [n for n, k, a in zip(model.joint_names, model.kind, model.axis) if k == PLANAR and not a[2] == 1.0]
        if odd:
            raise ManipdynError(f"{urdf_path}: joint {odd[0]!r} is planar with a normal other than z; Pinocchio's URDF "
                                f"reader moves every planar joint in its frame's xy plane (it ignores <axis>)")
        universal = any(b.endswith(f":{j}") for j, b in zip(model.joint_names, model.body_names))   # (io/urdf.py)
        if robot_format(urdf_path) != "mjcf" and (np.any(model.kind == HELICAL) or universal):
            raise ManipdynError(f"{urdf_path}: Pinocchio's URDF reader has no screw or universal joint type "
                                f"(<drake:joint>)")
        if robot_format(urdf_path) == "mjcf":          # an MJCF file: its free joint, if any, is in the file
            self.pm = P.buildModelFromMJCF(str(urdf_path))
            composite = [n for n, j in zip(self.pm.names[1:], self.pm.joints[1:])
                         if j.shortname() == "JointModelComposite"]
            if composite:
                raise ManipdynError(f"{urdf_path}: Pinocchio's buildModelFromMJCF makes the joints of one body one "
                                    f"composite joint ({', '.join(composite)}): its joints are not ours one by one")
        else:
            self.pm = P.buildModelFromUrdf(str(urdf_path), *root)
        if model.locked:                      # a reduced model: compare with Pinocchio's reduced model
            self.pm = P.buildReducedModel(self.pm, [self.pm.getJointId(j) for j in model.locked],
                                          self._locked_q(model.locked))
        self.pd = self.pm.createData()
        names = tuple(self.pm.names[1:])
        if names != model.joint_names:
            raise ManipdynError(f"{urdf_path}: joint order differs from Pinocchio's: ours "
                                f"{model.joint_names}, Pinocchio {names}")
        self.pm.gravity.linear = np.asarray(model.gravity, float)
        self.pm.armature = np.asarray(model.armature, float)      # M + diag(armature), as ours (docs §3)
        self.idx_q = np.array([self.pm.joints[i + 1].idx_q for i in range(model.njoints)], int)
        self.nq_j = np.array([self.pm.joints[i + 1].nq for i in range(model.njoints)], int)

    def _locked_q(self, locked):
        """Pinocchio's full q with the locked joints at their values (the others at neutral)."""
        P, pm = pin(), self.pm
        q = P.neutral(pm)
        for j, val in locked.items():
            jm = pm.joints[pm.getJointId(j)]
            q[jm.idx_q:jm.idx_q + jm.nq] = (np.cos(val), np.sin(val)) if jm.nq == 2 else val
        return q

    def to_pin_q(self, q):
        """Our q (nq,) -> Pinocchio's q (pm.nq,): continuous joints as (cos, sin), other blocks copied."""
        pq, m = np.zeros(self.pm.nq), self.model
        for i, (k, n) in enumerate(zip(self.idx_q, self.nq_j)):
            a, nq = m.idx_q[i], m.nqs[i]
            pq[k:k + n] = (np.cos(q[a]), np.sin(q[a])) if n == 2 and nq == 1 else q[a:a + nq]
        return pq

    def from_pin_q(self, pq):
        """Pinocchio's q (pm.nq,) -> ours (nq,): a continuous joint's angle is atan2(sin, cos)."""
        q, m = np.zeros(self.model.nq), self.model
        for i, (k, n) in enumerate(zip(self.idx_q, self.nq_j)):
            a, nq = m.idx_q[i], m.nqs[i]
            q[a:a + nq] = np.arctan2(pq[k + 1], pq[k]) if n == 2 and nq == 1 else pq[k:k + n]
        return q

    def fext(self, q, f_ext, f_ext_frame="local"):
        """Our {frame: (force, moment)} -> Pinocchio's per-joint fext, via Pinocchio's own frame placements."""
        P, pm, pd = pin(), self.pm, self.pd
        P.framesForwardKinematics(pm, pd, self.to_pin_q(q))
        out = [P.Force.Zero() for _ in range(pm.njoints)]
        for name, (f, m) in f_ext.items():
            fid = pm.getFrameId(name, P.FrameType.BODY)
            fr = pm.frames[fid]
            f, m = np.asarray(f, float), np.asarray(m, float)
            if f_ext_frame == "world":           # world axes about the frame origin -> frame axes
                Rw = pd.oMf[fid].rotation
                f, m = Rw.T @ f, Rw.T @ m
            out[fr.parentJoint] += fr.placement.act(P.Force(f, m))
        return out

    def terms(self, q, v, a, f_ext=None, f_ext_frame="local"):
        """Pinocchio's per-link terms for one state, in our names (see rnea_terms), arrays (nb, 3)."""
        P, pm, pd, nb = pin(), self.pm, self.pd, self.model.njoints
        pq = self.to_pin_q(q)
        ext = self.fext(q, f_ext, f_ext_frame) if f_ext else None
        tau = (P.rnea(pm, pd, pq, v, a, ext) if ext else P.rnea(pm, pd, pq, v, a)).copy()
        J = range(1, nb + 1)
        out = dict(
            w=[pd.v[i].angular for i in J], v=[pd.v[i].linear for i in J],
            f=[pd.f[i].linear for i in J], n=[pd.f[i].angular for i in J])
        inertial = [pm.inertias[i] * pd.a_gf[i] + pd.v[i].cross(pm.inertias[i] * pd.v[i]) for i in J]
        out["fc"] = [x.linear for x in inertial]
        out["nO"] = [x.angular for x in inertial]          # about the link frame origin
        P.forwardKinematics(pm, pd, pq, v, a)              # gravity-free spatial accelerations
        out["dw"] = [pd.a[i].angular for i in J]
        out["acc"] = [pd.a[i].linear + np.cross(pd.v[i].angular, pd.v[i].linear) for i in J]
        out = {k: np.array(x, float).reshape(nb, 3) for k, x in out.items()}
        out["tau"] = tau
        return out

    def dynamics(self, q, v, tau):
        """Pinocchio's M (crba, symmetric), C, g, C q̇ + g, q̈ (aba) and cond(M) for one state."""
        P, pm, pd = pin(), self.pm, self.pd
        pq = self.to_pin_q(q)
        M = P.crba(pm, pd, pq).copy()
        return dict(M=M, C=P.computeCoriolisMatrix(pm, pd, pq, v).copy(),
                    g=P.computeGeneralizedGravity(pm, pd, pq).copy(),
                    nle=P.nonLinearEffects(pm, pd, pq, v).copy(),
                    qdd=P.aba(pm, pd, pq, v, tau).copy(), cond=float(np.linalg.cond(M)))

    def derivatives(self, q, v, a, tau):
        """Pinocchio's ∂τ/∂q, ∂τ/∂q̇ at (q, q̇, q̈ = a) (computeRNEADerivatives) and ∂q̈/∂q, ∂q̈/∂q̇ at (q, q̇, τ)
        (computeABADerivatives), copied (the binding returns views of its data) — tangent-space q-derivatives."""
        P, pm, pd = pin(), self.pm, self.pd
        pq = self.to_pin_q(q)
        dq, dv = (np.array(x) for x in P.computeRNEADerivatives(pm, pd, pq, v, a)[:2])
        fq, fv = (np.array(x) for x in P.computeABADerivatives(pm, pd, pq, v, tau)[:2])
        return dict(dtau_dq=dq, dtau_dv=dv, dqdd_dq=fq, dqdd_dv=fv)

    def jacobians(self, q, v):
        """Every body frame's Jacobian and its time derivative, world-aligned and local: (nb, 6, nv) each."""
        P, pm, pd = pin(), self.pm, self.pd
        pq = self.to_pin_q(q)
        P.computeJointJacobians(pm, pd, pq)
        P.computeJointJacobiansTimeVariation(pm, pd, pq, v)
        P.updateFramePlacements(pm, pd)
        out = {}
        for key, ref in (("local_world_aligned", P.LOCAL_WORLD_ALIGNED), ("local", P.LOCAL)):
            ids = [pm.getFrameId(b, P.FrameType.BODY) for b in self.model.body_names]
            # (6, nv) each: eigenpy hands a 6 × 1 matrix back as a vector (6,) when nv = 1
            out["J_" + key] = np.array([np.reshape(P.getFrameJacobian(pm, pd, f, ref), (6, pm.nv)) for f in ids])
            out["dJ_" + key] = np.array([np.reshape(P.getFrameJacobianTimeVariation(pm, pd, f, ref), (6, pm.nv))
                                         for f in ids])
        return out

    def regressor(self, q, v, a):
        """Pinocchio's joint-torque regressor (nv, 10 nb) for one state (computeJointTorqueRegressor)."""
        P = pin()
        Y = P.computeJointTorqueRegressor(self.pm, self.pd, self.to_pin_q(q), v, a)
        return np.reshape(Y, (self.pm.nv, 10 * (self.pm.njoints - 1))).copy()   # eigenpy: 1 × n comes back (n,)
