"""URDF -> Model. The only module that reads robot XML.

The file is parsed once with a hardened parser (no DTD, no entities, no network), its elements are read by
yourdfpy, and the tree is walked the way Pinocchio's URDF reader walks it: depth-first from the root link,
the child joints of a link in the order of their names (urdfdom keeps joints in a map sorted by name),
fixed joints merged into the moving body they hang from. The walk is implemented here; Pinocchio is
never imported.
"""
from __future__ import annotations

import dataclasses
import io
import os
import warnings

import numpy as np
import yourdfpy
from lxml import etree

from ..errors import InertiaWarning, ModelError, URDFError
from ..model import PRISMATIC, REVOLUTE, Constraint, Frame, Model
from ..spatial import combine_inertias, rpy_matrix

MOVING = {"revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}
SUPPORTED = set(MOVING) | {"fixed"}
_INERTIA_KEYS = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def load_urdf(path, *, gravity=(0.0, 0.0, -9.81), strict: bool = False, locked=None, root=None, tips=None,
              prune=False) -> Model:
    """Read a URDF file into a Model (fixed base; revolute, continuous, prismatic and fixed joints).

    Parameters: path to the .urdf file; gravity (3,) in the base frame; strict=True refuses inertias that
    violate the triangle inequality instead of warning; locked / root / tips / prune as in
    ``manipdyn.reduce`` (model only what the scene needs).
    Raises URDFError naming the file and element at fault, ModelError for a non-physical body.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise URDFError(f"{path}: no such URDF file")
    with open(path, "rb") as fh:
        model = load_urdf_string(fh.read(), source=path, gravity=gravity, strict=strict)
    if locked or root or tips or prune:
        from ..reduce import reduce
        model = reduce(model, locked=locked, root=root, tips=tips, prune=prune)
    return model


def load_urdf_string(text, *, source="<string>", gravity=(0.0, 0.0, -9.81), strict=False) -> Model:
    """Same as load_urdf for URDF text (str or bytes); ``source`` names it in messages."""
    data = text.encode() if isinstance(text, str) else bytes(text)
    root = _parse_xml(data, source)
    _check_required(root, source)
    try:
        robot = yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False, load_meshes=False,
                                   build_collision_scene_graph=False, load_collision_meshes=False).robot
    except Exception as exc:  # yourdfpy raises bare KeyError/ValueError on malformed elements
        raise URDFError(f"{source}: cannot read URDF elements: {exc!r}") from exc
    model = _build(robot, source, np.asarray(gravity, float), strict)
    model = dataclasses.replace(model, constraints=_constraints(root, model, source),
                                actuated=_actuated(root, model, source))
    for note in model.notes:
        if "triangle inequality" in note:
            warnings.warn(f"{source}: {note}", InertiaWarning, stacklevel=3)
    return model


def _parse_xml(data: bytes, source: str):
    """Well-formed XML with a <robot> root; DTDs and entities are refused (no expansion, no network)."""
    if b"<!ENTITY" in data:                   # before parsing: nothing is expanded or fetched
        raise URDFError(f"{source}: DOCTYPE/ENTITY declarations are refused (entity expansion)")
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False,
                             remove_comments=True)
    try:
        root = etree.parse(io.BytesIO(data), parser).getroot()
    except etree.XMLSyntaxError as exc:
        raise URDFError(f"{source}: malformed XML: {exc}") from None
    if root.getroottree().docinfo.internalDTD is not None:
        raise URDFError(f"{source}: DOCTYPE/ENTITY declarations are refused (entity expansion)")
    if root.tag != "robot":
        raise URDFError(f"{source}: root element is <{root.tag}>, expected <robot>")
    return root


def _check_required(root, source):
    """What urdfdom requires and yourdfpy silently defaults: names, joint links, full inertia, numbers."""
    for kind in ("link", "joint"):
        names = [e.get("name") for e in root.findall(kind)]
        if None in names:
            raise URDFError(f"{source}: a <{kind}> has no name attribute")
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise URDFError(f"{source}: duplicate {kind} name(s): {', '.join(dup)}")
    for j in root.findall("joint"):
        for tag in ("parent", "child"):
            e = j.find(tag)
            if e is None or not e.get("link"):
                raise URDFError(f"{source}: joint {j.get('name')!r} has no <{tag} link=...>")
        if j.get("type") is None:
            raise URDFError(f"{source}: joint {j.get('name')!r} has no type attribute")
    for link in root.findall("link"):
        inertial = link.find("inertial")
        if inertial is None:
            continue
        mass, inertia = inertial.find("mass"), inertial.find("inertia")
        if mass is None or mass.get("value") is None:
            raise URDFError(f"{source}: link {link.get('name')!r}: <inertial> without <mass value=...>")
        if inertia is None or any(inertia.get(k) is None for k in _INERTIA_KEYS):
            raise URDFError(f"{source}: link {link.get('name')!r}: <inertia> needs all of "
                            f"{', '.join(_INERTIA_KEYS)}")
    if not root.get("name"):
        raise URDFError(f"{source}: <robot> has no name attribute")
    numeric = {"origin": ("xyz", "rpy"), "axis": ("xyz",), "mass": ("value",), "inertia": _INERTIA_KEYS,
               "limit": ("lower", "upper", "effort", "velocity")}
    for owner in root.findall("link") + root.findall("joint"):
        for e in owner.iter(*numeric):
            for key in numeric[e.tag]:
                value = e.get(key)
                try:
                    ok = value is None or bool(np.all(np.isfinite([float(x) for x in value.split()])))
                except ValueError:
                    ok = False
                if not ok:
                    raise URDFError(f"{source}: {owner.tag} {owner.get('name')!r}: <{e.tag} {key}="
                                    f"{value!r}> is not a list of finite numbers")


def _tree(robot, source):
    """Children of each link (joints sorted by name) and the single root link; errors name the culprit."""
    links = {l.name: l for l in robot.links}
    children, parent_of = {name: [] for name in links}, {}
    for j in sorted(robot.joints, key=lambda j: j.name):
        if j.type not in SUPPORTED:
            why = "floating/planar joints (free bases) are not supported" \
                if j.type in ("floating", "planar") else "unknown joint type"
            raise URDFError(f"{source}: joint {j.name!r}: type {j.type!r}: {why}")
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
        raise URDFError(f"{source}: several root links: {', '.join(roots)} (a URDF is one tree)")
    return links, children, roots[0]


def _build(robot, source, gravity, strict) -> Model:
    """Walk the tree from the root, numbering moving joints depth-first and merging fixed-joint links."""
    links, children, root = _tree(robot, source)
    joints, parts, frames, merged, notes = [], {-1: []}, {}, {root: []}, []

    def visit(link, body, R, p):          # (R, p): pose of `link` in the frame of `body`
        frames[link] = Frame(link, body, R, p)
        parts[body].append(_link_inertia(links[link], R, p, source))
        notes.extend(_triangle(parts[body][-1][2], link, source, strict))
        for j in children[link]:          # sorted by joint name
            Ro, po = (np.eye(3), np.zeros(3)) if j.origin is None else (j.origin[:3, :3], j.origin[:3, 3])
            if j.type == "fixed":
                merged[root if body < 0 else joints[body][0].child].append(j.child)
                visit(j.child, body, R @ Ro, p + R @ po)
            else:
                joints.append((j, body, R @ Ro, p + R @ po))
                parts[len(joints) - 1], merged[j.child] = [], []
                visit(j.child, len(joints) - 1, np.eye(3), np.zeros(3))

    visit(root, -1, np.eye(3), np.zeros(3))
    unreached = sorted(set(links) - set(frames))
    if unreached:                          # every link has one parent, yet some hang off no root: a cycle
        raise URDFError(f"{source}: links {', '.join(unreached)} are not connected to the root link "
                        f"{root!r}: their joints form a cycle")
    nv = len(joints)
    axes = [_unit_axis(j, source, notes) for j, *_ in joints]
    inertias = [combine_inertias(parts[i]) for i in range(nv)]
    _check_psd(combine_inertias(parts[-1])[2], f"fixed base {root!r} (with merged links "
               f"{', '.join(merged[root]) or 'none'})", source)
    for (j, *_), (_, _, I) in zip(joints, inertias):
        extra = f" (with merged links {', '.join(merged[j.child])})" if merged[j.child] else ""
        _check_psd(I, f"body {j.child!r}{extra}", source)
    lim = np.array([_limits(j) for j, *_ in joints], float).reshape(nv, 4)
    mimic = tuple((j.name, j.mimic.joint, float(j.mimic.multiplier), float(j.mimic.offset or 0.0))
                  for j, *_ in joints if j.mimic is not None)
    if mimic:
        notes.append(f"{len(mimic)} mimic joint(s) loaded as independent joints (Pinocchio's default): "
                     + ", ".join(m[0] for m in mimic))
    return Model(
        name=robot.name or os.path.basename(source), root_link=root,
        joint_names=tuple(j.name for j, *_ in joints), body_names=tuple(j.child for j, *_ in joints),
        parent=np.array([b for _, b, _, _ in joints], int).reshape(nv),
        kind=np.array([MOVING[j.type] for j, *_ in joints], int).reshape(nv),
        continuous=np.array([j.type == "continuous" for j, *_ in joints], bool).reshape(nv),
        axis=np.array(axes, float).reshape(nv, 3),
        R0=np.array([R for *_, R, _ in joints], float).reshape(nv, 3, 3),
        p0=np.array([p for *_, p in joints], float).reshape(nv, 3),
        mass=np.array([m for m, _, _ in inertias], float).reshape(nv),
        com=np.array([c for _, c, _ in inertias], float).reshape(nv, 3),
        inertia=np.array([I for _, _, I in inertias], float).reshape(nv, 3, 3),
        lower=lim[:, 0], upper=lim[:, 1], effort=lim[:, 2], velocity=lim[:, 3],
        gravity=np.array(gravity, float).reshape(3), frames=frames,
        merged={k: tuple(v) for k, v in merged.items()}, mimic=mimic, source=source, notes=tuple(notes))


def _unit_axis(j, source, notes):
    a = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), float)
    n = np.linalg.norm(a)
    if a.shape != (3,) or not n > 1e-12:
        raise URDFError(f"{source}: joint {j.name!r}: axis {a.tolist()} has no direction")
    if abs(n - 1.0) > 1e-9:
        notes.append(f"joint {j.name!r}: axis {a.tolist()} normalised")
    return a / n


def _limits(j):
    """(lower, upper, effort, velocity); missing values and continuous joints are unbounded."""
    L = j.limit
    get = lambda v, d: d if (L is None or v is None) else float(v)  # noqa: E731
    lo, hi = (-np.inf, np.inf) if j.type == "continuous" else \
        (get(L and L.lower, -np.inf), get(L and L.upper, np.inf))
    return lo, hi, get(L and L.effort, np.inf), get(L and L.velocity, np.inf)


def _link_inertia(link, R, p, source):
    """(m, c, I_c) of a URDF link in the frame where the link sits at (R, p); checks mass and moments."""
    inertial = link.inertial
    if inertial is None or inertial.mass is None:
        return 0.0, p.copy(), np.zeros((3, 3))
    m = float(inertial.mass)
    if m < 0:
        raise URDFError(f"{source}: link {link.name!r}: negative mass {m}")
    To = inertial.origin if inertial.origin is not None else np.eye(4)
    I = To[:3, :3] @ np.asarray(inertial.inertia, float) @ To[:3, :3].T
    return m, p + R @ To[:3, 3], R @ I @ R.T


def _check_psd(I, what, source):
    """Inertia must be positive semi-definite beyond round-off: smallest eigenvalue >= -1e-12 trace."""
    lam = np.linalg.eigvalsh(I)
    if lam[0] < -1e-12 * max(np.trace(I), 0.0) - 1e-18:   # 1e-18 kg m²: round-off on massless bodies
        raise ModelError(f"{source}: {what}: inertia is not positive semi-definite "
                         f"(eigenvalues {lam.tolist()})")


def _triangle(I, link, source, strict):
    """Principal moments of a physical body satisfy I1 + I2 >= I3: a note (or ModelError if strict)."""
    lam = np.sort(np.linalg.eigvalsh(I))
    tol = 1e-9 * max(np.sum(np.abs(lam)), 1e-300)
    if lam[0] < -tol or lam[0] + lam[1] >= lam[2] - tol:   # non-PSD is reported per body, later
        return []
    msg = (f"link {link!r}: principal moments {lam.tolist()} violate the triangle inequality "
           f"I1 + I2 >= I3 ({lam[0] + lam[1]:.6g} < {lam[2]:.6g})")
    if strict:
        raise ModelError(f"{source}: {msg}")
    return [msg]


def _vec(e, key, default, source, where):
    """A 3-vector attribute of an XML element (default if the element or attribute is absent)."""
    text = default if e is None or e.get(key) is None else e.get(key)
    try:
        x = np.array([float(t) for t in text.split()])
    except ValueError:
        x = np.array([np.nan])
    if x.shape != (3,) or not np.all(np.isfinite(x)):
        raise URDFError(f"{source}: {where}: {key}={text!r} is not three finite numbers")
    return x


def _constraints(root, model, source):
    """Loop closures from <constraint> elements (yourdfpy ignores them): frames mapped into body frames."""
    out, seen = [], set()
    for e in root.findall("constraint"):
        name, kind = e.get("name"), e.get("type")
        where = f"constraint {name!r}"
        if not name or name in seen:
            raise URDFError(f"{source}: a <constraint> has no name or a duplicate name ({name!r})")
        seen.add(name)
        if kind not in ("revolute", "spherical", "fixed"):
            raise URDFError(f"{source}: {where}: type {kind!r}; expected revolute, spherical or fixed")
        sides = []
        for side in ("parent", "child"):
            link_el = e.find(side)
            link = None if link_el is None else link_el.get("link")
            if link not in model.frames:
                raise URDFError(f"{source}: {where}: {side} link {link!r} is not defined")
            fr, org = model.frames[link], e.find(f"{side}_origin")
            R = rpy_matrix(_vec(org, "rpy", "0 0 0", source, where))
            p = _vec(org, "xyz", "0 0 0", source, where)
            axis = _vec(e.find(f"{side}_axis"), "xyz", "0 0 1", source, where)
            if np.linalg.norm(axis) < 1e-12:
                raise URDFError(f"{source}: {where}: {side}_axis has no direction")
            sides += [fr.body, link, fr.R @ R, fr.p + fr.R @ p, fr.R @ axis / np.linalg.norm(axis)]
        if sides[0] == sides[5]:
            raise URDFError(f"{source}: {where}: parent and child are the same rigid body")
        b = sides
        out.append(Constraint(name, kind, b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7], b[8], b[9]))
    return tuple(out)


def _actuated(root, model, source):  # noqa: ARG001
    """Joints named in <transmission> elements, in q order."""
    names = {j.get("name") for t in root.findall("transmission") for j in t.findall("joint")}
    return tuple(j for j in model.joint_names if j in names)   # others (fixed or absent) are ignored
