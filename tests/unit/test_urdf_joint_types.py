"""URDF's floating and planar joint types and Drake's <drake:joint> screw and universal joints: what the loader reads,
what it refuses (URDFError naming the joint), and Pinocchio's reading of the same files where it has one."""
import numpy as np
import pinocchio as pin
import pytest

import manipdyn as md
from manipdyn.errors import ManipdynError
from manipdyn.validation.reference import Reference

LINK = '<link name="{}"><inertial><origin xyz="0.1 0.05 -0.02"/><mass value="1.5"/><inertia ixx="0.03" iyy="0.04" ' \
       'izz="0.05" ixy="0.001" ixz="0" iyz="0.002"/></inertial></link>'


def robot(*joints, links=("a", "b")):
    return ('<robot name="r" xmlns:drake="http://drake.mit.edu"><link name="world"/>'
            + "".join(LINK.format(n) for n in links) + "".join(joints) + "</robot>")


def joint(name, kind, parent, child, extra="", tag="joint"):
    return f'<{tag} name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>' \
           f'<origin xyz="0.1 0.2 0.3" rpy="0.1 0.2 0.3"/>{extra}</{tag}>'


SCREW = joint("s", "screw", "a", "b", '<axis xyz="0 0 1"/><drake:screw_thread_pitch value="0.1"/>', "drake:joint")


@pytest.mark.parametrize("text,match", [
    (robot(joint("f", "floating", "world", "a"), joint("s", "screw", "a", "b", '<axis xyz="0 0 1"/>', "drake:joint")),
     "needs one <drake:screw_thread_pitch"),
    (robot(joint("f", "floating", "world", "a"),
           joint("r", "revolute", "a", "b", '<axis xyz="0 0 1"/><limit effort="1" velocity="1"/>'
                 '<drake:screw_thread_pitch value="0.1"/>')), "on a 'revolute' joint"),
    (robot(joint("f", "floating", "world", "a"),
           joint("s", "screw", "a", "b", '<axis xyz="0 0 1"/><drake:screw_thread_pitch value="nan"/>', "drake:joint")),
     "value"),
    (robot(joint("p", "planar", "world", "a", '<axis xyz="0 0 1"/>'), joint("f", "floating", "a", "b")),
     "must hang from the fixed base"),
    (robot(joint("f", "floating", "world", "a"), joint("u", "universal", "a", "b", "", "drake:joint"),
           joint("u.1", "fixed", "b", "c"), links=("a", "b", "c")), "'u.1' is taken"),
    (robot(joint("f", "floating", "world", "a"), joint("x", "gimbal", "a", "b")), "unknown joint type"),
    (robot(joint("p", "planar", "world", "a", '<axis xyz="0 0 1"/><mimic joint="q"/>'),
           joint("q", "revolute", "a", "b", '<axis xyz="0 0 1"/><limit effort="1" velocity="1"/>')),
     "a planar joint cannot be a <mimic>"),
])
def test_malformed_joints_are_refused_by_name(text, match):
    with pytest.raises(md.URDFError, match=match):
        md.load_urdf_string(text)


def test_a_floating_joint_with_root_joint_is_refused():
    with pytest.raises(md.URDFError, match="already frees the root link"):
        md.load_urdf_string(robot(joint("f", "floating", "world", "a"), SCREW), root_joint="free_flyer")


def test_a_planar_joint_moves_in_the_plane_normal_to_its_axis():
    """Any normal n: the body's origin stays in the plane through the joint origin normal to n, and n is fixed."""
    n = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    model = md.load_urdf_string(robot(joint("p", "planar", "world", "a", f'<axis xyz="{n[0]} {n[1]} {n[2]}"/>'),
                                      links=("a",)))
    R0, p0 = md.frame_placement(model, md.neutral(model), "a")
    for q in md.random_configuration(model, 0, 5):
        R, p = md.frame_placement(model, q, "a")
        assert abs((p - p0) @ (R0 @ n)) < 1e-15 and np.allclose(R @ n, R0 @ n, rtol=0, atol=1e-15)
        assert np.isclose(np.linalg.norm(p - p0), np.hypot(q[0], q[1]), rtol=0, atol=1e-15)
    with pytest.raises(md.InputError, match=r"planar joint p\.\(c s\)"):
        md.integrate(model, np.array([0.0, 0.0, 2.0, 0.0]), np.zeros(3))
    assert np.allclose(md.normalize(model, np.array([1.0, 2.0, 3.0, 4.0]))[2:], [0.6, 0.8])


def test_pinocchio_reads_the_floating_and_planar_types_as_ours(tmp_path):
    """A file's floating joint is Pinocchio's free flyer (no root_joint on either side); a planar joint about z its
    JointModelPlanar; the referee's Reference compares them term by term."""
    path = tmp_path / "r.urdf"
    path.write_text(robot(joint("f", "floating", "world", "a"), joint("p", "planar", "a", "b", '<axis xyz="0 0 1"/>')))
    model = md.load_urdf(path)
    assert model.floating and model.body_names[0] == "a" and model.root_link == "world"
    ref = Reference(model, path)
    assert [j.shortname() for j in ref.pm.joints[1:]] == ["JointModelFreeFlyer", "JointModelPlanar"]
    rng = np.random.default_rng(0)
    for q in md.random_configuration(model, rng, 3):
        v, a = rng.normal(size=model.nv), rng.normal(size=model.nv)
        t = pin.rnea(ref.pm, ref.pd, ref.to_pin_q(q), v, a)
        assert np.max(np.abs(md.rnea(model, q, v, a) - t)) <= 1e-13 * max(1.0, np.max(np.abs(t)))


def test_what_pinocchio_cannot_read_is_said(tmp_path):
    path = tmp_path / "s.urdf"
    path.write_text(robot(joint("f", "floating", "world", "a"), SCREW))
    with pytest.raises(ManipdynError, match="no screw or universal joint type"):
        Reference(md.load_urdf(path), path)
    path.write_text(robot(joint("p", "planar", "world", "a", '<axis xyz="1 0 0"/>'), links=("a",)))
    with pytest.raises(ManipdynError, match="ignores <axis>"):
        Reference(md.load_urdf(path), path)


def test_the_mjcf_export_names_the_kinds_it_lacks_and_the_gpu_takes_every_kind():
    model = md.load_urdf_string(robot(joint("f", "floating", "world", "a"), SCREW))
    with pytest.raises(md.ModelError, match="'s' is a helical joint, which MJCF has no type for"):
        from manipdyn.io.mjcf import to_mjcf
        to_mjcf(model)
    from manipdyn.gpu import _model
    _model(model, "rnea")                                    # a free flyer and a helical joint: on the lanes
    planar = md.load_urdf_string(robot(joint("p", "planar", "world", "a", '<axis xyz="0 0 1"/>'), SCREW))
    I, F = _model(planar, "frame_placement")               # a planar joint too (tests/gpu: its numbers)
    assert I is planar.kernel.lane_arrays[0] and F is planar.kernel.lane_arrays[1]
