"""The joint registry (joints.KINDS): each kind described once, its sizes held to Pinocchio's joint model of the same
name, and every dispatch on kind exhaustive — a code outside the registry raises, in Python and in the compiled
kernels, instead of being placed, integrated or differenced as another kind."""
import numpy as np
import pinocchio as pin
import pytest

from manipdyn import joints
from manipdyn.joints import IN_MODEL, KINDS, NQ, NV, UNIT_AT, UNIT_LEN, kind_of, motion_subspace, neutral_q

UNKNOWN = len(KINDS)          # the first code the registry does not hold


def test_each_kind_is_described_once_and_indexed_by_its_code():
    assert [k.code for k in KINDS] == list(range(len(KINDS)))
    assert len({k.name for k in KINDS}) == len(KINDS)
    urdf = [n for k in KINDS for n in k.urdf]
    assert len(urdf) == len(set(urdf))                       # a URDF type names one kind
    for k in KINDS:
        assert kind_of(k.code) is k and NQ[k.code] == k.nq and NV[k.code] == k.nv
        if k.code not in IN_MODEL:                           # the universal joint: expanded by the loaders
            with pytest.raises(ValueError, match="not in a Model"):
                motion_subspace(k.code, np.array([0.0, 0.0, 1.0]))
            continue
        S = motion_subspace(k.code, np.array([0.0, 0.0, 1.0]), 0.1)
        assert S.shape == (k.nv, 6) and np.linalg.matrix_rank(S) == k.nv
        assert neutral_q(k.code).shape == (k.nq,)
        if k.nq > 1 and k.nq == len(k.coords):               # named entries; the quaternion where the kind says
            assert len(k.rates) == k.nv
        if k.quat_at >= 0:
            assert k.coords[k.quat_at:k.quat_at + 4] == ("qx", "qy", "qz", "qw")
            assert k.rates[k.omega_at:k.omega_at + 3] == ("wx", "wy", "wz")
            assert (UNIT_AT[k.code], UNIT_LEN[k.code]) == (k.quat_at, 4)


@pytest.mark.parametrize("kind", KINDS, ids=[k.name for k in KINDS])
def test_sizes_match_pinocchio_s_joint_model_of_the_same_name(kind):
    cls, z = getattr(pin, kind.pinocchio), np.array([0.0, 0.0, 1.0])
    jm = cls(z, 0.1) if "Helical" in kind.pinocchio else cls(z) if "Unaligned" in kind.pinocchio else cls()
    assert (jm.nq, jm.nv) == (kind.nq, kind.nv)
    if kind.code in IN_MODEL:                                # the neutral configuration is Pinocchio's
        pm = pin.Model()
        pm.addJoint(0, jm, pin.SE3.Identity(), "j")
        assert np.array_equal(neutral_q(kind.code), pin.neutral(pm))


def test_an_unknown_code_raises_in_python():
    with pytest.raises(ValueError, match="unknown joint kind"):
        kind_of(UNKNOWN)
    with pytest.raises(ValueError, match="unknown joint kind"):
        motion_subspace(UNKNOWN, np.array([0.0, 0.0, 1.0]))


def test_an_unknown_code_raises_in_the_compiled_kernels():
    """joint_placement, integrate and difference: no fall-through branch places an unknown kind as a free flyer or
    adds its q and v as a 1-dof joint's."""
    kind, iq, iv = np.array([UNKNOWN], np.int64), np.zeros(1, np.int64), np.zeros(1, np.int64)
    R, p = np.empty((1, 3, 3)), np.empty((1, 3))
    with pytest.raises(ValueError, match="unknown joint kind"):
        joints.joint_placement(0, kind, iq, np.array([[0.0, 0.0, 1.0]]), np.zeros(1), np.eye(3)[None],
                               np.zeros((1, 3)), np.zeros(7), R, p)
    Q, V = np.zeros((1, 7)), np.zeros((1, 6))
    with pytest.raises(ValueError, match="unknown joint kind"):
        joints.integrate_kernel(kind, iq, iv, Q, V, np.empty_like(Q))
    with pytest.raises(ValueError, match="unknown joint kind"):
        joints.difference_kernel(kind, np.zeros(1, np.bool_), iq, iv, Q, Q, np.empty_like(V))
    for code in (joints.REVOLUTE, joints.PRISMATIC, UNKNOWN):     # the lanes' quaternion layout: only the two kinds
        with pytest.raises(ValueError, match="not a free flyer or a ball"):
            joints.quat_layout(code)
    assert joints.quat_layout(joints.FREEFLYER) == (3, 1.0) and joints.quat_layout(joints.BALL) == (0, 0.0)


def test_a_universal_code_never_reaches_a_kernel():
    """The universal joint is two revolute joints in a Model: its code in a kernel raises as an unknown one, and a
    Model holding it is refused by name."""
    kind, iq = np.array([joints.UNIVERSAL], np.int64), np.zeros(1, np.int64)
    with pytest.raises(ValueError, match="unknown joint kind"):
        joints.joint_placement(0, kind, iq, np.array([[0.0, 0.0, 1.0]]), np.zeros(1), np.eye(3)[None],
                               np.zeros((1, 3)), np.zeros(7), np.empty((1, 3, 3)), np.empty((1, 3)))
    import dataclasses
    import manipdyn as md
    from manipdyn.paths import bundled_dir
    model = md.load_urdf(bundled_dir() / "aau_arm.urdf")
    with pytest.raises(md.InputError, match="universal joint"):
        dataclasses.replace(model, kind=np.where(np.arange(model.njoints) == 1, joints.UNIVERSAL, model.kind))
