"""Robots with every joint kind of the registry, written twice from the same numbers: as URDF text (Drake's
``<drake:joint>`` for the screw and universal joints) for manipdyn's loader, and as a Pinocchio model built joint by
joint through Pinocchio's own joint models (``JointModelPlanar``, ``JointModelHelicalUnaligned``,
``JointModelUniversal``, ...), the reference the crosscheck tests hold every algorithm to."""
import numpy as np
import pinocchio as pin

from manipdyn.spatial import rpy_matrix

# (kind, parent index in the list; -1 = the root link "world"), in the depth-first order of both readers (fewer than
# ten joints: their names sort as their indices). The planar root carries a tree of every kind.
TREES = {
    "planar_root": [("planar", -1), ("screw", 0), ("universal", 1), ("revolute", 2), ("planar", 3),
                    ("prismatic", 0), ("spherical", 5), ("screw", 6)],
    "floating_root": [("floating", -1), ("universal", 0), ("screw", 1), ("revolute", 0), ("planar", 3),
                      ("universal", 4)],
    # without a planar joint: every kind here runs on the lane steps (batches, one state, the GPU)
    "screw_chain": [("screw", -1), ("revolute", 0), ("screw", 1), ("prismatic", 2), ("universal", 3), ("screw", 4)],
    "screw_floating": [("floating", -1), ("screw", 0), ("spherical", 1), ("screw", 2), ("universal", 0),
                       ("prismatic", 4)],
    # planar joints without a helical one: every algorithm's lane steps, the one-state CRBA and ABA drivers too
    "planar_chain": [("planar", -1), ("revolute", 0), ("spherical", 1), ("planar", 2), ("prismatic", 0),
                     ("universal", 4)],
}


def _unit(rng):
    a = rng.normal(size=3)
    return a / np.linalg.norm(a)


def _inertia(rng):
    """A full inertia tensor about the CoM obeying the triangle inequality: R diag(d) Rᵀ."""
    d = rng.uniform(0.01, 0.05, 3)
    d[2] = rng.uniform(abs(d[0] - d[1]) + 0.002, d[0] + d[1] - 0.002)
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q @ np.diag(d) @ Q.T


def kinds_robot(name, seed=0, gravity=(0.0, 0.0, -9.81), tree=None):
    """(urdf text, Pinocchio model) of TREES[name] (or of ``tree``, a list in TREES' form) with seeded random
    placements, axes, masses and inertias."""
    rng = np.random.default_rng(seed)
    pm = pin.Model()
    pm.gravity.linear = np.array(gravity, float)
    links, joints, ids = ['<link name="world"/>'], [], []
    for k, (kind, parent) in enumerate(TREES[name] if tree is None else tree):
        xyz, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-np.pi, np.pi, 3)
        mass, com, I = rng.uniform(0.5, 2.0), rng.uniform(-0.2, 0.2, 3), _inertia(rng)
        axis = _unit(rng)
        pitch = rng.uniform(-0.2, 0.2)                       # m/rad
        jm = {"planar": pin.JointModelPlanar(), "floating": pin.JointModelFreeFlyer(),
              "spherical": pin.JointModelSpherical(), "revolute": pin.JointModelRevoluteUnaligned(axis),
              "prismatic": pin.JointModelPrismaticUnaligned(axis),
              "screw": pin.JointModelHelicalUnaligned(axis, pitch),
              "universal": pin.JointModelUniversal(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]))}[kind]
        jid = pm.addJoint(0 if parent < 0 else ids[parent], jm, pin.SE3(rpy_matrix(rpy), xyz), f"j{k}")
        pm.appendBodyToJoint(jid, pin.Inertia(mass, com, I), pin.SE3.Identity())
        ids.append(jid)
        v = lambda x: " ".join(f"{c:.17g}" for c in x)     # noqa: E731
        links.append(f'<link name="l{k}"><inertial><origin xyz="{v(com)}"/><mass value="{mass:.17g}"/>'
                     f'<inertia ixx="{I[0, 0]:.17g}" iyy="{I[1, 1]:.17g}" izz="{I[2, 2]:.17g}" ixy="{I[0, 1]:.17g}" '
                     f'ixz="{I[0, 2]:.17g}" iyz="{I[1, 2]:.17g}"/></inertial></link>')
        tag = "drake:joint" if kind in ("screw", "universal") else "joint"
        body = [f'<parent link="{"world" if parent < 0 else f"l{parent}"}"/>', f'<child link="l{k}"/>',
                f'<origin xyz="{v(xyz)}" rpy="{v(rpy)}"/>']
        if kind in ("revolute", "prismatic", "screw"):
            body.append(f'<axis xyz="{v(axis)}"/>')
        if kind == "planar":
            body.append('<axis xyz="0 0 1"/>')
        if kind in ("revolute", "prismatic"):
            body.append('<limit effort="100" velocity="10" lower="-3" upper="3"/>')
        if kind == "screw":
            body.append(f'<drake:screw_thread_pitch value="{2 * np.pi * pitch:.17g}"/>')
        joints.append(f'<{tag} name="j{k}" type="{kind}">{"".join(body)}</{tag}>')
    text = (f'<robot name="{name}" xmlns:drake="http://drake.mit.edu">' + "".join(links) + "".join(joints)
            + "</robot>")
    return text, pm


def pin_names(pm):
    """Our joint names of a Pinocchio model's joints: a universal joint 'j' is ours 'j.1', 'j.2'."""
    out = []
    for n, j in zip(pm.names[1:], pm.joints[1:]):
        out += [f"{n}.1", f"{n}.2"] if j.shortname() == "JointModelUniversal" else [n]
    return tuple(out)
