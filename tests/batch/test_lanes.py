"""The lane kernels (rnea.rnea_lanes: the batch entry of rnea, nonlinear_effects and gravity_torques;
crba.crba_lanes: of mass_matrix; aba.aba_lanes: of aba; kinematics.frame_lanes: of frame_placement and
frame_jacobian) against Pinocchio and against the one-state kernels: blocks
of LANES states, a partial last block, a block that falls back to the one-state form (an angle beyond
spatial.SINCOS_MAX, a non-finite input, a singular articulated inertia), prismatic joints and a branching tree; the
batch-vs-single bound of docs/design.md §3 (1e-14; q̈ scaled by cond(M))."""
import numpy as np
import pinocchio as pin
import pytest
from conftest import AAU, assert_close, err, inertial_xml, urdf

import manipdyn as md
from manipdyn.dynamics.lanes import LANES
from manipdyn.errors import InputError, NumericalError
from manipdyn.joints import PRISMATIC
from manipdyn.spatial import SINCOS_MAX
from manipdyn.validation import random_states


def _tree(seed=7, n=9, tool=False):
    """A branching tree of revolute and prismatic joints with unaligned axes and rotated inertias (no continuous
    joint: Pinocchio gives those two q entries); tool: a massless link "tool" fixed to the last, offset and turned
    (a frame whose origin is not its body's)."""
    rng = np.random.default_rng(seed)
    links, joints = {"base": ""}, []
    for k in range(n):
        parent = "base" if k == 0 or rng.random() < 0.25 else f"L{rng.integers(0, k)}"
        d, m = rng.uniform(0.05, 1.0, 3), rng.uniform(0.1, 3.0)
        inertia = np.array([d[1] + d[2], d[0] + d[2], d[0] + d[1]]) * m / 10
        links[f"L{k}"] = inertial_xml(m, rng.uniform(-0.3, 0.3, 3), (*inertia, 0, 0, 0), rng.uniform(-3, 3, 3))
        axis = rng.normal(size=3)
        joints.append((f"j{k}", ("revolute", "prismatic")[k % 2], parent, f"L{k}",
                       rng.uniform(-0.5, 0.5, 3), rng.uniform(-3, 3, 3), axis / np.linalg.norm(axis)))
    if tool:
        links["tool"] = ""
        joints.append(("tool_joint", "fixed", f"L{n - 1}", "tool", (0.2, -0.1, 0.3), (0.4, -1.1, 2.0), None))
    return urdf(links, joints, name="lanes_tree")


@pytest.fixture(scope="module")
def models():
    return {"aau_arm": (md.load_urdf(AAU), pin.buildModelFromUrdf(str(AAU))),
            "tree": (md.load_urdf_string(_tree()), pin.buildModelFromXML(_tree()))}


@pytest.mark.parametrize("name", ["aau_arm", "tree"])
@pytest.mark.parametrize("N", [1, LANES - 1, LANES, 2 * LANES + 5])
def test_lane_batches_match_pinocchio_and_the_one_state_kernel(models, name, N):
    model, pm = models[name]
    assert np.sum(model.kind == PRISMATIC) == (4 if name == "tree" else 0)
    Q, V, A = random_states(model, N, np.random.default_rng(N))
    tau = md.rnea(model, Q, V, A)
    data = pm.createData()
    ref = np.stack([pin.rnea(pm, data, q, v, a) for q, v, a in zip(Q, V, A)])   # same q order (revolute, prismatic)
    assert_close(tau, ref, 1e-14, f"{name} N={N} vs Pinocchio")                  # measured ≤ 1.7e-15
    one = np.stack([md.rnea(model, q, v, a) for q, v, a in zip(Q, V, A)])
    assert_close(tau, one, 1e-14, f"{name} N={N} vs one state")                  # measured ≤ 7.4e-16
    h, g = md.nonlinear_effects(model, Q, V), md.gravity_torques(model, Q)
    ref_h = np.stack([pin.nonLinearEffects(pm, data, q, v) for q, v in zip(Q, V)])
    assert_close(h, ref_h, 1e-14, "h")                                             # measured ≤ 1.9e-15
    assert_close(g, np.stack([pin.computeGeneralizedGravity(pm, data, q) for q in Q]), 1e-14, "g")
    assert_close(h, np.stack([md.nonlinear_effects(model, q, v) for q, v in zip(Q, V)]), 1e-14, "h one")


def _pin_rnea_fext(pm, Q, V, A, fx, frame):
    """Pinocchio's τ with the wrenches fx = {frame name: (force (N, 3), moment (N, 3))} in the frame's axes or the
    world's, about the frame's origin, moved to each frame's joint (``pin.rnea``'s fext: joint axes, about its
    origin)."""
    pd, out = pm.createData(), []
    for s in range(Q.shape[0]):
        pin.framesForwardKinematics(pm, pd, Q[s])
        fext = [pin.Force.Zero() for _ in range(pm.njoints)]
        for name, (f, m) in fx.items():
            fid = pm.getFrameId(name, pin.FrameType.BODY)
            R = pd.oMf[fid].rotation if frame == "world" else np.eye(3)
            fext[pm.frames[fid].parentJoint] += pm.frames[fid].placement.act(pin.Force(R.T @ f[s], R.T @ m[s]))
        out.append(pin.rnea(pm, pd, Q[s], V[s], A[s], fext).copy())
    return np.array(out)


@pytest.mark.parametrize("frame", ["local", "world"])
def test_lane_rnea_with_external_wrenches_matches_pinocchio_and_the_one_state_kernel(frame):
    """Wrenches on a frame offset from its body (p × f), on a body deep in the tree and on a child of the base, over
    three blocks, the middle one run by the one-state form (an angle beyond SINCOS_MAX: its wrench rows must be
    that block's)."""
    text = _tree(tool=True)
    model, pm = md.load_urdf_string(text), pin.buildModelFromXML(text)
    N, rng = 2 * LANES + 5, np.random.default_rng(11)
    Q, V, A = random_states(model, N, rng)
    fx = {k: (rng.normal(0, 10, (N, 3)), rng.normal(0, 2, (N, 3))) for k in ("tool", "L5", "L0")}
    assert model.frames["tool"].body == model.frames["L8"].body and np.abs(model.frames["tool"].p).max() > 0.1
    tau = md.rnea(model, Q, V, A, f_ext=fx, f_ext_frame=frame)
    assert_close(tau, _pin_rnea_fext(pm, Q, V, A, fx, frame), 1e-14, f"f_ext {frame} vs Pinocchio")  # ≤ 1.9e-15
    one = np.stack([md.rnea(model, Q[s], V[s], A[s], f_ext={k: (f[s], m[s]) for k, (f, m) in fx.items()},
                            f_ext_frame=frame) for s in range(N)])
    assert_close(tau, one, 1e-14, f"f_ext {frame} vs one state")                                  # ≤ 8.6e-17
    assert err(tau, md.rnea(model, Q, V, A)) > 1e-3                  # the wrenches change τ
    Q[LANES + 3, 0] = 2 * SINCOS_MAX                                 # block 1 by the one-state form
    tau = md.rnea(model, Q, V, A, f_ext=fx, f_ext_frame=frame)
    assert_close(tau[LANES:2 * LANES], _pin_rnea_fext(pm, Q[LANES:2 * LANES], V[LANES:2 * LANES], A[LANES:2 * LANES],
                                                       {k: (f[LANES:2 * LANES], m[LANES:2 * LANES])
                                                        for k, (f, m) in fx.items()}, frame),
                 1e-14, "the one-state block")                                                   # ≤ 1.7e-15


def test_a_state_does_not_depend_on_its_block(models):
    model, _ = models["tree"]
    Q, V, A = random_states(model, 3 * LANES, np.random.default_rng(5))
    whole = md.rnea(model, Q, V, A)
    for a, b in ((0, 1), (7, 70), (LANES - 3, 2 * LANES + 1), (100, 3 * LANES)):
        assert np.array_equal(md.rnea(model, Q[a:b], V[a:b], A[a:b]), whole[a:b]), (a, b)


def test_a_block_with_a_huge_angle_runs_the_one_state_form(models):
    model, pm = models["aau_arm"]
    Q, V, A = random_states(model, 2 * LANES, np.random.default_rng(1))
    Q[LANES + 3, 0] = 4 * SINCOS_MAX                  # past sincos's range: that block goes through libm
    tau = md.rnea(model, Q, V, A)
    one = np.stack([md.rnea(model, q, v, a) for q, v, a in zip(Q, V, A)])
    assert np.array_equal(tau[LANES:], one[LANES:])   # the one-state kernel itself, bit for bit
    data = pm.createData()
    assert_close(tau[LANES + 3], pin.rnea(pm, data, Q[LANES + 3], V[LANES + 3], A[LANES + 3]), 1e-14, "huge angle")


def test_a_block_with_a_huge_angle_mass_matrix(models):
    """The CRBA's block with an angle beyond SINCOS_MAX runs state by state through the one-state driver, which
    places that joint with libm's sin and cos (lanes.screw_placement_one): Pinocchio's crba at that state."""
    model, pm = models["aau_arm"]
    Q = random_states(model, 2 * LANES, np.random.default_rng(1))[0]
    Q[LANES + 3, 0] = 4 * SINCOS_MAX
    M = md.mass_matrix(model, Q)
    one = np.stack([md.mass_matrix(model, q) for q in Q])
    assert np.array_equal(M[LANES:], one[LANES:])     # the one-state driver itself, bit for bit
    ref = pin.crba(pm, pm.createData(), Q[LANES + 3])
    assert_close(M[LANES + 3], np.triu(ref) + np.triu(ref, 1).T, 1e-14, "huge angle")   # measured 1.3e-16


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_a_non_finite_input_is_named_by_its_row(models, bad):
    model, _ = models["tree"]
    Q, V, A = random_states(model, 2 * LANES + 9, np.random.default_rng(2))
    A[LANES + 7, 4] = bad
    with pytest.raises(InputError, match=rf"a\[{LANES + 7}, 4\] \(joint 'j7'\) is {bad}"):
        md.rnea(model, Q, V, A)
    V[2 * LANES + 8, 0] = bad
    with pytest.raises(InputError, match=rf"v\[{2 * LANES + 8}, 0\] \(joint 'j0'\) is {bad}"):
        md.nonlinear_effects(model, Q, V)


def test_an_overflow_in_a_later_block_is_named_by_its_row(models):
    model, _ = models["aau_arm"]
    Q, V, A = random_states(model, 2 * LANES + 9, np.random.default_rng(3))
    V[LANES + 5] = 1e200                                  # finite input, τ ~ v² overflows to inf
    with pytest.raises(NumericalError, match=rf"row {LANES + 5}\b"):
        md.rnea(model, Q, V, A)
    frame = model.body_names[-1]                          # with a wrench: the block runs the scalar kernel
    f_ext = {frame: (np.ones((len(Q), 3)), np.zeros((len(Q), 3)))}
    with pytest.raises(NumericalError, match=rf"row {LANES + 5}\b"):
        md.rnea(model, Q, V, A, f_ext=f_ext)


def _pin_mass_matrix(pm, data, q):
    M = pin.crba(pm, data, q)
    return np.triu(M) + np.triu(M, 1).T                    # Pinocchio fills the upper triangle


@pytest.mark.parametrize("name", ["aau_arm", "tree"])
@pytest.mark.parametrize("N", [1, LANES - 1, 2 * LANES + 5])
def test_lane_mass_matrix_and_aba_match_pinocchio_and_the_one_state_kernels(models, name, N):
    model, pm = models[name]
    Q, V, T = random_states(model, N, np.random.default_rng(N + 1))
    data = pm.createData()
    M = md.mass_matrix(model, Q)
    assert_close(M, np.stack([_pin_mass_matrix(pm, data, q) for q in Q]), 1e-14, f"{name} N={N} M")  # ≤ 1.0e-15
    assert_close(M, np.stack([md.mass_matrix(model, q) for q in Q]), 1e-14, "M one")                # ≤ 5.9e-16
    assert np.array_equal(M, np.swapaxes(M, 1, 2))
    qdd = md.aba(model, Q, V, T)
    cond = np.linalg.cond(M).max()
    ref = np.stack([pin.aba(pm, data, q, v, t) for q, v, t in zip(Q, V, T)])
    assert_close(qdd, ref, 1e-14 * cond, f"{name} N={N} q̈")                      # measured ≤ 2.3e-18 × cond
    assert_close(qdd, np.stack([md.aba(model, q, v, t) for q, v, t in zip(Q, V, T)]), 1e-14 * cond,
                 "q̈ one")                                                       # measured ≤ 3.1e-18 × cond


def test_lane_aba_inverts_lane_rnea_on_a_long_batch(models):
    model, _ = models["tree"]
    Q, V, A = random_states(model, 5 * LANES + 3, np.random.default_rng(8))
    tau = md.rnea(model, Q, V, A)
    cond = np.linalg.cond(md.mass_matrix(model, Q)).max()
    assert_close(md.aba(model, Q, V, tau), A, 1e-14 * cond, "aba ∘ rnea")          # measured 7.4e-18 × cond


def test_lane_blocks_fall_back_and_name_the_culprit(models):
    model, pm = models["aau_arm"]
    Q, V, T = random_states(model, 2 * LANES + 9, np.random.default_rng(4))
    Q[LANES + 2, 1] = 4 * SINCOS_MAX                     # past sincos's range: that block runs the one-state kernels
    M, qdd = md.mass_matrix(model, Q), md.aba(model, Q, V, T)
    assert np.array_equal(M[LANES:2 * LANES], np.stack([md.mass_matrix(model, q) for q in Q[LANES:2 * LANES]]))
    data = pm.createData()
    assert_close(M[LANES + 2], _pin_mass_matrix(pm, data, Q[LANES + 2]), 1e-14, "huge angle M")
    assert_close(qdd[LANES + 2], pin.aba(pm, data, Q[LANES + 2], V[LANES + 2], T[LANES + 2]), 1e-12, "huge q̈")
    Q[2 * LANES + 4, 3] = np.nan
    with pytest.raises(InputError, match=rf"q\[{2 * LANES + 4}, 3\] \(joint '\w+'\) is nan"):
        md.mass_matrix(model, Q)
    with pytest.raises(InputError, match=rf"q\[{2 * LANES + 4}, 3\]"):
        md.aba(model, Q, V, T)
    Q[2 * LANES + 4, 3] = 0.0
    T[LANES + 6, 2] = np.inf
    with pytest.raises(InputError, match=rf"tau\[{LANES + 6}, 2\]"):
        md.aba(model, Q, V, T)


def test_a_lane_aba_overflow_in_a_later_block_is_named_by_its_row(models):
    model, _ = models["aau_arm"]
    Q, V, T = random_states(model, 2 * LANES + 9, np.random.default_rng(3))
    V[LANES + 5] = 1e200                                  # finite input, p^A ~ v² overflows
    with pytest.raises(NumericalError, match=rf"row {LANES + 5}\b"):
        md.aba(model, Q, V, T)


def test_lane_aba_names_a_singular_joint_in_a_later_block():
    links = {"base": "", "a": inertial_xml(1.0, (0.1, 0, 0), (0.01, 0.01, 0.01, 0, 0, 0)), "b": ""}
    joints = [("j0", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
              ("j1", "revolute", "a", "b", (0.3, 0, 0), (0, 0, 0), (0, 0, 1))]   # a massless tip link
    with pytest.warns(md.QuirkWarning, match="link 'b': no <inertial>"):
        model = md.load_urdf_string(urdf(links, joints, name="massless_tip"))
    Q, V, T = random_states(model, LANES + 3, np.random.default_rng(0))
    with pytest.raises(md.SingularError, match="joint 'j1'"):
        md.aba(model, Q, V, T)


@pytest.mark.parametrize("name", ["aau_arm", "tree"])
@pytest.mark.parametrize("reference", ["local_world_aligned", "local"])
def test_lane_frames_match_pinocchio_and_the_one_state_kernel(models, name, reference):
    model, pm = models[name]
    Q, _, _ = random_states(model, 2 * LANES + 5, np.random.default_rng(6))
    data, ref = pm.createData(), {"local_world_aligned": pin.LOCAL_WORLD_ALIGNED, "local": pin.LOCAL}[reference]
    for frame in (model.body_names[-1], model.body_names[len(model.body_names) // 2]):
        R, p = md.frame_placement(model, Q, frame)
        J = md.frame_jacobian(model, Q, frame, reference=reference)
        fid = pm.getFrameId(frame)
        pins = []
        for q in Q:
            pin.framesForwardKinematics(pm, data, q)
            pins.append((data.oMf[fid].rotation.copy(), data.oMf[fid].translation.copy(),
                         pin.computeFrameJacobian(pm, data, q, fid, ref)))
        assert_close(R, np.stack([x[0] for x in pins]), 1e-14, f"{name} {frame} R")    # measured ≤ 1.7e-15
        assert_close(p, np.stack([x[1] for x in pins]), 1e-14, f"{name} {frame} p")
        assert_close(J, np.stack([x[2] for x in pins]), 1e-14, f"{name} {frame} J")    # measured ≤ 1.8e-15
        one = [md.frame_placement(model, q, frame) for q in Q]
        assert_close(R, np.stack([x[0] for x in one]), 1e-14, "R one")
        assert_close(p, np.stack([x[1] for x in one]), 1e-14, "p one")
        assert_close(J, np.stack([md.frame_jacobian(model, q, frame, reference=reference) for q in Q]), 1e-14,
                     "J one")                                                        # measured ≤ 1.1e-15


def test_a_lane_frame_block_with_a_bad_angle_runs_the_one_state_form(models):
    model, _ = models["aau_arm"]
    Q, _, _ = random_states(model, LANES + 9, np.random.default_rng(9))
    Q[LANES + 4, 2] = 4 * SINCOS_MAX
    tip = model.body_names[-1]
    J = md.frame_jacobian(model, Q, tip)
    assert np.array_equal(J[LANES:], np.stack([md.frame_jacobian(model, q, tip) for q in Q[LANES:]]))
    Q[LANES + 7, 1] = np.nan
    with pytest.raises(InputError, match=rf"q\[{LANES + 7}, 1\]"):
        md.frame_placement(model, Q, tip)
