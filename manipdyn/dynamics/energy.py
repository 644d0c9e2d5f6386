"""Energies, from the links' motion (not from M): the physical laws the tests check the dynamics against.
Both read the one forward kinematics (core.forward_kinematics), for any joint type."""
from __future__ import annotations

import numpy as np

from .core import forward_kinematics
from .state import as_batch, check_output, quiet, unbatch


@quiet
def kinetic_energy(model, q, v):
    """T = Σ_links ½ m |v_C|² + ½ ωᵀ (R I Rᵀ) ω, v_C = v_o + ω × R c (world), float or (N,)."""
    (Q, V), single = as_batch(model, q=q, v=v)
    R, p, w, vo = forward_kinematics(model, Q, V)                      # (nb, N, ...) world
    c = np.einsum("bnij,bj->bni", R, model.com)                        # CoM offset from the origin, world
    vc = vo + np.cross(w, c)
    wl = np.einsum("bnji,bnj->bni", R, w)                              # ω in body axes: ωᵀ R I Rᵀ ω = ω'ᵀ I ω'
    T = 0.5 * np.einsum("b,bni,bni->n", model.mass, vc, vc) + 0.5 * np.einsum("bni,bij,bnj->n", wl, model.inertia, wl)
    return unbatch(check_output("kinetic_energy", "T", T, model, dict(q=Q, v=V)), single)


@quiet
def potential_energy(model, q):
    """V = −Σ_links m gᵀ c (gravity g in the base frame, CoM c in world coordinates), float or (N,)."""
    (Q,), single = as_batch(model, q=q)
    R, p = forward_kinematics(model, Q)
    c = p + np.einsum("bnij,bj->bni", R, model.com)
    V = -np.einsum("b,bni,i->n", model.mass, c, model.gravity)
    return unbatch(check_output("potential_energy", "V", V, model, dict(q=Q)), single)
