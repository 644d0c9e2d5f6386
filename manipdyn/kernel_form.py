"""The arrays the compiled kernels read of a Model, and how they are laid out.

``KernelForm`` (a model's ``Model.kernel``, built once by the Model's constructor) holds the model's numbers in
the kernels' layout: the joints' integers ``I`` and the floats ``F`` (``_floats``), the frames' rows, the
closures' rows, and the same model in z-aligned body frames for the lane kernels (``z_turn``, ``z_aligned``).
A closure's orientation rows are pairs of directions, one on each body (``orientation_pairs``,
``perpendicular_pair``); ``_closure_form`` lays them out. Everything here reads a model or a constraint by its
attributes (``manipdyn.model`` builds on this module, not the other way round).
"""
from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from .joints import PLANAR, motion_subspace, neutral_q, plane_axes
from .spatial import skew

__all__ = ["KernelForm", "z_turn", "z_aligned", "orientation_pairs", "perpendicular_pair"]


@dataclass(frozen=True, eq=False, slots=True)
class KernelForm:
    """What the compiled kernels (and the one-state fast paths) read of a Model, derived once when the model is
    built (``Model.kernel``): the Model holds the description, this holds the same numbers laid out for the
    kernels, as MuJoCo's mjModel holds its arrays or Pinocchio's Model its derived tree data. Read-only.

    The kernels take the whole model as two arrays, ``I`` and ``F`` (each array argument of a compiled call
    costs ~30 ns of dispatch, so 13 named arrays would cost a one-state call ~0.4 µs more); ``dynamics.model_arrays.unpack``
    turns them back into the named views of ``model_arrays.ModelArrays`` inside every kernel, and is the only reader of
    the layout below.
    """
    q_shape: tuple             # (nq,): one configuration
    v_shape: tuple             # (nv,): one velocity, acceleration or torque
    arrays: tuple              # (I, F), the two below, as the kernels take them
    I: np.ndarray              # (5, nb) int64, rows: parent, kind, idx_q, idx_v, nv_j (joints in q order)
    F: np.ndarray              # (4 nb + 1 + m + ⌈nv/9⌉, 3, 3) float64, blocks of 3×3: [0, nb) R0; [nb, 2nb) inertia
    #                            about the CoM; [2nb, 3nb) rows (axis, p0, com); [3nb, 4nb) mass in [·, 0, 0], pitch
    #                            in [·, 0, 1]; 4nb: −g
    #                            in row 0; then m = max(2, 2⌈nv/3⌉) blocks holding S (nv, 6) row by row ([linear;
    #                            angular], joints.motion_subspace); then the armature (nv,) (Model.armature)
    config: tuple              # (kind (nb,), continuous (nb,) bool, idx_q (nb,), idx_v (nb,)): configuration kernels
    joint_index: MappingProxyType  # joint name -> index in q order (O(1) lookups on large models)
    frame_rows: MappingProxyType   # frame name -> (body, X (4, 3) = [R; p]: the frame in its body)
    one_state_rows: MappingProxyType  # (frame name, reference) -> X (5, 3) = [R; p; (body, 0, local)]
    wrench_rows: MappingProxyType  # (frame name, "local" | "world") -> P (13,) = [R (9, row by row: the frame's
    #                                axes into the body's z-aligned axes, identity for "world"); origin in those axes
    #                                (3); body]: one wrench of a one-state call, for the lane arrays (z_aligned)
    closure_ints: np.ndarray   # (nc, 3) int64 [parent body, child body, number of orientation pairs (−1: coupling)]
    closure_floats: np.ndarray  # (nc, 24) [pp (3), pc (3), a_1..a_3 (9), b_1..b_3 (9)]; a coupling: [ratio, 0, ...]
    closure_labels: tuple      # (m,) the name of every closure row ("<closure>.x|y|z|r1|r2|r3|c")
    result_shapes: tuple       # one state's result of a route (dynamics/route.py), by route.SHAPES: (nv,), (nv, nv),
    #                            (nv, 10 nb) (the regressor)
    lane_arrays: tuple         # (I, F) of the same model in z-aligned body frames (``z_aligned``): what the lane
    #                            kernels take (a batch's route; the GPU)
    lane_turns: np.ndarray     # (nb, 3, 3) C_i: body i's z-aligned frame in its own (x_body = C_i x_lane); a
    #                            wrench's rows are turned with it as they are laid out (arguments.wrench_rows(lanes=True))
    lane_frame_rows: MappingProxyType   # frame_rows in those frames
    config_one: np.ndarray     # config and Model.unit_q packed in one int64 array for the one-state configuration
    #                            kernels (joints.config_views)
    neutral: np.ndarray        # (nq,) the neutral configuration (configuration.neutral returns a copy)

    @classmethod
    def of(cls, model) -> "KernelForm":
        """The kernel form of a Model (called once, by Model.__post_init__)."""
        nb = model.njoints
        I = np.zeros((5, nb), np.int64)
        if nb:
            I[:] = np.vstack([model.parent, model.kind, model.idx_q, model.idx_v, model.nvs])
        F = _floats(model, model.R0, model.inertia, model.axis, model.p0, model.com, np.tile(np.eye(3), (nb, 1, 1)))
        config = (np.array(model.kind, np.int64), np.array(model.continuous, np.bool_),
                  np.array(model.idx_q, np.int64), np.array(model.idx_v, np.int64))
        frame_rows, one_state, wrench = {}, {}, {}
        for name, fr in model.frames.items():
            R, p = np.asarray(fr.R, float), np.asarray(fr.p, float)
            X = np.ascontiguousarray(np.vstack([R, p]))
            frame_rows[name] = (int(fr.body), X)
            for reference in ("local_world_aligned", "local"):
                one_state[name, reference] = np.vstack([X, [float(fr.body), 0.0, float(reference == "local")]])
        ints, floats, labels = _closure_form(model.constraints)
        *turned, turn = z_aligned(model)
        for name, fr in model.frames.items():
            for axes in ("local", "world"):
                R, p = wrench_axes(turn[fr.body] if fr.body >= 0 else np.eye(3), fr, axes)
                wrench[name, axes] = np.concatenate([R.ravel(), p, [float(fr.body)]])
        Fz = _floats(model, *turned, turn)
        lane_frames = {}
        for name, (b, X) in frame_rows.items():
            C = turn[b] if b >= 0 else np.eye(3)             # the frame in the body's z-aligned frame: Cᵀ R, Cᵀ p
            lane_frames[name] = (b, np.ascontiguousarray(np.vstack([C.T @ X[:3], C.T @ X[3]])))
        units = np.asarray(model.unit_q, np.int64).reshape(-1)
        config_one = np.concatenate([[nb, units.size // 2], *config, units]).astype(np.int64)
        neutral = np.concatenate([neutral_q(k) for k in model.kind]) if nb else np.zeros(0)
        arrays = [I, F, Fz, *config, config_one, neutral, ints, floats, *(x for _, x in frame_rows.values()), *one_state.values(),
                  *wrench.values(), turn, *(x for _, x in lane_frames.values())]
        for a in arrays:
            a.setflags(write=False)
        return cls((model.nq,), (model.nv,), (I, F), I, F, config,
                   MappingProxyType({name: i for i, name in enumerate(model.joint_names)}),
                   MappingProxyType(frame_rows), MappingProxyType(one_state), MappingProxyType(wrench),
                   ints, floats, labels,
                   ((model.nv,), (model.nv, model.nv), (model.nv, 10 * nb)),
                   (I, Fz), turn, MappingProxyType(lane_frames), config_one, neutral)


def wrench_axes(C, fr, axes):
    """(R, p) for a wrench given at frame fr in ``axes`` ("local": the frame's, "world"), on fr's body whose kernel
    frame is C in the body's own (x_body = C x; C = ``lane_turns``' C_i for the lane arrays, the identity for the
    model's): R turns the wrench into the kernel frame's axes (the identity for "world": the kernels turn it with the
    orientation they compute), p is the frame's origin in those axes, about which its moment acts. The one place a
    wrench's frame is turned (``KernelForm.wrench_rows``, ``arguments.wrench_rows``, ``gpu``)."""
    Ct = np.asarray(C, float).T
    return (Ct @ np.asarray(fr.R, float) if axes == "local" else np.eye(3)), Ct @ np.asarray(fr.p, float)


def _floats(model, R0, inertia, axis, p0, com, turn):
    """F, the kernels' float array (KernelForm's layout), of the model with these joint frames, inertias, axes,
    origins, centres of mass and turns of the body frames from the links' (the model's own, with the identity, or
    ``z_aligned``'s)."""
    nb = model.njoints
    S = np.concatenate([motion_subspace(int(k), a, h) for k, a, h in zip(model.kind, axis, model.pitch)]) if nb \
        else np.zeros((0, 6))
    m = max(2, 2 * ((model.nv + 2) // 3))             # even: 9 m numbers reshape into (3 m / 2, 6) ⊇ S
    a = (model.nv + 8) // 9
    F = np.zeros((4 * nb + 1 + m + a + nb, 3, 3))     # then armature (nv,) in whole blocks, then the turns
    F[:nb], F[nb:2 * nb] = R0, inertia
    F[2 * nb:3 * nb, 0], F[2 * nb:3 * nb, 1], F[2 * nb:3 * nb, 2] = axis, p0, com
    F[3 * nb:4 * nb, 0, 0] = model.mass
    F[3 * nb:4 * nb, 0, 1] = model.pitch
    F[4 * nb, 0] = -np.asarray(model.gravity, float)
    F[4 * nb + 1:4 * nb + 1 + m].reshape(-1, 6)[:model.nv] = S
    F[4 * nb + 1 + m:4 * nb + 1 + m + a].reshape(-1)[:model.nv] = model.armature
    F[4 * nb + 1 + m + a:] = turn
    return F


def z_turn(k) -> np.ndarray:
    """C, the rotation that turns e_z into the unit vector k (C e_z = k): the identity for k = e_z, a half turn
    about x for k = −e_z, else the shortest turn, about u = e_z × k / |e_z × k|, by Rodrigues with cos = k_z and
    sin = |e_z × k| taken from k itself (``spatial.axis_angle`` takes an angle, whose sin and cos would round: this
    way a turn onto a coordinate axis is exact)."""
    k = np.asarray(k, float)
    c, s = k[2], np.hypot(k[0], k[1])
    if s == 0.0:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    u = np.array([-k[1] / s, k[0] / s, 0.0])
    return c * np.eye(3) + s * skew(u) + (1.0 - c) * np.outer(u, u)


def planar_turn(n) -> np.ndarray:
    """C for a planar joint of normal n: the columns e₁, e₂, n (``joints.plane_axes``), so that C e_x = e₁, C e_y = e₂
    and C e_z = n — in the turned frame the joint's x and y run along x and y, its turn is about z."""
    py = getattr(plane_axes, "py_func", plane_axes)     # its Python body: no compile (a plain function without jit)
    e1, e2 = py(float(n[0]), float(n[1]), float(n[2]))
    return np.column_stack([e1, e2, np.asarray(n, float)])


def z_aligned(model):
    """The model's joint frames, inertias, axes, origins and centres of mass with every 1-dof joint's body frame
    turned so that its joint axis is z (the chapter's z'_i, docs/design.md §4c), and a planar joint's so that its
    plane is x–y: body i's frame becomes C_i (``z_turn`` of its axis, ``planar_turn``; the identity for a ball or
    free joint), so R^{i−1}_i = R0'_i Rot(z, q), R0'_i = C_λᵀ R0_i C_i, p0'_i = C_λᵀ p0_i, c'_i = C_iᵀ c_i,
    I'_i = C_iᵀ I_i C_i, axis' = e_z. τ, M, q̈ and world placements are the same numbers: only what is written in a
    body's own axes changes.
    Returns (R0', I', axis', p0', c', C), each (nb, 3, 3) or (nb, 3)."""
    nb = model.njoints
    C = np.array([z_turn(model.axis[i]) if model.nvs[i] == 1 else planar_turn(model.axis[i])
                  if model.kind[i] == PLANAR else np.eye(3) for i in range(nb)]).reshape(nb, 3, 3)
    Cp = np.array([C[j] if j >= 0 else np.eye(3) for j in model.parent]).reshape(nb, 3, 3)
    Ct = np.swapaxes(C, 1, 2)
    R0 = np.swapaxes(Cp, 1, 2) @ np.asarray(model.R0, float) @ C
    J = Ct @ np.asarray(model.inertia, float) @ C
    turned = (np.asarray(model.nvs) == 1) | (np.asarray(model.kind) == PLANAR)
    axis = np.where(turned[:, None], [0.0, 0.0, 1.0], model.axis)       # C e_z = k: exactly z
    p0 = np.einsum("nji,nj->ni", Cp, np.asarray(model.p0, float))
    com = np.einsum("nji,nj->ni", C, np.asarray(model.com, float))
    return R0, 0.5 * (J + np.swapaxes(J, 1, 2)), axis.reshape(nb, 3), p0, com, C


def perpendicular_pair(e):
    """Two unit vectors completing e (3,) to a right-handed orthonormal basis."""
    t = np.eye(3)[np.argmin(np.abs(e))]
    n1 = np.cross(e, t)
    n1 /= np.linalg.norm(n1)
    return n1, np.cross(e, n1)


def orientation_pairs(c):
    """(a, b) direction pairs of a closure's orientation rows, a in the parent body frame, b in the child's
    (constraints/closures.py: Φ = a·b)."""
    if c.type == "revolute":
        n1, n2 = perpendicular_pair(c.axis_p)
        return [(n1, c.axis_c), (n2, c.axis_c)]
    if c.type == "fixed":
        A, B = c.Rp, c.Rc
        return [(A[:, 1], B[:, 2]), (A[:, 2], B[:, 0]), (A[:, 0], B[:, 1])]
    return []


def _closure_form(constraints):
    """(ints (nc, 3), floats (nc, 24), row labels) of KernelForm for a tuple of Constraint."""
    nc = len(constraints)
    ints, floats, labels = np.zeros((nc, 3), np.int64), np.zeros((nc, 24)), []
    for k, c in enumerate(constraints):
        if c.type == "coupling":
            ints[k], floats[k, 0] = (c.parent, c.child, -1), c.ratio
            labels.append(f"{c.name}.c")
            continue
        pairs = orientation_pairs(c)
        ints[k] = c.parent, c.child, len(pairs)
        floats[k, :3], floats[k, 3:6] = c.pp, c.pc
        for m, (a, b) in enumerate(pairs):
            floats[k, 6 + 3 * m:9 + 3 * m], floats[k, 15 + 3 * m:18 + 3 * m] = a, b
        labels += [f"{c.name}.{x}" for x in ("x", "y", "z")] + [f"{c.name}.r{m + 1}" for m in range(len(pairs))]
    return ints, floats, tuple(labels)
