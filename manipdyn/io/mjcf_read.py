"""MJCF (MuJoCo's XML) -> Model: the reader (``io/mjcf.py`` is the writer). Open kinematic trees and their closures.

What is read (MuJoCo's XML reference, "MJCF"; each number in the URDF reader's grammar, ``safe_xml.NUMBER``):

- ``<compiler angle="degree|radian" eulerseq inertiafromgeom="true|false|auto" autolimits inertiagrouprange>``
  (every ``<compiler>`` element, in file order); ``<option gravity>`` and ``<flag gravity="disable">`` (unless
  ``gravity=`` is given).
- ``<default>`` classes, nested; an element's attributes come from itself, else its ``class=``, else the nearest
  enclosing body's ``childclass=``, else the top-level class "main" — each class holding its ancestors' values
  (joint, geom and site attributes; others are not read).
- A free joint's body pose in the file is MuJoCo's ``qpos0`` only: the model's free flyer sits at the world origin
  (R0 = 1, p0 = 0) and q holds the body's pose, so ``neutral(model)`` is the identity pose, not the file's.
- The ``<worldbody>`` tree (several ``<worldbody>`` elements are appended, as MuJoCo does), walked iteratively
  in file order, depth-first: MuJoCo's and Pinocchio's ``buildModelFromMJCF`` joint order, which is q order.
  A body frame is ``pos`` + at most one of ``quat`` (w x y z, normalised), ``euler`` (``eulerseq``: lower case
  axes move with the frame, upper case stay fixed), ``axisangle``, ``xyaxes``, ``zaxis``; the same for
  ``<inertial>``, ``<geom>`` and ``<site>`` (geoms and sites also ``fromto``: the z axis from → to).
- Joints: ``hinge`` -> REVOLUTE, ``slide`` -> PRISMATIC about ``axis`` through ``pos`` (body frame; the
  model's body frame is then the joint frame, and the MJCF body's frame a Frame offset by −pos in it);
  ``ball`` -> BALL, turning the body about ``pos`` (its ``axis``, ``ref`` and ``range`` are not read, as by
  MuJoCo's dynamics: a ball's range is a cone limit of the contact solver; q = MuJoCo's qpos reordered to
  x y z w); ``free`` / ``<freejoint>`` -> a free flyer (alone in a child of ``<worldbody>``, as MuJoCo requires;
  the model is ``floating`` when it is joint 0, and further free bodies — objects beside a robot — are free flyers
  hanging from the base too). Several joints in one body are applied in order, as MuJoCo's ``mj_kinematics``:
  each but the last carries a massless body at its anchor (named ``"<body>:<joint>"``). A body without a
  joint is welded to its parent (merged, as URDF fixed links; ``Model.merged`` names them). A hinge's
  ``range`` is converted from degrees when ``angle="degree"``; a hinge without limits is ``continuous``. A
  joint's ``ref`` (MuJoCo's qpos0: the body moves by qpos − ref) is folded into the joint's placement, so q is
  MuJoCo's qpos (a "joint_ref" quirk says so).
- ``<compiler settotalmass>`` scales every body's mass and inertia, as MuJoCo does.
- Mass: ``<inertial mass pos diaginertia|fullinertia>`` (+ orientation), or the geoms when ``inertiafromgeom``
  says so (``true``: always, ignoring ``<inertial>``; ``auto``, the default: when the body has no
  ``<inertial>``): sphere, capsule, cylinder, box, ellipsoid, solid, density 1000 kg/m³ unless the geom's
  (or its class's) ``density``, a geom's ``mass`` overriding it; only geoms of groups within
  ``inertiagrouprange``. The formulas are MuJoCo's (checked against ``model.body_mass``, ``body_inertia``).
- ``<frame pos orientation childclass>`` (nested too): its bodies, joints, inertial, geoms and sites are placed
  through it, as MuJoCo does (a frame is not a body: nothing of it remains in the model).
- Sites, and every named body, become frames of the model (``Model.frames``; ``frame_placement`` of a body's
  name is MuJoCo's ``xpos``/``xmat``). Unnamed bodies, joints and sites are named ``body<id>``, ``joint<id>``,
  ``site<id>`` with MuJoCo's ids. The world is the fixed base, named "world". Bodies, joints and sites have name
  spaces of their own, as in MuJoCo: a site that shares a body's name is the frame ``site:<name>`` (``SITE_PREFIX``),
  the body's frame keeps the plain name.
- ``<equality>`` -> the model's closures (``Model.constraints``, model.Constraint, as the URDF reader's), in file
  order, as MuJoCo's compiler and ``mj_equalityAnchors`` read them:
  ``connect`` with ``body1`` and ``anchor`` (body semantic: the anchor in body1's frame; body2, default the world,
  holds the point that coincides with it at MuJoCo's qpos0 — the joints at their ``ref``, a free body at its pose in
  the file) or ``site1``/``site2`` (the sites' origins) -> "spherical"; two connects between the same two bodies,
  and no other, whose anchors are as far apart on each -> one "revolute" closure, its axis through them (the same
  constraint; what ``to_mjcf`` writes for a revolute closure). ``weld`` with ``body1`` (``anchor`` on body2, default
  0; ``relpose`` (x y z qw qx qy qz) body2's frame in body1's, the anchor's point on body1 at its position part; a
  zero quaternion, the default, takes both from qpos0) or ``site1``/``site2`` (the sites' frames) -> "fixed";
  ``torquescale="0"`` (no orientation rows) -> "spherical". ``joint``: ``joint1 = c0 + c1 joint2`` (``polycoef``;
  MuJoCo's positions are relative to qpos0, i.e. ``ref``) -> "coupling" with ratio c1, when the two joints hang
  from the same body (each alone on its side of their common ancestor: the closure model's coupling row); without
  ``joint2`` (or c1 = 0), joint1 = 0. ``tendon`` on one fixed tendon L = a q_a + b q_b (``<tendon><fixed>``, the
  four-bar grippers' finger couplings): L − L₀ = c0 is q_a − q_a₀ = c0/a − (b/a)(q_b − q_b₀), the joint equality's
  coupling with ratio −b/a (a tendon of one joint: q_a − q_a₀ = c0/a). ``class`` defaults (``<default><equality>``) give active, solref, solimp.
- ``<include file>``: the included file's children replace the element (its root is ``<mujoco>``, or
  ``<mujocoinclude>`` as in files written for MuJoCo before 2.1); paths are relative to the main file's folder and
  must resolve (symlinks too) inside it; depth and count are bounded, their bytes count towards ``max_bytes``.

Read and applied: a joint's ``armature``, ``damping``, ``frictionloss`` (≥ 0) become the model's ``armature``,
``damping`` and ``friction`` of each of its velocities (docs/design.md §3, Joint dynamics: M + diag(armature) as
MuJoCo; damping and friction as joint torques in forward dynamics and simulation, friction regularised by tanh where
MuJoCo's frictionloss is a soft constraint of its solver). A ``joint_dynamics=`` keyword sets or overrides them.
Read with a quirk (quirks.QUIRK_KINDS): a joint's nonzero ``stiffness``, ``springref``, ``springdamper``
("joint_dynamics": not applied yet); a body's
``gravcomp``, a tendon's ``stiffness``/``damping`` and ``<option density viscosity wind>`` (fluid forces)
("passive_force": MuJoCo's mj_rne leaves them out too);
top-level elements not known, and attributes outside MuJoCo's schema on the elements read (``_ATTRS``: body, frame,
inertial, joint, freejoint, geom, site, compiler, option, connect, weld, an equality's joint) ("unknown_element"; an
error with strict=True); an equality's ``solref``/``solimp`` and a weld's ``torquescale`` other than 1
("equality_softness": MuJoCo's softness and row scale, not a model parameter; the closure is rigid); an equality with
``active="false"`` ("inactive_equality": skipped).

Ignored (no effect on M or on the inverse dynamics τ of mj_rne): ``<asset>``, ``<contact>``, ``<actuator>``,
``<sensor>``, ``<visual>``, ``<statistic>``, ``<size>``, ``<keyframe>``, ``<custom>``, ``<extension>``, cameras
and lights, a geom's contact and visual attributes, geoms that do not give mass, fixed tendons without armature.

Refused (MJCFError naming the file, the element and what is not supported): a free joint below a body or beside
another joint, a free joint's ``align`` (or ``<compiler alignfree>``), ``flex`` equalities (and any other but connect, weld,
joint, tendon), a tendon equality between two tendons or on a spatial tendon or a fixed one of more than two joints,
a joint equality with
quadratic or higher ``polycoef`` terms, with an offset (c0 + ref1 − c1 ref2 ≠ 0: the coupling row has none), between
joints that do not hang from the same body, or on a free or ball joint, an equality whose two sides are one rigid body,
tendons with ``armature``, ``mesh``, ``hfield``,
``plane`` and ``sdf`` geoms that would give mass, ``shellinertia``, ``fromto`` on boxes and ellipsoids,
``<composite>``, ``<flexcomp>``, ``<replicate>``, ``<attach>``, ``<plugin>`` in a body,
``<compiler>`` options that change masses (``boundmass``, ``boundinertia``,
``balanceinertia="true"``) or frames (``coordinate="global"``); several orientations on one element.

Hostile input, as the URDF reader (docs/design.md §9): DTDs and entities refused, no network, a size limit over
the file and its includes, one number grammar, exact vector lengths, finite values within the URDF reader's
bounds, counts bounded (``MAX_BODIES``, ``MAX_INCLUDES``, ``MAX_INCLUDE_DEPTH``), an iterative tree walk.

Conventions converted here, never in the kernels (docs/design.md §3, §4e): MuJoCo's quaternions are
(w, x, y, z), the model's free flyer q is [x y z qx qy qz qw] and a ball joint's [qx qy qz qw]; MuJoCo's free-joint
``qvel`` is [linear in the world frame; angular in the body frame], the model's v is [linear; angular] both in the body frame; angles
default to degrees in MJCF.
"""
from __future__ import annotations

import dataclasses
import math
import os

import numpy as np

from ..errors import MJCFError, QuirkWarning
from ..joints import BALL, FREEFLYER, NV, PRISMATIC, REVOLUTE
from ..model import Constraint, Frame, Model, check_gravity, with_joint_dynamics
from ..quirks import QUIRK_KINDS, Quirk
from ..spatial import combine_inertias
from .safe_xml import LIST, MAX_BYTES, MAX_INERTIA, MAX_LENGTH, MAX_MASS, NUMBER, SPACE, parse_xml, show
from .urdf import _check_psd, _triangle

__all__ = ["load_mjcf", "load_mjcf_string", "MAX_BODIES", "MAX_INCLUDES", "MAX_INCLUDE_DEPTH"]

MAX_BODIES = 100_000       # bodies + joints + geoms + sites of one file
MAX_INCLUDES = 256         # <include> elements, all files together
MAX_INCLUDE_DEPTH = 8      # an included file including another ... this deep at most
SITE_PREFIX = "site:"        # the frame name of a site that shares a body's name
INCLUDE_ROOTS = ("mujoco", "mujocoinclude")   # an included file's root: <mujocoinclude> in files for MuJoCo < 2.1
MAX_DENSITY = 1e6          # kg/m³ (osmium: 2.26e4)
DEFAULT_DENSITY = 1000.0   # MuJoCo's geom density

_ORIENT = ("quat", "euler", "axisangle", "xyaxes", "zaxis")
_BODY_CHILDREN = {"inertial", "joint", "freejoint", "geom", "site", "body", "camera", "light"}
_REFUSED_BODY_CHILDREN = {"composite", "flexcomp", "replicate", "attach", "plugin"}
_TOP = {"compiler", "option", "size", "visual", "statistic", "default", "extension", "custom", "asset",
        "worldbody", "contact", "equality", "deformable", "tendon", "actuator", "sensor", "keyframe"}
_MASS_GEOMS = ("sphere", "capsule", "cylinder", "box", "ellipsoid")
_EQUALITIES = ("connect", "weld", "joint", "tendon")
_APPLIED = ("armature", "damping", "frictionloss")    # → Model.armature, damping, friction (each dof of the joint)
_DYNAMICS = ("stiffness", "springref")                # read, quirked, not applied

# The attributes of MuJoCo 3-4's schema on the elements the reader interprets (MJCF XML reference); any other is
# reported as an "unknown_element" quirk (MuJoCo refuses the file; an error with strict=True).
_O = ("pos", "quat", "axisangle", "xyaxes", "zaxis", "euler")
_ATTRS = {
    "body": {"name", "childclass", "mocap", "gravcomp", "user", "sleep", *_O},
    "frame": {"name", "childclass", *_O},
    "inertial": {"mass", "diaginertia", "fullinertia", *_O},
    "joint": {"name", "class", "type", "group", "pos", "axis", "springdamper", "limited", "actuatorfrclimited",
              "solreflimit", "solimplimit", "solreffriction", "solimpfriction", "stiffness", "range",
              "actuatorfrcrange", "actuatorgravcomp", "margin", "ref", "springref", "armature", "damping",
              "frictionloss", "user"},
    "freejoint": {"name", "group", "align"},
    "geom": {"name", "class", "type", "contype", "conaffinity", "condim", "group", "priority", "size", "material",
             "rgba", "friction", "mass", "density", "shellinertia", "solmix", "solref", "solimp", "margin", "gap",
             "fromto", "hfield", "mesh", "fitscale", "fluidshape", "fluidcoef", "user", *_O},
    "site": {"name", "class", "type", "group", "material", "size", "fromto", "rgba", "user", *_O},
    "connect": {"name", "class", "active", "solref", "solimp", "body1", "body2", "anchor", "site1", "site2"},
    "weld": {"name", "class", "active", "solref", "solimp", "body1", "body2", "anchor", "relpose", "site1", "site2",
             "torquescale"},
    "joint_eq": {"name", "class", "active", "solref", "solimp", "joint1", "joint2", "polycoef"},
    "tendon_eq": {"name", "class", "active", "solref", "solimp", "tendon1", "tendon2", "polycoef"},
    "compiler": {"autolimits", "boundmass", "boundinertia", "settotalmass", "balanceinertia", "strippath",
                 "coordinate", "angle", "fitaabb", "eulerseq", "meshdir", "texturedir", "assetdir", "discardvisual",
                 "usethread", "fusestatic", "inertiafromgeom", "inertiagrouprange", "saveinertial", "alignfree",
                 "exactmeshinertia", "maxhullvert"},
    "option": {"timestep", "apirate", "impratio", "tolerance", "ls_tolerance", "noslip_tolerance", "ccd_tolerance",
               "sleep_tolerance", "gravity", "wind", "magnetic", "density", "viscosity", "o_margin", "o_solref",
               "o_solimp", "o_friction", "integrator", "cone", "jacobian", "solver", "iterations", "ls_iterations",
               "noslip_iterations", "ccd_iterations", "sdf_iterations", "sdf_initpoints", "actuatorgroupdisable"},
}


def load_mjcf(path, *, gravity=None, strict: bool = False, locked=None, root=None, tips=None, prune=False,
              max_bytes: int = MAX_BYTES, zero_mass_inertia: str = "keep", non_psd_inertia: str = "refuse",
              joint_dynamics=None, asset_root=None):
    """Read an MJCF file into a Model (see the module docstring for what is read, refused and converted).

    Parameters as ``load_urdf`` where they apply: gravity (3,) in the world frame (None: the file's ``<option
    gravity>``, MuJoCo's default [0, 0, −9.81]); strict=True refuses unknown top-level elements and inertias that
    violate the triangle inequality; locked / root / tips / prune as in ``manipdyn.reduce``; max_bytes bounds the
    file and its includes together; zero_mass_inertia "keep" | "drop", non_psd_inertia "refuse" | "keep" as in
    load_urdf; joint_dynamics ``{joint: dict(armature=, damping=, friction=)}`` overrides the file's armature, damping
    and frictionloss of those joints (``model.with_joint_dynamics``). A free joint in the file makes a free flyer
    (no ``root_joint`` keyword: the file says). asset_root: a folder (holding the model's) whose tree the
    ``<include>`` files may come from, as suites that share assets across folders need (``../common/…``); by
    default only the model's own folder. Paths stay relative to the model's folder; absolute paths, and paths or
    symlinks that leave the granted tree, are refused as before.
    Raises MJCFError naming the file and element at fault, ModelError for a non-physical body.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise MJCFError(f"{path}: no such MJCF file")
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)
    model = load_mjcf_string(data, source=path, gravity=gravity, strict=strict, max_bytes=max_bytes,
                             zero_mass_inertia=zero_mass_inertia, non_psd_inertia=non_psd_inertia,
                             base_dir=os.path.dirname(os.path.abspath(path)), joint_dynamics=joint_dynamics,
                             asset_root=asset_root)
    if locked or root or tips or prune:
        from ..reduce import reduce
        model = reduce(model, locked=locked, root=root, tips=tips, prune=prune)
    return model


def load_mjcf_string(text, *, source="<string>", gravity=None, strict=False, max_bytes: int = MAX_BYTES,
                     zero_mass_inertia: str = "keep", non_psd_inertia: str = "refuse", base_dir=None,
                     joint_dynamics=None, asset_root=None):
    """Same as load_mjcf for MJCF text (str or bytes); ``source`` names it in messages; ``<include>`` files are
    read from ``base_dir`` (None: includes are refused), inside ``asset_root``'s tree (default: base_dir's)."""
    from .urdf import _check_policy
    _check_policy(zero_mass_inertia, non_psd_inertia, False, source)
    data = text.encode() if isinstance(text, str) else bytes(text)
    if len(data) > max_bytes:
        raise MJCFError(f"{source}: larger than the size limit of {max_bytes} bytes (pass max_bytes=... to raise it)")
    quirks = []
    xml = parse_xml(data, source, quirks, root_tag="mujoco", error=MJCFError)
    tree = _granted(asset_root, base_dir, source)
    _expand_includes(xml, source, base_dir, max_bytes - len(data), tree)
    reader = _Reader(xml, source, strict, zero_mass_inertia, quirks)
    g = reader.gravity() if gravity is None else check_gravity(gravity, source)
    model = with_joint_dynamics(reader.build(g, non_psd_inertia), joint_dynamics, source)
    _warn(model, source)
    return model


def _warn(model, source):
    import warnings
    for kind in QUIRK_KINDS:
        these = [q for q in model.quirks if q.kind == kind]
        if these:
            warnings.warn(f"{source}: {kind} ({len(these)}): " + "; ".join(f"{q.name!r}: {q.detail}"
                                                                           for q in these[:50]),
                          QuirkWarning, stacklevel=3)


# ---- includes -------------------------------------------------------------------------------------------------

def _granted(asset_root, base_dir, source):
    """The real path of the folder tree includes may come from: base_dir's, or ``asset_root`` (an existing folder
    that holds base_dir); None without a base_dir."""
    if asset_root is None:
        return None if base_dir is None else os.path.realpath(base_dir)
    try:
        tree = os.path.realpath(os.fspath(asset_root))
    except TypeError:
        raise MJCFError(f"{source}: asset_root must be a folder path, not {type(asset_root).__name__}") from None
    if not os.path.isdir(tree):
        raise MJCFError(f"{source}: asset_root {show(str(asset_root))}: no such folder")
    if base_dir is None:
        raise MJCFError(f"{source}: asset_root needs the model's folder (load_mjcf of a file, or base_dir= for text)")
    base = os.path.realpath(base_dir)
    if os.path.commonpath([base, tree]) != tree:
        raise MJCFError(f"{source}: asset_root {show(str(asset_root))} does not hold the model's folder {base!r}")
    return tree


def _confined(name, base_dir, source, tree=None):
    """The real path of an <include file=...> (relative to base_dir) inside the granted folder tree (``_granted``:
    base_dir's by default); MJCFError for absolute paths and escapes."""
    if base_dir is None:
        raise MJCFError(f"{source}: <include file={show(name or '')}>: includes need a folder (load_mjcf of a file, "
                        f"or base_dir= for text)")
    if not name or "\x00" in name or os.path.isabs(name) or name.startswith(("/", "\\")) or ":" in name:
        raise MJCFError(f"{source}: <include file={show(name or '')}>: an absolute, URL or empty path is refused "
                        f"(includes are relative to the model's folder)")
    base = os.path.realpath(base_dir)
    tree = base if tree is None else tree
    real = os.path.realpath(os.path.join(base, name))
    if os.path.commonpath([real, tree]) != tree or real == tree:
        where = f"the model's folder {base!r}" if tree == base else f"the granted folder {tree!r} (asset_root)"
        hint = "; load_mjcf(..., asset_root=FOLDER) (CLI: --asset-root) grants a wider tree" if tree == base else ""
        raise MJCFError(f"{source}: <include file={show(name)}>: resolves outside {where}{hint}")
    if not os.path.isfile(real):
        raise MJCFError(f"{source}: <include file={show(name)}>: no such file in the model's folder")
    return real


def _expand_includes(xml, source, base_dir, budget, tree=None):
    """Every <include file> replaced by the children of the included file's <mujoco> or <mujocoinclude> root
    (iteratively); bounded depth,
    count and bytes (``budget``: what is left of max_bytes)."""
    pending = [(e, 1) for e in xml.iter("include")]
    count = 0
    while pending:
        inc, depth = pending.pop()
        count += 1
        if count > MAX_INCLUDES:
            raise MJCFError(f"{source}: more than {MAX_INCLUDES} <include> elements")
        if depth > MAX_INCLUDE_DEPTH:
            raise MJCFError(f"{source}: <include file={show(inc.get('file') or '')}>: includes nested deeper "
                            f"than {MAX_INCLUDE_DEPTH}")
        path = _confined(inc.get("file"), base_dir, source, tree)
        with open(path, "rb") as fh:
            data = fh.read(max(budget, 0) + 1)
        budget -= len(data)
        if budget < 0:
            raise MJCFError(f"{source}: with <include file={show(inc.get('file'))}> the model exceeds the size "
                            f"limit (pass max_bytes=... to raise it)")
        sub = parse_xml(data, f"{source}: include {inc.get('file')!r}", None, root_tag=None, error=MJCFError)
        if sub.tag not in INCLUDE_ROOTS:
            raise MJCFError(f"{source}: include {inc.get('file')!r}: root element is <{str(sub.tag)[:40]}>, expected "
                            f"<mujoco> (or <mujocoinclude>, older MuJoCo's root of an included file)")
        parent, at = inc.getparent(), inc.getparent().index(inc)
        parent.remove(inc)
        children = [c for c in sub if isinstance(c.tag, str)]
        for k, c in enumerate(children):
            parent.insert(at + k, c)
        pending += [(e, depth + 1) for c in children for e in c.iter("include")]


# ---- numbers and orientations ---------------------------------------------------------------------------------

def _quat_R(q):
    """Rotation matrix of a quaternion (w, x, y, z), normalised."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _axis_R(axis, angle):
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def _z_to(v):
    """MuJoCo's mju_quatZ2Vec: the smallest rotation taking (0, 0, 1) to v (a half turn about x if opposite)."""
    v = np.asarray(v, float) / np.linalg.norm(v)
    a = np.cross([0.0, 0.0, 1.0], v)
    s = np.linalg.norm(a)
    if s < 1e-15:
        return np.diag([1.0, -1.0, -1.0]) if v[2] < 0 else np.eye(3)
    return _axis_R(a / s, math.atan2(s, v[2]))


class _Reader:
    """One MJCF document (includes expanded) read into a Model."""

    def __init__(self, xml, source, strict, zero_mass_inertia, quirks):
        self.xml, self.source, self.strict, self.zmi, self.quirks = xml, source, strict, zero_mass_inertia, quirks
        self.count = 0
        for e in xml:
            if isinstance(e.tag, str) and e.tag not in _TOP:
                if strict:
                    raise MJCFError(f"{source}: <{e.tag}> under <mujoco> is not an MJCF element manipdyn reads "
                                    f"(strict=True)")
                quirks.append(Quirk("unknown_element", f"<{e.tag}>", f"<{e.tag}> under <mujoco>: not read"))
        for e in xml:
            if isinstance(e.tag, str) and e.tag in ("compiler", "option"):
                self.known(e, f"<{e.tag}>")
        self.compiler()
        self.defaults()
        self.refuse_top()
        self.fluid()

    def known(self, e, where, tag=None):
        """Attributes of e outside MuJoCo's schema: an "unknown_element" quirk each (an error with strict=True);
        tag: the schema's key when it is not e.tag (an equality's <joint>)."""
        tag = tag or e.tag
        if tag not in _ATTRS:                                   # cameras, lights: not read at all
            return
        for key in e.keys():
            if key not in _ATTRS[tag]:
                detail = f"{where}: <{e.tag} {key}={show(e.get(key))}>: not an MJCF attribute manipdyn knows; not read"
                if self.strict:
                    raise MJCFError(f"{self.source}: {detail} (strict=True)")
                self.quirks.append(Quirk("unknown_element", f"<{e.tag} {key}>", detail))

    # -- numbers ---------------------------------------------------------------------------------------------
    def nums(self, e, key, counts, where, text=None):
        """The numbers of attribute ``key`` (text: the value from a default class), their count in ``counts``."""
        text = e.get(key) if text is None else text
        if text is None:
            return None
        at = f"{self.source}: {where}: <{e.tag} {key}={show(text)}>"
        if not LIST.fullmatch(text):
            bad = next(t for t in SPACE.split(text) if t and not NUMBER.fullmatch(t))
            raise MJCFError(f"{at}: {show(bad, 30)} is not a number (plain decimal: sign, digits, fraction, "
                            f"exponent; no nan, inf, hex, '_' or non-ASCII digits)")
        x = [float(t) for t in text.split()]
        if len(x) not in counts:
            raise MJCFError(f"{at}: {len(x)} number(s), expected {' or '.join(map(str, counts))}")
        if not all(map(math.isfinite, x)):
            raise MJCFError(f"{at}: overflows the float range")
        return np.array(x)

    def bounded(self, x, bound, what, e, key, where):
        if x is not None and np.any(np.abs(x) > bound):
            raise MJCFError(f"{self.source}: {where}: <{e.tag} {key}={show(e.get(key) or '')}>: {what} beyond the "
                            f"bound {bound:g}")
        return x

    def attr(self, e, key, cls):
        """An attribute of e from e itself, else its default class (cls: the class in force)."""
        v = e.get(key)
        if v is None and cls is not None:
            v = self.classes[cls].get(e.tag if e.tag != "freejoint" else "joint", {}).get(key)
        return v

    def num(self, e, key, cls, where, counts=(1,), default=None):
        text = self.attr(e, key, cls)
        if text is None:
            return None if default is None else np.array(default, float)
        return self.nums(e, key, counts, where, text)

    # -- compiler, option, defaults ----------------------------------------------------------------------------
    def compiler(self):
        c = {}
        for e in self.xml.findall("compiler"):
            c.update(e.attrib)
        src = self.source
        angle = c.get("angle", "degree")
        if angle not in ("degree", "radian"):
            raise MJCFError(f"{src}: <compiler angle={show(angle)}>: expected degree or radian")
        self.deg = angle == "degree"
        seq = c.get("eulerseq", "xyz")
        if len(seq) != 3 or any(ch not in "xyzXYZ" for ch in seq):
            raise MJCFError(f"{src}: <compiler eulerseq={show(seq)}>: three of x, y, z, X, Y, Z")
        self.seq = seq
        self.fromgeom = c.get("inertiafromgeom", "auto")
        if self.fromgeom not in ("true", "false", "auto"):
            raise MJCFError(f"{src}: <compiler inertiafromgeom={show(self.fromgeom)}>: expected true, false or auto")
        self.autolimits = c.get("autolimits", "true") == "true"
        self.alignfree = c.get("alignfree", "false")
        e = next(iter(self.xml.findall("compiler")), None)
        rng = [0, 5]
        if "inertiagrouprange" in c:
            rng = self.nums(e, "inertiagrouprange", (2,), "compiler", c["inertiagrouprange"])
        self.groups = rng
        self.total = None
        if "settotalmass" in c:
            self.total = float(self.nums(e, "settotalmass", (1,), "compiler", c["settotalmass"])[0])
            if not 0 < self.total <= MAX_MASS:
                raise MJCFError(f"{src}: <compiler settotalmass={show(c['settotalmass'])}>: outside (0, {MAX_MASS:g}]")
        for key, ok in (("coordinate", ("local",)), ("balanceinertia", ("false",)),
                        ("boundmass", ("0",)), ("boundinertia", ("0",))):
            if key in c and (ok is None or c[key] not in ok):
                raise MJCFError(f"{src}: <compiler {key}={show(c[key])}> changes the model's frames or masses: "
                                f"not supported")

    def gravity(self):
        """<option gravity> (MuJoCo's default [0, 0, −9.81]); zero with <option><flag gravity="disable">."""
        g = np.array([0.0, 0.0, -9.81])
        for e in self.xml.findall("option"):
            x = self.nums(e, "gravity", (3,), "option")
            if x is not None:
                g = self.bounded(x, MAX_LENGTH, "gravity", e, "gravity", "option")
            if any(f.get("gravity") == "disable" for f in e.findall("flag")):
                g = np.zeros(3)
        return check_gravity(g, self.source)

    def fluid(self):
        """<option density viscosity wind>: MuJoCo's fluid forces (passive, not in mj_rne): a quirk when nonzero."""
        for e in self.xml.findall("option"):
            for key, n in (("density", 1), ("viscosity", 1), ("wind", 3)):
                x = self.nums(e, key, (n,), "option")
                if x is not None and np.any(x != 0):
                    self.quirks.append(Quirk("passive_force", f"option {key}", f"<option {key}={show(e.get(key))}>: "
                                             f"fluid forces, not applied"))

    def defaults(self):
        """classes: name -> {tag: {attr: text}} with every ancestor class's values."""
        self.classes = {}
        stack = [(d, None) for d in reversed(self.xml.findall("default"))]
        while stack:
            d, parent = stack.pop()
            name = d.get("class", "main" if parent is None else None)
            if name is None:
                raise MJCFError(f"{self.source}: a nested <default> has no class attribute")
            if name in self.classes:
                raise MJCFError(f"{self.source}: <default class={show(name)}> is defined twice")
            own = {tag: dict(v) for tag, v in (self.classes[parent] if parent else {}).items()}
            for c in d:
                if isinstance(c.tag, str) and c.tag != "default":
                    own.setdefault(c.tag, {}).update(c.attrib)
            self.classes[name] = own
            stack += [(c, name) for c in reversed(d.findall("default"))]
        self.classes.setdefault("main", {})

    def refuse_top(self):
        src = self.source
        for e in self.xml.findall("equality"):
            for c in e:
                if isinstance(c.tag, str) and c.tag not in _EQUALITIES:
                    why = ("a flex equality constrains a flex, not rigid bodies or joints: not supported"
                           if c.tag in ("flex", "flexvert") else "not an equality manipdyn knows (connect, weld, "
                           "joint, tendon)")
                    raise MJCFError(f"{src}: <equality><{c.tag} name={show(c.get('name') or '')}>: {why}")
        self.tendons = {}                           # fixed tendons: name -> [(joint name, coef)]; spatial: None
        for t in self.xml.findall("tendon"):
            for c in t:
                if not isinstance(c.tag, str):
                    continue
                name = c.get("name") or f"<{c.tag}>"
                if c.get("name") is not None:
                    self.tendons[c.get("name")] = None if c.tag != "fixed" else [
                        (j.get("joint"), self.coef(j, f"tendon {name!r}"))
                        for j in c if isinstance(j.tag, str) and j.tag == "joint"]
                if c.get("armature") is not None and float(self.nums(c, "armature", (1,), f"tendon {name!r}")[0]):
                    raise MJCFError(f"{src}: tendon {name!r}: armature (adds to M): not supported yet")
                for k in ("stiffness", "damping"):
                    x = self.nums(c, k, (1,), f"tendon {name!r}") if c.get(k) is not None else None
                    if x is not None and x[0] != 0:
                        self.quirks.append(Quirk("passive_force", name, f"tendon {k} {x[0]:g}: not applied"))

    def coef(self, j, where):
        """A fixed tendon's <joint coef> (required, as MuJoCo's)."""
        x = self.nums(j, "coef", (1,), where)
        if x is None:
            raise MJCFError(f"{self.source}: {where}: <joint joint={show(j.get('joint') or '')}> needs coef")
        return float(x[0])

    def cls(self, e, inherited):
        name = e.get("class", inherited)
        if name not in self.classes:
            raise MJCFError(f"{self.source}: <{e.tag} name={e.get('name')!r} class={show(name)}>: no such default "
                            f"class")
        return name

    # -- frames ----------------------------------------------------------------------------------------------
    def angle(self, x):
        return math.radians(x) if self.deg else float(x)

    def frame(self, e, cls, where):
        """(R, p) of an element's pos + orientation (its class's when it sets none)."""
        given = [k for k in _ORIENT if e.get(k) is not None]
        if len(given) > 1:
            raise MJCFError(f"{self.source}: {where}: <{e.tag}> has several orientations ({', '.join(given)})")
        if not given and cls is not None:
            d = self.classes[cls].get(e.tag, {})
            given = [k for k in _ORIENT if k in d][:1]
        p = self.bounded(self.num(e, "pos", cls, where, (3,), (0, 0, 0)), MAX_LENGTH, "coordinate", e, "pos", where)
        R = np.eye(3)
        if given:
            k = given[0]
            x = self.num(e, k, cls, where, {"quat": (4,), "euler": (3,), "axisangle": (4,), "xyaxes": (6,),
                                            "zaxis": (3,)}[k])
            R = self.rotation(k, x, e, where)
        return R, p

    def rotation(self, k, x, e, where):
        zero = lambda v: not np.any(v)  # noqa: E731
        if k == "quat":
            if zero(x):
                raise MJCFError(f"{self.source}: {where}: <{e.tag} quat> is zero")
            return _quat_R(x / np.max(np.abs(x)))
        if k == "axisangle":
            if zero(x[:3]):
                raise MJCFError(f"{self.source}: {where}: <{e.tag} axisangle> has no axis")
            return _axis_R(x[:3] / np.max(np.abs(x[:3])), self.angle(x[3]))
        if k == "zaxis":
            if zero(x):
                raise MJCFError(f"{self.source}: {where}: <{e.tag} zaxis> is zero")
            return _z_to(x / np.max(np.abs(x)))
        if k == "xyaxes":
            a, b = x[:3], x[3:]
            if zero(a) or np.linalg.norm(np.cross(a, b)) == 0:
                raise MJCFError(f"{self.source}: {where}: <{e.tag} xyaxes> is degenerate")
            a = a / np.linalg.norm(a)
            b = b - a * (a @ b)
            b = b / np.linalg.norm(b)
            return np.column_stack([a, b, np.cross(a, b)])
        R = np.eye(3)                                          # euler, MuJoCo's rule per letter of eulerseq
        for ch, t in zip(self.seq, x):
            Rk = _axis_R(np.eye(3)["xyz".index(ch.lower())], self.angle(t))
            R = R @ Rk if ch.islower() else Rk @ R
        return R

    # -- bodies ----------------------------------------------------------------------------------------------
    def tick(self):
        self.count += 1
        if self.count > MAX_BODIES:
            raise MJCFError(f"{self.source}: more than {MAX_BODIES} bodies, joints, geoms and sites")

    def build(self, gravity, non_psd_inertia):
        src = self.source
        joints, parts, frames, merged = [], {-1: []}, {}, {"world": []}
        self.names, self.jnames, self.site_frames = {"body": {"world": "body"}, "site": {}}, set(), {}
        frames["world"] = Frame("world", -1, np.eye(3), np.zeros(3))
        self.ids = {"body": 0, "joint": 0, "site": 0}            # MuJoCo's ids: depth-first, file order
        stack = []
        for wb in self.xml.findall("worldbody"):
            items = self.expand(wb, "main", "<worldbody>")
            for c, *_ in items:
                if c.tag in ("joint", "freejoint", "inertial"):
                    raise MJCFError(f"{src}: <worldbody> holds a <{c.tag}>: the world cannot move")
            self.sites(items, -1, np.eye(3), np.zeros(3), frames)
            stack += [(c, -1, Rf, pf, cf) for c, Rf, pf, cf, _ in items if c.tag == "body"]
        stack.reverse()
        while stack:
            e, b, Rp, pp, cc = stack.pop()
            self.tick()
            self.ids["body"] += 1
            name = self.unique(e.get("name") or f"body{self.ids['body']}", "body")
            where = f"body {name!r}"
            cc_here = e.get("childclass", cc)
            if cc_here not in self.classes:
                raise MJCFError(f"{src}: {where}: childclass={show(cc_here)}: no such default class")
            items = self.expand(e, cc_here, where)
            self.known(e, where)
            for c, *_ in items:
                self.known(c, f"{where}: <{c.tag} name={c.get('name')!r}>" if c.get("name") else f"{where}: <{c.tag}>")
            if e.get("mocap") not in (None, "false") and b != -1:
                raise MJCFError(f"{src}: {where}: mocap body below another body (MuJoCo refuses it too)")
            Rb, pb = self.frame(e, None, where)
            R, p = Rp @ Rb, pp + Rp @ pb                        # the MJCF body's frame in our body b
            jels = [(c, Rf, pf) for c, Rf, pf, *_ in items if c.tag in ("joint", "freejoint")]
            if not jels:                                        # welded to its parent: merged
                merged[joints[b]["body"] if b >= 0 else "world"].append(name)
            anchor = None
            for k, (j, Rf, pf) in enumerate(jels):
                b, R, p, anchor = self.joint(j, Rf, pf, k, len(jels), name, cc_here, joints, b, R, p, anchor)
                parts[b], merged[joints[b]["body"]] = [], []
                if joints[b]["body"] != name:                   # a massless body between two joints
                    self.unique(joints[b]["body"], "body between two joints")
                    frames[joints[b]["body"]] = Frame(joints[b]["body"], b, np.eye(3), np.zeros(3))
            frames[name] = Frame(name, b, R, p)
            m, c, Ic = self.body_inertia(e, items, where)
            parts[b].append((m, p + R @ c, R @ Ic @ R.T))
            g = e.get("gravcomp")
            if g is not None and self.nums(e, "gravcomp", (1,), where)[0] != 0:
                self.quirks.append(Quirk("passive_force", name, f"gravcomp {e.get('gravcomp')}: not applied"))
            self.sites(items, b, R, p, frames)
            stack += [(c, b, R @ Rf, p + R @ pf, cf) for c, Rf, pf, cf, _ in reversed(items) if c.tag == "body"]
        if self.total is not None:                              # <compiler settotalmass>: every body scaled
            m_all = sum(m for ps in parts.values() for m, _, _ in ps)
            if m_all <= 0:
                raise MJCFError(f"{src}: <compiler settotalmass> on a model without mass")
            k = self.total / m_all
            parts = {b: [(k * m, c, k * I) for m, c, I in ps] for b, ps in parts.items()}
        constraints = self.equalities(joints, frames)
        return self.assemble(joints, parts, self.with_sites(frames), merged, gravity, non_psd_inertia, constraints)

    def expand(self, e, cc, where):
        """The children of a body (or the world) with <frame> elements flattened, in file order: [(element, R, p,
        class in force, inside a frame?)], (R, p) the element's frame-of-reference in the body's frame (the
        product of the enclosing frames' pos + orientation; identity outside frames). Iterative."""
        out, stack = [], [(c, np.eye(3), np.zeros(3), cc, False) for c in reversed(e)]
        while stack:
            c, Rf, pf, cf, framed = stack.pop()
            if not isinstance(c.tag, str):
                continue
            if c.tag not in _BODY_CHILDREN | {"frame"}:
                why = "not supported yet" if c.tag in _REFUSED_BODY_CHILDREN else "not an MJCF body element"
                raise MJCFError(f"{self.source}: {where}: <{c.tag}>: {why}")
            if c.tag != "frame":
                out.append((c, Rf, pf, cf, framed))
                continue
            self.tick()
            cn = c.get("childclass", cf)
            if cn not in self.classes:
                raise MJCFError(f"{self.source}: {where}: <frame childclass={show(cn)}>: no such default class")
            self.known(c, f"{where}: <frame name={c.get('name')!r}>")
            R2, p2 = self.frame(c, None, f"{where}: <frame name={c.get('name')!r}>")
            stack += [(x, Rf @ R2, pf + Rf @ p2, cn, True) for x in reversed(c)]
        return out

    def sites(self, items, b, R, p, frames):
        """The <site> items (expand's rows) as frames of our body b, in which their body's frame is (R, p)."""
        for s, Rf, pf, cc, _ in items:
            if s.tag != "site":
                continue
            self.tick()
            self.ids["site"] += 1
            name = self.unique(s.get("name") or f"site{self.ids['site'] - 1}", "site")
            cls = self.cls(s, cc)
            Rs, ps = self.fromto(s, cls, f"site {name!r}", *self.frame(s, cls, f"site {name!r}"))
            self.site_frames[name] = Frame(name, b, R @ Rf @ Rs, p + R @ (pf + Rf @ ps))

    def joint(self, j, Rf, pf, k, n, body, cls, joints, b, R, p, anchor):
        """Joint k of n in MJCF body ``body`` whose frame is (R, p) in our body b, the joint placed through (Rf, pf)
        (its <frame>s; identity outside) in the body: appends it to ``joints``; returns (its body, the MJCF body's
        frame in it, its anchor in the MJCF body's frame)."""
        src = self.source
        self.tick()
        self.ids["joint"] += 1
        jcls = self.cls(j, cls)
        jname = j.get("name") or f"joint{self.ids['joint'] - 1}"
        if jname in self.jnames:
            raise MJCFError(f"{src}: joint name {jname!r} is used twice")
        self.jnames.add(jname)
        kind = "free" if j.tag == "freejoint" else (self.attr(j, "type", jcls) or "hinge")
        jw = f"joint {jname!r} (in body {body!r})"
        if kind not in ("hinge", "slide", "ball", "free"):
            raise MJCFError(f"{src}: {jw}: type {show(kind)}: unknown joint type (hinge, slide, ball, free)")
        if kind == "free" and (j.get("align") or self.alignfree) in ("true",):
            raise MJCFError(f"{src}: {jw}: align / <compiler alignfree> (the free body's frame moved to its inertial "
                            f"frame): not supported yet")
        if kind == "free":                                  # q holds the body's pose in the world
            if b != -1 or n > 1:                            # MuJoCo: only in a child of the world, and alone
                raise MJCFError(f"{src}: {jw}: a free joint that is not alone in a child of <worldbody>: not "
                                f"supported (MuJoCo refuses it too)")
            joints.append(dict(name=jname, body=body, kind=FREEFLYER, parent=-1, R0=np.eye(3), p0=np.zeros(3),
                               axis=np.zeros(3), lim=(-np.inf, np.inf), continuous=False, q0=(R, p),
                               dyn=self.joint_quirks(j, jcls, jname, jw, kind)))
            return len(joints) - 1, np.eye(3), np.zeros(3), np.zeros(3)
        a = self.bounded(self.num(j, "pos", jcls, jw, (3,), (0, 0, 0)), MAX_LENGTH, "coordinate", j, "pos", jw)
        if kind == "ball":          # turns the body about its anchor, quaternion in the body's axes (mj_kinematics):
            a = pf + Rf @ a         # our joint frame at the anchor with the body's axes, R_J = R(quat); MuJoCo reads
            R0, p0 = (R, p + R @ a) if anchor is None else (np.eye(3), a - anchor)   # no axis, ref or range for it
            joints.append(dict(name=jname, body=body if k == n - 1 else f"{body}:{jname}", kind=BALL, parent=b,
                               R0=R0, p0=p0, axis=np.zeros(3), lim=(-np.inf, np.inf), continuous=False, q0=0.0,
                               dyn=self.joint_quirks(j, jcls, jname, jw, kind)))
            return len(joints) - 1, np.eye(3), -a, a
        u = self.num(j, "axis", jcls, jw, (3,), (0, 0, 1))
        if not np.any(u):
            raise MJCFError(f"{src}: {jw}: <joint axis={show(self.attr(j, 'axis', jcls))}> has no direction")
        u = u / np.max(np.abs(u))
        a, u = pf + Rf @ a, Rf @ (u / np.linalg.norm(u))        # through the enclosing <frame>s, if any
        dyn = self.joint_quirks(j, jcls, jname, jw, kind)
        lim, cont = self.limits(j, jcls, jw, kind)
        # mj_kinematics: each joint turns the body about its anchor, in the frame the previous joints left
        R0, p0 = (R, p + R @ a) if anchor is None else (np.eye(3), a - anchor)
        ref, x = self.num(j, "ref", jcls, jw, (1,), (0,))[0], 0.0
        if ref != 0:                                        # MuJoCo moves the body by qpos − ref: folded in
            x = self.angle(ref) if kind == "hinge" else self.bounded(np.array([ref]), MAX_LENGTH, "ref", j, "ref",
                                                                     jw)[0]
            R0, p0 = (R0 @ _axis_R(u, -x), p0) if kind == "hinge" else (R0, p0 - x * (R0 @ u))
            self.quirks.append(Quirk("joint_ref", jname, f"ref {ref:g}: q = MuJoCo's qpos (q = 0 is not the pose "
                                     f"drawn in the file; the file's pose is q = {x:g})"))
        joints.append(dict(name=jname, body=body if k == n - 1 else f"{body}:{jname}",
                           kind=REVOLUTE if kind == "hinge" else PRISMATIC, parent=b, R0=R0, p0=p0, axis=u, lim=lim,
                           continuous=cont, q0=x, dyn=dyn))
        return len(joints) - 1, np.eye(3), -a, a

    def unique(self, name, what):
        """``name`` of a body (``what`` names how it came to be) or a site, once in its name space (MuJoCo's)."""
        space = self.names["site" if what == "site" else "body"]
        if name in space:
            raise MJCFError(f"{self.source}: {what} name {name!r} is used twice (also a {space[name]})")
        space[name] = what
        return name

    def with_sites(self, frames):
        """The bodies' frames and the sites' (a site sharing a body's name as SITE_PREFIX + its name)."""
        out = dict(frames)
        for name, f in self.site_frames.items():
            key = name if name not in frames else SITE_PREFIX + name
            if key in out:
                raise MJCFError(f"{self.source}: site {name!r} shares a body's name, and {key!r} is a body's name "
                                f"too: rename one of them (manipdyn names such a site's frame {SITE_PREFIX}<name>)")
            out[key] = Frame(key, f.body, f.R, f.p)
        return out

    def fromto(self, e, cls, where, R, p):
        ft = self.num(e, "fromto", cls, where, (6,))
        if ft is None:
            return R, p
        self.bounded(ft, MAX_LENGTH, "coordinate", e, "fromto", where)
        d = ft[3:] - ft[:3]
        if not np.any(d):
            raise MJCFError(f"{self.source}: {where}: <{e.tag} fromto> has zero length")
        return _z_to(d), 0.5 * (ft[:3] + ft[3:])

    def joint_quirks(self, j, jcls, jname, jw, kind):
        """(armature, damping, frictionloss) of the joint (each ≥ 0, applied: Model.armature, damping, friction);
        a quirk for what is read and not applied (stiffness, springref, springdamper)."""
        found, dyn = [], []
        for key in _APPLIED:
            x = self.num(j, key, jcls, jw)
            x = 0.0 if x is None else float(x[0])
            if not 0.0 <= x <= MAX_MASS:
                raise MJCFError(f"{self.source}: {jw}: {key}={x!r}: must be >= 0 and <= {MAX_MASS:g}")
            dyn.append(x)
        for key in _DYNAMICS:
            x = self.num(j, key, jcls, jw)
            if x is not None and x[0] != 0:
                found.append(f"{key} {x[0]:g}")
        sd = self.num(j, "springdamper", jcls, jw, (2,))
        if sd is not None and np.any(sd != 0):
            found.append(f"springdamper {sd[0]:g} {sd[1]:g}")
        if found:
            self.quirks.append(Quirk("joint_dynamics", jname, ", ".join(found) + ": read, not applied yet"))
        if kind == "free" and dyn[0] > 0:
            self.quirks.append(Quirk("free_armature", jname, f"armature {dyn[0]:g} on a free joint: applied to the "
                                     f"body-frame twist's derivative (Pinocchio's model.armature); MuJoCo's τ differs by "
                                     f"armature · R (ω × v_lin) on the linear rows (M is the same)"))
        return tuple(dyn)

    def limits(self, j, jcls, jw, kind):
        rng = self.num(j, "range", jcls, jw, (2,))
        limited = self.attr(j, "limited", jcls) or "auto"
        if limited not in ("true", "false", "auto"):
            raise MJCFError(f"{self.source}: {jw}: limited={show(limited)}: expected true, false or auto")
        on = rng is not None and (limited == "true" or (limited == "auto" and self.autolimits))
        if not on:
            return (-np.inf, np.inf), kind == "hinge"
        lo, hi = (self.angle(x) for x in rng) if kind == "hinge" else rng
        if kind == "slide":
            self.bounded(rng, MAX_LENGTH, "limit", j, "range", jw)
        if lo > hi:
            raise MJCFError(f"{self.source}: {jw}: range {rng.tolist()}: lower > upper")
        return (float(lo), float(hi)), False

    # -- equality constraints (closures) ---------------------------------------------------------------------
    def equalities(self, joints, frames):
        """<equality> connect, weld and joint elements as the model's closures (model.Constraint), in file order;
        two connects between the same two bodies whose anchors are as far apart on each body become one revolute
        closure (the axis through them: the same constraint, 5 independent rows instead of 6 of rank 5)."""
        out, names, poses = [], set(), None
        self.joint_bodies = [j["body"] for j in joints]
        for e in self.xml.findall("equality"):
            for c in e:
                if not isinstance(c.tag, str):
                    continue
                k = len(names)
                name = c.get("name") or f"equality{k}"
                where = f"<equality><{c.tag} name={show(name)}>"
                if name in names:
                    raise MJCFError(f"{self.source}: {where}: the name is used twice")
                names.add(name)
                self.known(c, where, {"joint": "joint_eq", "tendon": "tendon_eq"}.get(c.tag, c.tag))
                cls = self.cls(c, "main")
                get = lambda key: c.get(key, self.classes[cls].get("equality", {}).get(key))  # noqa: E731
                active = get("active") or "true"
                if active not in ("true", "false"):
                    raise MJCFError(f"{self.source}: {where}: active={show(active)}: expected true or false")
                if active == "false":
                    self.quirks.append(Quirk("inactive_equality", name, f"{where}: active=\"false\": not a closure "
                                             f"of the model (MuJoCo starts with it off)"))
                    continue
                soft = [f"{key}={show(get(key))}" for key in ("solref", "solimp") if get(key) is not None]
                if c.tag in ("joint", "tendon"):
                    out.append((self.joint_equality if c.tag == "joint" else self.tendon_equality)(
                        c, name, where, joints, get))
                    if soft:
                        self.quirks.append(Quirk("equality_softness", name, f"{where}: {', '.join(soft)}: MuJoCo's "
                                                 f"constraint softness, not a model parameter; the closure is rigid "
                                                 f"here"))
                    continue
                if poses is None:
                    poses = _poses_at_qpos0(joints)
                ts = self.nums(c, "torquescale", (1,), where, get("torquescale")) if c.tag == "weld" else None
                if ts is not None and ts[0] != 1:
                    soft.append(f"torquescale={show(get('torquescale'))}")
                out.append(self.body_equality(c, name, where, frames, poses, ts is not None and ts[0] == 0, get))
                if soft:
                    self.quirks.append(Quirk("equality_softness", name, f"{where}: {', '.join(soft)}: MuJoCo's "
                                             f"constraint softness (or row scale), not a model parameter; the "
                                             f"closure is rigid here"))
        return _merge_connects(out)

    def site_or_body(self, c, key, frames, where, kind, required=True):
        """The frame (model.Frame) of the body or site named by attribute key (world for a missing body2)."""
        n = c.get(key)
        if n is None:
            if required:
                raise MJCFError(f"{self.source}: {where}: needs {key}")
            return frames["world"]
        if n not in self.names[kind]:
            raise MJCFError(f"{self.source}: {where}: {key}={show(n)}: no such {kind}")
        return self.site_frames[n] if kind == "site" else frames[n]

    def body_equality(self, c, name, where, frames, poses, point_only, get):
        """A connect (spherical closure) or weld (fixed; spherical with torquescale 0) as MuJoCo's compiler and
        mj_equalityAnchors read it: body semantic (connect: body1 and anchor; weld: body1) or site semantic."""
        weld = c.tag == "weld"
        body = c.get("body1") is not None and (weld or c.get("anchor") is not None)
        if not body and (c.get("site1") is None or c.get("site2") is None):
            raise MJCFError(f"{self.source}: {where}: needs body1{'' if weld else ' and anchor'}, or site1 and site2")
        if not body:                                        # the sites' frames coincide (weld) or their origins
            f1, f2 = (self.site_or_body(c, k, frames, where, "site") for k in ("site1", "site2"))
            a = (f1.body, f1.R, f1.p)
            b = (f2.body, f2.R, f2.p)
        else:
            f1 = self.site_or_body(c, "body1", frames, where, "body")
            f2 = self.site_or_body(c, "body2", frames, where, "body", required=False)
            T1, T2 = _compose(poses, f1), _compose(poses, f2)   # the MJCF bodies' frames in the world at qpos0
            anchor = self.bounded(self.nums(c, "anchor", (3,), where), MAX_LENGTH, "coordinate", c, "anchor", where)
            anchor = np.zeros(3) if anchor is None else anchor
            if not weld:                                    # anchor on body1; body2's point: the same at qpos0
                x = T1[1] + T1[0] @ anchor
                p1, R1, p2, R2 = anchor, np.eye(3), T2[0].T @ (x - T2[1]), np.eye(3)
            else:                                           # anchor on body2; relpose: body2's frame in body1's
                rel = self.nums(c, "relpose", (7,), where, get("relpose"))
                if rel is None or not np.any(rel[3:]):      # MuJoCo's default: the relative pose at qpos0
                    x = T2[1] + T2[0] @ anchor
                    p1, R1 = T1[0].T @ (x - T1[1]), T1[0].T @ T2[0]
                else:
                    self.bounded(rel[:3], MAX_LENGTH, "coordinate", c, "relpose", where)
                    p1, R1 = rel[:3], _quat_R(rel[3:] / np.max(np.abs(rel[3:])))
                p2, R2 = anchor, np.eye(3)
            a = (f1.body, f1.R @ R1, f1.p + f1.R @ p1)     # into our bodies' frames
            b = (f2.body, f2.R @ R2, f2.p + f2.R @ p2)
        if a[0] == b[0]:
            raise MJCFError(f"{self.source}: {where}: both sides are on the same rigid body (nothing to close)")
        kind = "fixed" if weld and not point_only else "spherical"
        z = np.zeros(3)
        return Constraint(name, kind, a[0], self.body_name(a[0]), a[1], a[2], z, b[0], self.body_name(b[0]), b[1],
                          b[2], z, source=c.tag)

    def body_name(self, b):
        return "world" if b < 0 else self.joint_bodies[b]

    def joint_equality(self, c, name, where, joints, get):
        """q1 − q1₀ = c₀ + c₁ (q2 − q2₀) (MuJoCo's joint equality, q₀ = qpos0) as a coupling row (``coupling``)."""
        i1, i2 = (self.joint_id(c.get(key), key, where, joints, key == "joint1") for key in ("joint1", "joint2"))
        poly = self.polycoef(c, where, get)
        return self.coupling(name, where, joints, i1, i2, poly[0], poly[1], "joint")

    def tendon_equality(self, c, name, where, joints, get):
        """L − L₀ = c₀ (MuJoCo's tendon equality on one fixed tendon L = a q_a + b q_b, L₀ its length at qpos0):
        q_a − q_a₀ = c₀ / a − (b / a)(q_b − q_b₀), a coupling row (``coupling``); a tendon of one joint fixes it.
        Refused by name: an equality between two tendons, a spatial tendon, more than two joints."""
        t = c.get("tendon1")
        if t is None:
            raise MJCFError(f"{self.source}: {where}: needs tendon1")
        if t not in self.tendons:
            raise MJCFError(f"{self.source}: {where}: tendon1={show(t)}: no such tendon")
        if c.get("tendon2") is not None:
            raise MJCFError(f"{self.source}: {where}: tendon2={show(c.get('tendon2'))}: an equality between two "
                            f"tendons' lengths: not supported (one fixed tendon of one or two joints is)")
        terms = self.tendons[t]
        if terms is None or not 1 <= len(terms) <= 2:
            what = "a spatial tendon" if terms is None else f"a fixed tendon of {len(terms)} joints"
            raise MJCFError(f"{self.source}: {where}: tendon {t!r} is {what}: not supported (a coupling relates one "
                            f"or two joints: a fixed tendon of one or two)")
        poly = self.nums(c, "polycoef", (5,), where, get("polycoef"))     # c₁ … c₄ multiply tendon2's length: none
        p0 = 0.0 if poly is None else float(poly[0])
        (n1, a), *rest = terms
        if a == 0 or not np.isfinite(a):
            raise MJCFError(f"{self.source}: {where}: tendon {t!r}: coef {a:g} of joint {n1!r}: not a coupling")
        i1 = self.joint_id(n1, "tendon joint", where, joints, True)
        i2 = self.joint_id(rest[0][0], "tendon joint", where, joints, True) if rest else None
        return self.coupling(name, where, joints, i1, i2, p0 / a, -rest[0][1] / a if rest else 0.0, "tendon")

    def joint_id(self, n, key, where, joints, required):
        """The index in ``joints`` of joint n (attribute key), a hinge or slide; None for a missing optional one."""
        if n is None:
            if required:
                raise MJCFError(f"{self.source}: {where}: needs {key}")
            return None
        idx = {j["name"]: i for i, j in enumerate(joints)}
        if n not in idx:
            raise MJCFError(f"{self.source}: {where}: {key}={show(n)}: no such joint")
        if joints[idx[n]]["kind"] in (FREEFLYER, BALL):
            raise MJCFError(f"{self.source}: {where}: {key}={show(n)} is a "
                            f"{'free' if joints[idx[n]]['kind'] == FREEFLYER else 'ball'} joint; a coupling relates "
                            f"hinge and slide joints")
        return idx[n]

    def polycoef(self, c, where, get):
        """A joint equality's polycoef (5,) (default 0 1 0 0 0); its quadratic and higher terms refused by name (the
        closure model's coupling is linear)."""
        poly = self.nums(c, "polycoef", (5,), where, get("polycoef"))
        poly = np.array([0.0, 1.0, 0, 0, 0]) if poly is None else poly
        if np.any(poly[2:]):
            raise MJCFError(f"{self.source}: {where}: polycoef={show(get('polycoef'))}: a polynomial coupling "
                            f"(quadratic or higher terms): not supported (the closure model's coupling is linear)")
        return poly

    def coupling(self, name, where, joints, i1, i2, p0, c1, source):
        """q1 − q1₀ = p0 + c1 (q2 − q2₀) (q₀ = qpos0; i2 None: q1 − q1₀ = p0) as a coupling row: linear, without
        offset, and the two joints each alone on their side of a common ancestor (model.Constraint; source: the
        equality's tag)."""
        poly = (p0, c1)
        b1 = i1
        if i2 is None or poly[1] == 0:                      # q1 = 0: the coupling of body1's parent and body1
            a = joints[i1]["parent"]
        else:
            a = i2
            if a == b1 or joints[a]["parent"] != joints[b1]["parent"]:
                raise MJCFError(f"{self.source}: {where}: joints {joints[i1]['name']!r} and {joints[i2]['name']!r} "
                                f"are not each alone on their side of a common ancestor (siblings): not supported "
                                f"(the closure model's coupling relates the joints on the two tree paths below the "
                                f"bodies' common ancestor)")
        r1, r2 = joints[i1]["q0"], (joints[i2]["q0"] if i2 is not None else 0.0)
        c1 = poly[1] if i2 is not None else 0.0
        offset = poly[0] + r1 - c1 * r2                     # q1 = offset + c1 q2
        if abs(offset) > 1e-12 * (1 + abs(poly[0]) + abs(r1) + abs(c1 * r2)):   # round-off of the refs: none
            raise MJCFError(f"{self.source}: {where}: q1 = {offset:g} + {c1:g} q2 (polycoef and the joints' ref): a "
                            f"coupling with an offset: not supported (the closure model's coupling row has none)")
        if not np.isfinite(c1) or abs(c1) > MAX_MASS:
            raise MJCFError(f"{self.source}: {where}: ratio {c1:g} beyond the bound {MAX_MASS:g}")
        I3, z = np.eye(3), np.zeros(3)
        return Constraint(name, "coupling", a, self.body_name(a), I3, z, z, b1, self.body_name(b1), I3, z, z,
                          ratio=float(c1) if a == i2 else 0.0, source=source)

    # -- mass ------------------------------------------------------------------------------------------------
    def body_inertia(self, e, items, where):
        """(m, c, I about c) of one MJCF body in its own frame (items: its children, expand's rows)."""
        ins = [(x, Rf, pf) for x, Rf, pf, *_ in items if x.tag == "inertial"]
        if len(ins) > 1:
            raise MJCFError(f"{self.source}: {where}: several <inertial> elements")
        inertial, Ri, pi = ins[0] if ins else (None, None, None)
        geoms = [(g, Rf, pf, cc) for g, Rf, pf, cc, _ in items if g.tag == "geom"]
        for _ in geoms:
            self.tick()
        use = self.fromgeom == "true" or (self.fromgeom == "auto" and inertial is None)
        if use:
            parts = [(m, pf + Rf @ c, Rf @ I @ Rf.T) for g, Rf, pf, cc in geoms
                     for m, c, I in self.geom_inertia(g, self.cls(g, cc), where)]
            return combine_inertias(parts) if parts else (0.0, np.zeros(3), np.zeros((3, 3)))
        if inertial is None:
            return 0.0, np.zeros(3), np.zeros((3, 3))
        w = f"{where}: <inertial>"
        m = self.nums(inertial, "mass", (1,), w)
        if m is None:
            raise MJCFError(f"{self.source}: {w} has no mass attribute")
        m = float(m[0])
        if m < 0:
            raise MJCFError(f"{self.source}: {w}: negative mass {m:g}")
        self.bounded(np.array([m]), MAX_MASS, "mass (kg)", inertial, "mass", w)
        if inertial.get("fullinertia") is not None and any(inertial.get(k) is not None for k in _ORIENT):
            raise MJCFError(f"{self.source}: {w}: fullinertia with an orientation (MuJoCo refuses it too)")
        if inertial.get("pos") is None:
            raise MJCFError(f"{self.source}: {w} has no pos attribute (MuJoCo requires it)")
        R, c = self.frame(inertial, None, w)
        diag, full = (self.nums(inertial, k, (n,), w) for k, n in (("diaginertia", 3), ("fullinertia", 6)))
        if (diag is None) == (full is None):
            raise MJCFError(f"{self.source}: {w}: needs one of diaginertia or fullinertia")
        for x, k in ((diag, "diaginertia"), (full, "fullinertia")):
            self.bounded(x, MAX_INERTIA, "inertia (kg m²)", inertial, k, w)
        if diag is not None:
            if np.any(diag < 0):
                raise MJCFError(f"{self.source}: {w}: negative diaginertia {diag.tolist()}")
            I = R @ np.diag(diag) @ R.T
        else:
            xx, yy, zz, xy, xz, yz = full
            I = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        if m == 0 and np.any(I):
            self.quirks.append(Quirk("zero_mass_inertia", where.split(" ", 1)[1].strip("'"), "mass 0, inertia "
                                     f"{np.round(I, 12).tolist()}: " + ("kept (Pinocchio's behaviour)" if self.zmi == "keep"
                                                                       else "dropped (zero_mass_inertia='drop')")))
        if m == 0 and self.zmi == "drop":
            return 0.0, np.zeros(3), np.zeros((3, 3))
        return m, pi + Ri @ c, Ri @ (0.5 * (I + I.T)) @ Ri.T

    def geom_inertia(self, g, cls, where):
        """[(m, c, I_c)] of one geom in the body frame ([] when it gives no mass), MuJoCo's solid formulas."""
        w = f"{where}: geom {g.get('name') or ''!r}".replace(": geom ''", ": an unnamed geom")
        group = self.num(g, "group", cls, w, (1,), (0,))[0]
        if not (self.groups[0] <= group <= self.groups[1]):
            return []
        kind = self.attr(g, "type", cls) or "sphere"
        mass = self.num(g, "mass", cls, w)
        density = self.num(g, "density", cls, w, (1,), (DEFAULT_DENSITY,))[0]
        if mass is not None:
            self.bounded(mass, MAX_MASS, "mass (kg)", g, "mass", w)
            if mass[0] < 0:
                raise MJCFError(f"{self.source}: {w}: negative mass {mass[0]:g}")
        if not 0 <= density <= MAX_DENSITY:
            raise MJCFError(f"{self.source}: {w}: density {density:g} outside [0, {MAX_DENSITY:g}] kg/m³")
        if (mass is None and density == 0) or (mass is not None and mass[0] == 0):
            return []
        if kind not in _MASS_GEOMS:
            why = ("mesh inertia is not supported yet" if kind == "mesh" else "a geom of this type cannot give mass"
                   if kind in ("plane", "hfield", "sdf") else "unknown geom type")
            raise MJCFError(f"{self.source}: {w}: type {show(kind)} contributes to the body's inertia "
                            f"(inertiafromgeom): {why}")
        if (self.attr(g, "shellinertia", cls) or "false") == "true":
            raise MJCFError(f"{self.source}: {w}: shellinertia: not supported yet")
        size = self.num(g, "size", cls, w, (1, 2, 3), (0, 0, 0))
        self.bounded(size, MAX_LENGTH, "size", g, "size", w)
        R, p = self.frame(g, cls, w)
        if self.attr(g, "fromto", cls) is not None:
            if kind not in ("capsule", "cylinder"):
                raise MJCFError(f"{self.source}: {w}: fromto on a {kind}: not supported yet")
            R, p = self.fromto(g, cls, w, R, p)
            ft = self.num(g, "fromto", cls, w, (6,))
            size = np.array([size[0], 0.5 * np.linalg.norm(ft[3:] - ft[:3])])
        need = {"sphere": 1, "capsule": 2, "cylinder": 2, "box": 3, "ellipsoid": 3}[kind]
        if len(size) < need or np.any(size[:need] <= 0):
            raise MJCFError(f"{self.source}: {w}: a {kind} needs {need} positive size(s), got "
                            f"{show(self.attr(g, 'size', cls) or '')}")
        vol, Id = _solid(kind, size[:need])                 # Id: principal moments per unit mass
        m = float(mass[0]) if mass is not None else density * vol
        if not m <= MAX_MASS:
            raise MJCFError(f"{self.source}: {w}: mass {m:g} kg beyond the bound {MAX_MASS:g}")
        return [(m, p, R @ np.diag(m * Id) @ R.T)]

    # -- the model -------------------------------------------------------------------------------------------
    def assemble(self, joints, parts, frames, merged, gravity, non_psd_inertia, constraints=()):
        src, nb = self.source, len(joints)
        inertias = [combine_inertias(parts[i]) if parts[i] else (0.0, np.zeros(3), np.zeros((3, 3)))
                    for i in range(nb)]
        what = [f"body {j['body']!r}" for j in joints]
        for i, lam in _check_psd([I for _, _, I in inertias], what, src, non_psd_inertia):
            self.quirks.append(Quirk("non_psd_inertia", joints[i]["body"], f"smallest eigenvalue {lam[0]:.6g} kg m²: "
                                     f"kept (non_psd_inertia='keep')"))
        bad = _triangle([I for _, _, I in inertias], [j["body"] for j in joints], src, self.strict)
        self.quirks += [Quirk("triangle", n, msg) for n, msg in bad]
        order = list(QUIRK_KINDS)
        name = self.xml.get("model") or ("mjcf" if src.startswith("<") else os.path.splitext(os.path.basename(src))[0])
        lim = np.array([j["lim"] for j in joints], float).reshape(nb, 2)
        return Model(
            name=name, root_link="world", joint_names=tuple(j["name"] for j in joints),
            body_names=tuple(j["body"] for j in joints),
            parent=np.array([j["parent"] for j in joints], int).reshape(nb),
            kind=np.array([j["kind"] for j in joints], int).reshape(nb),
            continuous=np.array([j["continuous"] for j in joints], bool).reshape(nb),
            axis=np.array([j["axis"] for j in joints], float).reshape(nb, 3),
            R0=np.array([j["R0"] for j in joints], float).reshape(nb, 3, 3),
            p0=np.array([j["p0"] for j in joints], float).reshape(nb, 3),
            mass=np.array([m for m, _, _ in inertias], float).reshape(nb),
            com=np.array([c for _, c, _ in inertias], float).reshape(nb, 3),
            inertia=np.array([I for _, _, I in inertias], float).reshape(nb, 3, 3),
            lower=lim[:, 0], upper=lim[:, 1], effort=np.full(nb, np.inf), velocity=np.full(nb, np.inf),
            gravity=np.array(gravity, float).reshape(3), frames=frames,
            merged={k: tuple(v) for k, v in merged.items()}, mimic=(), source=src, notes=(), constraints=constraints,
            quirks=tuple(sorted(self.quirks, key=lambda q: order.index(q.kind))),
            **{key: np.array([j["dyn"][k] for j in joints for _ in range(NV[j["kind"]])], float)
               for k, key in enumerate(("armature", "damping", "friction"))})


def _solid(kind, s):
    """(volume, principal moments per unit mass (3,)) of a solid primitive with MuJoCo's size parameters
    (user_objects.cc, mjCGeom: half-lengths; a capsule is a cylinder of half-height s[1] and two hemispheres)."""
    if kind == "sphere":
        r = s[0]
        return 4 / 3 * math.pi * r ** 3, np.full(3, 0.4 * r * r)
    if kind == "capsule":
        r, h = s[0], 2 * s[1]
        vol = math.pi * r * r * (h + 4 / 3 * r)
        ms = (4 / 3 * r) / (h + 4 / 3 * r)                  # the hemispheres' share of the mass
        mc = 1 - ms
        ixx = mc * (3 * r * r + h * h) / 12 + ms * (0.4 * r * r + h * (3 * r + 2 * h) / 8)
        return vol, np.array([ixx, ixx, mc * r * r / 2 + ms * 0.4 * r * r])
    if kind == "cylinder":
        r, h = s[0], 2 * s[1]
        return math.pi * r * r * h, np.array([(3 * r * r + h * h) / 12] * 2 + [r * r / 2])
    if kind == "box":
        a, b, c = s
        return 8 * a * b * c, np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / 3
    a, b, c = s                                             # ellipsoid
    return 4 / 3 * math.pi * a * b * c, np.array([b * b + c * c, a * a + c * c, a * a + b * b]) / 5


def _poses_at_qpos0(joints):
    """[(R, p)] of each of our bodies in the world at MuJoCo's qpos0 (each joint at its ref; a free body at its pose
    in the file): the configuration MuJoCo's compiler takes a connect's or weld's missing anchor and pose from."""
    out = []
    for j in joints:
        Rp, pp = (np.eye(3), np.zeros(3)) if j["parent"] < 0 else out[j["parent"]]
        if j["kind"] == FREEFLYER:
            out.append(j["q0"])
            continue
        if j["kind"] == BALL:                                  # qpos0: the identity quaternion
            out.append((Rp @ j["R0"], pp + Rp @ j["p0"]))
            continue
        R, p = Rp @ j["R0"], pp + Rp @ j["p0"]                 # the joint frame; then the joint's motion by q0
        out.append((R @ _axis_R(j["axis"], j["q0"]), p) if j["kind"] == REVOLUTE
                   else (R, p + R @ (j["q0"] * j["axis"])))
    return out


def _compose(poses, f):
    """(R, p) in the world at qpos0 of a frame (model.Frame) on one of our bodies (-1: the world)."""
    R, p = (np.eye(3), np.zeros(3)) if f.body < 0 else poses[f.body]
    return R @ f.R, p + R @ f.p


def _merge_connects(closures):
    """Two spherical closures (connects) between the same two bodies, and no other, whose anchors are equally far
    apart on each body (relative 1e-12) -> one revolute closure at the first anchor, its axis through the second
    (coincident anchors with equal spacing ⇔ a coincident point and an aligned axis)."""
    pairs = {}
    for k, c in enumerate(closures):
        pairs.setdefault((c.parent, c.child), []).append(k)
    out, drop = list(closures), set()
    for ks in pairs.values():
        if len(ks) != 2 or any(closures[k].type != "spherical" for k in ks):
            continue
        c1, c2 = (closures[k] for k in ks)
        dp, dc = c2.pp - c1.pp, c2.pc - c1.pc
        lp, lc = np.linalg.norm(dp), np.linalg.norm(dc)
        if lp == 0 or abs(lp - lc) > 1e-12 * lp:
            continue
        out[ks[0]] = dataclasses.replace(c1, type="revolute", axis_p=dp / lp, axis_c=dc / lc)
        drop.add(ks[1])
    return tuple(c for k, c in enumerate(out) if k not in drop)
