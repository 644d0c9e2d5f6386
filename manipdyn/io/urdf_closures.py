"""Closed loops in a URDF: the closure elements under <robot>, which yourdfpy ignores, read into the one closure
model (model.Constraint) once the tree is loaded. ``read_closures(root, model, source)`` returns them in file order;
``CLOSURE_TAGS`` names the elements.

The dialects:
- <constraint name type="revolute|spherical|fixed"> with <parent link>, <parent_origin>, <parent_axis xyz>,
  <child link>, <child_origin>, <child_axis xyz> (manipdyn's form): each axis in the frame of its link, default
  0 0 1.
- URDF+ (Chignoli et al., arXiv 2411.19753; generalized_rbda's models): <loop name type> with
  <predecessor link><origin/></predecessor>, <successor link><origin/></successor> and one <axis xyz> in the loop
  frame (default 1 0 0, as in its urdfdom fork), turned by each side's <origin rpy>. Type revolute or continuous
  -> "revolute", fixed, spherical; prismatic and planar loops are refused (no such closure here).
- <loop_constraint name> with <parent link>, <parent_origin>, <child link>, <child_origin> (URDF+'s older form):
  generalized_rbda enforces only that the two points coincide -> "spherical".
- <coupling name> with <predecessor link>, <successor link>, <ratio value> (default 1), and the older
  <joint_constraint name> with <parent link>, <child link>, <gear_ratio value>: a gear between the joint
  coordinates -> "coupling" (see model.Constraint). The joints between the two links must not include the free
  flyer (a coupling relates 1-dof joints).

Rules for every dialect: a closure has a name, unique across all kinds; each side names a link of the tree, and
its frame (the side's origin element, xyz and rpy; absent = the link frame) is mapped into the frame of the body
that link belongs to after fixed joints are merged; the two sides must be on different rigid bodies; numbers are in the URDF grammar
(io/safe_xml.py), origin coordinates within ±MAX_LENGTH, a ratio within ±MAX_MASS; an axis must have a direction
and is scaled to unit length. Errors are URDFErrors naming the element.
"""
from __future__ import annotations

import numpy as np

from ..errors import URDFError
from ..joints import FREEFLYER
from ..model import Constraint
from ..spatial import rpy_matrix
from .safe_xml import MAX_LENGTH, MAX_MASS, bounded, numbers

__all__ = ["read_closures", "CLOSURE_TAGS"]


def read_closures(root, model, source):
    """The closures under <robot> ``root`` (an lxml element) of the loaded tree ``model``, in file order: a tuple of
    model.Constraint, every dialect of the module docstring. URDFError for a closure without a name or with a name
    already taken, and for what each dialect refuses."""
    out, seen = [], set()
    for e in root:
        if not isinstance(e.tag, str) or e.tag not in _CLOSURE_READERS:
            continue
        name = e.get("name")
        if not name or name in seen:
            raise URDFError(f"{source}: a <{e.tag}> has no name or a duplicate name ({name!r})")
        seen.add(name)
        out.append(_CLOSURE_READERS[e.tag](e, name, f"{e.tag} {name!r}", model, source))
    return tuple(out)


def _vec(e, key, default, source, where, bound=np.inf):
    """A 3-vector attribute of an XML element (default if the element or attribute is absent), in the
    URDF grammar, each coordinate within ±bound."""
    x = None if e is None else numbers(e, key, 3, where, source)
    if x is None:
        return np.array(default, float)
    return np.array(bounded(x, bound, "coordinate", e, key, where, source), float)


def _side(model, link_el, org, axis, where, role, source):
    """(body, link, R, p, axis) of one closure side in its body's frame: link_el names the link, org is its
    <origin>-like element (xyz, rpy; absent = identity), axis (3,) in the link frame (or the origin frame if
    the caller rotated it)."""
    link = None if link_el is None else link_el.get("link")
    if link not in model.frames:
        raise URDFError(f"{source}: {where}: {role} link {link!r} is not defined")
    fr = model.frames[link]
    R = rpy_matrix(_vec(org, "rpy", (0, 0, 0), source, where))
    p = _vec(org, "xyz", (0, 0, 0), source, where, bound=MAX_LENGTH)
    return fr.body, link, fr.R @ R, fr.p + fr.R @ p, fr.R @ axis


def _unit(axis, what, where, source):
    """axis (3,) scaled to unit length (by its largest entry first: no overflow); URDFError if zero."""
    if not np.any(axis):
        raise URDFError(f"{source}: {where}: {what} has no direction")
    axis = axis / np.max(np.abs(axis))
    return axis / np.linalg.norm(axis)


def _closure(name, kind, a, b, where, source, tag, ratio=0.0):
    """The Constraint from two sides (body, link, R, p, axis); the sides must be different rigid bodies."""
    if a[0] == b[0]:
        raise URDFError(f"{source}: {where}: both sides are on the same rigid body ({a[1]!r}, {b[1]!r})")
    return Constraint(name, kind, a[0], a[1], a[2], a[3], a[4], b[0], b[1], b[2], b[3], b[4], ratio=ratio, source=tag)


def _read_constraint(e, name, where, model, source):
    kind = e.get("type")
    if kind not in ("revolute", "spherical", "fixed"):
        raise URDFError(f"{source}: {where}: type {kind!r}; expected revolute, spherical or fixed")
    sides = []
    for role in ("parent", "child"):
        axis = _unit(_vec(e.find(f"{role}_axis"), "xyz", (0, 0, 1), source, where), f"{role}_axis", where, source)
        sides.append(_side(model, e.find(role), e.find(f"{role}_origin"), axis, where, role, source))
    return _closure(name, kind, *sides, where, source, "constraint")


_LOOP_TYPES = {"revolute": "revolute", "continuous": "revolute", "fixed": "fixed", "spherical": "spherical"}


def _read_loop(e, name, where, model, source):
    kind = e.get("type")
    if kind not in _LOOP_TYPES:
        why = "no such closure in manipdyn" if kind in ("prismatic", "planar") else "unknown type"
        raise URDFError(f"{source}: {where}: type {kind!r}: {why}; expected revolute, continuous, fixed or spherical")
    axis = _unit(_vec(e.find("axis"), "xyz", (1, 0, 0), source, where), "<axis>", where, source)
    sides = []
    for role in ("predecessor", "successor"):
        el = e.find(role)
        org = None if el is None else el.find("origin")
        R = rpy_matrix(_vec(org, "rpy", (0, 0, 0), source, where))
        sides.append(_side(model, el, org, R @ axis, where, role, source))   # the axis is in the loop frame
    return _closure(name, _LOOP_TYPES[kind], *sides, where, source, "loop")


def _read_loop_constraint(e, name, where, model, source):
    sides = [_side(model, e.find(role), e.find(f"{role}_origin"), np.zeros(3), where, role, source)
             for role in ("parent", "child")]
    return _closure(name, "spherical", *sides, where, source, "loop_constraint")


def _read_coupling(e, name, where, model, source, roles=("predecessor", "successor"), ratio_tag="ratio"):
    sides = [_side(model, e.find(role), None, np.zeros(3), where, role, source) for role in roles]
    r = e.find(ratio_tag)
    ratio = 1.0 if r is None else numbers(r, "value", 1, where, source)
    if r is not None and ratio is None:
        raise URDFError(f"{source}: {where}: <{ratio_tag}> has no value attribute")
    ratio = 1.0 if r is None else bounded(ratio, MAX_MASS, "ratio", r, "value", where, source)[0]
    c = _closure(name, "coupling", *sides, where, source, e.tag, ratio=float(ratio))
    for b in _path(model.parent, c.parent, c.child):
        if model.kind[b] == FREEFLYER:
            raise URDFError(f"{source}: {where}: the joints between {c.parent_link!r} and {c.child_link!r} include "
                            f"the free flyer; a coupling relates 1-dof joints only")
    return c


def _path(parent, a, b):
    """Bodies on the tree path between bodies a and b, below their common ancestor (parent[i] < i)."""
    out = []
    while a != b:
        if a > b:
            out.append(a)
            a = parent[a]
        else:
            out.append(b)
            b = parent[b]
    return out


_CLOSURE_READERS = {
    "constraint": _read_constraint, "loop": _read_loop, "loop_constraint": _read_loop_constraint,
    "coupling": _read_coupling,
    "joint_constraint": lambda e, n, w, m, s: _read_coupling(e, n, w, m, s, ("parent", "child"), "gear_ratio"),
}
CLOSURE_TAGS = tuple(_CLOSURE_READERS)   # the closure elements under <robot>, each read by one reader above
