"""Hostile MJCF (docs/design.md §9, the URDF reader's rules): includes confined to the model's folder, bounded in
depth, count and bytes; no DTDs or entities; a size limit; one number grammar, exact vector lengths, finite values
within bounds; counts bounded; and every unsupported feature refused by name — each an MJCFError naming the file,
the element and the value or feature at fault."""
from __future__ import annotations

import os
import warnings

import pytest

import manipdyn as md
from manipdyn import MJCFError, load_mjcf, load_mjcf_string
from manipdyn.io import mjcf_read


def doc(body="", top="", joint='<joint name="j" axis="0 1 0"/>', geom='<geom type="sphere" size="0.1"/>'):
    return (f'<mujoco model="m">{top}<worldbody><body name="b" pos="0 0 1">{joint}{geom}{body}</body>'
            f'</worldbody></mujoco>')


def refused(text, *words, **kw):
    with pytest.raises(MJCFError) as exc:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            load_mjcf_string(text, **kw)
    for w in words:
        assert w in str(exc.value), (w, str(exc.value))
    return str(exc.value)


def test_the_base_document_loads():
    assert load_mjcf_string(doc()).joint_names == ("j",)


# ---- XML -----------------------------------------------------------------------------------------------------

def test_entities_and_dtds_are_refused():
    text = '<?xml version="1.0"?><!DOCTYPE mujoco [<!ENTITY big "0 0 1">]><mujoco>' + doc()[8:]
    refused(text, "ENTITY")
    refused('<!DOCTYPE mujoco SYSTEM "http://example.com/x.dtd">' + doc(), "DOCTYPE")


def test_size_limit_and_root_element():
    refused(doc(), "size limit", max_bytes=50)
    refused("<robot name='r'/>", "<robot>", "<mujoco>")
    refused("<mujoco><worldbody>", "malformed XML")


# ---- numbers -------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "1_0", "0x10", "\u0661", "1e400", "1,5", "one"])
def test_numbers_outside_the_grammar_name_the_element(value):
    msg = refused(doc(geom=f'<geom type="sphere" size="0.1" mass="{value}"/>'), "body 'b'", "mass")
    assert "geom" in msg


@pytest.mark.parametrize("where,text", [
    ("pos", '<body name="c" pos="1 2"><joint/></body>'),
    ("quat", '<body name="c" quat="1 0 0"><joint/></body>'),
    ("axis", None),
    ("diaginertia", '<body name="c"><joint/><inertial pos="0 0 0" mass="1" diaginertia="1 1"/></body>'),
    ("fullinertia", '<body name="c"><joint/><inertial pos="0 0 0" mass="1" fullinertia="1 1 1 0 0"/></body>'),
    ("xyaxes", '<body name="c" xyaxes="1 0 0 0 1"><joint/></body>'),
])
def test_wrong_vector_lengths(where, text):
    if text is None:
        refused(doc(joint='<joint name="j" axis="0 1"/>'), "joint 'j'", "axis", "expected 3")
    else:
        refused(doc(body=text), where, "number(s), expected")


def test_bounds_and_signs():
    refused(doc(body='<body name="c" pos="1e7 0 0"><joint/></body>'), "body 'c'", "bound")
    refused(doc(geom='<geom type="sphere" size="0.1" mass="1e13"/>'), "bound")
    refused(doc(body='<body name="c"><joint/><inertial pos="0 0 0" mass="-1" diaginertia="1 1 1"/></body>'), "negative mass")
    refused(doc(geom='<geom type="sphere" size="0.1" density="1e9"/>'), "density")
    refused(doc(geom='<geom type="box" size="0.1 0.2"/>'), "box", "3 positive size")
    refused(doc(joint='<joint name="j" axis="0 0 0"/>'), "joint 'j'", "no direction")
    refused(doc(body='<body name="c" quat="0 0 0 0"><joint/></body>'), "quat", "zero")


# ---- structure -----------------------------------------------------------------------------------------------

def test_joint_types_by_name():
    ball = load_mjcf_string(doc(joint='<joint name="j" type="ball" axis="0 0 0" range="0 1" ref="2"/>'))
    assert ball.q_names == ("j.qx", "j.qy", "j.qz", "j.qw") and ball.v_names == ("j.wx", "j.wy", "j.wz")
    refused(doc(joint='<joint name="j" type="ball"/><joint name="h" axis="0 1 0"/>',
                top='<equality><joint joint1="j" joint2="h"/></equality>'), "joint1='j' is a ball joint")
    refused(doc(joint='<joint name="j" type="screw"/>'), "joint 'j'", "unknown joint type")
    refused(doc(body='<body name="c"><freejoint name="f"/></body>'), "joint 'f'", "free joint")
    refused(doc(joint='<freejoint name="f"/><joint name="j"/>'), "joint 'f'", "free joint")


def test_unsupported_features_are_named():
    refused(doc(top='<equality><tendon tendon1="t"/></equality>'), "<equality><tendon", "tendon1='t': no such tendon")
    refused(doc(top='<tendon><fixed name="t" armature="0.1"><joint joint="j" coef="1"/></fixed></tendon>'),
            "tendon 't'", "armature")
    refused(doc(top='<asset><mesh name="m" file="m.stl"/></asset>', geom='<geom type="mesh" mesh="m"/>'),
            "mesh inertia is not supported yet")
    refused(doc(body='<frame pos="1 0 0"><composite type="grid"/></frame>'), "<composite>", "not supported yet")
    refused(doc(body='<body name="c"><joint/><inertial mass="1" diaginertia="1 1 1"/></body>'), "no pos attribute")
    refused(doc(body='<frame pos="1 0 0"><body name="c"><joint class="nope"/></body></frame>'), "no such default")
    refused(doc(body='<composite type="grid"/>'), "<composite>")
    refused(doc(top='<compiler boundmass="0.1"/>'), "boundmass")
    refused(doc(geom='<geom type="box" fromto="0 0 0 1 0 0" size="0.1"/>'), "fromto on a box")
    refused(doc(body='<body name="c" quat="1 0 0 0" euler="0 0 1"><joint/></body>'), "several orientations")
    refused(doc(body='<body name="c"><joint class="nope"/></body>'), "no such default class")
    refused(doc(body='<body name="b"><joint/></body>'), "'b'", "used twice")
    refused(doc(body='<site name="s"/><site name="s" pos="1 0 0"/>'), "site name 's'", "used twice")
    refused(doc(body='<site name="b"/><body name="site:b"/>'), "site 'b' shares a body's name", "'site:b'")
    refused(doc(joint='<joint name="j"/><joint name="k"/>', body='<body name="b:j"/>'), "'b:j'", "used twice")


def test_unknown_top_level_elements_are_quirks_or_errors_with_strict():
    with pytest.warns(md.QuirkWarning, match="unknown_element"):
        m = load_mjcf_string(doc(top="<gadget/>"))
    assert ("unknown_element", "<gadget>") in {(q.kind, q.name) for q in m.quirks}
    refused(doc(top="<gadget/>"), "<gadget>", "strict", strict=True)


def test_attributes_outside_mujocos_schema_are_quirks_or_errors_with_strict():
    text = doc(joint='<joint name="j" axis="0 1 0" dampng="3"/>', top='<option collision="all"/>')
    with pytest.warns(md.QuirkWarning, match="unknown_element"):
        m = load_mjcf_string(text)
    assert {q.name for q in m.quirks if q.kind == "unknown_element"} == {"<joint dampng>", "<option collision>"}
    refused(text, "<option collision='all'>", "strict", strict=True)
    refused(doc(joint='<freejoint name="f" align="true"/>'), "joint 'f'", "align")
    refused(doc(top='<compiler alignfree="true"/>', joint='<freejoint name="f"/>'), "joint 'f'", "alignfree")


def test_counts_are_bounded(monkeypatch):
    monkeypatch.setattr(mjcf_read, "MAX_BODIES", 5)
    refused(doc(body="".join(f'<site name="s{k}"/>' for k in range(6))), "more than 5")


def test_a_deep_chain_is_walked_without_recursion():
    n = 200                                       # lxml's own nesting limit (256) bounds the depth first
    text = ('<mujoco><worldbody>' + "".join(f'<body name="b{k}" pos="0 0 0.1"><joint/><geom size="0.01"/>'
                                            for k in range(n)) + "</body>" * n + "</worldbody></mujoco>")
    assert load_mjcf_string(text).nv == n


# ---- includes ------------------------------------------------------------------------------------------------

def _tree(tmp_path):
    (tmp_path / "model").mkdir()
    (tmp_path / "model" / "part.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    (tmp_path / "outside.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    return tmp_path / "model"


def _main(folder, include, name="main.xml"):
    p = folder / name
    p.write_text(doc(top=f'<include file="{include}"/>'))
    return p


def test_an_include_inside_the_folder_loads(tmp_path):
    assert load_mjcf(_main(_tree(tmp_path), "part.xml")).nv == 1


@pytest.mark.parametrize("include,words", [
    ("../outside.xml", ("outside the model's folder",)),
    ("sub/../../outside.xml", ("outside the model's folder",)),
    ("/etc/hostname", ("absolute",)),
    ("", ("absolute, URL or empty",)),
    ("http://example.com/x.xml", ("absolute, URL or empty",)),
    ("missing.xml", ("no such file",)),
])
def test_includes_that_escape_or_miss_are_refused(tmp_path, include, words):
    folder = _tree(tmp_path)
    with pytest.raises(MJCFError) as exc:
        load_mjcf(_main(folder, include))
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_a_symlink_out_of_the_folder_is_refused(tmp_path):
    folder = _tree(tmp_path)
    os.symlink(tmp_path / "outside.xml", folder / "link.xml")
    with pytest.raises(MJCFError, match="outside the model's folder"):
        load_mjcf(_main(folder, "link.xml"))


def test_include_depth_count_and_bytes_are_bounded(tmp_path):
    folder = _tree(tmp_path)
    (folder / "self.xml").write_text('<mujoco><include file="self.xml"/></mujoco>')       # includes itself
    with pytest.raises(MJCFError, match="nested deeper than"):
        load_mjcf(_main(folder, "self.xml"))
    (folder / "many.xml").write_text("<mujoco>" + '<include file="part.xml"/>' * 300 + "</mujoco>")
    with pytest.raises(MJCFError, match="more than 256 <include>"):
        load_mjcf(_main(folder, "many.xml"))
    (folder / "big.xml").write_text("<mujoco>" + " " * 5000 + "</mujoco>")
    with pytest.raises(MJCFError, match="size limit"):
        load_mjcf(_main(folder, "big.xml"), max_bytes=3000)
    (folder / "entity.xml").write_text('<!DOCTYPE mujoco [<!ENTITY x "1">]><mujoco/>')
    with pytest.raises(MJCFError, match="ENTITY"):
        load_mjcf(_main(folder, "entity.xml"))


def test_includes_in_text_need_a_folder():
    refused(doc(top='<include file="part.xml"/>'), "includes need a folder")


# ---- asset_root: a granted folder tree for includes ------------------------------------------------------------

def _suite(tmp_path):
    """A suite's layout: robots/arm/main.xml includes ../../common/defaults.xml; outside.xml beside the suite."""
    (tmp_path / "suite" / "robots" / "arm").mkdir(parents=True)
    (tmp_path / "suite" / "common").mkdir()
    (tmp_path / "suite" / "common" / "defaults.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    (tmp_path / "outside.xml").write_text('<mujoco><compiler angle="radian"/></mujoco>')
    return _main(tmp_path / "suite" / "robots" / "arm", "../../common/defaults.xml")


def test_a_granted_tree_lets_includes_leave_the_models_folder(tmp_path):
    main = _suite(tmp_path)
    with pytest.raises(MJCFError, match=r"outside the model's folder .*asset_root=FOLDER.*--asset-root"):
        load_mjcf(main)
    assert load_mjcf(main, asset_root=tmp_path / "suite").nv == 1
    with pytest.raises(MJCFError, match="outside the granted folder"):      # a tree that holds the model, not the
        load_mjcf(main, asset_root=str(tmp_path / "suite" / "robots"))      # shared folder


@pytest.mark.parametrize("include,words", [
    ("../../../outside.xml", ("outside the granted folder", "(asset_root)")),
    ("/etc/hostname", ("absolute",)),
    ("../../common/missing.xml", ("no such file",)),
])
def test_the_granted_tree_keeps_every_other_rule(tmp_path, include, words):
    _suite(tmp_path)
    main = _main(tmp_path / "suite" / "robots" / "arm", include, "other.xml")
    with pytest.raises(MJCFError) as exc:
        load_mjcf(main, asset_root=tmp_path / "suite")
    assert all(w in str(exc.value) for w in words), str(exc.value)


def test_a_symlink_out_of_the_granted_tree_is_refused(tmp_path):
    _suite(tmp_path)
    os.symlink(tmp_path / "outside.xml", tmp_path / "suite" / "common" / "link.xml")
    main = _main(tmp_path / "suite" / "robots" / "arm", "../../common/link.xml", "linked.xml")
    with pytest.raises(MJCFError, match="outside the granted folder"):
        load_mjcf(main, asset_root=tmp_path / "suite")


@pytest.mark.parametrize("root,words", [("missing", "no such folder"), ("elsewhere", "does not hold the model's folder")])
def test_an_asset_root_must_be_a_folder_holding_the_models(tmp_path, root, words):
    main = _suite(tmp_path)
    (tmp_path / "elsewhere").mkdir()
    with pytest.raises(MJCFError, match=words):
        load_mjcf(main, asset_root=tmp_path / root)
    with pytest.raises(MJCFError, match="folder path"):
        load_mjcf(main, asset_root=3.5)
