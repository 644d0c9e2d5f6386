"""URDF loading: Pinocchio's q order, fixed-joint merging, continuous/mimic joints, and typed errors."""
import re
import warnings

import numpy as np
import pinocchio as pin
import pytest
from conftest import assert_close, inertial_xml, urdf, zoo_paths

from manipdyn import InertiaWarning, ModelError, URDFError, load_urdf, load_urdf_string

ZOO = {p.name: p for p in zoo_paths()}


def file_order(path):
    text = path.read_text()
    return [m.group(1) for m in re.finditer(r'<joint\s+name="([^"]+)"\s+type="(?!fixed)', text)]


@pytest.mark.parametrize("name", ["baxter.urdf", "allegro_right_hand.urdf", "panda.urdf", "ur5_robot.urdf"])
def test_q_order_is_pinocchios(name):
    model = load_urdf(ZOO[name])
    assert model.joint_names == tuple(pin.buildModelFromUrdf(str(ZOO[name])).names[1:])
    assert all(model.parent[i] < i for i in range(model.nv))


@pytest.mark.parametrize("name", ["baxter.urdf", "allegro_right_hand.urdf"])
def test_q_order_differs_from_file_order(name):
    # the reason the rule matters: file order would be wrong on these two
    model = load_urdf(ZOO[name])
    assert list(model.joint_names) != file_order(ZOO[name])
    assert sorted(model.joint_names) == sorted(file_order(ZOO[name]))


def test_continuous_joints_are_one_angle():
    model = load_urdf(ZOO["kinova.urdf"])
    pm = pin.buildModelFromUrdf(str(ZOO["kinova.urdf"]))
    assert model.nq == model.nv == pm.nv == 6 and pm.nq == 9
    assert model.continuous.sum() == 3


def test_mimic_joints_load_independent_and_say_so():
    model = load_urdf(ZOO["panda.urdf"])
    assert model.nv == 9 and model.mimic == (("panda_finger_joint2", "panda_finger_joint1", 1.0, 0.0),)
    assert "mimic" in model.summary() and "independent" in model.summary()


def test_fixed_joints_merge_and_frames_stay_addressable():
    links = {"base": "", "l1": inertial_xml(2.0, (0.1, 0, 0), (0.1, 0.2, 0.3, 0, 0, 0)),
             "tool": inertial_xml(1.0, (0, 0, 0.05), (0.01, 0.01, 0.01, 0, 0, 0), rpy=(0.3, 0, 0))}
    joints = [("j1", "revolute", "base", "l1", (0, 0, 1), (0, 0, 0), (0, 0, 1)),
              ("tool_joint", "fixed", "l1", "tool", (0.5, 0, 0), (0, 0.5, 0), None)]
    model = load_urdf_string(urdf(links, joints))
    assert model.nv == 1 and model.merged["l1"] == ("tool",)
    fr = model.frame("tool")
    assert fr.body == 0 and np.allclose(fr.p, [0.5, 0, 0])
    # merged mass and CoM against a hand computation (parallel-axis theorem checked against Pinocchio)
    c_tool = fr.p + fr.R @ np.array([0, 0, 0.05])
    assert model.mass[0] == 3.0
    assert_close(model.com[0], (2.0 * np.array([0.1, 0, 0]) + 1.0 * c_tool) / 3.0, 1e-15, "com")  # measured 0
    pm = pin.buildModelFromXML(urdf(links, joints))
    assert_close(model.inertia[0], pm.inertias[1].inertia, 2e-15, "merged inertia")  # measured 5.6e-17


def test_massless_links_and_zero_inertia_are_valid():
    links = {"base": "", "a": "", "b": inertial_xml(1.0)}
    joints = [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
              ("jb", "prismatic", "a", "b", (0, 0, 0), (0, 0, 0), (1, 0, 0))]
    model = load_urdf_string(urdf(links, joints))
    assert model.mass.tolist() == [0.0, 1.0] and "massless bodies: a" in model.summary()


GOOD = urdf({"base": "", "a": inertial_xml(1.0, I=(1, 1, 1, 0, 0, 0))},
            [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1))])
BAD = {
    "malformed XML": GOOD[:-20],
    "parent link 'ghost' is not defined": GOOD.replace('<parent link="base"/>', '<parent link="ghost"/>'),
    "cycle|child of two joints": GOOD.replace("</robot>", '<joint name="jb" type="fixed"><parent link="a"/>'
                                             '<child link="base"/></joint></robot>'),
    "several root links: base, c|several root links: c, base": GOOD.replace("</robot>", '<link name="c"/></robot>'),
    "negative mass": GOOD.replace('<mass value="1.0"/>', '<mass value="-1.0"/>'),
    "not positive semi-definite": GOOD.replace('ixy="0"', 'ixy="5"'),
    "unknown joint type": GOOD.replace('type="revolute"', 'type="hinge"'),
    "needs one <drake:screw_thread_pitch": GOOD.replace('type="revolute"', 'type="screw"'),
    "is not a URDF number": GOOD.replace('<mass value="1.0"/>', '<mass value="nan"/>'),
    "ENTITY": GOOD.replace('<?xml version="1.0"?>', '<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]>'),
    "has no direction": GOOD.replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>'),
}


@pytest.mark.parametrize("match", list(BAD), ids=lambda s: s.split("|")[0][:30])
def test_malformed_urdf_raises_named_error(match):
    with pytest.raises((URDFError, ModelError), match=match):
        load_urdf_string(BAD[match], source="bad.urdf")


def test_error_names_the_file(tmp_path):
    with pytest.raises(URDFError, match="nope.urdf: no such"):
        load_urdf(tmp_path / "nope.urdf")


def test_triangle_inequality_warns_or_refuses():
    bad = GOOD.replace('ixx="1"', 'ixx="3"')
    with pytest.warns(InertiaWarning, match="link 'a'.*triangle"):
        load_urdf_string(bad)
    with pytest.raises(ModelError, match="triangle"):
        load_urdf_string(bad, strict=True)


def test_model_is_immutable():
    model = load_urdf_string(GOOD)
    with pytest.raises(ValueError):
        model.mass[0] = 2.0
    with pytest.raises(AttributeError):
        model.mass = np.zeros(1)


def test_round_off_inertias_load():
    # icub carries eigenvalues of -5e-20 on massless bodies: round-off, not an error
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from manipdyn.validation import robots_dir
        model = load_urdf(robots_dir() / "icub_description/robots/icub.urdf")
    assert model.nv > 30
