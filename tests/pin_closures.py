"""Closure rows Φ, Φ_q, Φ̇_q q̇ from Pinocchio's frame kinematics — the independent reference for manipdyn's
one closure source (constraints/closures.py).

Each closure side becomes an operational frame of Pinocchio's model at the closure point (axes of the body
it hangs on); then, with J = getFrameJacobian and J̇ = getFrameJacobianTimeVariation (LOCAL_WORLD_ALIGNED):
  position rows      Φ = p_A − p_B,  Φ_q = J_A,v − J_B,v,  Φ̇_q q̇ = (J̇_A,v − J̇_B,v) q̇
  orientation rows   Φ = a·b,  Φ_q = (a × b)ᵀ (J_A,ω − J_B,ω),
                     Φ̇_q q̇ = [(ω_A × a) × b + a × (ω_B × b)]·(ω_A − ω_B) + (a × b)·(J̇_A,ω − J̇_B,ω) q̇
with a, b the direction pairs written out again here from the row convention (closures.py's docstring):
revolute (n1, e_B), (n2, e_B) with n1 = e_A × (the unit axis least aligned with e_A), n2 = e_A × n1;
fixed (y_A, z_B), (z_A, x_B), (x_A, y_B); spherical none. The closure data (bodies, points, axes, frames) are
read from the Model; Pinocchio's joint k + 1 is our body k (checked by name).
A coupling (gear; Pinocchio has no such constraint) is written from Pinocchio's tree instead: the joints from the
two bodies' common ancestor (walked on ``pm.parents``) down to each body, Φ = ratio Σ q_A − Σ q_B, Φ_q its
coefficients at Pinocchio's idx_v, Φ̇_q q̇ = 0 (constant coefficients).
"""
import numpy as np

from manipdyn.validation.reference import pin


def _perp(e):
    """n1, n2 completing e to a right-handed basis: n1 = e × (the unit axis least aligned with e)."""
    t = np.zeros(3)
    t[np.argmin(np.abs(e))] = 1.0
    n1 = np.cross(e, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(e, n1)


def _pairs(c):
    if c.type == "revolute":
        return [(n, c.axis_c) for n in _perp(c.axis_p)]
    if c.type == "fixed":
        A, B = c.Rp, c.Rc
        return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]
    return []


class PinClosures:
    """Pinocchio's model ``pm`` of ``model`` with an operational frame per closure side."""

    def __init__(self, model, pm):
        P = pin()
        names = [pm.names[k] for k in range(1, pm.njoints)]
        assert tuple(names) == model.joint_names, (names, model.joint_names)
        self.model, self.pm = model, pm
        self.sides = []
        for k, c in enumerate(model.constraints):
            ids = []
            for side, (b, p) in enumerate(((c.parent, c.pp), (c.child, c.pc))):
                frame = P.Frame(f"closure{k}_{side}", b + 1, pm.getFrameId(pm.names[b + 1]) if b >= 0 else 0,
                                P.SE3(np.eye(3), np.asarray(p, float)), P.FrameType.OP_FRAME)
                ids.append(pm.addFrame(frame))
            self.sides.append((c, ids))
        self.pd = pm.createData()

    def rows(self, q, v):
        """Φ (m,), Φ_q (m, nv), Φ̇_q q̇ (m,) at Pinocchio's q (nq,) and v (nv,)."""
        P, pm, pd = pin(), self.pm, self.pd
        P.computeJointJacobians(pm, pd, q)
        P.computeJointJacobiansTimeVariation(pm, pd, q, v)
        P.updateFramePlacements(pm, pd)
        phi, jac, bias = [], [], []
        for c, (fa, fb) in self.sides:
            if c.type == "coupling":
                row = self._coupling(c, q)
                phi.append(row @ self._angles(q))
                jac.append(row)
                bias.append(0.0)
                continue
            (RA, pA), (RB, pB) = ((pd.oMf[f].rotation, pd.oMf[f].translation) for f in (fa, fb))
            JA, JB = (np.reshape(P.getFrameJacobian(pm, pd, f, P.LOCAL_WORLD_ALIGNED), (6, pm.nv)) for f in (fa, fb))
            dJA, dJB = (np.reshape(P.getFrameJacobianTimeVariation(pm, pd, f, P.LOCAL_WORLD_ALIGNED), (6, pm.nv))
                        for f in (fa, fb))
            phi += list(pA - pB)
            jac += list(JA[:3] - JB[:3])
            bias += list((dJA[:3] - dJB[:3]) @ v)
            wA, wB = JA[3:] @ v, JB[3:] @ v
            for a0, b0 in _pairs(c):
                a, b = RA @ a0, RB @ b0
                axb = np.cross(a, b)
                phi.append(a @ b)
                jac.append(axb @ (JA[3:] - JB[3:]))
                daxb = np.cross(np.cross(wA, a), b) + np.cross(a, np.cross(wB, b))
                bias.append(daxb @ (wA - wB) + axb @ ((dJA[3:] - dJB[3:]) @ v))
        nv = pm.nv
        return np.array(phi), np.array(jac).reshape(-1, nv), np.array(bias)

    def _angles(self, q):
        """One coordinate per velocity of 1-dof joints: q itself, or atan2(sin, cos) of a continuous joint."""
        pm, out = self.pm, np.zeros(self.pm.nv)
        for j in range(1, pm.njoints):
            jm = pm.joints[j]
            if jm.nv == 1:
                out[jm.idx_v] = np.arctan2(q[jm.idx_q + 1], q[jm.idx_q]) if jm.nq == 2 else q[jm.idx_q]
        return out

    def _coupling(self, c, q):
        """Φ_q of a coupling (nv,): +ratio on the joints down to the parent body, −1 down to the child body."""
        pm, row = self.pm, np.zeros(self.pm.nv)
        up = lambda j: [j] + up(pm.parents[j]) if j > 0 else []   # noqa: E731  joint ids up to the universe
        a, b = up(c.parent + 1), up(c.child + 1)
        common = set(a) & set(b)
        for j in a:
            if j not in common:
                row[pm.joints[j].idx_v] += c.ratio
        for j in b:
            if j not in common:
                row[pm.joints[j].idx_v] -= 1.0
        return row
