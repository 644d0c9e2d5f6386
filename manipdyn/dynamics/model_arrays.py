"""The model as the compiled kernels read it: two arrays, and their named views.

Kernel form (``kernel_arrays``, built once per model, laid out by ``kernel_form.KernelForm``): two arrays instead
of many (each array argument of a compiled call costs ~30 ns of dispatch, each reshape inside a kernel as much
again):
  I (5, nb) int64        = rows parent, kind, idx_q, idx_v, nv_j (one column per joint: rows are contiguous
                           views, ~40 ns cheaper per call to unpack than strided columns)
  F (4 nb + 1 + m, 3, 3) = blocks of 3×3 numbers:  F[0:nb] R0,  F[nb:2nb] inertia (about the CoM, body axes),
                           F[2nb:3nb] rows [axis; p0; com],  F[3nb:4nb, 0, 0] mass,  F[3nb:4nb, 0, 1] pitch,  F[4nb, 0] −g,
                           F[4nb+1:4nb+1+m] S (nv, 6), padded to m = max(2, 2⌈nv/3⌉) blocks,
                           F[4nb+1+m:4nb+1+m+a] the armature (nv,), padded to a = ⌈nv/9⌉ whole blocks,
                           F[4nb+1+m+a:] the turn C_i of each body frame from its link's (x_link = C_i x),
viewed again by ``unpack`` inside the kernels (slices, one reshape).
S holds one row per joint velocity, [linear; angular] in the body frame (``joints.motion_subspace``).

Placement convention (owned here): R maps body coordinates into the parent's (or the world's), x_parent
= R x_body + p; so the chapter's R^i_{i−1} x is Rᵀ x.
"""
from __future__ import annotations

from collections import namedtuple

from .._jit import njit


def kernel_arrays(model):
    """(I, F): the model in the kernels' two-array form (``model.Model.kernel``, built with the model)."""
    return model.kernel.arrays


ModelArrays = namedtuple("ModelArrays", "parent kind iq iv nvj S axis R0 p0 mass com inertia mg armature pitch turn")
ModelArrays.__doc__ = """The model as every kernel reads it (``unpack``), views of Model.kernel's (I, F):
    parent (nb,) int   λ(i), −1 for the fixed base (parent[i] < i)
    kind (nb,) int     the joint's code in the registry (joints.KINDS, joints.IN_MODEL)
    iq, iv (nb,) int   joint i's first entry in q and in v
    nvj (nb,) int      joint i's number of velocities
    S (nv, 6)          motion subspace rows [linear; angular] in the body frame (joints.motion_subspace)
    axis (nb, 3)       joint axis in the body frame
    R0 (nb, 3, 3)      joint frame in the parent body at q = 0;   p0 (nb, 3) its origin
    mass (nb,)         body mass;   com (nb, 3) centre of mass (body frame);   inertia (nb, 3, 3) about the CoM
    mg (3,)            −g, the base acceleration that stands for gravity
    armature (nv,)     rotor inertia per velocity (Model.armature): M + diag(armature), τ += armature ⊙ q̈
    pitch (nb,)        a helical joint's pitch, m/rad (0 for every other kind)
    turn (nb, 3, 3)    C_i, body i's frame in its link's (x_link = C_i x): the identity in the model's own form, the
                       turn onto the joint axis in the lane steps' z-aligned form (kernel_form.z_aligned)"""


@njit(cache=True, inline="always")
def unpack(I, F):
    """The named views (``ModelArrays``) of the two kernel arrays (the layout is Model.kernel's: KernelForm)."""
    nb = I.shape[1]
    nv = I[3, nb - 1] + I[4, nb - 1] if nb else 0        # velocities in body order: the last body's end
    m = max(2, 2 * ((nv + 2) // 3))                      # S's blocks (KernelForm.of)
    e = 4 * nb + 1 + m + (nv + 8) // 9                   # the armature's end
    B = F[2 * nb:3 * nb]
    return ModelArrays(I[0], I[1], I[2], I[3], I[4], F[4 * nb + 1:4 * nb + 1 + m].reshape(-1, 6)[:nv],
                       B[:, 0], F[:nb], B[:, 1], F[3 * nb:4 * nb, 0, 0], B[:, 2], F[nb:2 * nb], F[4 * nb, 0],
                       F[4 * nb + 1 + m:e].reshape(-1)[:nv], F[3 * nb:4 * nb, 0, 1], F[e:e + nb])
