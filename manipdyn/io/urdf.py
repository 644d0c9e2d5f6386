"""URDF -> Model: the URDF loader. Its closure elements are read by io/urdf_closures.py; the hardened XML parse,
the number grammar and the bounds it checks are io/safe_xml.py's (the MJCF reader, io/mjcf_read.py, shares them).

The file is parsed once with a hardened parser (no DTD, no entities, no network, a size limit), every
number manipdyn reads is checked on the raw XML against one grammar and physical bounds, its elements are
then read by yourdfpy, and the tree is walked the way Pinocchio's URDF reader walks it: depth-first from the
root link, the child joints of a link in the order of their names (urdfdom keeps joints in a map sorted by
name), fixed joints merged into the moving body they hang from. The walk is implemented here, iteratively
(no recursion limit) and in time linear in the number of links; Pinocchio is never imported.

What the loader refuses (URDFError naming the file, the link or joint, the attribute and its value):
- numbers outside the URDF grammar ``safe_xml.NUMBER`` (plain decimal: optional sign, digits with an optional
  fraction, an optional exponent). Python's float() also reads ``1_0``, non-ASCII digits, ``nan``, ``inf``
  and surrounding Unicode spaces; urdfdom (Pinocchio's reader) does not, and neither do we. Numbers that
  overflow (``1e400``) are refused too. Vectors must have exactly their count of numbers.
- masses, inertias and lengths beyond ``MAX_MASS``, ``MAX_INERTIA``, ``MAX_LENGTH`` (io/safe_xml.py: the
  bounds keep every computation of the model finite) and negative masses or effort/velocity limits;
- joint axes that are zero (an axis that is not unit is normalised, with a note);
- revolute/prismatic joints without ``<limit effort= velocity=>`` (urdfdom refuses them too; a missing
  lower/upper is 0, as the URDF specification and urdfdom say), with ``strict=True`` limits with lower > upper;
- mimic joints naming a joint that does not exist, or themselves;
- files larger than ``max_bytes`` (default ``MAX_BYTES``, io/safe_xml.py);
- inertias that are not positive semi-definite beyond round-off (per body after merging), unless
  ``non_psd_inertia="keep"`` (Pinocchio, PyBullet and Drake load them): then a "non_psd_inertia" quirk names each.

What the loader reads as other engines do, with a quirk (see quirks.QUIRK_KINDS): an XML declaration whose version
is not 1.x (``<?xml version="0.0"?>``, which libxml2 refuses) is read as XML 1.0 ("xml_version"); an ``<inertial>``
with ``<mass>`` but no ``<inertia>`` is a point mass at its ``<origin>`` ("point_mass", Pinocchio 4.1's reading);
whitespace before the XML declaration and NUL bytes after the document (a C string's terminator), both of which
libxml2 refuses, are removed ("xml_text"); a ``<limit>`` with lower > upper is read as no position limit
("inverted_limits", PyBullet's reading; limits never enter the dynamics).

The root link (docs/design.md §3): by default it is the fixed base, body −1; its mass and inertia (with the links
fixed to it) move with no joint, so they have no effect on the dynamics — Pinocchio's buildModelFromUrdf
attaches them to the universe (``model.inertias[0]``), likewise without effect. A URDF describes no base
joint, so whether a robot is bolted down is the caller's choice: ``root_joint="free_flyer"`` (Pinocchio's
``buildModelFromUrdf(path, pin.JointModelFreeFlyer())``) adds joint 0, a FREEFLYER named "root_joint", whose
body is the root link with its merged fixed children (mass, CoM, inertia), at R0 = 1, p0 = 0 with parent −1;
every URDF joint then comes one index later. Its limits in the Model (one entry per joint, as for every
joint) are lower = −inf, upper = +inf, effort = velocity = inf (Pinocchio stores ±max float per q entry).
Without it, a root body that carries mass gets a note and a FloatingBaseWarning (a legged robot or humanoid
loaded as if bolted down) — unless the root link is named "world", the URDF convention for a robot fixed to
the world (UR, xArm, Z1 in example-robot-data).
"""
from __future__ import annotations

import dataclasses
import math
import os
import re
import warnings
from collections import Counter

import numpy as np
import yourdfpy

from ..errors import FloatingBaseWarning, InertiaWarning, InputError, ModelError, QuirkWarning, URDFError
from ..joints import FREEFLYER, KINDS, universal_pair
from ..model import Frame, MimicModel, Model, check_gravity, with_joint_dynamics
from ..quirks import QUIRK_KINDS, Quirk
from ..spatial import combine_inertias
from .safe_xml import MAX_BYTES, MAX_INERTIA, MAX_LENGTH, MAX_MASS, bounded, numbers, parse_xml, show
from .urdf_closures import CLOSURE_TAGS, read_closures

MOVING = {name: k.code for k in KINDS for name in k.urdf}   # the registry's URDF names: revolute, continuous,
#      prismatic, floating, planar; spherical (PyBullet's extension), screw and universal (Drake's <drake:joint>)
SUPPORTED = set(MOVING) | {"fixed"}
ROOT_JOINTS = (None, "free_flyer")   # accepted values of root_joint
ROOT_JOINT_NAME = "root_joint"       # the free flyer's name (Pinocchio's)
_KIND = {**MOVING, "free_flyer": FREEFLYER}
_NO_AXIS = ("free_flyer", "floating", "spherical", "universal")   # joints without an axis (or position limits)
_UNBOUNDED = _NO_AXIS + ("planar",)                               # joints without position limits
DRAKE = "http://drake.mit.edu"       # the namespace of Drake's URDF extensions (<drake:joint>, its screw pitch)
UNIVERSAL_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))   # Drake's universal joint: about x, then about the turned y
_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def load_urdf(path, *, root_joint=None, gravity=(0.0, 0.0, -9.81), strict: bool = False, locked=None,
              root=None, tips=None, prune=False, max_bytes: int = MAX_BYTES, zero_mass_inertia: str = "keep",
              non_psd_inertia: str = "refuse", mimic: bool = False, joint_dynamics=None):
    """Read a URDF file into a Model (revolute, continuous, prismatic, fixed, floating and planar joints; PyBullet's
    spherical; Drake's ``<drake:joint>`` screw and universal joints: the registry's URDF names, manipdyn.joints).

    Parameters: path to the .urdf file; root_joint None (fixed base) or "free_flyer" (the root link is a
    free body, as Pinocchio's ``buildModelFromUrdf(path, pin.JointModelFreeFlyer())``; see the module
    docstring); gravity (3,) in the base frame; strict=True refuses inertias that violate the triangle
    inequality instead of warning, and elements or a <robot version> it does not read; locked / root / tips
    / prune as in ``manipdyn.reduce`` (model only what the scene needs; with root_joint="free_flyer",
    locked={"root_joint": pose (7,)} fixes the root link at that pose, and ``root`` fixes it at the neutral
    pose); max_bytes: larger files are refused unread; zero_mass_inertia "keep" (a link of mass 0 keeps its
    rotational inertia, as Pinocchio 4.1 does: checked, ``model.inertias`` holds it with m = 0) or "drop"
    (such a link is massless: no inertia at all); non_psd_inertia "refuse" (a body whose inertia is not positive
    semi-definite beyond round-off is a ModelError naming every such body) or "keep" (loaded as Pinocchio, PyBullet
    and Drake load it, with a "non_psd_inertia" quirk naming each body's link and its smallest eigenvalue);
    mimic=True honours <mimic> (returns a MimicModel: mimic joints carry no coordinate, as Pinocchio 4.1's
    ``buildModelFromUrdf(path, mimic=True)``), mimic=False loads them as independent joints; joint_dynamics
    ``{joint: dict(armature=, damping=, friction=)}`` sets or overrides those joints' parameters (the file's
    ``<dynamics damping friction>`` are read; URDF has no armature), ``model.with_joint_dynamics``.
    What the loader noticed is in ``model.quirks`` (see quirks.QUIRK_KINDS) and warned about once per kind.
    Raises URDFError naming the file and element at fault, ModelError for a non-physical body, InputError
    for a root_joint other than None or "free_flyer" or a bad policy value.
    """
    path = os.fspath(path)
    _check_root_joint(root_joint, path)
    _check_policy(zero_mass_inertia, non_psd_inertia, mimic, path)
    if mimic and (locked or root or tips or prune):
        raise InputError(f"{path}: locked/root/tips/prune cannot yet be combined with mimic=True")
    if not os.path.isfile(path):
        raise URDFError(f"{path}: no such URDF file")
    with open(path, "rb") as fh:
        data = fh.read(max_bytes + 1)        # never more than the limit, whatever the file claims
    model = load_urdf_string(data, source=path, root_joint=root_joint, gravity=gravity, strict=strict,
                             max_bytes=max_bytes, zero_mass_inertia=zero_mass_inertia,
                             non_psd_inertia=non_psd_inertia, mimic=mimic, joint_dynamics=joint_dynamics)
    if locked or root or tips or prune:
        from ..reduce import reduce
        model = reduce(model, locked=locked, root=root, tips=tips, prune=prune)
    return model


def load_urdf_string(text, *, source="<string>", root_joint=None, gravity=(0.0, 0.0, -9.81), strict=False,
                     max_bytes: int = MAX_BYTES, zero_mass_inertia: str = "keep", non_psd_inertia: str = "refuse",
                     mimic: bool = False, joint_dynamics=None):
    """Same as load_urdf for URDF text (str or bytes); ``source`` names it in messages."""
    _check_root_joint(root_joint, source)
    _check_policy(zero_mass_inertia, non_psd_inertia, mimic, source)
    data = text.encode() if isinstance(text, str) else bytes(text)
    if len(data) > max_bytes:
        raise URDFError(f"{source}: larger than the size limit of {max_bytes} bytes "
                        f"(pass max_bytes=... to load_urdf to raise it)")
    g = check_gravity(gravity, source)
    quirks = []
    root = parse_xml(data, source, quirks)
    pitches = _drake_joints(root, source)
    _check_xml(root, source, strict, quirks)
    model = _build(_read_elements(root, source), source, g, strict, free=root_joint == "free_flyer",
                   zero_mass_inertia=zero_mass_inertia, non_psd_inertia=non_psd_inertia, quirks=quirks,
                   pitches=pitches)
    model = dataclasses.replace(model, constraints=read_closures(root, model, source),
                                actuated=_actuated(root, model, source))
    quirks += [Quirk("mimic", j, f"= {mult:g} * {t} + {off:g}: " + ("honoured (mimic=True)" if mimic else
                     "loaded as an independent joint (mimic=False)")) for j, t, mult, off in model.mimic]
    order = list(QUIRK_KINDS)
    model = dataclasses.replace(model, quirks=tuple(sorted(quirks, key=lambda q: order.index(q.kind))))
    model = with_joint_dynamics(model, joint_dynamics, source)
    _warn(model, source)
    return _mimic_model(model, source) if mimic else model


def _drake_joints(root, source):
    """Drake's URDF joint extensions read as joints: every <drake:joint> becomes a <joint> (Drake writes its screw and
    universal joints so), and each screw joint's <drake:screw_thread_pitch value> (metres per turn, right-handed) is
    taken out and returned as the helical pitch, metres per radian: {joint name: value / 2π}. URDFError for a screw
    joint without exactly one pitch, or a pitch that is not a finite number within ±MAX_LENGTH."""
    for e in root.findall(f"{{{DRAKE}}}joint"):
        e.tag = "joint"
    out = {}
    for j in root.findall("joint"):
        found = j.findall(f"{{{DRAKE}}}screw_thread_pitch")
        where = f"joint {j.get('name')!r}"
        if j.get("type") == "screw" and len(found) != 1:
            raise URDFError(f"{source}: {where}: a screw joint needs one <drake:screw_thread_pitch value=...> "
                            f"(metres per turn; xmlns:drake=\"{DRAKE}\")")
        for e in found:
            if j.get("type") != "screw":
                raise URDFError(f"{source}: {where}: <drake:screw_thread_pitch> on a {j.get('type')!r} joint")
            x = bounded(numbers(e, "value", 1, where, source), MAX_LENGTH, "pitch", e, "value", where, source)
            if x is None:
                raise URDFError(f"{source}: {where}: <drake:screw_thread_pitch> has no value attribute")
            out[j.get("name")] = float(x[0]) / (2.0 * math.pi)
            j.remove(e)
    return out


def _check_policy(zero_mass_inertia, non_psd_inertia, mimic, source):
    """zero_mass_inertia is "keep" or "drop", non_psd_inertia "refuse" or "keep", mimic a bool; InputError naming
    the accepted values otherwise."""
    if not (isinstance(zero_mass_inertia, str) and zero_mass_inertia in ("keep", "drop")):
        raise InputError(f"{source}: zero_mass_inertia={zero_mass_inertia!r}; accepted values: 'keep' (Pinocchio's "
                         f"behaviour: the rotational inertia of a mass-0 link is kept) or 'drop'")
    if not (isinstance(non_psd_inertia, str) and non_psd_inertia in ("refuse", "keep")):
        raise InputError(f"{source}: non_psd_inertia={non_psd_inertia!r}; accepted values: 'refuse' (the default: a "
                         f"ModelError) or 'keep' (Pinocchio's behaviour: the inertia is loaded as written)")
    if not isinstance(mimic, (bool, np.bool_)):
        raise InputError(f"{source}: mimic={mimic!r}; expected True or False")


_WHAT = {"mimic": "joint", "version": "", "xml_version": "", "unknown_element": ""}
_WARNING = {"triangle": InertiaWarning, "zero_mass_inertia": InertiaWarning, "point_mass": InertiaWarning,
            "non_psd_inertia": InertiaWarning, "free_root": FloatingBaseWarning}


def _warn(model, source):
    """One warning per quirk kind, naming every link or joint of that kind."""
    for kind in QUIRK_KINDS:
        these = [q for q in model.quirks if q.kind == kind]
        if not these:
            continue
        what = _WHAT.get(kind, "link")
        if kind == "free_root":
            text = these[0].detail
        else:
            text = f"{kind} ({len(these)}): " + "; ".join(
                f"{what} {q.name!r}: {q.detail}" if what else q.detail for q in these[:50])
        warnings.warn(f"{source}: {text}", _WARNING.get(kind, QuirkWarning), stacklevel=4)


def _check_root_joint(root_joint, source):
    """root_joint is None (fixed base) or "free_flyer"; InputError naming the accepted values otherwise."""
    if not (root_joint is None or (isinstance(root_joint, str) and root_joint in ROOT_JOINTS)):
        raise InputError(f"{source}: root_joint={root_joint!r}; accepted values: None (fixed base) or "
                         f"'free_flyer' (the root link is a free body, Pinocchio's JointModelFreeFlyer)")


def _read_elements(root, source):
    """yourdfpy's readers applied to each <link> and <joint> of the checked tree: a yourdfpy Robot.

    <visual> and <collision> are removed first: the dynamics never use them (manipdyn.viz reads them
    when a viewer asks), so a broken visual does not stop the model loading, as in Pinocchio.
    """
    for e in root.findall("link/visual") + root.findall("link/collision"):
        e.getparent().remove(e)
    robot = yourdfpy.Robot(name=root.get("name"))
    for kind, read, out in (("link", yourdfpy.URDF._parse_link, robot.links),
                            ("joint", yourdfpy.URDF._parse_joint, robot.joints)):
        for e in root.findall(kind):
            try:
                out.append(read(e))
            except Exception as exc:  # yourdfpy raises bare KeyError/ValueError on malformed elements
                raise URDFError(f"{source}: {kind} {e.get('name')!r} cannot be read: {exc!r}") from exc
    return robot


# ---- checks on the raw XML, before yourdfpy (whose float() is not the URDF grammar) reads it -------------

def _check_origin(e, where, source):
    """<origin xyz rpy>: three numbers each, xyz within ±MAX_LENGTH metres."""
    bounded(numbers(e, "xyz", 3, where, source), MAX_LENGTH, "coordinate", e, "xyz", where, source)
    numbers(e, "rpy", 3, where, source)


# Elements the loader reads or knowingly leaves to other tools; anything else is an "unknown_element" quirk.
ROBOT_CHILDREN = {"link", "joint", "material", "transmission", "gazebo", "ros2_control", *CLOSURE_TAGS}
LINK_CHILDREN = {"inertial", "visual", "collision"}
JOINT_CHILDREN = {"parent", "child", "origin", "axis", "limit", "dynamics", "mimic", "calibration",
                  "safety_controller"}
INERTIAL_CHILDREN = {"origin", "mass", "inertia"}
URDFDOM_VERSIONS = ((1, 0), (1, 2))   # urdfdom 6.0 (Pinocchio 4.1's reader) accepts "x.y" from 1.0 to 1.2


def _check_version(root, source, strict, quirks):
    """<robot version>: urdfdom 6.0 reads "x.y" (two non-negative integers, surrounding spaces allowed) and
    accepts 1.0 to 1.2, refusing "0.0", "2.0", "1", "1.0.0", "foo" (checked with pin 4.1). No element manipdyn
    reads changed meaning between those versions except 1.1's quat_xyzw origins, which are refused wherever
    they appear. Any other version string is loaded with a "version" quirk (an error with strict=True)."""
    text = root.get("version")
    if text is None:
        return
    parts = text.strip().split(".")
    ok = len(parts) == 2 and all(re.fullmatch(r"[0-9]+", x) for x in parts)
    if ok and URDFDOM_VERSIONS[0] <= (int(parts[0]), int(parts[1])) <= URDFDOM_VERSIONS[1]:
        return
    why = ("not of the form 'x.y'" if not ok else "outside 1.0-1.2")
    detail = (f"<robot version={show(text)}>: {why}; urdfdom 6 (Pinocchio 4.1) refuses the file, manipdyn reads "
              f"it as URDF 1.0")
    if strict:
        raise URDFError(f"{source}: {detail} (strict=True)")
    quirks.append(Quirk("version", "robot", detail))


def _check_unknown(root, source, strict, quirks):
    """Every element the loader does not know is reported by its path (an error with strict=True)."""
    def tag(e):
        return e.tag if isinstance(e.tag, str) else None     # comments and processing instructions: skipped
    found = []
    for e in root:
        t = tag(e)
        if t is None:
            continue
        if t not in ROBOT_CHILDREN:
            found.append((f"<{t}>", f"<{t} name={e.get('name')!r}> under <robot>"))
            continue
        known = {"link": LINK_CHILDREN, "joint": JOINT_CHILDREN}.get(t)
        for c in (e if known else ()):
            if tag(c) is not None and tag(c) not in known:
                found.append((f"{t} {e.get('name')!r}/<{tag(c)}>", f"<{tag(c)}> in {t} {e.get('name')!r}"))
            if tag(c) == "inertial":
                found += [(f"{t} {e.get('name')!r}/inertial/<{tag(x)}>", f"<{tag(x)}> in the <inertial> of "
                           f"{t} {e.get('name')!r}") for x in c if tag(x) is not None and tag(x) not in INERTIAL_CHILDREN]
    for e in root.iter("origin"):
        if e.get("quat_xyzw") is not None:
            raise URDFError(f"{source}: an <origin quat_xyzw=...> (URDF 1.1) is not supported: use rpy")
    if found and strict:
        raise URDFError(f"{source}: elements manipdyn does not read (strict=True): "
                        + ", ".join(w for _, w in found[:20]))
    quirks += [Quirk("unknown_element", name, f"{where}: not read by manipdyn") for name, where in found]


def _check_xml(root, source, strict=False, quirks=None):
    """What urdfdom requires and yourdfpy silently defaults or misreads: names, links, numbers, bounds;
    the version and unknown elements go to ``quirks`` (errors with strict=True).

    Visual and collision elements are not checked: the dynamics never read them (see _read_elements).
    """
    if not root.get("name"):
        raise URDFError(f"{source}: <robot> has no name attribute")
    quirks = [] if quirks is None else quirks
    _check_version(root, source, strict, quirks)
    _check_unknown(root, source, strict, quirks)
    joints, links = root.findall("joint"), root.findall("link")
    _check_names(joints, links, source)
    names = {j.get("name") for j in joints}
    for j in joints:
        _dangling_mimic(j, names, source, strict, quirks)
        _check_joint(j, names, source, strict, quirks)
    balls = {j.get("name") for j in joints if j.get("type") == "spherical"}
    for j in joints:
        for e in j.findall("mimic"):
            if e.get("joint") in balls:
                raise URDFError(f"{source}: joint {j.get('name')!r}: <mimic joint={e.get('joint')!r}> names a "
                                f"spherical joint (a mimic relates angles or displacements)")
    for link in links:
        _check_link(link, source)


def _check_names(joints, links, source):
    """Every link and joint has a name, and no two of a kind share one (counted once: linear time)."""
    for kind, elements in (("link", links), ("joint", joints)):
        count = Counter(e.get("name") for e in elements)
        if None in count:
            raise URDFError(f"{source}: a <{kind}> has no name attribute")
        dup = sorted(n for n, k in count.items() if k > 1)
        if dup:
            raise URDFError(f"{source}: duplicate {kind} name(s): {', '.join(dup[:20])}")


def _check_joint(j, joint_names, source, strict=False, quirks=None):
    """One <joint>: links, type, origin, axis, limit and mimic, as urdfdom requires them."""
    name, kind = j.get("name"), j.get("type")
    where = f"joint {name!r}"
    for tag in ("parent", "child"):
        e = j.find(tag)
        if e is None or not e.get("link"):
            raise URDFError(f"{source}: {where} has no <{tag} link=...>")
    if kind is None:
        raise URDFError(f"{source}: {where} has no type attribute")
    if kind not in SUPPORTED:
        raise URDFError(f"{source}: {where}: type {kind!r}: unknown joint type (known: "
                        f"{', '.join(sorted(SUPPORTED))})")
    for e in j.findall("origin"):
        _check_origin(e, where, source)
    for e in j.findall("axis"):
        _check_axis(e, where, source, moving=kind not in ("fixed",) + _NO_AXIS)
    limits = j.findall("limit")
    if not limits and kind in ("revolute", "prismatic"):
        raise URDFError(f"{source}: {where}: a {kind} joint needs <limit effort=... velocity=...> "
                        f"(URDF specification; Pinocchio's reader refuses it too)")
    for e in limits:
        _check_limit(e, where, kind, source, strict, quirks)
    for e in j.findall("mimic"):
        _check_mimic(e, name, joint_names, source)
        if kind in ("spherical", "floating", "planar", "universal"):     # (a fixed joint's <mimic>: ignored)
            raise URDFError(f"{source}: {where}: a {kind} joint cannot be a <mimic> joint (a mimic relates angles "
                            f"or displacements)")
    for e in j.findall("dynamics"):            # Model.damping, Model.friction (docs/design.md §3, Joint dynamics)
        for k in ("damping", "friction"):
            x = numbers(e, k, 1, where, source)
            if x is not None and not 0.0 <= x[0] <= MAX_MASS:
                raise URDFError(f"{source}: {where}: <dynamics {k}={x[0]!r}>: must be >= 0 and <= {MAX_MASS:g}")


def _check_axis(e, where, source, moving):
    """<axis xyz>: three numbers, not all zero on a moving joint (urdfdom reads a bare <axis> as zero)."""
    if e.get("xyz") is None:
        raise URDFError(f"{source}: {where}: <axis> has no xyz attribute")
    a = numbers(e, "xyz", 3, where, source)
    if moving and not any(a):
        raise URDFError(f"{source}: {where}: <axis xyz={show(e.get('xyz'))}> has no direction")


def _check_limit(e, where, kind, source, strict=False, quirks=None):
    """<limit>: effort and velocity given and >= 0; prismatic limits within MAX_LENGTH; lower > upper is read as no
    limit with an "inverted_limits" quirk (PyBullet's reading; urdfdom keeps the numbers), an error with strict."""
    values = {k: numbers(e, k, 1, where, source) for k in ("lower", "upper", "effort", "velocity")}
    for k in ("effort", "velocity"):
        if values[k] is None:
            raise URDFError(f"{source}: {where}: <limit> has no {k} attribute (URDF specification)")
        if values[k][0] < 0:
            raise URDFError(f"{source}: {where}: <limit {k}={show(e.get(k))}>: must be >= 0")
    lo, hi = (values[k][0] if values[k] else 0.0 for k in ("lower", "upper"))   # URDF default: 0
    if kind == "prismatic":
        for k in ("lower", "upper"):
            bounded(values[k], MAX_LENGTH, "limit", e, k, where, source)
    if lo > hi:
        detail = f"<limit lower={show(e.get('lower', '0'))} upper={show(e.get('upper', '0'))}>: lower > upper"
        if strict or quirks is None:
            raise URDFError(f"{source}: {where}: {detail} (strict=True; by default it is read as no limit)")
        quirks.append(Quirk("inverted_limits", where.split(" ", 1)[1].strip("'"),
                            f"{detail}: read as no position limit, as PyBullet reads it"))
        e.set("lower", "-inf")                 # what yourdfpy's float() then reads; the grammar checks ran above
        e.set("upper", "inf")


def _dangling_mimic(j, joint_names, source, strict, quirks):
    """A <mimic joint=...> naming no joint of the file (example-robot-data's alex_psyonic_hands has one):
    the mimic is dropped with a "mimic" quirk, as Pinocchio, PyBullet and MuJoCo load the file; an error with
    strict=True. A mimic without a joint attribute, or of itself, stays an error (_check_mimic)."""
    for e in j.findall("mimic"):
        target = e.get("joint")
        if target is None or target in joint_names:
            continue
        detail = f"<mimic joint={target!r}> names no joint of the file: ignored, the joint moves on its own"
        if strict:
            raise URDFError(f"{source}: joint {j.get('name')!r}: {detail} (strict=True)")
        quirks.append(Quirk("mimic", j.get("name"), detail))
        j.remove(e)


def _check_mimic(e, name, joint_names, source):
    """<mimic joint multiplier offset>: the mimicked joint exists and is another joint; finite numbers."""
    where, target = f"joint {name!r}", e.get("joint")
    if target is None or target not in joint_names:
        raise URDFError(f"{source}: {where}: <mimic joint={target!r}> names no joint of the file")
    if target == name:
        raise URDFError(f"{source}: {where}: <mimic joint={target!r}> mimics itself")
    for k in ("multiplier", "offset"):
        numbers(e, k, 1, where, source)


def _check_link(link, source):
    """One <link>: inertial (mass, six moments, origin) within bounds; visual/collision origins. A <mass> without
    <inertia> is a point mass (a "point_mass" quirk, _inertial_quirks); an <inertia> lacking a moment is refused."""
    where = f"link {link.get('name')!r}"
    for inertial in link.findall("inertial"):
        masses, inertias = inertial.findall("mass"), inertial.findall("inertia")
        if not masses or any(m.get("value") is None for m in masses):
            raise URDFError(f"{source}: {where}: <inertial> without <mass value=...>")
        if any(e.get(k) is None for e in inertias for k in _INERTIA_KEYS):
            raise URDFError(f"{source}: {where}: <inertia> needs all of {', '.join(_INERTIA_KEYS)}")
        for e in masses:
            m = numbers(e, "value", 1, where, source)[0]
            if m < 0:
                raise URDFError(f"{source}: {where}: negative mass {m:g} (<mass value={show(e.get('value'))}>)")
            bounded([m], MAX_MASS, "mass (kg)", e, "value", where, source)
        for e in inertias:
            for k in _INERTIA_KEYS:
                bounded(numbers(e, k, 1, where, source), MAX_INERTIA, "inertia (kg m²)", e, k, where, source)
        for e in inertial.findall("origin"):
            _check_origin(e, where, source)


def _tree(robot, source):
    """Children of each link (joints sorted by name) and the single root link; errors name the culprit."""
    links = {l.name: l for l in robot.links}
    children, parent_of = {name: [] for name in links}, {}
    for j in sorted(robot.joints, key=lambda j: j.name):
        for role, link in (("parent", j.parent), ("child", j.child)):
            if link not in links:
                raise URDFError(f"{source}: joint {j.name!r}: {role} link {link!r} is not defined")
        if j.child in parent_of:
            raise URDFError(f"{source}: link {j.child!r} is the child of two joints, "
                            f"{parent_of[j.child].name!r} and {j.name!r} (a loop: declare it as a "
                            f"<constraint> instead)")
        parent_of[j.child] = j
        children[j.parent].append(j)
    roots = [name for name in links if name not in parent_of]
    if len(roots) != 1:
        if not roots:
            raise URDFError(f"{source}: no root link: the joints form a cycle")
        raise URDFError(f"{source}: several root links: {', '.join(roots[:20])} (a URDF is one tree)")
    return links, children, roots[0]


def _walk(children, root):
    """Depth-first pre-order from the root, children in joint-name order, without recursion.

    Yields (joint, link): the joint (None for the root) and the link it carries; a link comes after
    its parent and before its siblings' subtrees, as a recursive walk would give them.
    """
    stack = [(None, root)]
    while stack:
        j, link = stack.pop()
        yield j, link
        stack.extend((c, c.child) for c in reversed(children[link]))


def _build(robot, source, gravity, strict, free=False, zero_mass_inertia="keep", non_psd_inertia="refuse",
           quirks=None, pitches=None) -> Model:
    """Walk the tree from the root, numbering moving joints depth-first and merging fixed-joint links.

    free: the root link is body 0, carried by a free flyer (joint 0, parent −1); else the fixed base −1.
    A ``floating`` joint is a free flyer too: it must hang from the fixed base (the root link and links fixed to it).
    A ``universal`` joint is expanded into the two revolute joints it is (joints.universal_pair): "<joint>.1" about
    x, carrying a massless body "<child link>:<joint>.1", and "<joint>.2" about y of that body, carrying the child
    (the MJCF reader's names for the joints of one body).
    Inertial quirks (non-PSD ones with non_psd_inertia="keep", and the free-root one) are appended to ``quirks``;
    pitches: {screw joint: pitch, m/rad} (``_drake_joints``)."""
    quirks = [] if quirks is None else quirks
    links, children, root = _tree(robot, source)
    joints, parts, frames, merged, notes = [], {-1: []}, {}, {root: []}, []
    names = {j.name for j in robot.joints}
    if free:
        if any(j.name == ROOT_JOINT_NAME and j.type in MOVING for j in robot.joints):
            raise URDFError(f"{source}: joint {ROOT_JOINT_NAME!r} exists already; the free flyer needs the name")
        joints.append((yourdfpy.Joint(name=ROOT_JOINT_NAME, type="free_flyer", parent=None, child=root),
                       -1, np.eye(3), np.zeros(3)))
        parts[0] = []
    for j, link in _walk(children, root):
        if j is None:                      # the root: the fixed base -1, or the free flyer's body 0
            body, R, p = (0 if free else -1), np.eye(3), np.zeros(3)
        else:                              # (R, p): pose of `link` in the frame of `body`
            fp = frames[j.parent]
            Ro, po = (np.eye(3), np.zeros(3)) if j.origin is None else (j.origin[:3, :3], j.origin[:3, 3])
            body, R, p = fp.body, fp.R @ Ro, fp.p + fp.R @ po
            if j.type == "fixed":
                merged[root if body < 0 else joints[body][0].child].append(link)
            elif j.type == "floating" and (body >= 0 or free):
                raise URDFError(f"{source}: joint {j.name!r}: a floating joint must hang from the fixed base "
                                + ("(root_joint='free_flyer' already frees the root link: load without it)" if free
                                   else f"(the root link {root!r}); its parent {j.parent!r} moves"))
            elif j.type == "universal":
                mid = f"{link}:{j.name}.1"        # the MJCF reader's name for a body between two joints
                taken = [x for x in (mid, f"{j.name}.1", f"{j.name}.2") if x in links or x in names]
                if taken:
                    raise URDFError(f"{source}: joint {j.name!r}: the universal joint's two revolute joints and its "
                                    f"middle body need the names {j.name}.1, {j.name}.2, {mid}; {taken[0]!r} is taken")
                (_, a1), (_, a2) = universal_pair(*UNIVERSAL_AXES)
                turn = yourdfpy.Limit(effort=math.inf, velocity=math.inf, lower=-math.inf, upper=math.inf)
                joints.append((yourdfpy.Joint(name=f"{j.name}.1", type="revolute", parent=j.parent, child=mid,
                                              axis=a1, limit=turn, dynamics=j.dynamics), body, R, p))
                parts[len(joints) - 1], merged[mid] = [(0.0, np.zeros(3), np.zeros((3, 3)))], []   # massless
                frames[mid] = Frame(mid, len(joints) - 1, np.eye(3), np.zeros(3))
                joints.append((yourdfpy.Joint(name=f"{j.name}.2", type="revolute", parent=mid, child=link, axis=a2,
                               limit=turn, dynamics=j.dynamics), len(joints) - 1, np.eye(3), np.zeros(3)))
                body, R, p = len(joints) - 1, np.eye(3), np.zeros(3)
                parts[body], merged[link] = [], []
            else:
                joints.append((j, body, R, p))
                body, R, p = len(joints) - 1, np.eye(3), np.zeros(3)
                parts[body], merged[link] = [], []
        frames[link] = Frame(link, body, R, p)
        parts[body].append(_link_inertia(links[link], R, p, source, zero_mass_inertia))
    unreached = sorted(set(links) - set(frames))
    if unreached:                          # every link has one parent, yet some hang off no root: a cycle
        raise URDFError(f"{source}: links {', '.join(unreached[:20])} are not connected to the root link "
                        f"{root!r}: their joints form a cycle")
    link_I = [parts[f.body][k][2] for f, k in _part_index(frames, parts)]
    quirks += _inertial_quirks(links, root, joints, free, zero_mass_inertia)
    bad = _triangle(link_I, list(frames), source, strict)
    quirks += [Quirk("triangle", name, msg) for name, msg in bad]
    notes += [f"link {name!r}: {msg}" for name, msg in bad]
    if not free:
        note = _fixed_base_note(root, merged[root], parts[-1])
        notes += note
        why = _free_root_shape(root, joints, frames, parts, gravity) if note else None
        if why:
            quirks.append(Quirk("free_root", root, f"{note[0]}; it looks free: {why}"))
    return _assemble(robot, source, gravity, root, joints, parts, frames, merged, notes, non_psd_inertia, quirks,
                     pitches or {})


def _inertial_quirks(links, root, joints, free, policy):
    """zero_mass_inertia, point_mass, no_inertial and rotated_root_inertial quirks of the links (see
    quirks.QUIRK_KINDS)."""
    out = []
    for name, link in links.items():
        x = link.inertial
        if x is not None and x.mass is not None and x.inertia is None:
            c = (x.origin if x.origin is not None else np.eye(4))[:3, 3]
            out.append(Quirk("point_mass", name, f"<mass value={float(x.mass):g}> without <inertia>: a point mass "
                             f"at <origin xyz> {c.tolist()} (zero rotational inertia about it, as Pinocchio 4.1 "
                             f"reads it)"))
        elif x is not None and x.mass is not None and float(x.mass) == 0.0 and np.any(np.asarray(x.inertia, float)):
            what = ("kept (Pinocchio's behaviour: the body has rotational inertia without mass)" if policy == "keep"
                    else "dropped (zero_mass_inertia='drop': the link is massless)")
            out.append(Quirk("zero_mass_inertia", name, f"mass 0, inertia diagonal "
                             f"{np.diag(np.asarray(x.inertia, float)).tolist()}: {what}"))
    carried = [j.child for j, *_ in joints if j.type != "free_flyer" and j.child in links] + ([root] if free else [])
    out += [Quirk("no_inertial", c, "no <inertial>: a massless link" + (" on a moving joint" if c != root else ""))
            for c in carried if links[c].inertial is None]
    x = links[root].inertial
    if x is not None and x.origin is not None and not np.allclose(x.origin[:3, :3], np.eye(3), rtol=0, atol=1e-12):
        out.append(Quirk("rotated_root_inertial", root, "the root link's <inertial><origin rpy> is not zero (its "
                         "inertia is rotated into the link frame here, as Pinocchio does)"))
    return out


HANG = 0.6   # a subtree "hangs" when its lowest frame is below the root by >= HANG x the robot's extent


def _free_root_shape(root, joints, frames, parts, gravity):
    """Why a fixed-base tree whose root carries mass looks like a free body, or None (docs/design.md §8: measured on the
    zoo, at q = 0, "below" along gravity, extent = the largest distance of a link frame from the root):
    - legs: two or more of the root's subtrees hang (lowest frame >= HANG extent below the root): every
      legged robot and humanoid of example-robot-data (feet at 0.75-1.0 extent); no arm has two (at most one:
      talos_left_arm, hanging from its shoulder);
    - a heavy body with a hanging appendage: one subtree hangs and the root holds half the mass or more
      (the flying arms borinot 0.91, hextilt 0.77; talos_left_arm's shoulder holds 0.15);
    - nothing moves: no joint at all (a lone body: quadrotor, iris_simple)."""
    if not joints:
        return "no joint moves it (a lone body)"
    down = np.asarray(gravity, float)
    down = down / np.linalg.norm(down) if np.any(down) else np.array([0.0, 0.0, -1.0])
    Rw, pw, top = [], [], []
    for i, (_, b, R, p) in enumerate(joints):
        Rb, pb = (np.eye(3), np.zeros(3)) if b < 0 else (Rw[b], pw[b])
        Rw.append(Rb @ R)
        pw.append(pb + Rb @ p)
        top.append(i if b < 0 else top[b])
    pts = [(top[f.body], pw[f.body] + Rw[f.body] @ f.p) for f in frames.values() if f.body >= 0]
    extent = max(np.linalg.norm(x) for x in [x for _, x in pts] + [f.p for f in frames.values() if f.body < 0])
    low = {}
    for t, x in pts:
        low[t] = max(low.get(t, -np.inf), float(x @ down))       # depth below the root, along gravity
    hanging = sum(d >= HANG * extent for d in low.values()) if extent > 0 else 0
    m_root = sum(mk for mk, _, _ in parts[-1])
    m_all = m_root + sum(mk for b, ps in parts.items() if b >= 0 for mk, _, _ in ps)
    if hanging >= 2:
        return f"{hanging} of the root's {len(low)} subtrees hang below it (legs)"
    if hanging == 1 and m_root >= 0.5 * m_all:
        return (f"one subtree hangs below a root holding {m_root / m_all:.0%} of the mass (a heavy body with a "
                f"hanging appendage)")
    return None


def _fixed_base_note(root, merged, parts):
    """A note when the fixed base carries mass (rule: root body mass > 0, root link not named "world")."""
    m = sum(mk for mk, _, _ in parts)
    if m <= 0.0 or root == "world":
        return []
    fixed = f" with the links fixed to it ({', '.join(merged)})" if merged else ""
    return [f"root link {root!r}{fixed} carries {m:.6g} kg that no joint moves: as the fixed base its mass "
            f"and inertia have no effect on the dynamics (Pinocchio attaches them to the universe likewise); "
            f"if it is a free body, load with root_joint=\"free_flyer\""]


def _part_index(frames, parts):
    """(frame, k) for every link: its inertia is parts[frame.body][k] (links were added in frame order)."""
    seen = dict.fromkeys(parts, 0)
    for f in frames.values():
        yield f, seen[f.body]
        seen[f.body] += 1


def _assemble(robot, source, gravity, root, joints, parts, frames, merged, notes, non_psd_inertia="refuse",
              quirks=None, pitches=None) -> Model:
    """The Model's arrays from the walk's joints (joint, parent body, R0, p0) and merged body parts; with
    non_psd_inertia="keep", a "non_psd_inertia" quirk per body whose inertia is not PSD goes to ``quirks``."""
    nb = len(joints)                       # joints = bodies (a free flyer included)
    quirks = [] if quirks is None else quirks
    axes = [_unit_axis(j, source, notes) for j, *_ in joints]
    inertias = [combine_inertias(parts[i]) for i in range(nb)]
    what = [f"fixed base {root!r} (with merged links {', '.join(merged[root]) or 'none'})"]
    for j, *_ in joints:
        extra = f" (with merged links {', '.join(merged[j.child])})" if merged[j.child] else ""
        what.append(f"body {j.child!r}{extra}")
    base = [combine_inertias(parts[-1])[2]] if parts[-1] else [np.zeros((3, 3))]   # free: no fixed base
    links = [root] + [j.child for j, *_ in joints]          # the link that names each body (fixed base first)
    for i, lam in _check_psd(base + [I for _, _, I in inertias], what, source, non_psd_inertia):
        quirks.append(Quirk("non_psd_inertia", links[i], f"{what[i]}: inertia not positive semi-definite, smallest "
                            f"eigenvalue {lam[0]:.6g} kg m² (eigenvalues {lam.tolist()}): kept "
                            f"(non_psd_inertia='keep', as Pinocchio, PyBullet and Drake load it)"))
    lim = np.array([_limits(j) for j, *_ in joints], float).reshape(nb, 4)
    mimic = tuple((j.name, j.mimic.joint, float(j.mimic.multiplier), float(j.mimic.offset or 0.0))
                  for j, *_ in joints if j.mimic is not None)
    if mimic:
        notes.append(f"{len(mimic)} mimic joint(s) loaded as independent joints (Pinocchio's default): "
                     + ", ".join(m[0] for m in mimic))
    return Model(
        name=robot.name or os.path.basename(source), root_link=root,
        joint_names=tuple(j.name for j, *_ in joints), body_names=tuple(j.child for j, *_ in joints),
        parent=np.array([b for _, b, _, _ in joints], int).reshape(nb),
        kind=np.array([_KIND[j.type] for j, *_ in joints], int).reshape(nb),
        continuous=np.array([j.type == "continuous" for j, *_ in joints], bool).reshape(nb),
        axis=np.array(axes, float).reshape(nb, 3),
        R0=np.array([R for *_, R, _ in joints], float).reshape(nb, 3, 3),
        p0=np.array([p for *_, p in joints], float).reshape(nb, 3),
        mass=np.array([m for m, _, _ in inertias], float).reshape(nb),
        com=np.array([c for _, c, _ in inertias], float).reshape(nb, 3),
        inertia=np.array([I for _, _, I in inertias], float).reshape(nb, 3, 3),
        lower=lim[:, 0], upper=lim[:, 1], effort=lim[:, 2], velocity=lim[:, 3],
        gravity=np.array(gravity, float).reshape(3), frames=frames,
        merged={k: tuple(v) for k, v in merged.items()}, mimic=mimic, source=source, notes=tuple(notes),
        damping=_dynamics(joints, "damping"), friction=_dynamics(joints, "friction"),
        pitch=np.array([(pitches or {}).get(j.name, 0.0) for j, *_ in joints], float).reshape(nb))


def _dynamics(joints, key):
    """<dynamics damping|friction> per velocity (nv,): 0 where absent; a free flyer's six entries are 0, a spherical
    joint's three take its value."""
    out = []
    for j, *_ in joints:
        if j.type in ("free_flyer", "floating"):
            out += [0.0] * 6
        else:
            x = getattr(j.dynamics, key, None) if j.dynamics is not None else None
            out += [float(x or 0.0)] * KINDS[_KIND[j.type]].nv
    return np.array(out, float)


def _unit_axis(j, source, notes):
    """The joint's unit axis (3,); scaled by its largest component first, so 1e200 or 1e-200 cannot
    overflow or underflow the norm. A zero axis is refused (checked on the XML already). A free flyer and a
    spherical joint have none (zeros)."""
    if j.type in _NO_AXIS:
        return np.zeros(3)
    a = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
    scale = np.max(np.abs(a)) if a.shape == (3,) else 0.0
    if not (np.isfinite(scale) and scale > 0):
        raise URDFError(f"{source}: joint {j.name!r}: axis {a.tolist()} has no direction")
    u = a / scale
    u = u / np.linalg.norm(u)
    if abs(np.linalg.norm(a / scale) * scale - 1.0) > 1e-9:
        notes.append(f"joint {j.name!r}: axis {a.tolist()} normalised")
    return u


def _limits(j):
    """(lower, upper, effort, velocity): continuous joints are unbounded, a missing lower/upper is 0 (the
    URDF default, as urdfdom reads it), a continuous joint without <limit> has unbounded effort/velocity, a
    free flyer and a spherical joint are unbounded."""
    if j.type in _UNBOUNDED or (j.type == "screw" and j.limit is None):
        return -np.inf, np.inf, np.inf, np.inf
    L = j.limit
    get = lambda v, d: d if (L is None or v is None) else float(v)  # noqa: E731
    lo, hi = (-np.inf, np.inf) if j.type == "continuous" else (get(L and L.lower, 0.0), get(L and L.upper, 0.0))
    return lo, hi, get(L and L.effort, np.inf), get(L and L.velocity, np.inf)


def _link_inertia(link, R, p, source, zero_mass_inertia="keep"):
    """(m, c, I_c) of a URDF link in the frame where the link sits at (R, p); checks mass and moments.
    A link of mass 0 keeps its rotational inertia ("keep", Pinocchio) or has none ("drop"); a <mass> without
    <inertia> is a point mass at the <inertial> origin (I_c = 0, as Pinocchio 4.1 reads it)."""
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        return 0.0, p.copy(), np.zeros((3, 3))
    m = float(inertial.mass)
    if m < 0:
        raise URDFError(f"{source}: link {link.name!r}: negative mass {m}")
    if m == 0.0 and zero_mass_inertia == "drop":
        return 0.0, p.copy(), np.zeros((3, 3))
    To = inertial.origin if inertial.origin is not None else np.eye(4)
    if inertial.inertia is None:              # a point mass (checked on the XML: no <inertia> element at all)
        return m, p + R @ To[:3, 3], np.zeros((3, 3))
    I = To[:3, :3] @ np.asarray(inertial.inertia, float) @ To[:3, :3].T
    return m, p + R @ To[:3, 3], R @ I @ R.T


def _check_psd(Is, what, source, policy="refuse"):
    """Inertias Is (n, 3, 3) must be positive semi-definite beyond round-off: smallest eigenvalue >=
    -1e-12 trace - 1e-18 kg m² (round-off on massless bodies). With policy "refuse", ModelError names every one
    that is not, what[i], and the policy that loads them; with "keep", returns [(i, eigenvalues (3,) ascending)]
    of each."""
    Is = np.asarray(Is, float).reshape(-1, 3, 3)
    lam = np.linalg.eigvalsh(Is)
    tr = np.maximum(np.trace(Is, axis1=1, axis2=2), 0.0)
    bad = np.flatnonzero(lam[:, 0] < -1e-12 * tr - 1e-18)
    if len(bad) and policy != "keep":
        raise ModelError(f"{source}: {len(bad)} inertia(s) not positive semi-definite: "
                         + "; ".join(f"{what[i]}: eigenvalues {lam[i].tolist()}" for i in bad[:50])
                         + "; pass non_psd_inertia='keep' to load them as Pinocchio does")
    return [(int(i), lam[i]) for i in bad]


def _triangle(Is, links, source, strict):
    """Principal moments of a physical body satisfy I1 + I2 >= I3: [(link, message)] for every link that
    violates it (ModelError naming all of them if strict).

    Is (n, 3, 3) per link, links (n,) their names. Non-PSD inertias are reported per body, later."""
    lam = np.linalg.eigvalsh(np.asarray(Is, float).reshape(-1, 3, 3))       # ascending
    tol = 1e-9 * np.maximum(np.sum(np.abs(lam), axis=1), 1e-300)
    bad = [(links[i], f"principal moments {lam[i].tolist()} violate the triangle inequality I1 + I2 >= I3 "
                      f"({lam[i, 0] + lam[i, 1]:.6g} < {lam[i, 2]:.6g})")
           for i in np.flatnonzero((lam[:, 0] >= -tol) & (lam[:, 0] + lam[:, 1] < lam[:, 2] - tol))]
    if bad and strict:
        raise ModelError(f"{source}: {len(bad)} link(s) violate the triangle inequality: "
                         + "; ".join(f"link {n!r}: {m}" for n, m in bad[:50]))
    return bad


def _actuated(root, model, source):
    """Joints named in <transmission> elements, and (URDF+) moving joints not marked independent="false" when
    any joint carries the attribute (its default is true), in q order."""
    names = {j.get("name") for t in root.findall("transmission") for j in t.findall("joint")}
    marked = {j.get("name"): j.get("independent") for j in root.findall("joint") if j.get("independent") is not None}
    for name, value in marked.items():
        if value not in ("true", "false"):
            raise URDFError(f"{source}: joint {name!r}: independent={show(value)}; expected \"true\" or \"false\"")
    if marked:
        names |= {j for j in model.joint_names if marked.get(j, "true") == "true" and j != ROOT_JOINT_NAME}
    return tuple(j for j in model.joint_names if j in names)   # others (fixed or absent) are ignored


def _mimic_model(model, source):
    """The MimicModel of a tree with <mimic> joints: q_m = multiplier q_t + offset, resolved through chains
    (a mimic of a mimic); q order = the tree's with the mimic joints removed (Pinocchio 4.1's order)."""
    rule = {j: (t, mult, off) for j, t, mult, off in model.mimic}
    for j in rule:                                        # a mimic joint must be a moving joint of the tree
        for n in (j, rule[j][0]):
            if n not in model.joint_names:
                raise URDFError(f"{source}: mimic joint {j!r}: {n!r} is not a moving joint of the tree")
    idx = {n: i for i, n in enumerate(model.joint_names)}
    free = [n for n in model.joint_names if n not in rule]
    col = {n: k for k, n in enumerate(free)}
    nv_full, nq_full = model.nv, model.nq
    G, off = np.zeros((nv_full, len(free) + (model.nv - model.njoints))), np.zeros(nq_full)
    Gq = np.zeros((nq_full, len(free) + (model.nq - model.njoints)))
    ff = 1 if model.floating else 0                       # a free flyer (joint 0): 7 q, 6 v, identity blocks
    if ff:
        G[:6, :6], Gq[:7, :7] = np.eye(6), np.eye(7)
    shift_v, shift_q = (5, 6) if ff else (0, 0)           # extra columns of the free flyer
    for n in model.joint_names[ff:]:
        seen, t, mult, c = {n}, n, 1.0, 0.0               # follow the chain: q_n = mult q_t + c
        while t in rule:
            t2, m2, o2 = rule[t]
            if t2 in seen:
                raise URDFError(f"{source}: mimic joints {sorted(seen)} mimic each other in a cycle")
            seen.add(t2)
            mult, c, t = mult * m2, c + mult * o2, t2
        i, k = idx[n], col[t]
        G[model.idx_v[i], k + shift_v] = mult
        Gq[model.idx_q[i], k + shift_q] = mult
        off[model.idx_q[i]] = c
    notes = tuple(x for x in model.notes if "mimic joint(s) loaded as independent" not in x)
    full = dataclasses.replace(model, notes=notes + (f"mimic joints honoured (mimic=True): "
                                                     f"{', '.join(rule)}",))
    return MimicModel(full, G, Gq, off, tuple(free), model.mimic)
