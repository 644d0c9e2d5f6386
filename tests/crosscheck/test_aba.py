"""aba (dynamics/aba.py: the articulated-body algorithm, one compiled source) against independent references:

- Pinocchio's aba on every example-robot-data arm, the AAU arm, random trees (revolute, prismatic and fixed
  joints: merged links give frames with offsets) and solo12 on a free-flyer root — one state (the
  ``aba_one`` entry: ``aba_steps_one``) and batches (``aba_lanes``), with f_ext per frame converted to Pinocchio's per-joint
  fext, in both frames;
- the identity M q̈ + h = τ with Pinocchio's M (crba) and h (nonLinearEffects);
- the same source run uncompiled (MANIPDYN_NOJIT=1, in a subprocess) on three small models, to 1e-14.

q̈ comes from a solve: its error bound scales with cond(M) (docs/design.md §3). Every tolerance is within 100× of
the error measured on correct code (written beside it).
"""
import dataclasses
import functools
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, err, inertial_xml, urdf, zoo_paths
from nojit import assert_uncompiled_equals_compiled

import manipdyn as md
from manipdyn.validation import random_states, robots_dir
from manipdyn.validation.reference import Reference

SOLO12 = "solo_description/robots/solo12.urdf"


# ---- models: ours and Pinocchio's, with q mapped to Pinocchio's q --------------------------------------

def _random_tree_text(seed, n=12):
    """URDF of a random tree: revolute, prismatic and fixed joints (fixed ones merge links into bodies, so
    link frames sit at offsets in their bodies), random axes, placements and inertias."""
    rng = np.random.default_rng(seed)
    links, joints = {"base": ""}, []
    for k in range(n):
        parent = "base" if k == 0 or rng.random() < 0.2 else f"L{rng.integers(0, k)}"
        d, m = rng.uniform(0.05, 1.0, 3), rng.uniform(0.1, 3.0)
        I = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10      # a physical inertia
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*I, 0, 0, 0), rng.uniform(-np.pi, np.pi, 3))
        axis = rng.normal(size=3)
        kind = ("revolute", "prismatic", "fixed")[rng.integers(3)] if k else "revolute"
        joints.append((f"j{k:02d}", kind, parent, f"L{k}", rng.uniform(-0.5, 0.5, 3),
                       rng.uniform(-np.pi, np.pi, 3), axis / np.linalg.norm(axis)))
    return urdf(links, joints, name=f"tree{seed}")


@dataclasses.dataclass
class Case:
    model: md.Model
    pm: object                    # Pinocchio's model
    to_pin: object                # our q (nq,) -> Pinocchio's q

    def states(self, n, seed):
        """n random states (q, q̇, τ) (docs/design.md §3; a free flyer anywhere within 1 m, uniformly oriented)."""
        return random_states(self.model, n, np.random.default_rng(seed))


@functools.lru_cache(maxsize=None)
def case(name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if name.startswith("tree"):
            text = _random_tree_text(int(name[4:]))
            model, pm = md.load_urdf_string(text), pin.buildModelFromXML(text)
            assert model.joint_names == tuple(pm.names[1:])
            return Case(model, pm, lambda q: q)                  # no continuous joints: same q
        if name == "solo12_floating":                            # Pinocchio's free-flyer root
            path = robots_dir() / SOLO12
            ref = Reference(md.load_urdf(path, root_joint="free_flyer"), path)
            return Case(ref.model, ref.pm, ref.to_pin_q)
        path = AAU if name == "aau_arm" else next(p for p in zoo_paths() if p.stem == name)
        ref = Reference(md.load_urdf(path), path)
        return Case(ref.model, ref.pm, ref.to_pin_q)


def pin_fext(c, q, f_ext, frame):
    """Our {frame: (force, moment)} for one state -> Pinocchio's per-joint fext (local joint frame, about
    the joint origin), through Pinocchio's own frame placements."""
    pd = c.pm.createData()
    pin.framesForwardKinematics(c.pm, pd, c.to_pin(q))
    out = [pin.Force.Zero() for _ in range(c.pm.njoints)]
    for name, (f, m) in f_ext.items():
        fid = c.pm.getFrameId(name, pin.FrameType.BODY)
        if frame == "world":                                     # world axes -> the frame's axes
            Rw = pd.oMf[fid].rotation
            f, m = Rw.T @ f, Rw.T @ m
        out[c.pm.frames[fid].parentJoint] += c.pm.frames[fid].placement.act(pin.Force(f, m))
    return out


def pinocchio(c, Q, V, T, f_ext=None, frame="local"):
    """Pinocchio's q̈, M, h (= C q̇ + g) and cond(M) for every state."""
    pd = c.pm.createData()
    out = {k: [] for k in ("qdd", "M", "h", "cond")}
    for s in range(len(Q)):
        pq = c.to_pin(Q[s])
        if f_ext:
            fx = {k: (np.broadcast_to(f, (len(Q), 3))[s], np.broadcast_to(m, (len(Q), 3))[s])
                  for k, (f, m) in f_ext.items()}
            out["qdd"].append(pin.aba(c.pm, pd, pq, V[s], T[s], pin_fext(c, Q[s], fx, frame)).copy())
        else:
            out["qdd"].append(pin.aba(c.pm, pd, pq, V[s], T[s]).copy())
        M = pin.crba(c.pm, pd, pq).copy()
        out["M"].append(M)
        out["h"].append(pin.nonLinearEffects(c.pm, pd, pq, V[s]).copy())
        out["cond"].append(np.linalg.cond(M))
    return {k: np.array(x) for k, x in out.items()}


# ---- against Pinocchio ------------------------------------------------------------------------------------

# Tolerances × cond(M) of each state (the worst state of 7, one-state call included, measured × 30 rounded
# up): (q̈ vs pin.aba, M q̈ + h vs τ)                                 measured: q̈, residual (/ cond)
TOL = {
    "aau_arm": (6e-19, 2e-17),                          # 1.7e-20 5.5e-19
    "ur5_robot": (7e-17, 4e-16),                        # 2.1e-18 1.0e-17
    "ur10_robot": (8e-19, 2e-17),                       # 2.6e-20 4.8e-19
    "ur3_robot": (2e-17, 7e-17),                        # 6.1e-19 2.1e-18
    "ur5_gripper": (9e-17, 2e-15),                      # 2.8e-18 4.1e-17
    "panda": (6e-17, 5e-16),                            # 2.0e-18 1.4e-17
    "kinova": (8e-18, 2e-16),                           # 2.6e-19 3.8e-18
    "xarm7": (2e-18, 7e-17),                            # 3.5e-20 2.1e-18
    "z1": (2e-17, 2e-16),                               # 5.1e-19 3.7e-18
    "so100": (3e-17, 5e-16),                            # 8.6e-19 1.5e-17
    "so101": (7e-17, 6e-16),                            # 2.2e-18 2.0e-17
    "double_pendulum": (3e-15, 2e-15),                  # 7.4e-17 5.0e-17
    "double_pendulum_continuous": (3e-15, 2e-15),       # 7.4e-17 5.0e-17
    "TwoDofs": (3e-15, 3e-15),                          # 7.2e-17 9.1e-17
    "finger_edu": (6e-15, 7e-15),                       # 1.8e-16 2.1e-16
    "allegro_right_hand": (3e-16, 6e-16),               # 8.9e-18 1.9e-17
    "allegro_left_hand": (3e-16, 7e-16),                # 9.8e-18 2.1e-17
    "baxter": (1e-16, 5e-16),                           # 3.3e-18 1.4e-17
    "talos_left_arm": (6e-17, 9e-16),                   # 1.9e-18 2.9e-17
    "tree3": (8e-17, 2e-15),                            # 2.4e-18 4.3e-17
    "tree4": (9e-16, 2e-14),                            # 2.7e-17 4.3e-16
    "solo12_floating": (2e-18, 3e-17),                  # 5.5e-20 7.4e-19
}
CASES = list(TOL)


@pytest.mark.parametrize("name", CASES)
def test_aba_matches_pinocchio_one_state_and_batch(name):
    c = case(name)
    Q, V, T = c.states(7, 41)
    ref = pinocchio(c, Q, V, T)
    batch, one = md.aba(c.model, Q, V, T), md.aba(c.model, Q[0], V[0], T[0])
    assert one.shape == (c.model.nv,) and batch.shape == (7, c.model.nv)
    tol_qdd, tol_residual = TOL[name]
    for s, qdd in [(0, one)] + list(enumerate(batch)):
        assert err(qdd, ref["qdd"][s]) <= tol_qdd * ref["cond"][s], f"state {s}: q̈ vs pin.aba"
        residual = ref["M"][s] @ qdd + ref["h"][s]
        assert err(residual, T[s]) <= tol_residual * ref["cond"][s], f"state {s}: M q̈ + h vs τ"


def _wrenches(c, N, rng):
    """f_ext on three frames: the last body, a link frame with an offset in its body (a merged link, when
    the model has one) and a second frame on that same body, the last with per-state values (N, 3)."""
    m = c.model
    merged = [f for f in m.frames.values() if f.body >= 0 and (np.any(f.p) or not np.allclose(f.R, np.eye(3)))]
    names = [m.body_names[-1]]
    if merged:
        names += [merged[0].name, m.body_names[merged[0].body]]
    else:
        names += [m.body_names[0]]
    out = {n: (rng.normal(size=3), rng.normal(size=3)) for n in names[:-1]}
    out[names[-1]] = (rng.normal(size=(N, 3)), rng.normal(size=(N, 3)))
    return out


# × cond(M), measured × 30 rounded up: (local, world)                 measured (/ cond): local, world
TOL_FEXT = {
    "ur5_robot": (6e-17, 8e-17),                        # 1.8e-18 2.4e-18
    "panda": (5e-17, 4e-17),                            # 1.4e-18 1.3e-18
    "baxter": (2e-16, 2e-16),                           # 4.9e-18 5.4e-18
    "tree3": (3e-16, 2e-16),                            # 6.7e-18 5.8e-18
    "tree4": (9e-16, 1e-15),                            # 2.9e-17 3.2e-17
    "solo12_floating": (7e-19, 9e-19),                  # 2.1e-20 3.0e-20
}
FEXT_CASES = list(TOL_FEXT)


@pytest.mark.parametrize("frame", ["local", "world"])
@pytest.mark.parametrize("name", FEXT_CASES)
def test_aba_f_ext_matches_pinocchio(name, frame):
    c = case(name)
    Q, V, T = c.states(5, 43)
    fx = _wrenches(c, 5, np.random.default_rng(44))
    ref = pinocchio(c, Q, V, T, fx, frame)
    qdd = md.aba(c.model, Q, V, T, f_ext=fx, f_ext_frame=frame)
    tol = TOL_FEXT[name][frame == "world"]
    for s in range(5):
        assert err(qdd[s], ref["qdd"][s]) <= tol * ref["cond"][s], f"state {s}"
    one = md.aba(c.model, Q[2], V[2], T[2], f_ext={k: (np.broadcast_to(f, (5, 3))[2], np.broadcast_to(n, (5, 3))[2])
                                                   for k, (f, n) in fx.items()}, f_ext_frame=frame)
    assert err(one, qdd[2]) <= 1e-15                     # measured 0: the same kernel, N = 1


def test_free_flying_point_mass_is_singular_at_the_root():
    # a point mass on a free flyer: D_root = I_root (6 × 6) has rank 3, the Cholesky pivot of rotation fails
    model = md.load_urdf_string(urdf({"ball": inertial_xml(2.0)}, []), root_joint="free_flyer")
    q, z = np.r_[0.0, 0, 0, 0, 0, 0, 1], np.zeros(6)
    with pytest.raises(md.SingularError, match="'root_joint'"):
        md.aba(model, q, z, z)
    solid = dataclasses.replace(model, inertia=np.diag([0.1, 0.2, 0.3])[None])
    assert err(md.aba(solid, q, z, np.r_[2.0, 0, 0, 0.1, 0, 0]), [1.0, 0, -9.81, 1.0, 0, 0]) <= 1e-15  # measured 0


def test_free_flyer_state_checks_name_the_coordinate():
    m = case("solo12_floating").model
    q, z = np.r_[0, 0, 0, 0, 0, 0, 1, np.zeros(12)], np.zeros(18)
    with pytest.raises(md.InputError, match=r"shape \(18,\)"):
        md.aba(m, z, z, z)                                   # q has nq = 19 entries
    bad = q.copy()
    bad[4] = np.nan
    with pytest.raises(md.InputError, match="root_joint.qy"):
        md.aba(m, bad, z, z)


def test_cholesky_route_matches_pinocchio_on_a_free_flyer():
    c = case("solo12_floating")
    Q, V, T = c.states(5, 45)
    ref = pinocchio(c, Q, V, T)
    qdd = md.forward_dynamics(c.model, Q, V, T, method="cholesky")
    for s in range(5):
        assert err(qdd[s], ref["qdd"][s]) <= 2e-18 * ref["cond"][s], f"state {s}"   # measured 4.5e-20 × cond


# ---- the same source, uncompiled -------------------------------------------------------------------------

NOJIT_CASES = ["double_pendulum", "tree4", "solo12_floating"]
PROBE = """
import json, sys
import numpy as np
sys.path[:0] = [{tests!r}, {here!r}]
import manipdyn as md
from manipdyn import _jit
import test_aba as T
out = {{"nojit": _jit.NOJIT}}
for name in {names!r}:
    c = T.case(name)
    Q, V, Tau = c.states(3, 47)
    fx = T._wrenches(c, 3, np.random.default_rng(48))
    out[name] = [md.aba(c.model, Q, V, Tau).tolist(), md.aba(c.model, Q[0], V[0], Tau[0]).tolist(),
                 md.aba(c.model, Q, V, Tau, f_ext=fx, f_ext_frame="world").tolist()]
print(json.dumps(out))
"""



def test_uncompiled_source_gives_the_compiled_numbers():
    assert_uncompiled_equals_compiled(PROBE, __file__, NOJIT_CASES, tol=1e-14)   # measured 0 (bit-identical)
