"""A Model as MuJoCo MJCF text: the merged bodies, their joints, and the loop closures as equality constraints.

What is written (MuJoCo's XML reference, "MJCF"), so that MuJoCo's open-tree dynamics are ours:

- ``<compiler angle="radian" autolimits="true" inertiafromgeom="false" balanceinertia="false"/>``: MuJoCo keeps
  the inertias as given (no geoms are written; nothing to derive them from, and no triangle "balancing").
- One ``<body>`` per moving body of the Model (fixed links already merged), nested as ``parent``: ``pos`` and
  ``quat`` = the joint frame in the parent body at q = 0 (``p0``, ``R0``), so the body frame is the joint frame
  after its motion, as ours. ``<inertial pos mass fullinertia>``: the merged CoM and the inertia about the CoM
  in body axes (ixx iyy izz ixy ixz iyz); an inertia that is not positive definite (a zero moment, a massless
  body), which MuJoCo refuses as fullinertia, is written as principal axes ``quat`` + ``diaginertia``.
- ``<joint type="hinge"|"slide" axis>`` at the body origin, ``range`` only for a limited joint (not a
  continuous one); the model's nonzero ``armature``, ``damping`` and ``friction`` as ``armature``, ``damping``,
  ``frictionloss`` (MuJoCo applies frictionloss as a soft constraint: docs/design.md §3, Joint dynamics). A free-flyer
  root becomes ``<freejoint>`` (MuJoCo's q is [x y z qw qx qy qz], its v [linear (world); angular (body)]
  and its linear acceleration the origin's p̈, not ours: map states before comparing); a ball joint
  ``<joint type="ball">`` at the body origin (MuJoCo's q [qw qx qy qz], ours [qx qy qz qw]; v the same).
  Several joints of one MJCF body, which the MJCF reader makes a chain of massless bodies named
  ``"<body>:<joint>"`` (each the one child's parent, at R0 = 1), are written back as that one body with its joints
  at their anchors (``pos``), as read (MuJoCo refuses a massless moving body).
- ``<option gravity>``: the Model's gravity.
- Closures (``Model.constraints``) as ``<equality>`` elements between sites placed on the closure frames, so
  no assumption is made about q = 0 (MuJoCo computes a ``connect``'s or ``weld``'s relative pose at qpos0
  unless sites are given):
  ``spherical`` -> one ``connect`` (3 rows); ``revolute`` -> two ``connect``s, at the closure point and at a
  point ``REVOLUTE_ARM`` metres along the closure axis on each side (6 rows of rank 5: coincident point and
  aligned axis; MuJoCo has no hinge equality, and its soft constraints accept the redundant row);
  ``fixed`` -> ``weld`` of the two closure frames; ``coupling`` -> ``joint`` equality q_child = ratio ·
  q_parent (polycoef "0 ratio 0 0 0") when each side of the loop has one joint (refused otherwise: MuJoCo
  relates two joints only). A revolute closure's axes are taken as pointing the same way when assembled
  (axis_p = axis_c in the world); ``axis_sign`` flips a closure's child-side point when the file's axes
  are opposed at assembly.
- ``<mimic>`` joints of a MimicModel: ``joint`` equalities q = multiplier · q_target + offset.

Every name comes from the URDF (untrusted): the document is built with ``xml.etree`` (attributes escaped by
the serializer), never by formatting strings. Numbers are written with ``repr`` (shortest exact round trip).
MuJoCo itself is not imported here.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..errors import ModelError
from ..joints import BALL, FREEFLYER, KINDS, PRISMATIC
from ..model import MimicModel

__all__ = ["to_mjcf", "REVOLUTE_ARM", "EQ_SOLREF", "EQ_SOLIMP"]

REVOLUTE_ARM = 0.1       # m: the second connect of a revolute closure sits this far along the axis
EQ_SOLREF = (0.02, 1.0)  # MuJoCo's default time constant and damping ratio
EQ_SOLIMP = (0.9999, 0.9999, 0.001, 0.5, 2.0)  # the hardest impedance MuJoCo allows (mjMAXIMP = 0.9999)


def _num(x) -> str:
    return repr(float(x))


def _vec(x) -> str:
    return " ".join(_num(t) for t in np.ravel(x))


def _quat(R) -> np.ndarray:
    """Unit quaternion [w x y z] of a rotation matrix (Shepperd's method: the largest pivot)."""
    R = np.asarray(R, float)
    t = np.trace(R)
    k = int(np.argmax([t, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [0.25 * s, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        s = 2.0 * np.sqrt(1.0 + R[0, 0] - R[1, 1] - R[2, 2])
        q = [(R[2, 1] - R[1, 2]) / s, 0.25 * s, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        s = 2.0 * np.sqrt(1.0 + R[1, 1] - R[0, 0] - R[2, 2])
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, 0.25 * s, (R[1, 2] + R[2, 1]) / s]
    else:
        s = 2.0 * np.sqrt(1.0 + R[2, 2] - R[0, 0] - R[1, 1])
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, 0.25 * s]
    q = np.array(q)
    return q / np.linalg.norm(q)


def _hosts(model):
    """(host, off): the joint host[i] whose MJCF body holds body i's joint, and body i's origin off[i] in that body's
    frame. A chain the MJCF reader made of several joints of one body (each but the last a massless body named
    ``"<body>:<joint>"``, its one child at R0 = 1) is written back as that one body with several joints; every other
    body is its own host (off 0)."""
    nb = model.njoints
    children = np.bincount(model.parent[model.parent >= 0], minlength=nb)
    host, off = list(range(nb)), [np.zeros(3) for _ in range(nb)]
    names, joints = model.body_names, model.joint_names
    for i in range(nb):
        a = model.parent[i]
        stem = names[a][:-len(joints[a]) - 1] if a >= 0 and names[a].endswith(f":{joints[a]}") else None
        chained = (stem and names[i] in (stem, f"{stem}:{joints[i]}") and children[a] == 1 and model.mass[a] == 0
                   and not np.any(model.inertia[a]) and np.array_equal(model.R0[i], np.eye(3)))
        if chained and FREEFLYER not in (model.kind[a], model.kind[i]):
            host[i], off[i] = host[a], off[a] + model.p0[i]
    return host, off


def _body(parent_el, model, i, pos) -> ET.Element:
    """Body i: frame (its joint frame at pos in parent_el's body frame), inertial, joint."""
    b = ET.SubElement(parent_el, "body", name=model.body_names[i], pos=_vec(pos), quat=_vec(_quat(model.R0[i])))
    _contents(b, model, i, np.zeros(3))
    return b


def _contents(b, model, i, off):
    """Body i's inertial and joint in the MJCF body b, in whose frame body i's origin is off (a later joint of b)."""
    if b.find("inertial") is not None:               # a later joint: b is named after its last body, holds its mass
        b.set("name", model.body_names[i])
        for el in b.findall("inertial"):
            b.remove(el)
    I = model.inertia[i]
    el = ET.SubElement(b, "inertial", pos=_vec(off + model.com[i]), mass=_num(model.mass[i]))
    moments, axes = np.linalg.eigh(I)
    if moments[0] > 0:                               # MuJoCo diagonalises fullinertia itself
        el.set("fullinertia", _vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
    else:                                            # fullinertia must be positive definite: principal axes
        if np.linalg.det(axes) < 0:                  # (a zero moment, a massless body) given as quat + diag
            axes[:, 0] = -axes[:, 0]
        el.set("quat", _vec(_quat(axes)))
        el.set("diaginertia", _vec(np.maximum(moments, 0.0)))
    dyn = _joint_dynamics(model, i)
    at = {"pos": _vec(off)} if off.any() else {}
    if model.kind[i] == FREEFLYER:
        if dyn:                                      # <freejoint> takes none: a free <joint> does, one per joint
            ET.SubElement(b, "joint", name=model.joint_names[i], type="free", **dyn)
        else:
            ET.SubElement(b, "freejoint", name=model.joint_names[i])
        return
    if model.kind[i] == BALL:
        ET.SubElement(b, "joint", name=model.joint_names[i], type="ball", **at, **dyn)
        return
    j = ET.SubElement(b, "joint", name=model.joint_names[i],
                      type="slide" if model.kind[i] == PRISMATIC else "hinge", **at, axis=_vec(model.axis[i]), **dyn)
    lo, hi = model.lower[i], model.upper[i]
    if not model.continuous[i] and np.isfinite(lo) and np.isfinite(hi):
        j.set("range", _vec([lo, hi]))


def _joint_dynamics(model, i) -> dict:
    """Joint i's nonzero armature, damping, friction as MuJoCo's ``armature``, ``damping``, ``frictionloss`` (one
    number per joint: a free flyer's six, a ball joint's three entries must be equal; ModelError otherwise)."""
    out = {}
    for key, attr in (("armature", "armature"), ("damping", "damping"), ("friction", "frictionloss")):
        x = getattr(model, key)[model.idx_v[i]:model.idx_v[i] + model.nvs[i]]
        if np.any(x != x[0]):
            raise ModelError(f"model {model.name!r}: joint {model.joint_names[i]!r}: {key} {x.tolist()} differs "
                             f"between its velocities; MJCF gives a joint one {attr}")
        if x[0] != 0.0:
            out[attr] = _num(x[0])
    return out


def _site(bodies, worldbody, body, name, pos, R=None, off=None):
    """A site at (pos, R) in body's frame (-1: the world); off[body]: that frame's origin in its MJCF body's."""
    el = ET.SubElement(worldbody if body < 0 else bodies[body], "site", name=name,
                       pos=_vec(pos if body < 0 else off[body] + pos))
    if R is not None:
        el.set("quat", _vec(_quat(R)))


def _one_joint(model, path, c, side):
    """The single joint on one side of a coupling's loop (None if that side has none)."""
    if len(path) > 1:
        raise ModelError(f"model {model.name!r}: coupling {c.name!r}: the {side} side of the loop has "
                         f"{len(path)} joints ({', '.join(model.joint_names[b] for b in path)}); a MuJoCo joint "
                         "equality relates one joint to one other")
    return model.joint_names[path[0]] if path else None


def _coupling(eq, model, c, attrs):
    """ratio · q(parent side) − q(child side) = 0 as joint1 = q(child side), joint2 = q(parent side)."""
    anc_p, anc_c, pp, pc = c.parent, c.child, [], []
    while anc_p != anc_c:                            # the tree paths below the common ancestor (parent[i] < i)
        if anc_p > anc_c:
            pp.append(anc_p)
            anc_p = model.parent[anc_p]
        else:
            pc.append(anc_c)
            anc_c = model.parent[anc_c]
    jp, jc = _one_joint(model, pp, c, "parent"), _one_joint(model, pc, c, "child")
    if jc is None and jp is None:
        raise ModelError(f"model {model.name!r}: coupling {c.name!r} relates no joint")
    if jc is None:                                   # ratio · q_p = 0
        jc, jp, poly = jp, None, "0 0 0 0 0"
    else:
        poly = f"0 {_num(c.ratio)} 0 0 0" if jp is not None else "0 0 0 0 0"
    el = ET.SubElement(eq, "joint", name=c.name, joint1=jc, polycoef=poly, **attrs)
    if jp is not None and poly != "0 0 0 0 0":
        el.set("joint2", jp)


def to_mjcf(model, *, axis_sign=None, solref=EQ_SOLREF, solimp=EQ_SOLIMP, revolute_arm=REVOLUTE_ARM) -> str:
    """The Model as MJCF text (see the module docstring for what maps to what).

    Parameters: model, a Model or MimicModel (its mimic joints become joint equalities); axis_sign, {closure
    name: ±1} for revolute closures whose axes point opposite ways when assembled (default +1); solref
    (2,), solimp (5,), the equality constraints' softness (default: MuJoCo's hardest impedance);
    revolute_arm, m, the spacing of a revolute closure's two connects.
    Returns the XML document as a str. Raises ModelError for a closure MuJoCo cannot express.
    """
    mimic = ()
    if isinstance(model, MimicModel):
        model, mimic = model.full, model.mimic
    bare = [(n, KINDS[int(k)].name) for n, k in zip(model.joint_names, model.kind) if not KINDS[int(k)].mjcf]
    if bare:
        raise ModelError(f"model {model.name!r}: joint {bare[0][0]!r} is a {bare[0][1]} joint, which MJCF has no type "
                         f"for (MJCF joints: free, ball, slide, hinge)")
    root = ET.Element("mujoco", model=model.name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true", inertiafromgeom="false",
                  balanceinertia="false")
    ET.SubElement(root, "option", gravity=_vec(model.gravity))
    world = ET.SubElement(root, "worldbody")
    bodies, (host, off) = [], _hosts(model)
    for i in range(model.njoints):                   # parent[i] < i: every parent is written before its child
        a = model.parent[i]
        if host[i] != i:                             # a later joint of its parent's MJCF body
            bodies.append(bodies[a])
            _contents(bodies[a], model, i, off[i])
        else:
            bodies.append(_body(world if a < 0 else bodies[a], model, i, model.p0[i] + (off[a] if a >= 0 else 0)))
    attrs = dict(solref=_vec(solref), solimp=_vec(solimp))
    eq = ET.Element("equality")
    sign = dict(axis_sign or {})
    for k, c in enumerate(model.constraints):
        tag = f"{c.name}#{k}"                        # site names: unique whatever the closure names are
        if c.type in ("spherical", "revolute"):
            _site(bodies, world, c.parent, f"{tag}:parent", c.pp, off=off)
            _site(bodies, world, c.child, f"{tag}:child", c.pc, off=off)
            ET.SubElement(eq, "connect", name=c.name, site1=f"{tag}:parent", site2=f"{tag}:child", **attrs)
        if c.type == "revolute":
            s = float(sign.get(c.name, 1.0))
            _site(bodies, world, c.parent, f"{tag}:parent_axis", c.pp + revolute_arm * c.axis_p, off=off)
            _site(bodies, world, c.child, f"{tag}:child_axis", c.pc + s * revolute_arm * c.axis_c, off=off)
            ET.SubElement(eq, "connect", name=f"{c.name}:axis", site1=f"{tag}:parent_axis",
                          site2=f"{tag}:child_axis", **attrs)
        elif c.type == "fixed":
            _site(bodies, world, c.parent, f"{tag}:parent", c.pp, c.Rp, off=off)
            _site(bodies, world, c.child, f"{tag}:child", c.pc, c.Rc, off=off)
            ET.SubElement(eq, "weld", name=c.name, site1=f"{tag}:parent", site2=f"{tag}:child", **attrs)
        elif c.type == "coupling":
            _coupling(eq, model, c, attrs)
    for j, target, mult, off in mimic:
        ET.SubElement(eq, "joint", name=f"mimic:{j}", joint1=j, joint2=target,
                      polycoef=f"{_num(off)} {_num(mult)} 0 0 0", **attrs)
    if len(eq):
        root.append(eq)
    ET.indent(root)
    return ET.tostring(root, encoding="unicode") + "\n"
