"""Energies, from the links' motion (not from M): the physical laws the tests check the dynamics against.
Both read the one forward kinematics (forward_kinematics.fk_pass), compiled, for any joint type:

    T = Σ_links ½ m |v_C|² + ½ ω'ᵀ I ω',   v_C = v_o + ω × R c (world),  ω' = Rᵀ ω (body axes)
    V = −Σ_links m gᵀ c_world  (= Σ m (−g)ᵀ c_world)
"""
from __future__ import annotations

import numpy as np

from .._jit import A1, A2, MODEL, entry, njit
from .forward_kinematics import fk_pass, fk_scratch
from .kernel_inputs import nonfinite_input
from .model_arrays import kernel_arrays, unpack
from .arguments import as_batch, fast, fast_shape, raise_kernel_error
from .status import bad_result


@njit(cache=True, inline="always")
def energy_of(mdl, q, v, Rl, pl, Rw, pw, ww, vw):
    """T of one state (v (nv,)) or V (v with no entries: potential energy); Rl … vw are forward_kinematics.fk_pass's
    scratch arrays. Non-finite input gives a non-finite energy."""
    mass, com, inertia, mg = mdl.mass, mdl.com, mdl.inertia, mdl.mg
    fk_pass(mdl, q, v, Rl, pl, Rw, pw, ww, vw)
    kinetic = v.shape[0] > 0
    e = 0.0
    for b in range(mass.shape[0]):
        R = Rw[b]
        cx = R[0, 0] * com[b, 0] + R[0, 1] * com[b, 1] + R[0, 2] * com[b, 2]     # R c: CoM from the origin
        cy = R[1, 0] * com[b, 0] + R[1, 1] * com[b, 1] + R[1, 2] * com[b, 2]
        cz = R[2, 0] * com[b, 0] + R[2, 1] * com[b, 1] + R[2, 2] * com[b, 2]
        if not kinetic:                                                        # V: m (−g)ᵀ c_world
            e += mass[b] * (mg[0] * (pw[b, 0] + cx) + mg[1] * (pw[b, 1] + cy) + mg[2] * (pw[b, 2] + cz))
            continue
        wx, wy, wz = ww[b, 0], ww[b, 1], ww[b, 2]
        ux = vw[b, 0] + wy * cz - wz * cy                                      # v_C = v_o + ω × R c
        uy = vw[b, 1] + wz * cx - wx * cz
        uz = vw[b, 2] + wx * cy - wy * cx
        ax = R[0, 0] * wx + R[1, 0] * wy + R[2, 0] * wz                        # ω' = Rᵀ ω
        ay = R[0, 1] * wx + R[1, 1] * wy + R[2, 1] * wz
        az = R[0, 2] * wx + R[1, 2] * wy + R[2, 2] * wz
        Ii = inertia[b]
        e += 0.5 * (mass[b] * (ux * ux + uy * uy + uz * uz)
                    + ax * (Ii[0, 0] * ax + Ii[0, 1] * ay + Ii[0, 2] * az)
                    + ay * (Ii[1, 0] * ax + Ii[1, 1] * ay + Ii[1, 2] * az)
                    + az * (Ii[2, 0] * ax + Ii[2, 1] * ay + Ii[2, 2] * az))
    return e


@njit(cache=True)
def energy_kernel(I, F, Q, V, out):
    """out[s] = T (V (N, nv)) or V (V with no columns: potential energy) of every state of Q (N, nq). Returns
    its status (dynamics/status.py; a non-finite out[s]: index s)."""
    nb, mdl = I.shape[1], unpack(I, F)
    Rl, pl, Rw, pw, ww, vw = fk_scratch(nb)
    for s in range(Q.shape[0]):
        bad = nonfinite_input(Q, V, s)
        if bad >= 0:
            return bad
        out[s] = energy_of(mdl, Q[s], V[s], Rl, pl, Rw, pw, ww, vw)
        if not np.isfinite(out[s]):
            return bad_result(nb, s)
    return -1


@njit(cache=True, inline="always")
def energy_one(I, F, q, v):
    """The energy of one state q (nq,), v (nv,) or (0,) (potential): ``energy_of``, as ``energy_kernel`` runs it on
    a state (without its loop, row views and result array: 0.61 → 0.40 µs a call in a compiled loop, ur5). A
    non-finite input makes a non-finite energy (no product or sum of the passes drops a NaN or ±inf), on which the
    public call takes the checked path, which names the input."""
    nb, mdl = I.shape[1], unpack(I, F)
    Rl, pl, Rw, pw, ww, vw = fk_scratch(nb)
    return energy_of(mdl, q, v, Rl, pl, Rw, pw, ww, vw)


@njit(cache=True)
def potential_one(I, F, q):
    """V of one state q (nq,): energy_one with no velocities."""
    return energy_one(I, F, q, q[:0])


# The compiled code every call reaches (``_jit.entry``; arrays of any strides): batches, and one state
ENERGY = entry(energy_kernel, *MODEL, A2, A2, A1)
KINETIC_ONE = entry(energy_one, *MODEL, A1, A1)
POTENTIAL_ONE = entry(potential_one, *MODEL, A1)


def _energy(model, call, *arrays):
    """The kernel on (q,) (potential) or (q, v) (kinetic): float for one state, (N,) for a batch; anything but
    float64 arrays is checked and converted first."""
    kinetic = len(arrays) == 2
    nd = fast_shape(model, *arrays)
    if nd == 1:
        batches = tuple(x[None] for x in arrays)
    elif nd == 2:
        batches = arrays
    else:
        batches, single = as_batch(model, **dict(zip(("q", "v"), arrays)))
        nd = 1 if single else 2
        if not model.njoints:
            return 0.0 if single else np.zeros(batches[0].shape[0])
    Q = batches[0]
    Vb = batches[1] if kinetic else np.empty((Q.shape[0], 0))
    out = np.empty(Q.shape[0])
    code = ENERGY.call(*kernel_arrays(model), Q, Vb, out)
    if code != -1:
        raise_kernel_error(model, code, ("q", "v")[:len(arrays)], batches, call, "T" if kinetic else "V",
                           out)
    return float(out[0]) if nd == 1 else out


def kinetic_energy(model, q, v):
    """T = Σ_links ½ m |v_C|² + ½ ωᵀ (R I Rᵀ) ω, v_C = v_o + ω × R c (world), float or (N,)."""
    k = fast(model, q, v)
    if k is not None:                             # one float64 state: a finite result is the answer
        e = KINETIC_ONE.call(k[0], k[1], q, v)
        if e - e == 0.0:
            return e
    return _energy(model, "kinetic_energy", q, v)


def potential_energy(model, q):
    """V = −Σ_links m gᵀ c (gravity g in the base frame, CoM c in world coordinates), float or (N,)."""
    k = fast(model, q)
    if k is not None:
        e = POTENTIAL_ONE.call(k[0], k[1], q)
        if e - e == 0.0:
            return e
    return _energy(model, "potential_energy", q)


