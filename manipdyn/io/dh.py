"""D-H table -> URDF, standard (Denavit–Hartenberg) or modified (Craig) convention.

Input: a sequence of rows, one dict per joint i = 1..n:
    type      "revolute" (default) or "prismatic"
    alpha, a  link twist (rad) and length (m): standard: α_i, a_i of T_{i-1,i} = Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i);
              modified: α_{i-1}, a_{i-1} of T_{i-1,i} = Rx(α_{i-1}) Tx(a_{i-1}) Rz(θ_i) Tz(d_i)
    d, theta  offset (m) and angle (rad); the joint variable adds to theta (revolute) or d (prismatic)
    name, link            joint and child-link names (default joint<i>, link<i>)
    mass, com, inertia    kg; CoM (3,) in D-H frame i; inertia about the CoM in D-H frame i's axes,
                          3×3 or [ixx, iyy, izz, ixy, ixz, iyz] (default: massless)
    lower, upper, effort, velocity    joint limits (default ±π, 100, 10)
tool: optional {"name": ..., "xyz": ..., "rpy": ...}: a fixed frame given in D-H frame n.

Frame placement rule: a URDF joint turns about (or slides along) its own frame's z axis, so the URDF frame
F_i of link i is put ON joint i's axis: F_i = DH_{i-1} · pre_i · (joint motion), DH_i = F_i · post_i, with
    standard  revolute   pre = Rz(θ_off)              post = Tz(d) Tx(a) Rx(α)
              prismatic  pre = Rz(θ) Tz(d_off)        post = Tx(a) Rx(α)
    modified  revolute   pre = Rx(α) Tx(a) Tz(d) Rz(θ_off)   post = 1 (F_i is D-H frame i)
              prismatic  pre = Rx(α) Tx(a) Rz(θ) Tz(d_off)   post = 1
so joint i's origin in F_{i-1} is post_{i-1} · pre_i, and link i's mass properties move from D-H frame i into
F_i through post_i. (Plugging a standard table into equations written for frames on their own joint axes is
the chapter's convention clash, docs/design.md §6.)
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import URDFError
from ..spatial import matrix_rpy


def _T(R=np.eye(3), p=(0.0, 0.0, 0.0)):
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, p
    return T


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return _T(np.array([[1, 0, 0], [0, c, -s], [0, s, c]]))


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return _T(np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]))


def _tx(x):
    return _T(p=(x, 0.0, 0.0))


def _tz(z):
    return _T(p=(0.0, 0.0, z))


def _num(row, i, key, default=None):
    """A finite number of row i (1-based in messages)."""
    if key not in row:
        if default is None:
            raise URDFError(f"D-H table row {i}: missing key {key!r}")
        return default
    try:
        x = float(row[key])
    except (TypeError, ValueError):
        raise URDFError(f"D-H table row {i}: {key} = {row[key]!r} is not a number") from None
    if not np.isfinite(x):
        raise URDFError(f"D-H table row {i}: {key} = {x} is not finite")
    return x


def _inertia(row, i):
    """(mass, com (3,), inertia (3, 3)) of row i, validated."""
    m = _num(row, i, "mass", 0.0)
    if m < 0:
        raise URDFError(f"D-H table row {i}: negative mass {m}")
    c = np.asarray(row.get("com", (0.0, 0.0, 0.0)), float)
    I = np.asarray(row.get("inertia", np.zeros((3, 3))), float)
    if I.shape == (6,):
        ixx, iyy, izz, ixy, ixz, iyz = I
        I = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
    if c.shape != (3,) or I.shape != (3, 3) or not (np.all(np.isfinite(c)) and np.all(np.isfinite(I))):
        raise URDFError(f"D-H table row {i}: com must be 3 finite numbers and inertia 3×3 or 6 finite numbers")
    if not np.allclose(I, I.T, rtol=0, atol=1e-12 * max(np.abs(I).max(), 1.0)):
        raise URDFError(f"D-H table row {i}: inertia is not symmetric")
    return m, c, I


def _pre_post(row, i, convention):
    """(pre_i, post_i, kind) of row i, see the module docstring."""
    kind = row.get("type", "revolute")
    if kind not in ("revolute", "prismatic"):
        raise URDFError(f"D-H table row {i}: type {kind!r}; expected 'revolute' or 'prismatic'")
    al, a, d, th = (_num(row, i, k) for k in ("alpha", "a", "d", "theta"))
    rev = kind == "revolute"
    if convention == "standard":
        pre = _rz(th) if rev else _rz(th) @ _tz(d)
        post = _tz(d) @ _tx(a) @ _rx(al) if rev else _tx(a) @ _rx(al)
    elif convention == "modified":
        pre = _rx(al) @ _tx(a) @ (_tz(d) @ _rz(th) if rev else _rz(th) @ _tz(d))
        post = np.eye(4)
    else:
        raise URDFError(f"D-H convention {convention!r}; expected 'standard' or 'modified'")
    return pre, post, kind


def _origin(T):
    return (f'<origin xyz="{" ".join(repr(float(x)) for x in T[:3, 3])}" '
            f'rpy="{" ".join(repr(float(x)) for x in matrix_rpy(T[:3, :3]))}"/>')


_KEYS = {"ixx": (0, 0), "iyy": (1, 1), "izz": (2, 2), "ixy": (0, 1), "ixz": (0, 2), "iyz": (1, 2)}


def _link_xml(name, m, c, I, post):
    """<link> with the D-H-frame mass properties moved into the URDF frame through post."""
    if m == 0.0 and not np.any(I):
        return f'  <link name="{name}"/>'
    R, p = post[:3, :3], post[:3, 3]
    cF, IF = p + R @ c, R @ I @ R.T
    return (f'  <link name="{name}">\n    <inertial>\n      <origin xyz="{" ".join(repr(float(x)) for x in cF)}" '
            f'rpy="0 0 0"/>\n      <mass value="{float(m)!r}"/>\n      <inertia '
            + " ".join(f'{k}="{float(IF[a, b])!r}"' for k, (a, b) in _KEYS.items()) + '/>\n    </inertial>\n  </link>')


def dh_to_urdf(table, *, convention="standard", name="robot", base_link="base_link", tool=None,
               path=None, comment=None) -> str:
    """URDF text of a D-H table (see the module docstring for the input format); written to ``path`` if given.

    Raises URDFError naming the row and key at fault.
    """
    if not len(table):
        raise URDFError("D-H table has no rows")
    out = ['<?xml version="1.0"?>']
    if comment:
        out.append(f"<!-- {comment.strip()} -->")
    out += [f'<robot name="{name}">', f'  <link name="{base_link}"/>']
    prev_link, prev_post = base_link, np.eye(4)
    for i, row in enumerate(table, start=1):
        pre, post, kind = _pre_post(row, i, convention)
        link, joint = row.get("link", f"link{i}"), row.get("name", f"joint{i}")
        m, c, I = _inertia(row, i)
        lo, hi = _num(row, i, "lower", -np.pi), _num(row, i, "upper", np.pi)
        out.append(_link_xml(link, m, c, I, post))
        out.append(f'  <joint name="{joint}" type="{kind}">\n    <parent link="{prev_link}"/>\n'
                   f'    <child link="{link}"/>\n    {_origin(prev_post @ pre)}\n    <axis xyz="0 0 1"/>\n'
                   f'    <limit lower="{lo!r}" upper="{hi!r}" effort="{_num(row, i, "effort", 100.0)!r}" '
                   f'velocity="{_num(row, i, "velocity", 10.0)!r}"/>\n  </joint>')
        prev_link, prev_post = link, post
    if tool is not None:
        from ..spatial import rpy_matrix
        T = _T(rpy_matrix(tool.get("rpy", (0, 0, 0))), np.asarray(tool.get("xyz", (0, 0, 0)), float))
        out.append(f'  <link name="{tool.get("name", "tool")}"/>')
        out.append(f'  <joint name="{tool.get("name", "tool")}_joint" type="fixed">\n    <parent link="{prev_link}"/>\n'
                   f'    <child link="{tool.get("name", "tool")}"/>\n    {_origin(prev_post @ T)}\n  </joint>')
    out.append("</robot>\n")
    text = "\n".join(out)
    if path is not None:
        Path(path).write_text(text)
    return text
