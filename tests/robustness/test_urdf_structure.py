"""Hostile URDF structure: vector counts, axes, mass/inertia/length bounds, limits, mimic, size limit.

Every refused case raises a ManipdynError subclass (never another exception) whose message names the
file and the element at fault. Accepted edge cases are checked against Pinocchio or a closed form.
"""
import numpy as np
import pinocchio as pin
import pytest
from conftest import assert_close

from manipdyn import InputError, ManipdynError, ModelError, URDFError, load_urdf, load_urdf_string, rnea
from manipdyn.io.safe_xml import MAX_BYTES, MAX_INERTIA, MAX_LENGTH, MAX_MASS
from manipdyn.validation import robots_dir

LIMIT = '<limit lower="-1" upper="1" effort="10" velocity="2"/>'


def robot(j1="", l1="", j1_type="revolute", j1_origin='<origin xyz="0 0 0.1" rpy="0 0 0"/>',
          j1_axis='<axis xyz="0 0 1"/>', j1_limit=LIMIT, extra=""):
    """base -> j1 -> l1 -> j2 (revolute about y) -> l2; j1/l1 take extra elements, extra extra joints."""
    l1 = l1 or ('<inertial><origin xyz="0 0 0.05"/><mass value="1"/>'
                '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>')
    return f'''<?xml version="1.0"?>
<robot name="structure">
  <link name="base"/>
  <link name="l1">{l1}</link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>
    </inertial></link>
  <joint name="j1" type="{j1_type}"><parent link="base"/><child link="l1"/>{j1_origin}{j1_axis}{j1_limit}{j1}</joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/>{LIMIT}</joint>
  {extra}
</robot>
'''


def inertial(mass="1", ixx="0.1", ixy="0", com="0 0 0.05"):
    return (f'<inertial><origin xyz="{com}"/><mass value="{mass}"/>'
            f'<inertia ixx="{ixx}" ixy="{ixy}" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial>')


CONSTRAINT = ('<constraint name="c" type="spherical"><parent link="base"/><child link="l2"/>'
              '<parent_origin xyz="{pxyz}" rpy="{prpy}"/><child_axis xyz="{caxis}"/></constraint>')


def constraint(pxyz="0 0 0", prpy="0 0 0", caxis="0 0 1"):
    return CONSTRAINT.format(pxyz=pxyz, prpy=prpy, caxis=caxis)


# ---- refused: case id -> (URDF text, words the message must contain) ----------------------------------
VECTORS = {   # attribute -> (builder of the text for a value, owner, element) ; each gets 0, 1, 2, 4 numbers
    "joint_origin_xyz": (lambda v: robot(j1_origin=f'<origin xyz="{v}"/>'), "joint 'j1'", "<origin xyz="),
    "joint_origin_rpy": (lambda v: robot(j1_origin=f'<origin rpy="{v}"/>'), "joint 'j1'", "<origin rpy="),
    "axis": (lambda v: robot(j1_axis=f'<axis xyz="{v}"/>'), "joint 'j1'", "<axis xyz="),
    "inertial_origin": (lambda v: robot(l1=inertial(com=v)), "link 'l1'", "<origin xyz="),
    "constraint_origin": (lambda v: robot(extra=constraint(pxyz=v)), "constraint 'c'", "<parent_origin xyz="),
    "constraint_rpy": (lambda v: robot(extra=constraint(prpy=v)), "constraint 'c'", "<parent_origin rpy="),
    "constraint_axis": (lambda v: robot(extra=constraint(caxis=v)), "constraint 'c'", "<child_axis xyz="),
}
COUNTS = {"empty": "", "one": "1", "two": "0 1", "four": "0 0 1 4"}
SCALARS = {   # a scalar attribute given two numbers
    "mass": (robot(l1=inertial(mass="1 2")), "link 'l1'", "<mass value="),
    "inertia": (robot(l1=inertial(ixx="0.1 0.1")), "link 'l1'", "<inertia ixx="),
    "limit": (robot(j1_limit='<limit lower="-1 0" upper="1" effort="1" velocity="1"/>'), "joint 'j1'",
              "<limit lower="),
}

REFUSED = {}
for attr, (build, owner, element) in VECTORS.items():
    for cid, value in COUNTS.items():
        REFUSED[f"count-{attr}-{cid}"] = (build(value), [owner, element, "expected 3"])
for attr, (text, owner, element) in SCALARS.items():
    REFUSED[f"count-{attr}-two"] = (text, [owner, element, "2 number(s), expected 1"])

REFUSED.update({
    # axes: zero (also signed zeros and underflow to zero) and a bare <axis>
    "axis-zero": (robot(j1_axis='<axis xyz="0 0 0"/>'), ["joint 'j1'", "no direction"]),
    "axis-signed-zeros": (robot(j1_axis='<axis xyz="-0 +0 0.0"/>'), ["joint 'j1'", "no direction"]),
    "axis-underflow": (robot(j1_axis='<axis xyz="1e-400 0 0"/>'), ["joint 'j1'", "no direction"]),
    "axis-prismatic-zero": (robot(j1_type="prismatic", j1_axis='<axis xyz="0 0 0"/>'),
                            ["joint 'j1'", "no direction"]),
    "axis-bare": (robot(j1_axis="<axis/>"), ["joint 'j1'", "<axis> has no xyz"]),
    "constraint-axis-zero": (robot(extra=constraint(caxis="0 0 0")), ["constraint 'c'", "child_axis has no direction"]),
    # masses and inertias
    "mass-negative": (robot(l1=inertial(mass="-1")), ["link 'l1'", "negative mass"]),
    "mass-1e13": (robot(l1=inertial(mass="1e13")), ["link 'l1'", "<mass value='1e13'>", "beyond the bound"]),
    "mass-1e308": (robot(l1=inertial(mass="1e308")), ["link 'l1'", "<mass value='1e308'>", "beyond the bound"]),
    "inertia-1e13": (robot(l1=inertial(ixx="1e13")), ["link 'l1'", "<inertia ixx='1e13'>", "beyond the bound"]),
    "inertia-offdiag--1e300": (robot(l1=inertial(ixy="-1e300")), ["link 'l1'", "<inertia ixy=", "beyond"]),
    "inertia-not-psd": (robot(l1=inertial(ixy="5")), ["body 'l1'", "not positive semi-definite",
                                                     "non_psd_inertia='keep'"]),
    "inertia-missing-key": (robot(l1='<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1"/></inertial>'),
                            ["link 'l1'", "<inertia> needs all of"]),
    "mass-missing": (robot(l1='<inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>'),
                     ["link 'l1'", "without <mass"]),
    # lengths
    "length-joint-origin": (robot(j1_origin='<origin xyz="0 1e7 0"/>'), ["joint 'j1'", "<origin xyz=", "beyond"]),
    "length-inertial-origin": (robot(l1=inertial(com="-1e7 0 0")), ["link 'l1'", "<origin xyz=", "beyond"]),
    "length-constraint-origin": (robot(extra=constraint(pxyz="0 0 2e6")), ["constraint 'c'", "<parent_origin xyz=",
                                                                            "beyond"]),
    "length-prismatic-limit": (robot(j1_type="prismatic",
                                     j1_limit='<limit lower="-1e7" upper="1" effort="1" velocity="1"/>'),
                               ["joint 'j1'", "<limit lower='-1e7'>", "beyond"]),
    # limits
    "limit-negative-effort": (robot(j1_limit='<limit lower="-1" upper="1" effort="-1" velocity="1"/>'),
                              ["joint 'j1'", "<limit effort='-1'>", ">= 0"]),
    "limit-negative-velocity": (robot(j1_limit='<limit lower="-1" upper="1" effort="1" velocity="-0.5"/>'),
                                ["joint 'j1'", "<limit velocity='-0.5'>", ">= 0"]),
    "limit-no-effort": (robot(j1_limit='<limit lower="-1" upper="1" velocity="1"/>'),
                        ["joint 'j1'", "<limit> has no effort"]),
    "limit-no-velocity": (robot(j1_limit='<limit lower="-1" upper="1" effort="1"/>'),
                          ["joint 'j1'", "<limit> has no velocity"]),
    "limit-missing-revolute": (robot(j1_limit=""), ["joint 'j1'", "revolute joint needs <limit"]),
    "limit-missing-prismatic": (robot(j1_type="prismatic", j1_limit=""), ["joint 'j1'", "prismatic joint needs <limit"]),
    # mimic
    "mimic-self": (robot(j1='<mimic joint="j1"/>'), ["joint 'j1'", "mimics itself"]),
    "mimic-no-joint-attribute": (robot(j1='<mimic multiplier="2"/>'), ["joint 'j1'", "<mimic joint=None>"]),
    # types and names
    "joint-type-unknown": (robot(j1_type="hinge"), ["joint 'j1'", "unknown joint type"]),
    "joint-type-screw-no-pitch": (robot(j1_type="screw"), ["joint 'j1'", "needs one <drake:screw_thread_pitch"]),
    "duplicate-link": (robot(extra='<link name="l2"/>'), ["duplicate link name(s): l2"]),
    "duplicate-joint": (robot(extra='<joint name="j2" type="fixed"><parent link="base"/><child link="x"/></joint>'),
                        ["duplicate joint name(s): j2"]),
    "xml-depth": (robot(extra="<a>" * 5000 + "</a>" * 5000), ["malformed XML"]),
})


@pytest.mark.parametrize("case", list(REFUSED))
def test_refused_with_a_named_error(case):
    text, words = REFUSED[case]
    with pytest.raises(ManipdynError) as info:
        load_urdf_string(text, source="structure.urdf")
    msg = str(info.value)
    assert isinstance(info.value, (URDFError, ModelError)), msg
    assert msg.startswith("structure.urdf: "), msg
    for w in words:
        assert w in msg, f"{w!r} not in {msg!r}"


INVERTED = {       # <limit> with lower > upper: PyBullet reads no limit, urdfdom keeps the numbers, strict refuses
    "revolute": dict(j1_limit='<limit lower="1" upper="-1" effort="1" velocity="1"/>'),
    "default-upper": dict(j1_limit='<limit lower="0.5" effort="1" velocity="1"/>'),
    "prismatic": dict(j1_type="prismatic", j1_limit='<limit lower="0.2" upper="0.1" effort="1" velocity="1"/>'),
    "continuous": dict(j1_type="continuous", j1_limit='<limit lower="3" upper="-3" effort="1" velocity="1"/>'),
}


@pytest.mark.parametrize("case", list(INVERTED))
def test_inverted_limits_are_no_limit_with_a_quirk_or_refused_when_strict(case):
    text = robot(**INVERTED[case])
    with pytest.warns(UserWarning, match="lower > upper"):
        model = load_urdf_string(text, source="structure.urdf")
    assert [(k.kind, k.name) for k in model.quirks if k.kind == "inverted_limits"] == [("inverted_limits", "j1")]
    assert (model.lower[0], model.upper[0]) == (-np.inf, np.inf)
    free = load_urdf_string(robot(**{**INVERTED[case], "j1_limit": LIMIT}), source="structure.urdf")
    q, v, a = np.array([0.3, -0.7]), np.array([1.0, 2.0]), np.array([-0.5, 0.4])
    assert np.array_equal(rnea(model, q, v, a), rnea(free, q, v, a))     # limits never enter the dynamics
    with pytest.raises(URDFError, match=r"joint 'j1': <limit lower=.*lower > upper \(strict=True"):
        load_urdf_string(text, source="structure.urdf", strict=True)


@pytest.mark.parametrize("before,after", [("\n  \t", ""), ("", "\0"), ("\r\n", "\n\0\0\n")])
def test_space_before_the_declaration_and_trailing_nul_are_read_with_a_quirk(before, after):
    """libxml2 refuses both; urdfdom, MuJoCo and PyBullet read such files (pybullet_data's diff_ring.urdf and
    humanoid.urdf): the bytes are removed, the model is the clean file's."""
    with pytest.warns(UserWarning, match="removed"):
        model = load_urdf_string((before + robot() + after).encode(), source="structure.urdf")
    assert [k.kind for k in model.quirks] == ["xml_text"]
    clean = load_urdf_string(robot(), source="structure.urdf")
    assert np.array_equal(model.mass, clean.mass) and np.array_equal(model.p0, clean.p0)
    refused = {"text before the declaration": "x" + robot(), "NUL inside": robot().replace("<link", "\0<link", 1)}
    for text in refused.values():
        with pytest.raises(URDFError, match="malformed XML"):
            load_urdf_string(text, source="structure.urdf")


@pytest.mark.parametrize("target", ["nowhere", "l2"])          # no such joint; a link's name
def test_mimic_of_a_missing_joint_is_dropped_with_a_quirk_or_refused_when_strict(target):
    text = robot(j1=f'<mimic joint="{target}"/>')
    with pytest.warns(UserWarning, match=f"mimic joint='{target}'> names no joint"):
        model = load_urdf_string(text, source="structure.urdf")
    assert [(k.kind, k.name) for k in model.quirks if k.kind == "mimic"] == [("mimic", "j1")]
    assert model.mimic == () and model.joint_names == ("j1", "j2")      # both joints move on their own
    plain = load_urdf_string(robot(), source="structure.urdf")
    q, v, a = np.array([0.3, -0.7]), np.array([1.0, 2.0]), np.array([-0.5, 0.4])
    assert np.array_equal(rnea(model, q, v, a), rnea(plain, q, v, a))
    with pytest.raises(URDFError, match=f"joint 'j1': <mimic joint='{target}'> names no joint.*strict=True"):
        load_urdf_string(text, source="structure.urdf", strict=True)


def test_huge_attribute_is_refused_with_a_short_message():
    text = robot(j1_origin=f'<origin xyz="{"1" * 1_000_000}x 0 0"/>')
    with pytest.raises(URDFError, match="joint 'j1': <origin xyz=") as info:
        load_urdf_string(text)
    assert len(str(info.value)) < 400


# ---- size limit ---------------------------------------------------------------------------------------

def test_size_limit_refuses_a_larger_file(tmp_path):
    path = tmp_path / "big.urdf"
    path.write_text(robot())
    with pytest.raises(URDFError, match=r"big.urdf: larger than the size limit of 100 bytes"):
        load_urdf(path, max_bytes=100)
    assert load_urdf(path, max_bytes=path.stat().st_size).nv == 2      # exactly at the limit: loads


def test_default_size_limit_refuses_unread(tmp_path):
    path = tmp_path / "sparse.urdf"
    with open(path, "wb") as fh:                  # sparse file of zeros, one byte over the default limit
        fh.truncate(MAX_BYTES + 1)
    with pytest.raises(URDFError, match=f"sparse.urdf: larger than the size limit of {MAX_BYTES} bytes"):
        load_urdf(path)


def test_size_limit_applies_to_strings():
    with pytest.raises(URDFError, match="<string>: larger than the size limit of 50 bytes"):
        load_urdf_string(robot(), max_bytes=50)


def test_largest_zoo_file_fits_the_default_limit():
    largest = max(p.stat().st_size for p in robots_dir().rglob("*.urdf"))
    assert 100_000 < largest < MAX_BYTES / 100                  # 0.21 MB (tiago_dual) against 50 MB


def test_bad_gravity_is_an_input_error():
    with pytest.raises(InputError, match="gravity"):
        load_urdf_string(robot(), gravity=(0, 0, float("nan")))
    with pytest.raises(InputError, match="gravity"):
        load_urdf_string(robot(), gravity=(0, -9.81))


# ---- accepted edge cases, against Pinocchio or a closed form -----------------------------------------

@pytest.mark.parametrize("axis,unit", [
    ("1e200 0 0", (1, 0, 0)), ("0 3e200 4e200", (0, 0.6, 0.8)), ("0 3e-200 -4e-200", (0, 0.6, -0.8)),
    ("0 0 -2", (0, 0, -1)), ("1e308 1e308 0", (2 ** -0.5, 2 ** -0.5, 0)), ("0 3 4", (0, 0.6, 0.8))])
def test_axis_is_normalised_robustly(axis, unit):
    model = load_urdf_string(robot(j1_axis=f'<axis xyz="{axis}"/>'))
    assert_close(model.axis[0], unit, 1e-15, "axis")         # measured 1.1e-16
    assert any("normalised" in n for n in model.notes)


def test_bounds_are_inclusive():
    text = robot(l1=inertial(mass=repr(MAX_MASS), ixx=repr(MAX_INERTIA), com=f"0 0 {MAX_LENGTH!r}"))
    model = load_urdf_string(text)
    assert model.mass[0] == MAX_MASS


def test_missing_lower_upper_are_zero_as_in_pinocchio():
    text = robot(j1_limit='<limit effort="3" velocity="4"/>')
    model, pm = load_urdf_string(text), pin.buildModelFromXML(text)
    assert (model.lower[0], model.upper[0]) == (pm.lowerPositionLimit[0], pm.upperPositionLimit[0]) == (0, 0)
    assert (model.effort[0], model.velocity[0]) == (pm.effortLimit[0], pm.velocityLimit[0]) == (3, 4)


def test_continuous_joint_without_limit_is_unbounded_as_in_pinocchio():
    text = robot(j1_type="continuous", j1_limit="")
    model, pm = load_urdf_string(text), pin.buildModelFromXML(text)
    assert model.continuous[0] and np.isinf(model.lower[0]) and np.isinf(model.upper[0])
    assert model.effort[0] == pm.effortLimit[0] == np.inf and model.velocity[0] == pm.velocityLimit[0] == np.inf


@pytest.mark.parametrize("visual", [
    '<visual><origin xyz="nan 1_0"/><geometry><box size="1 1 1"/></geometry></visual>',
    '<visual><geometry><cylinder radius="x"/></geometry></visual>',
    '<collision><geometry><mesh/></geometry></collision>',
    '<visual><geometry><inertia/></geometry><material name="m"><color rgba="red"/></material></visual>'])
def test_broken_visual_does_not_stop_the_dynamics_as_in_pinocchio(visual):
    # the dynamics never read visuals (manipdyn.viz does, on demand); Pinocchio loads these too
    text = robot(l1=inertial(mass="2") + visual)
    model, pm = load_urdf_string(text), pin.buildModelFromXML(text)
    assert model.nv == pm.nv == 2 and model.mass[0] == pm.inertias[1].mass == 2.0


def test_dynamics_numbers_follow_the_grammar():
    with pytest.raises(URDFError, match="joint 'j1': <dynamics damping='1_0'>: '1_0' is not a URDF number"):
        load_urdf_string(robot(j1='<dynamics damping="1_0" friction="0"/>'))


def test_fixed_joint_may_carry_a_zero_axis():
    text = robot(extra='<link name="tool"/><joint name="t" type="fixed"><parent link="l2"/><child link="tool"/>'
                       '<axis xyz="0 0 0"/></joint>')
    assert load_urdf_string(text).merged["l2"] == ("tool",)


def test_merged_far_link_keeps_its_small_moment_as_in_pinocchio():
    # a tool 1e5 m out along z, merged through a fixed joint: the merged moment about z gets m (x² + y²)
    # terms of ~5e-5, which |d|² − z² (|d|² ~ 2.5e9) computes with an error of 4.5e-7 (cancellation)
    tool = ('<link name="tool"><inertial><origin xyz="0 0.01 0"/><mass value="1"/><inertia ixx="1e-6" ixy="0" '
            'ixz="0" iyy="1e-6" iyz="0" izz="1e-6"/></inertial></link><joint name="t" type="fixed">'
            '<parent link="l1"/><child link="tool"/><origin xyz="0 0 1e5"/></joint>')
    text = robot(extra=tool)
    model, pm = load_urdf_string(text), pin.buildModelFromXML(text)
    assert_close(model.inertia[0], pm.inertias[1].inertia, 1e-14, "merged inertia")   # measured 1.9e-16
    assert_close(model.inertia[0][2, 2], pm.inertias[1].inertia[2, 2], 1e-15, "moment about z")  # measured 0
