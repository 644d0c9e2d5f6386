"""A floating-base model for the tests: a fixed-base Model with a free-flyer root joint prepended (the
root link becomes body 0), until the loader offers it. Pinocchio's counterpart is
buildModelFromUrdf(path, JointModelFreeFlyer()): same q layout ([x y z qx qy qz qw] first), same v."""
import dataclasses

import numpy as np

import manipdyn as md
from manipdyn.joints import FREEFLYER


def with_free_flyer(model, mass, com, inertia):
    """``model`` with a free flyer "root_joint" carrying the root link (mass, CoM (3,), inertia about the
    CoM in the root link's axes (3, 3)); the other joints, frames and closures keep their places."""
    def cat(first, rest):
        return np.concatenate([np.asarray(first, rest.dtype)[None], rest])
    frames = {name: dataclasses.replace(f, body=f.body + 1) for name, f in model.frames.items()}
    closures = tuple(dataclasses.replace(c, parent=c.parent + 1, child=c.child + 1) for c in model.constraints)
    return dataclasses.replace(
        model, joint_names=("root_joint",) + model.joint_names, body_names=(model.root_link,) + model.body_names,
        parent=cat(-1, np.where(model.parent < 0, 0, model.parent + 1)), kind=cat(FREEFLYER, model.kind),
        continuous=cat(False, model.continuous), axis=cat(np.zeros(3), model.axis), R0=cat(np.eye(3), model.R0),
        p0=cat(np.zeros(3), model.p0), mass=cat(mass, model.mass), com=cat(com, model.com),
        inertia=cat(inertia, model.inertia), lower=cat(-np.inf, model.lower), upper=cat(np.inf, model.upper),
        effort=cat(np.inf, model.effort), velocity=cat(np.inf, model.velocity), frames=frames,
        constraints=closures, actuated=model.actuated,
        **{k: np.concatenate([np.zeros(6), getattr(model, k)]) for k in ("armature", "damping", "friction")})


def random_floating_states(model, n, rng):
    """n states (q (n, nq), v (n, nv)): the root anywhere within 1 m with a uniformly random orientation,
    the joints as docs/design.md §3 (revolute uniform in [−π, π], prismatic in [−0.5, 0.5]), v ~ N(0, 2²)."""
    Q = np.empty((n, model.nq))
    Q[:, :3] = rng.uniform(-1.0, 1.0, (n, 3))
    quat = rng.normal(size=(n, 4))
    Q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    rest = model.kind[1:]
    Q[:, 7:] = np.where(rest == md.REVOLUTE, rng.uniform(-np.pi, np.pi, (n, len(rest))),
                        rng.uniform(-0.5, 0.5, (n, len(rest))))
    return Q, rng.normal(0.0, 2.0, (n, model.nv))


def integrate(model, Q, V):
    """Q ⊕ V (joints.integrate_kernel): the configuration reached from Q at velocity V in unit time."""
    from manipdyn.joints import integrate_kernel
    Q, V = np.atleast_2d(Q).astype(float), np.atleast_2d(V).astype(float)
    out = np.empty_like(Q)
    integrate_kernel(np.asarray(model.kind), np.asarray(model.idx_q), np.asarray(model.idx_v), Q, V, out)
    return out
