"""Floating bases (free-flyer root) against Pinocchio's buildModelFromUrdf(path, pin.JointModelFreeFlyer()).

Legged robots, humanoids and a lone free body of example-robot-data: the loader's model (nq, nv, q order,
every body's inertia and placement), the configuration helpers (neutral, integrate, difference,
random_configuration, normalize) against pin.neutral / pin.integrate / pin.difference, the loader's
root_joint argument and its free-body warning, and the dynamics (rnea, crba, aba, validate) at random
states. Our q goes to Pinocchio's through validation.Reference.to_pin_q (continuous joints as cos/sin; the
free-flyer block is the same).

The tests named test_dynamics_* need the free-flyer kernels (rnea, crba, aba, kinematics); with kernels
that do not know the free flyer they fail (or the compiled ones crash): deselect them with -k "not dynamics".
"""
import functools
import warnings

import numpy as np
import pytest
from conftest import assert_close, err, inertial_xml, urdf

import manipdyn
from manipdyn import (FREEFLYER, FloatingBaseWarning, InputError, URDFError, difference, integrate, load_urdf,
                      load_urdf_string, neutral, normalize, random_configuration)
from manipdyn.validation.reference import Reference
from manipdyn.validation.zoo import FLOATING, floating_paths, robots_dir

pin = pytest.importorskip("pinocchio")

ROBOTS = {   # name -> path under robots/
    "solo12": "solo_description/robots/solo12.urdf",
    "anymal": "anymal_b_simple_description/robots/anymal.urdf",
    "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    "go1": "go1_description/urdf/go1.urdf",
    "talos": "talos_data/robots/talos_reduced.urdf",
    "romeo": "romeo_description/urdf/romeo.urdf",        # 24 massless finger bodies: M singular
    "icub": "icub_description/robots/icub.urdf",
    "pr2": "pr2_description/urdf/pr2.urdf",             # continuous (cos/sin in Pinocchio) and prismatic joints
    "hector": "hector_description/robots/quadrotor_base.urdf",   # the free flyer alone (nv = 6)
}
SINGULAR_M = {"romeo"}


@functools.lru_cache(maxsize=None)
def robot(name):
    """(our free-flyer model, its Reference: Pinocchio's free-flyer model and the q conversion)."""
    path = robots_dir() / ROBOTS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # inertia notes of the e-r-d files (triangle inequality)
        model = load_urdf(path, root_joint="free_flyer")
    return model, Reference(model, path)


def pq(ref, Q):
    """Our q (nq,) or (N, nq) -> Pinocchio's."""
    Q = np.asarray(Q)
    return ref.to_pin_q(Q) if Q.ndim == 1 else np.array([ref.to_pin_q(q) for q in Q])


def velocities(model, rng, n, angular):
    """(n, nv) velocities: N(0, 1) everywhere, the free flyer's angular part N(0, angular²)."""
    V = rng.normal(0.0, 1.0, (n, model.nv))
    V[:, 3:6] *= angular
    return V


# ---- the loader ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ROBOTS)
def test_loader_builds_pinocchios_free_flyer_model(name):
    model, ref = robot(name)
    pm = ref.pm
    assert (model.nq, model.nv, model.njoints) == (pm.nq - int(model.continuous.sum()), pm.nv, pm.njoints - 1)
    assert model.joint_names == tuple(pm.names[1:]) and model.joint_names[0] == "root_joint"
    assert model.floating and model.kind[0] == FREEFLYER and model.kind[1:].tolist().count(FREEFLYER) == 0
    assert model.parent.tolist() == [p - 1 for p in pm.parents[1:]]
    assert model.body_names[0] == model.root_link
    assert np.all(model.R0[0] == np.eye(3)) and np.all(model.p0[0] == 0.0)
    assert model.lower[0] == -np.inf and model.upper[0] == np.inf
    for i in range(model.njoints):            # the root body carries the root link and its fixed children
        Y, X = pm.inertias[i + 1], pm.jointPlacements[i + 1]
        assert_close(model.mass[i], Y.mass, 1e-14, f"{name} mass {i}")             # measured 0 (sums in one order)
        assert_close(model.com[i], Y.lever, 1e-14, f"{name} com {i}")             # measured ≤ 2e-16
        assert_close(model.inertia[i], Y.inertia, 1e-13, f"{name} inertia {i}")   # measured ≤ 1.8e-15 (hyq)
        assert_close(model.R0[i], X.rotation, 1e-14, f"{name} R0 {i}")            # measured ≤ 2e-16
        assert_close(model.p0[i], X.translation, 1e-14, f"{name} p0 {i}")
    assert model.q_names[:7] == tuple(f"root_joint.{c}" for c in ("x", "y", "z", "qx", "qy", "qz", "qw"))


def test_the_floating_zoo_loads_as_pinocchio_does():
    paths = floating_paths()
    assert len(paths) == len(FLOATING) >= 20       # a missing robot must fail loudly, not shrink the zoo
    for path in paths:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            model = load_urdf(path, root_joint="free_flyer")
        pm = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
        assert model.joint_names == tuple(pm.names[1:]) and model.nv == pm.nv, path.name
        assert_close(model.mass, [Y.mass for Y in pm.inertias[1:]], 1e-14, path.name)


@pytest.mark.parametrize("value", ["floating", "FreeFlyer", "free-flyer", "", 1, True, ("free_flyer",)])
def test_root_joint_refuses_other_values(value, write_urdf):
    text = urdf({"base": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0))}, [])
    for load in (lambda: load_urdf(write_urdf(text), root_joint=value),
                 lambda: load_urdf_string(text, root_joint=value)):
        with pytest.raises(InputError, match="accepted values: None .*'free_flyer'"):
            load()


def test_root_joint_with_a_reduction():
    # the reduction itself is held to Pinocchio's buildReducedModel in test_reduce.py
    path = robots_dir() / ROBOTS["solo12"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_urdf(path, root_joint="free_flyer", locked={"FL_HAA": 0.2}, tips=["FR_FOOT"])
    assert model.joint_names == ("root_joint", "FR_HAA", "FR_HFE", "FR_KFE") and (model.nq, model.nv) == (10, 9)
    assert model.locked["FL_HAA"] == 0.2 and model.locked["HL_KFE"] == 0.0
    with pytest.raises(InputError, match="'root_joint' is 0.0: expected a pose"):
        load_urdf(path, root_joint="free_flyer", locked={"root_joint": 0.0})


def test_a_moving_joint_named_root_joint_is_refused():
    text = urdf({"base": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0)), "l1": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0))},
                [("root_joint", "revolute", "base", "l1", (0, 0, 0), (0, 0, 0), (0, 0, 1))])
    with pytest.raises(URDFError, match="'root_joint' exists already"):
        load_urdf_string(text, root_joint="free_flyer")
    with warnings.catch_warnings():
        warnings.simplefilter("error", FloatingBaseWarning)   # a body beside the root, nothing hangs: no warning
        assert load_urdf_string(text).joint_names == ("root_joint",)     # without the free flyer: fine


BODY = {"base": inertial_xml(2.5, com=(0.1, 0, 0), I=(0.1, 0.2, 0.3, 0, 0, 0)), "leg": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0)),
        "imu": inertial_xml(0.5, I=(0.01, 0.01, 0.01, 0, 0, 0))}
BODY_JOINTS = [("hip", "revolute", "base", "leg", (0, 0, -0.3), (0, 0, 0), (0, 1, 0)),   # hangs: 0.3 below
               ("imu_fixed", "fixed", "base", "imu", (0.2, 0, 0), (0, 0, 0), None)]


def test_a_fixed_base_with_mass_gets_a_note_and_a_warning():
    text = urdf(BODY, BODY_JOINTS)
    with pytest.warns(FloatingBaseWarning, match=r"root link 'base' .*\(imu\) carries 3 kg that no joint moves"):
        model = load_urdf_string(text)
    note = [n for n in model.notes if "no joint moves" in n]
    assert len(note) == 1 and 'root_joint="free_flyer"' in note[0] and "no effect on the dynamics" in note[0]
    pm = pin.buildModelFromXML(text)                  # Pinocchio puts the same mass on the universe
    assert f"carries {pm.inertias[0].mass:.6g} kg" in note[0]
    assert not model.floating and model.nv == model.nq == 1


def test_the_free_body_warning_is_not_given_when_it_does_not_apply():
    cases = {"free flyer": (urdf(BODY, BODY_JOINTS), "free_flyer"),
             "massless root": (urdf({**BODY, "base": "", "imu": ""}, BODY_JOINTS), None),
             "root named world": (urdf({"world": inertial_xml(3.0, I=(1, 1, 1, 0, 0, 0)), "leg": BODY["leg"]},
                                       [("hip", "revolute", "world", "leg", (0, 0, 0), (0, 0, 0), (0, 1, 0))]), None)}
    for what, (text, root_joint) in cases.items():
        with warnings.catch_warnings():
            warnings.simplefilter("error", FloatingBaseWarning)
            model = load_urdf_string(text, root_joint=root_joint)
        assert not any("no joint moves" in n for n in model.notes), what


def test_the_free_flyer_body_is_the_fixed_base_merged_and_the_rest_is_unchanged():
    text = urdf(BODY, BODY_JOINTS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FloatingBaseWarning)
        fixed = load_urdf_string(text)
    free = load_urdf_string(text, root_joint="free_flyer")
    assert free.joint_names == ("root_joint", "hip") and free.body_names == ("base", "leg")
    assert free.mass[0] == 3.0 and free.frames["imu"].body == 0 and fixed.frames["imu"].body == -1
    assert_close(free.com[0], [(2.5 * 0.1 + 0.5 * 0.2) / 3.0, 0, 0], 1e-15, "merged CoM")
    for key in ("mass", "com", "inertia", "R0", "p0", "axis", "lower", "upper"):
        assert np.array_equal(getattr(free, key)[1:], getattr(fixed, key)), key
    assert free.parent.tolist() == [-1, 0] and fixed.parent.tolist() == [-1]


@pytest.mark.parametrize("name", ["solo12", "pr2"])
def test_a_fixed_base_load_is_pinocchios_fixed_base_model(name):
    path = robots_dir() / ROBOTS[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_urdf(path)
    pm = pin.buildModelFromUrdf(str(path))
    assert not model.floating and model.joint_names == tuple(pm.names[1:])
    assert_close(model.mass, [Y.mass for Y in pm.inertias[1:]], 1e-14, name)


# ---- the configuration space --------------------------------------------------------------------------

@pytest.mark.parametrize("name", ROBOTS)
def test_neutral_is_pinocchios(name):
    model, ref = robot(name)
    assert np.array_equal(ref.to_pin_q(neutral(model)), pin.neutral(ref.pm))


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("angular", [1e-10, 1e-6, 1.1e-3, 3e-3, 0.3, 3.0])
def test_integrate_is_pinocchios(name, angular):
    model, ref = robot(name)
    rng = np.random.default_rng(7)
    Q, V = random_configuration(model, rng, 40), velocities(model, rng, 40, angular)
    Q1 = integrate(model, Q, V)
    for s in range(40):
        assert_close(ref.to_pin_q(Q1[s]), pin.integrate(ref.pm, ref.to_pin_q(Q[s]), V[s]), 1e-12,
                     f"{name} row {s}")    # measured ≤ 1.9e-13 at |ω| ≈ 1e-3: Pinocchio's exp6 error there
                                           # (test_integrate_is_exact: ours ≤ 4.4e-16), else ≤ 7.8e-16


@pytest.mark.parametrize("angular", [1e-6, 1.1e-3, 3e-3, 0.05, 0.3, 3.0])
def test_integrate_is_exact(angular):
    """The free flyer's q ⊕ v = (p + R V(ω) v, quat ⊗ exp(ω)) against a 40-digit evaluation of the closed
    form, V(ω) = 1 + (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×² (RBDA / Murray–Li–Sastry exp of se(3))."""
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 40
    model, _ = robot("hector")
    rng = np.random.default_rng(15)
    Q, V = random_configuration(model, rng, 30), velocities(model, rng, 30, angular)
    Q1 = integrate(model, Q, V)
    for q, v, q1 in zip(Q, V, Q1):
        x, y, z, w = (mp.mpf(float(t)) for t in q[3:7])
        R = mp.matrix([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                       [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                       [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        om, lin = mp.matrix([mp.mpf(float(t)) for t in v[3:6]]), mp.matrix([mp.mpf(float(t)) for t in v[:3]])
        th = mp.sqrt(sum(t ** 2 for t in om))
        hat = mp.matrix([[0, -om[2], om[1]], [om[2], 0, -om[0]], [-om[1], om[0], 0]])
        Vv = lin + (1 - mp.cos(th)) / th ** 2 * (hat * lin) + (th - mp.sin(th)) / th ** 3 * (hat * (hat * lin))
        p1 = [float(mp.mpf(float(q[k])) + (R * Vv)[k]) for k in range(3)]
        k, c = mp.sin(th / 2) / th, mp.cos(th / 2)
        e = [k * om[0], k * om[1], k * om[2], c]        # quat ⊗ exp(ω), scalar last
        quat = [w * e[0] + x * e[3] + y * e[2] - z * e[1], w * e[1] - x * e[2] + y * e[3] + z * e[0],
                w * e[2] + x * e[1] - y * e[0] + z * e[3], w * e[3] - x * e[0] - y * e[1] - z * e[2]]
        n = mp.sqrt(sum(t ** 2 for t in quat)) * mp.sign(c)   # the sign nearest the start (θ > π: c < 0)
        assert_close(q1, np.array(p1 + [float(t / n) for t in quat]), 5e-15, f"|ω| ~ {angular}")  # measured ≤ 4.4e-16


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("angular", [1e-6, 1.1e-3, 3e-3, 0.3, 3.0])
def test_difference_is_pinocchios(name, angular):
    model, ref = robot(name)
    rng = np.random.default_rng(8)
    Q0, V = random_configuration(model, rng, 40), velocities(model, rng, 40, angular)
    Q1 = integrate(model, Q0, V)
    D = difference(model, Q0, Q1)
    for s in range(40):   # measured ≤ 2.1e-12 at |ω| ≈ 1e-3, |v| ≈ 1: Pinocchio's own log6 error there (ours
        # against the exact v: ≤ 9e-16, test_difference_undoes_integrate); ≤ 1e-15 at the other scales
        assert_close(D[s], pin.difference(ref.pm, ref.to_pin_q(Q0[s]), ref.to_pin_q(Q1[s])), 1e-11, f"{name} {s}")


@pytest.mark.parametrize("name", ROBOTS)
def test_difference_of_unrelated_configurations_is_pinocchios(name):
    model, ref = robot(name)
    rng = np.random.default_rng(9)
    Q0, Q1 = random_configuration(model, rng, 40), random_configuration(model, rng, 40)
    D = difference(model, Q0, Q1)
    for s in range(40):
        assert_close(D[s], pin.difference(ref.pm, ref.to_pin_q(Q0[s]), ref.to_pin_q(Q1[s])), 1e-13,
                     f"{name} {s}")      # measured ≤ 2.4e-15 (pr2)


@pytest.mark.parametrize("name", ROBOTS)
@pytest.mark.parametrize("angular", [1e-12, 1e-10, 1e-6, 1.1e-3, 0.3, 3.0])
def test_difference_undoes_integrate(name, angular):
    """q0 ⊕ v ⊖ q0 = v for rotations below π, down to the smallest steps. Pinocchio is not the reference
    for the tiniest: its difference gives 0 for a 7.7e-11 rad step of pr2's continuous
    r_forearm_roll_joint (measured), so the reference here is the v that made q1 (integrate being
    checked against Pinocchio above)."""
    model, _ = robot(name)
    rng = np.random.default_rng(10)
    Q0, V = random_configuration(model, rng, 40), velocities(model, rng, 40, angular)
    V[:, 3:6] *= np.minimum(1.0, 3.0 / np.linalg.norm(V[:, 3:6], axis=1, keepdims=True))   # |ω| ≤ 3 < π
    V[:, 6:] = np.clip(V[:, 6:], -3.0, 3.0)          # continuous joints: the shortest angle is v itself
    assert_close(difference(model, Q0, integrate(model, Q0, V)), V, 1e-14, name)   # measured ≤ 8.9e-16


@pytest.mark.parametrize("theta", [np.pi - 1e-3, np.pi - 1e-7, np.pi - 1e-12, np.pi, np.pi + 1e-9,
                                   2 * np.pi - 1e-3, 5.0, 1e-13])
@pytest.mark.parametrize("name", ["solo12", "talos", "hector"])
def test_large_and_tiny_rotations_match_pinocchio(name, theta):
    """Rotation vectors of angle θ near π (the log's branch point: difference returns the shorter of the
    two rotations, θ ≤ π, as Pinocchio does), beyond π, and tiny."""
    model, ref = robot(name)
    rng = np.random.default_rng(11)
    for _ in range(10):
        v = rng.normal(0.0, 1.0, model.nv)
        u = rng.normal(size=3)
        v[3:6] = theta * u / np.linalg.norm(u)
        q0 = random_configuration(model, rng)
        q1 = integrate(model, q0, v)
        p0, p1 = ref.to_pin_q(q0), ref.to_pin_q(q1)
        p1_pin = pin.integrate(ref.pm, p0, v)
        if theta == np.pi:    # ±quat name one rotation; the sign nearest the start is a tie at exactly π
            p1_pin[3:7] *= np.sign(np.dot(p1_pin[3:7], p1[3:7]))
        assert_close(p1, p1_pin, 1e-14, f"integrate θ={theta}")                                 # measured ≤ 5.6e-16
        assert_close(difference(model, q0, q1), pin.difference(ref.pm, p0, p1), 5e-14,
                     f"difference θ={theta}")                                                 # measured ≤ 6.6e-16


def test_one_state_equals_a_batch_row():
    model, _ = robot("pr2")
    rng = np.random.default_rng(12)
    Q, V = random_configuration(model, rng, 5), velocities(model, rng, 5, 1.0)
    Q1, D = integrate(model, Q, V), difference(model, Q, Q[::-1])
    assert Q1.shape == (5, model.nq) and D.shape == (5, model.nv)
    for s in range(5):
        assert_close(integrate(model, Q[s], V[s]), Q1[s], 1e-15, "integrate")
        assert_close(difference(model, Q[s], Q[4 - s]), D[s], 1e-15, "difference")
    assert integrate(model, Q[:0], V[:0]).shape == (0, model.nq)


def test_random_configuration_ranges():
    model, _ = robot("pr2")
    Q = random_configuration(model, 3, n=4000)
    assert Q.shape == (4000, model.nq) and np.array_equal(Q, random_configuration(model, 3, n=4000))
    assert random_configuration(model, 3).shape == (model.nq,)
    assert np.all(np.abs(Q[:, :3]) <= 1.0) and np.all(np.abs(np.linalg.norm(Q[:, 3:7], axis=1) - 1) < 1e-15)
    for i in range(1, model.njoints):
        x = Q[:, model.idx_q[i]]
        lo, hi = model.lower[i], model.upper[i]
        if not np.isfinite(lo):                       # continuous joints: the full circle
            lo, hi = -np.pi, np.pi
        assert lo <= x.min() and x.max() <= hi and (hi - lo == 0 or x.max() - x.min() > 0.9 * (hi - lo)), \
            model.joint_names[i]


def test_random_orientations_are_uniform():
    """Uniform on S³ (so on SO(3)): E[x_k⁴] = 3/(n(n+2)) = 1/8 for each component (n = 4), where a
    normalised uniform cube gives 0.107; the std of the mean of 20000 samples is 0.0014."""
    model, _ = robot("hector")
    quat = random_configuration(model, np.random.default_rng(13), n=20000)[:, 3:7]
    assert np.all(np.abs(np.mean(quat ** 4, axis=0) - 0.125) < 0.007)
    assert np.all(np.abs(np.mean(quat, axis=0)) < 0.03)


def test_normalize():
    model, _ = robot("solo12")
    q = random_configuration(model, 0)
    q[3:7] *= 2.5
    n = normalize(model, q)
    assert_close(n[3:7], q[3:7] / 2.5, 1e-16, "quaternion")
    assert np.array_equal(n[:3], q[:3]) and np.array_equal(n[7:], q[7:])
    q[3:7] = 0.0
    with pytest.raises(InputError, match="root_joint.*is zero"):
        normalize(model, q)


def test_configuration_inputs_are_checked():
    model, _ = robot("solo12")
    q, v = neutral(model), np.zeros(model.nv)
    with pytest.raises(InputError, match=r"q has shape \(18,\); expected \(19,\)"):
        integrate(model, v, v)
    with pytest.raises(InputError, match=r"v has shape \(19,\); expected \(18,\)"):
        integrate(model, q, q)
    with pytest.raises(InputError, match=r"q1 has shape"):
        difference(model, q, v)
    bad = q.copy()
    bad[6] = 1.001
    with pytest.raises(InputError, match=r"q1: the quaternion root_joint.*norm 1.001"):
        difference(model, q, bad)
    with pytest.raises(InputError, match=r"q\[1\]: the quaternion"):
        integrate(model, np.array([q, bad]), np.zeros((2, model.nv)))
    with pytest.raises(InputError, match=r"q: the quaternion root_joint.*norm 1.001"):     # one state: the
        integrate(model, bad, np.zeros(model.nv))                                          # compiled path's check
    with pytest.raises(InputError, match=r"q0: the quaternion root_joint.*norm 1.001"):
        difference(model, bad, q)
    nan = q.copy()
    nan[2] = np.nan
    with pytest.raises(InputError, match=r"q\[2\] \(joint 'root_joint.z'\) is nan"):
        normalize(model, nan)
    with pytest.raises(InputError, match=r"q0\[2\] \(joint 'root_joint.z'\) is nan"):
        difference(model, nan, q)
    v[4] = np.nan
    with pytest.raises(InputError, match="root_joint.wy"):
        integrate(model, q, v)
    with pytest.raises(InputError, match="rng must be"):
        random_configuration(model, rng="seed")


def test_from_pin_q_inverts_to_pin_q():
    model, ref = robot("pr2")
    q = random_configuration(model, 14)
    assert_close(ref.from_pin_q(ref.to_pin_q(q)), q, 1e-15, "round trip")


def test_cli_inspect_shows_the_free_flyer(capsys):
    from manipdyn.cli import main
    path = robots_dir() / ROBOTS["solo12"]
    assert main(["inspect", str(path), "--root-joint", "free_flyer"]) == 0
    out = capsys.readouterr().out
    assert "nq = 19, nv = 18" in out and "q[0] root_joint" in out and "free_flyer" in out
    assert "q[7] FL_HAA" in out and "no joint moves" not in out
    assert main(["inspect", str(path)]) == 0                       # fixed base: the warning is shown
    assert "warning:" in capsys.readouterr().out
    assert main(["inspect", str(path), "--root-joint", "floating"]) == 2
    assert "choose from 'free_flyer'" in capsys.readouterr().err
    assert main(["inspect", str(path), "--root-joint", "free_flyer", "--lock", "FL_HAA=0.5"]) == 0
    out = capsys.readouterr().out
    assert "nq = 18, nv = 17" in out and "locked joints: FL_HAA = 0.5" in out
    assert main(["inspect", str(path), "--root-joint", "free_flyer", "--lock", "root_joint=0"]) == 2
    assert "expected a pose" in capsys.readouterr().err
    assert main(["inspect", str(path), "--root-joint", "free_flyer", "--lock", "root_joint=1,2,3,0,0,0.6,0.8"]) == 0
    out = capsys.readouterr().out
    assert "nq = nv = 12" in out and "root_joint = [1.0, 2.0, 3.0, 0.0, 0.0, 0.6, 0.8]" in out


def test_exports():
    for name in ("neutral", "integrate", "difference", "random_configuration", "normalize",
                 "FloatingBaseWarning", "FREEFLYER"):
        assert name in manipdyn.__all__ and hasattr(manipdyn, name)


# ---- the dynamics (need the free-flyer kernels) ---------------------------------------------------------

def _states(model, n, seed):
    rng = np.random.default_rng(seed)
    return (random_configuration(model, rng, n), rng.normal(0.0, 2.0, (n, model.nv)),
            rng.normal(0.0, 5.0, (n, model.nv)))


@pytest.mark.parametrize("name", ROBOTS)
def test_dynamics_rnea_is_pinocchios(name):
    model, ref = robot(name)
    Q, V, A = _states(model, 20, 20)
    tau = manipdyn.rnea(model, Q, V, A)
    for s in range(20):
        assert_close(tau[s], pin.rnea(ref.pm, ref.pd, ref.to_pin_q(Q[s]), V[s], A[s]), 1e-13,
                     f"{name} {s}")    # the fixed-base zoo measures ≤ 7.4e-15 (test_rnea_terms)


@pytest.mark.parametrize("name", ROBOTS)
def test_dynamics_mass_matrix_is_pinocchios_crba(name):
    model, ref = robot(name)
    Q, _, _ = _states(model, 20, 21)
    M = manipdyn.mass_matrix(model, Q)
    for s in range(20):
        assert_close(M[s], pin.crba(ref.pm, ref.pd, ref.to_pin_q(Q[s])), 1e-13,
                     f"{name} {s}")    # the fixed-base zoo measures ≤ 7e-16


@pytest.mark.parametrize("name", sorted(set(ROBOTS) - SINGULAR_M))
def test_dynamics_aba_is_pinocchios(name):
    """q̈ from a solve: the bound scales with κ = cond(M); the residual τ − rnea_pin(q, v, q̈) too, scaled by
    ‖M‖ ‖q̈‖ / ‖τ‖ (max norms). Bounds set from an LU solve of Pinocchio's own M, h: err/κ ≤ 2e-18 and
    scaled residual ≤ 3.1e-17 (measured on these robots)."""
    model, ref = robot(name)
    Q, V, T = _states(model, 20, 22)
    qdd = manipdyn.aba(model, Q, V, T)
    for s in range(20):
        p = ref.to_pin_q(Q[s])
        M = pin.crba(ref.pm, ref.pd, p)
        assert err(qdd[s], pin.aba(ref.pm, ref.pd, p, V[s], T[s])) <= 1e-16 * np.linalg.cond(M), f"{name} {s}"
        scale = max(1.0, np.abs(M).max() * np.abs(qdd[s]).max() / max(np.abs(T[s]).max(), 1.0))
        assert_close(pin.rnea(ref.pm, ref.pd, p, V[s], qdd[s]), T[s], 1e-15 * scale, f"{name} residual {s}")


@pytest.mark.parametrize("name", ["solo12", "talos", "pr2", "hector"])
def test_dynamics_validate_passes_on_a_floating_robot(name):
    """validate's terms in the kernels' reach (Newton–Euler terms, CRBA, g, C q̇ + g, ABA, Jacobians, the
    RNEA and ABA derivatives)."""
    from manipdyn.validation import validate
    model, ref = robot(name)
    rep = validate(model, robots_dir() / ROBOTS[name], n_states=20, seed=5, tol=5e-13)
    core = {"w", "v", "dw", "acc", "fc", "nO", "f", "n", "tau", "f_ext", "n_ext", "tau_ext", "M_crba", "g",
            "qdd_aba", "J_local_world_aligned", "J_local", "dJ_local_world_aligned", "dJ_local", "Y",
            "dtau_dq", "dtau_dv", "dqdd_dq", "dqdd_dv"}
    assert core <= {t.term for t in rep.terms}           # a misspelt key would check nothing
    bad = [f"{t.term}: {'not supported' if not t.supported else f'{t.err:.2e}'}" for t in rep.terms
           if t.term in core and not t.passed]
    assert not bad, f"{bad}; notes: {rep.notes}"


def test_dynamics_cli_validates_a_free_flyer(tmp_path):
    import os
    import subprocess
    import sys
    from conftest import ROOT
    path = robots_dir() / ROBOTS["hector"]
    r = subprocess.run([sys.executable, "-m", "manipdyn.cli", "validate", str(path), "--root-joint", "free_flyer",
                        "--states", "3", "--quiet"], capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert "root_joint" in r.stdout and "1/1 models pass every term" in r.stdout
