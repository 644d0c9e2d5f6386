"""Energies, from the links' motion (not from M): the physical laws the tests check the dynamics against."""
from __future__ import annotations

import numpy as np

from .kinematics import axes_world, body_twists, placements
from .state import as_batch, check_output, quiet, unbatch


@quiet
def kinetic_energy(model, q, v):
    """T = Σ_links ½ m |v_C|² + ½ ωᵀ (R I Rᵀ) ω, float or (N,)."""
    (Q, V), single = as_batch(model, q=q, v=v)
    R, p = placements(model, Q)
    w, vel = body_twists(model, p, axes_world(model, R), V)
    c = np.einsum("bnij,bj->bni", R, model.com)                    # CoM offset from the origin, world
    vc = vel + np.cross(w, c)
    Iw = R @ model.inertia[:, None] @ np.swapaxes(R, -1, -2)
    T = 0.5 * np.einsum("b,bni,bni->n", model.mass, vc, vc) + 0.5 * np.einsum("bni,bnij,bnj->n", w, Iw, w)
    return unbatch(check_output("kinetic_energy", "T", T, model, dict(q=Q, v=V)), single)


@quiet
def potential_energy(model, q):
    """V = −Σ_links m gᵀ c (gravity g in the base frame, CoM c in world coordinates), float or (N,)."""
    (Q,), single = as_batch(model, q=q)
    R, p = placements(model, Q)
    c = p + np.einsum("bnij,bj->bni", R, model.com)
    V = -np.einsum("b,bni,i->n", model.mass, c, model.gravity)
    return unbatch(check_output("potential_energy", "V", V, model, dict(q=Q)), single)
