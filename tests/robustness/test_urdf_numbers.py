"""Hostile numbers in a URDF: every number form outside the URDF grammar, in every kind of attribute the
loader reads, raises URDFError naming the file, the link/joint/constraint, the attribute and the value.

The grammar is plain decimal (sign, digits, fraction, exponent). Python's float() accepts more — '1_0',
non-ASCII digits, 'nan', 'inf', surrounding Unicode spaces — and urdfdom (Pinocchio's reader) refuses
all of them, as manipdyn does.
"""
import pytest

from manipdyn import ManipdynError, URDFError, load_urdf_string

# Every slot is one number the loader reads; GOOD values give a valid robot (checked below).
GOOD = {
    "j1_xyz": "0 0 0.1", "j1_rpy": "0 0 0", "j1_axis": "0 0 1",
    "j1_lower": "-1", "j1_upper": "1", "j1_effort": "10", "j1_velocity": "2",
    "l1_mass": "1", "l1_ixx": "0.1", "l1_ixy": "0", "l1_com": "0 0 0.05", "l1_com_rpy": "0 0 0",
    "j2_mult": "1", "j2_offset": "0",
    "c_pxyz": "0 0 0", "c_prpy": "0 0 0", "c_caxis": "0 0 1",
}


def robot(**slots):
    """A three-link robot (j1 revolute, j2 mimicking j1, a spherical <constraint> c) with slots replaced."""
    s = {**GOOD, **slots}
    inertia = f'ixx="{s["l1_ixx"]}" ixy="{s["l1_ixy"]}" ixz="0" iyy="0.1" iyz="0" izz="0.1"'
    return f'''<?xml version="1.0"?>
<robot name="numbers">
  <link name="base"/>
  <link name="l1"><inertial><origin xyz="{s["l1_com"]}" rpy="{s["l1_com_rpy"]}"/><mass value="{s["l1_mass"]}"/>
    <inertia {inertia}/></inertial></link>
  <link name="l2"><inertial><mass value="1"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/>
    </inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="{s["j1_xyz"]}" rpy="{s["j1_rpy"]}"/><axis xyz="{s["j1_axis"]}"/>
    <limit lower="{s["j1_lower"]}" upper="{s["j1_upper"]}" effort="{s["j1_effort"]}" velocity="{s["j1_velocity"]}"/>
  </joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/><origin xyz="0 0 0.2"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
    <mimic joint="j1" multiplier="{s["j2_mult"]}" offset="{s["j2_offset"]}"/></joint>
  <constraint name="c" type="spherical"><parent link="base"/><child link="l2"/>
    <parent_origin xyz="{s["c_pxyz"]}" rpy="{s["c_prpy"]}"/><child_origin xyz="0 0 0"/>
    <parent_axis xyz="0 0 1"/><child_axis xyz="{s["c_caxis"]}"/></constraint>
</robot>
'''


# slot -> (owner named in the message, element and attribute named in the message, numbers in the slot)
SLOTS = {
    "j1_xyz": ("joint 'j1'", "<origin xyz=", 3),
    "j1_rpy": ("joint 'j1'", "<origin rpy=", 3),
    "j1_axis": ("joint 'j1'", "<axis xyz=", 3),
    "j1_lower": ("joint 'j1'", "<limit lower=", 1),
    "j1_upper": ("joint 'j1'", "<limit upper=", 1),
    "j1_effort": ("joint 'j1'", "<limit effort=", 1),
    "j1_velocity": ("joint 'j1'", "<limit velocity=", 1),
    "l1_mass": ("link 'l1'", "<mass value=", 1),
    "l1_ixx": ("link 'l1'", "<inertia ixx=", 1),
    "l1_ixy": ("link 'l1'", "<inertia ixy=", 1),
    "l1_com": ("link 'l1'", "<origin xyz=", 3),
    "l1_com_rpy": ("link 'l1'", "<origin rpy=", 3),
    "j2_mult": ("joint 'j2'", "<mimic multiplier=", 1),
    "j2_offset": ("joint 'j2'", "<mimic offset=", 1),
    "c_pxyz": ("constraint 'c'", "<parent_origin xyz=", 3),
    "c_prpy": ("constraint 'c'", "<parent_origin rpy=", 3),
    "c_caxis": ("constraint 'c'", "<child_axis xyz=", 3),
}

# bad number form -> what float() does with it (why the grammar is needed)
FORMS = {
    "underscore": "1_0",            # float: 10.0
    "arabic_indic": "\u0663",       # float: 3.0
    "fullwidth": "\uff11",          # float: 1.0
    "nan": "nan",                   # float: nan
    "inf": "-inf",                  # float: -inf
    "infinity": "Infinity",         # float: inf
    "hex": "0x1p3",                 # float: ValueError (float.fromhex reads it)
    "comma": "1,5",                 # decimal comma
    "word": "one",
    "overflow": "1e400",            # in the grammar, but overflows to inf
}


def _put(slot, form):
    """The slot's good value with its middle (or only) number replaced by ``form``."""
    parts = GOOD[slot].split()
    parts[len(parts) // 2] = form
    return " ".join(parts)


def test_good_robot_loads():
    model = load_urdf_string(robot())
    assert model.joint_names == ("j1", "j2") and len(model.constraints) == 1


@pytest.mark.parametrize("form", list(FORMS))
@pytest.mark.parametrize("slot", list(SLOTS))
def test_bad_number_is_refused_and_named(slot, form):
    owner, attribute, _ = SLOTS[slot]
    with pytest.raises(ManipdynError) as info:
        load_urdf_string(robot(**{slot: _put(slot, FORMS[form])}), source="numbers.urdf")
    msg = str(info.value)
    assert isinstance(info.value, URDFError), msg
    assert msg.startswith("numbers.urdf: ") and owner in msg and attribute in msg, msg
    assert ("overflows" if form == "overflow" else "is not a URDF number") in msg, msg


@pytest.mark.parametrize("text", ["1", "-1", "+1", "1.", ".5", "-.5e-3", "1E+2", "0.0", "007", "  2 "])
def test_grammar_accepts_plain_decimals(text):
    model = load_urdf_string(robot(j2_offset=text))
    assert model.mimic == (("j2", "j1", 1.0, float(text)),)
