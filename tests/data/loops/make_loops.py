"""Writes the spatial closed-chain test mechanisms of tests/crosscheck/test_spatial_loops.py.

Each mechanism is a spanning tree (ordinary URDF joints) plus <constraint> closures. The geometry is
chosen so that every closure row is independent (no planar or co-axial special case):

  rusr_revolute   spatial RUSR four-bar (crank R, universal U at the crank tip, spherical S as three
                  concurrent revolutes, rocker) closed at the rocker's pivot on the base by a REVOLUTE
                  closure with a skew axis: 6 tree joints, 5 independent rows, mobility 1.
  weld7           two spatial branches from the base (R R P R, and R R R) whose tips are welded by a
                  FIXED closure between a merged tool link and the second tip, both closure frames
                  rotated: 7 tree joints, 6 independent rows, mobility 1.
  rusr_spherical  spatial RUSR four-bar: crank R, U at its tip, coupler, and a rocker on a skew pivot,
                  the coupler end joined to the rocker end by a SPHERICAL closure: 4 tree joints,
                  3 independent rows, mobility 1.
  slider_crank    spatial slider-crank: crank R, U, coupler, and a PRISMATIC slider on a line skew to the
                  crank plane, coupler end to slider by a spherical closure; the slider is actuated:
                  4 tree joints, 3 independent rows, mobility 1.
  two_loops       rusr_revolute and weld7 side by side under one base, closures in that order (the fixed
                  closure's rows start at row 5): 13 tree joints, 11 independent rows, mobility 2.

A closure is specified in world terms at a chosen configuration q0: a world point W (the shared origin),
a world rotation RW (fixed closures) and a world axis e (revolute closures). The script computes the
link poses at q0 with Pinocchio's forward kinematics and writes parent_origin / child_origin (and the
axes) in the two links' frames, so the closures hold at q0 by construction. q0 (in Pinocchio's joint
order, which manipdyn follows) and the rank expected from the mobility count go to manifest.json.

Run from the repository root:  python tests/data/loops/make_loops.py
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin

HERE = Path(__file__).resolve().parent


def rpy_of(R):
    """URDF rpy (fixed-axis X-Y-Z) of a rotation matrix."""
    return pin.rpy.matrixToRpy(R)


def rot(rpy):
    return pin.rpy.rpyToMatrix(*rpy)


def unit(x):
    x = np.asarray(x, float)
    return x / np.linalg.norm(x)


def f(x):
    return " ".join(f"{(0.0 if abs(v) < 1e-15 else float(v)):.15g}" for v in x)


class Mech:
    """A spanning tree (links, joints) with closures given in world terms at q0."""

    def __init__(self, name):
        self.name, self.links, self.joints, self.closures, self.q0, self.actuated = name, [], [], [], {}, []

    def link(self, name, mass=0.0, seg=(0, 0, 0)):
        """A link whose centre of mass is mid-way along seg (link frame), with a generic inertia."""
        self.links.append((name, mass, 0.5 * np.asarray(seg, float), seg))

    def joint(self, name, kind, parent, child, xyz, axis, rpy=(0, 0, 0), q0=0.0, actuated=False):
        self.joints.append((name, kind, parent, child, np.asarray(xyz, float), np.asarray(rpy, float),
                            unit(axis) if axis is not None else None))
        if kind != "fixed":
            self.q0[name] = q0
        if actuated:
            self.actuated.append(name)

    def closure(self, name, kind, parent, child, W, RW=np.eye(3), axis=(0, 0, 1)):
        """W, RW, axis: world point, world rotation and world axis of the closure at q0 (callables of the
        Pinocchio model/data at q0, or constants)."""
        self.closures.append((name, kind, parent, child, W, RW, axis))

    # ---- output
    def tree_xml(self):
        out = [f'<robot name="{self.name}">', '  <link name="base"/>']
        for name, mass, com, seg in self.links:
            if mass == 0.0:
                out.append(f'  <link name="{name}"/>')
                continue
            L2 = max(float(np.dot(seg, seg)), 0.01)
            k = mass * L2 / 12.0               # moments k·(1, 1.3, 0.6): positive, triangle inequality holds
            out.append(f'  <link name="{name}"><inertial><origin xyz="{f(com)}" rpy="0 0 0"/>'
                       f'<mass value="{mass}"/><inertia ixx="{k:.6g}" iyy="{1.3 * k:.6g}" izz="{0.6 * k:.6g}" '
                       f'ixy="{0.1 * k:.6g}" ixz="0" iyz="{-0.05 * k:.6g}"/></inertial></link>')
        for name, kind, parent, child, xyz, rpy, axis in self.joints:
            ax = f'<axis xyz="{f(axis)}"/>' if axis is not None else ""
            lim = '<limit lower="-1e3" upper="1e3" effort="100" velocity="100"/>' if kind != "fixed" else ""
            out.append(f'  <joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
                       f'<origin xyz="{f(xyz)}" rpy="{f(rpy)}"/>{ax}{lim}</joint>')
        return out

    def write(self, header):
        xml = self.tree_xml()
        pm = pin.buildModelFromXML("\n".join(xml + ["</robot>"]))
        pd = pm.createData()
        names = list(pm.names[1:])
        q0 = np.array([self.q0[n] for n in names])
        pin.framesForwardKinematics(pm, pd, q0)
        pose = lambda link: pd.oMf[pm.getFrameId(link)]  # noqa: E731
        for name, kind, parent, child, W, RW, axis in self.closures:
            W, RW, axis = (x(pose) if callable(x) else np.asarray(x, float) for x in (W, RW, axis))
            xml.append(f'  <constraint name="{name}" type="{kind}">')
            for side, link in (("parent", parent), ("child", child)):
                M = pose(link)
                R, p = M.rotation, M.translation
                xml.append(f'    <{side} link="{link}"/>')
                xml.append(f'    <{side}_origin xyz="{f(R.T @ (W - p))}" rpy="{f(rpy_of(R.T @ RW))}"/>')
                if kind == "revolute":
                    xml.append(f'    <{side}_axis xyz="{f(R.T @ unit(axis))}"/>')
            xml.append("  </constraint>")
        for j in self.actuated:
            xml.append(f'  <transmission name="{j}_drive"><type>transmission_interface/SimpleTransmission</type>'
                       f'<joint name="{j}"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>'
                       f'<actuator name="{j}_motor"><mechanicalReduction>1</mechanicalReduction></actuator>'
                       f'</transmission>')
        text = '<?xml version="1.0"?>\n<!-- ' + header.strip() + "\n     Written by make_loops.py. -->\n" \
            + "\n".join(xml) + "\n</robot>\n"
        (HERE / f"{self.name}.urdf").write_text(text)
        return names, q0


# ---------------------------------------------------------------- the mechanisms
def rusr_revolute(m, pre=""):
    """Crank R (z) at the origin; U (x, y) at its tip; coupler to a spherical S (x, y, z) whose last body is
    the rocker; the rocker's pivot on the base is a revolute closure with a skew axis."""
    m.link(pre + "crank", 0.3, (0.12, 0, 0))
    m.link(pre + "ucross", 0.05)
    m.link(pre + "coupler", 0.5, (0.35, 0, 0.05))
    m.link(pre + "sa", 0.05)
    m.link(pre + "sb", 0.05)
    m.link(pre + "rocker", 0.4, (0.1, 0.2, -0.1))
    m.joint(pre + "j1_crank", "revolute", "base", pre + "crank", (0, 0, 0), (0, 0, 1), q0=0.4, actuated=True)
    m.joint(pre + "j2_ua", "revolute", pre + "crank", pre + "ucross", (0.12, 0, 0), (1, 0, 0), q0=0.3)
    m.joint(pre + "j3_ub", "revolute", pre + "ucross", pre + "coupler", (0, 0, 0), (0, 1, 0), q0=-0.5)
    m.joint(pre + "j4_sa", "revolute", pre + "coupler", pre + "sa", (0.35, 0, 0.05), (1, 0, 0), q0=0.2)
    m.joint(pre + "j5_sb", "revolute", pre + "sa", pre + "sb", (0, 0, 0), (0, 1, 0), q0=-0.3)
    m.joint(pre + "j6_sc", "revolute", pre + "sb", pre + "rocker", (0, 0, 0), (0, 0, 1), q0=0.6)
    e = unit((0.3, 0.9, 0.3))                        # pivot axis, skew to the crank axis z

    def pivot(pose):                                 # P = S-centre + 0.25 m perpendicular to e
        S = pose(pre + "rocker").translation
        r = np.array([0.1, 0.0, -1.0])
        return S + 0.25 * unit(r - (r @ e) * e)
    m.closure(pre + "pivot", "revolute", pre + "rocker", "base", pivot, axis=e)


def weld7(m, pre=""):
    """Branch A: R(z) R(y) P(x, tilted) R(skew) + a merged tool link; branch B: R(z) R(x) R(skew); the tool
    frame (rotated by rpy 0.1 0.2 0.3 and shifted) is welded to branch B's tip."""
    m.link(pre + "a1", 0.4, (0, 0, 0.2))
    m.link(pre + "a2", 0.3, (0.1, 0, 0))
    m.link(pre + "a3", 0.3, (0.3, 0, 0))
    m.link(pre + "a4", 0.2, (0.1, 0.05, 0))
    m.link(pre + "a_tool", 0.1, (0.02, 0, 0.01))
    m.link(pre + "b1", 0.4, (0, 0, 0.25))
    m.link(pre + "b2", 0.3, (0, 0.2, 0))
    m.link(pre + "b3", 0.3, (-0.2, 0, 0.1))
    m.joint(pre + "jA1", "revolute", "base", pre + "a1", (0, 0, 0.1), (0, 0, 1), q0=0.3, actuated=True)
    m.joint(pre + "jA2", "revolute", pre + "a1", pre + "a2", (0, 0, 0.2), (0, 1, 0), q0=-0.6)
    m.joint(pre + "jA3", "prismatic", pre + "a2", pre + "a3", (0.05, 0, 0), (1, 0, 0), rpy=(0, 0.3, 0), q0=0.12)
    m.joint(pre + "jA4", "revolute", pre + "a3", pre + "a4", (0.3, 0, 0), (0, 0.6, 0.8), q0=0.5)
    m.joint(pre + "jA5_tool", "fixed", pre + "a4", pre + "a_tool", (0.1, 0.05, 0), None, rpy=(0.2, -0.4, 0.7))
    m.joint(pre + "jB1", "revolute", "base", pre + "b1", (0.6, 0.1, 0), (0, 0, 1), q0=-0.4)
    m.joint(pre + "jB2", "revolute", pre + "b1", pre + "b2", (0, 0, 0.25), (1, 0, 0), q0=0.7)
    m.joint(pre + "jB3", "revolute", pre + "b2", pre + "b3", (0, 0.2, 0), (0.6, 0.0, 0.8), q0=-0.2)
    off = pin.SE3(rot((0.1, 0.2, 0.3)), np.array([0.02, 0.0, 0.01]))
    weld = lambda pose: pose(pre + "a_tool") * off  # noqa: E731
    m.closure(pre + "weld", "fixed", pre + "a_tool", pre + "b3", lambda pose: weld(pose).translation,
              RW=lambda pose: weld(pose).rotation)


def rusr_spherical(m):
    """Crank R (z); U (x, y) at its tip; coupler; rocker on a skew pivot (rpy 0.5 0.3 0, local z axis);
    the coupler end (0.3, 0, 0.05) meets the rocker by a spherical closure."""
    m.link("crank", 0.3, (0.12, 0, 0))
    m.link("ucross", 0.05)
    m.link("coupler", 0.5, (0.3, 0, 0.05))
    m.link("rocker", 0.4, (0.15, 0.1, 0))
    m.joint("j1_crank", "revolute", "base", "crank", (0, 0, 0), (0, 0, 1), q0=0.5, actuated=True)
    m.joint("j2_ua", "revolute", "crank", "ucross", (0.12, 0, 0), (1, 0, 0), q0=0.4)
    m.joint("j3_ub", "revolute", "ucross", "coupler", (0, 0, 0), (0, 1, 0), q0=-0.3)
    m.joint("j4_rocker", "revolute", "base", "rocker", (0.25, 0.15, 0.1), (0, 0, 1), rpy=(0.5, 0.3, 0), q0=0.8)
    tip = lambda pose: pose("coupler").act(np.array([0.3, 0.0, 0.05]))  # noqa: E731
    m.closure("ball", "spherical", "coupler", "rocker", tip)


def slider_crank(m):
    """Crank R (z); U at its tip; coupler; slider on a prismatic joint along a line tilted by rpy
    (0.2, 0.15, 0.1) (skew to the crank plane); the coupler end meets the slider by a spherical closure."""
    m.link("crank", 0.3, (0.1, 0, 0))
    m.link("ucross", 0.05)
    m.link("coupler", 0.4, (0.3, 0, 0))
    m.link("slider", 0.6, (0.0, 0.02, 0.03))
    m.joint("j1_crank", "revolute", "base", "crank", (0, 0, 0), (0, 0, 1), q0=0.7)
    m.joint("j2_ua", "revolute", "crank", "ucross", (0.1, 0, 0), (1, 0, 0), q0=1.3)
    m.joint("j3_ub", "revolute", "ucross", "coupler", (0, 0, 0), (0, 1, 0), q0=0.9)
    m.joint("j4_slider", "prismatic", "base", "slider", (0.2, 0.05, 0.08), (1, 0, 0), rpy=(0.2, 0.15, 0.1),
            q0=0.1, actuated=True)
    tip = lambda pose: pose("coupler").act(np.array([0.3, 0.0, 0.0]))  # noqa: E731
    m.closure("ball", "spherical", "coupler", "slider", tip)


def main():
    specs = {
        "rusr_revolute": ([rusr_revolute], 5, "Spatial RUSR four-bar closed by a revolute closure at the "
                          "rocker pivot (skew axis): 6 tree joints, rank 5 of 5 rows, mobility 1."),
        "weld7": ([weld7], 6, "Two spatial branches (R R P R + merged tool link, and R R R) welded by a fixed "
                  "closure, both closure frames rotated: 7 tree joints, rank 6 of 6 rows, mobility 1."),
        "rusr_spherical": ([rusr_spherical], 3, "Spatial RUSR four-bar closed by a spherical closure between "
                           "coupler end and rocker end: 4 tree joints, rank 3 of 3 rows, mobility 1."),
        "slider_crank": ([slider_crank], 3, "Spatial slider-crank: crank R, U, coupler, prismatic slider on a "
                         "skew line (actuated), spherical closure: 4 tree joints, rank 3 of 3, mobility 1."),
        "two_loops": ([lambda m: rusr_revolute(m, "a_"), lambda m: weld7(m, "b_")], 11,
                      "rusr_revolute (prefix a_) and weld7 (prefix b_) under one base, revolute closure "
                      "first, so the fixed closure's rows start at row 5: rank 11 of 11, mobility 2."),
    }
    manifest = {}
    for name, (builders, rank, header) in specs.items():
        m = Mech(name)
        for b in builders:
            b(m)
        names, q0 = m.write(header)
        manifest[name] = {"file": f"{name}.urdf", "joints": names, "q0": q0.tolist(), "rank": rank,
                          "actuated": m.actuated}
    (HERE / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")


if __name__ == "__main__":
    main()
