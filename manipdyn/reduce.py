"""Model only what a scene needs: lock joints, keep the chains from a root to tips, prune massless leaves.

A locked joint becomes a fixed joint at its given value (as Pinocchio's buildReducedModel does): its body
merges into its parent body (mass, CoM and inertia combined; frames kept, re-expressed), and the joints
below it keep moving with the merged body as their parent. ``root``/``tips`` lock every joint that is not on
a chain from the root link to one of the tip links — bodies beyond the tips merge into them as payload,
side branches merge into the chain they hang from (or into the fixed base, where they no longer matter).

A free-flyer root (``root_joint``) is a joint like the others here: locked, it takes a pose (7,) =
[x y z qx qy qz qw] (default: the neutral pose, origin and identity) and the root link becomes the fixed base
at that pose, as in Pinocchio, whose buildReducedModel places every locked joint by its own joint model at
the reference configuration. ``root`` locks every joint above the root link *and the joint that carries
it*, the free flyer included: the chains then start from a fixed link. Joints locked by ``root``/``tips``
or ``prune`` are held at the neutral value (0; the free flyer at the neutral pose).
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .errors import InputError, ModelError
from .joints import BALL, COORDS, FREEFLYER, NQ, PLANAR, UNIT_AT, UNIT_LEN, joint_placement, neutral_q
from .model import QUAT_TOL, Constraint, Frame
from .spatial import combine_inertias


def reduce(model, *, locked=None, root=None, tips=None, prune=False):
    """A new Model with ``locked`` = {joint: value} fixed, only the root→tips chains moving (if given),
    and, with prune=True, massless moving leaves dropped.

    A value is a real number for a revolute (rad) or prismatic (m) joint, a pose (7,) [x y z qx qy qz qw]
    with a unit quaternion for the free flyer (the root link is then fixed there), or None for the neutral
    value. ``Model.locked`` of the result keeps them (floats; a tuple of 7 for the free flyer). Raises
    InputError naming unknown joints/links or a bad value, ModelError naming a closure whose two sides
    become one rigid body."""
    values = {j: _lock_value(model, model.joint_index(j), v) for j, v in dict(locked or {}).items()}
    values.update({j: _lock_value(model, model.joint_index(j), None)
                   for j in _off_chain(model, root, tips) if j not in values})
    if prune:
        values.update({j: _lock_value(model, model.joint_index(j), None) for j in _massless_leaves(model, values)})
    keep = [i for i, j in enumerate(model.joint_names) if j not in values]
    return _rebuild(model, keep, values)


def _lock_value(model, i, value):
    """The value joint i is locked at, as a q block (nq_i,) float array: None gives the neutral value (0;
    a free flyer's neutral pose [0 0 0 0 0 0 1]; a ball joint's [0 0 0 1]). InputError names the joint and the
    value at fault."""
    k = int(model.kind[i])
    name, nq, at = model.joint_names[i], NQ[k], UNIT_AT[k] if UNIT_LEN[k] else -1
    if value is None:
        return neutral_q(k)
    try:
        x = np.asarray(value)
    except (TypeError, ValueError):
        x = None
    what = {FREEFLYER: "a pose ", BALL: "a quaternion ", PLANAR: "a planar position "}.get(k, "")
    want = "a real number" if nq == 1 else f"{what}[{' '.join(COORDS[k])}] ({nq},)"
    if x is None or x.dtype.kind not in "fiu" or x.size != nq or x.ndim > 1 or (nq > 1 and x.ndim != 1):
        raise InputError(f"locked value of joint {name!r} is {value!r}: expected {want}")
    x = x.astype(float).reshape(nq)
    if not np.all(np.isfinite(x)):
        raise InputError(f"locked value of joint {name!r} is {value!r}: must be finite")
    if at >= 0 and abs(np.linalg.norm(x[at:]) - 1.0) > QUAT_TOL:
        raise InputError(f"locked value of joint {name!r}: the {'quaternion' if nq - at == 4 else 'rotation'} ({' '.join(COORDS[k][at:])}) = {x[at:].tolist()} "
                         f"has norm {np.linalg.norm(x[at:]):.12g}, not 1 (within {QUAT_TOL:g})")
    if at >= 0:                                    # a rotation exactly (the placement reads it as one)
        x[at:] /= np.linalg.norm(x[at:])
    return x


def _off_chain(model, root, tips):
    """Joints to lock so that only chains from ``root`` to ``tips`` move (walks up parent links: no
    per-body ancestor sets, so linear in the size of the chains)."""
    if root is None and tips is None:
        return []
    body_of = lambda link: model.frame(link).body  # noqa: E731
    has_child = set(model.parent.tolist())
    tip_bodies = [body_of(t) for t in (tips or [])] or [i for i in range(model.njoints)
                                                        if i not in has_child]   # default: every leaf
    on_chain = set()
    for b in tip_bodies:
        while b >= 0 and b not in on_chain:
            on_chain.add(b)
            b = int(model.parent[b])
    if root is not None:
        rb = body_of(root)
        above = set(_ancestors(model, rb))         # joints between the base and the root link: locked
        on_chain -= above
        missing = [t for t, b in zip(tips or [], tip_bodies) if rb >= 0 and rb not in _ancestors(model, b)]
        if missing:
            raise InputError(f"tip link(s) {', '.join(missing)} do not hang below root link {root!r}")
    return [model.joint_names[i] for i in range(model.njoints) if i not in on_chain]


def _ancestors(model, b):
    """Body b and its ancestors up to the base, b first: [b, parent[b], ...] (empty for the base)."""
    out = []
    while b >= 0:
        out.append(b)
        b = int(model.parent[b])
    return out


def _massless_leaves(model, values):
    """Moving joints whose whole subtree carries no mass and no inertia (repeatedly, leaves first)."""
    drop = set(values)
    live_children = [0] * model.njoints           # children not dropped (children come after parents)
    for i in reversed(range(model.njoints)):
        if not live_children[i] and model.mass[i] == 0.0 and not np.any(model.inertia[i]):
            drop.add(model.joint_names[i])
        if model.joint_names[i] not in drop and model.parent[i] >= 0:
            live_children[model.parent[i]] += 1
    return [j for j in drop if j not in values]


def _rebuild(model, keep, values):
    """Renumber the kept joints; carry every locked body into the kept body (or base) it hangs from."""
    new_of = {}                                    # old body -> (new body, R, p): old frame in new frame
    parts, parent, R0, p0 = {-1: []}, [], [], []
    merged = {k: list(v) for k, v in model.merged.items()}
    base, kept = (-1, np.eye(3), np.zeros(3)), set(keep)
    for i in range(model.njoints):                 # bodies, not velocity entries (a free flyer has 6)
        nb, Rt, pt = new_of.get(model.parent[i], base)
        if i in kept:
            k = len(parent)
            parent.append(nb)
            R0.append(Rt @ model.R0[i])
            p0.append(pt + Rt @ model.p0[i])
            new_of[i], parts[k] = (k, np.eye(3), np.zeros(3)), []
        else:
            Ri, pi = _fixed_placement(model, i, values[model.joint_names[i]])
            new_of[i] = (nb, Rt @ Ri, pt + Rt @ pi)
            host = model.root_link if nb < 0 else model.body_names[keep[nb]]
            if host != model.body_names[i]:        # a locked free flyer: its body is the root link itself
                moved = [model.body_names[i]] + merged.pop(model.body_names[i], [])
                merged.setdefault(host, []).extend(moved)
    for i in range(model.njoints):
        nb, Rt, pt = new_of[i]
        parts[nb].append((model.mass[i], pt + Rt @ model.com[i], Rt @ model.inertia[i] @ Rt.T))
    inert = [combine_inertias(parts[k]) for k in range(len(keep))]
    frames = {n: _move_frame(f, new_of, base) for n, f in model.frames.items()}
    names = [model.joint_names[i] for i in keep]
    sel = np.array(keep, int)
    dof = np.array([r for i in keep for r in range(model.idx_v[i], model.idx_v[i] + model.nvs[i])], int)
    return dataclasses.replace(
        model, joint_names=tuple(names), body_names=tuple(model.body_names[i] for i in keep),
        parent=np.array(parent, int).reshape(-1), kind=model.kind[sel], continuous=model.continuous[sel],
        axis=model.axis[sel], R0=np.array(R0).reshape(-1, 3, 3), p0=np.array(p0).reshape(-1, 3),
        mass=np.array([m for m, _, _ in inert]).reshape(-1), com=np.array([c for _, c, _ in inert]).reshape(-1, 3),
        inertia=np.array([I for _, _, I in inert]).reshape(-1, 3, 3), lower=model.lower[sel],
        upper=model.upper[sel], effort=model.effort[sel], velocity=model.velocity[sel], frames=frames,
        armature=model.armature[dof], damping=model.damping[dof], friction=model.friction[dof], pitch=model.pitch[sel],
        merged={k: tuple(v) for k, v in merged.items()},
        mimic=tuple(m for m in model.mimic if m[0] in names and m[1] in names),
        constraints=tuple(_move_constraint(c, new_of, base) for c in model.constraints),
        actuated=tuple(j for j in model.actuated if j in names),
        locked={**model.locked, **{j: float(v[0]) if len(v) == 1 else tuple(map(float, v))
                                   for j, v in values.items()}})


def _fixed_placement(model, i, value):
    """(R, p) of body i in its parent with joint i held at ``value`` (its q block, (nq_i,)): the one joint
    model's X = X0 X_J(q), whatever the joint type."""
    R, p = np.empty((1, 3, 3)), np.empty((1, 3))                  # joint i as the only joint of a model
    joint_placement(0, np.array([model.kind[i]], np.int64), np.zeros(1, np.int64),
                    np.ascontiguousarray(model.axis[i:i + 1], float), np.ascontiguousarray(model.pitch[i:i + 1], float),
                    np.ascontiguousarray(model.R0[i:i + 1], float),
                    np.ascontiguousarray(model.p0[i:i + 1], float), np.ascontiguousarray(np.atleast_1d(value), float), R, p)
    return R[0], p[0]


def _move_frame(f, new_of, base):
    nb, Rt, pt = new_of.get(f.body, base)
    return Frame(f.name, nb, Rt @ f.R, pt + Rt @ f.p)


def _move_constraint(c, new_of, base):
    if c.type == "coupling":           # its row sums joint coordinates along a path that locking changes
        raise ModelError(f"closure {c.name!r} (a coupling between joint coordinates) cannot yet be kept by "
                         f"reduce(): locking joints changes the coordinates it relates")
    (a, Ra, pa), (b, Rb, pb) = new_of.get(c.parent, base), new_of.get(c.child, base)
    if a == b:
        raise ModelError(f"closure {c.name!r} cannot be kept: locking makes {c.parent_link!r} and "
                         f"{c.child_link!r} one rigid body (unlock a joint of the loop or drop the closure)")
    return Constraint(c.name, c.type, a, c.parent_link, Ra @ c.Rp, pa + Ra @ c.pp, Ra @ c.axis_p,
                      b, c.child_link, Rb @ c.Rc, pb + Rb @ c.pc, Rb @ c.axis_c, source=c.source)
