"""Loader quirks (Model.quirks), the zero_mass_inertia and non_psd_inertia policies, point masses, <robot version>
and the XML declaration's version, unknown elements, URDF+ closures and couplings, mimic joints honoured — each
against Pinocchio 4.1 where Pinocchio is the reference."""
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from manipdyn import (FloatingBaseWarning, InertiaWarning, InputError, ModelError, URDFError, load_urdf,
                      load_urdf_string)
from manipdyn.constraints import closure_terms, constrained_forward_dynamics
from manipdyn.dynamics import mimic as mim
import manipdyn
from manipdyn.dynamics.crba import mass_matrix
from manipdyn.errors import QuirkWarning
from manipdyn.validation.measure import error
from manipdyn.validation.reference import pin
from manipdyn.validation.zoo import ARMS, FLOATING, robots_dir

ROOT = Path(__file__).resolve().parents[2]
P = pin()


def inertial(m, I=(0.1, 0.2, 0.25), xyz="0.1 0 0", rpy="0 0 0"):
    return (f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{m}"/><inertia ixx="{I[0]}" iyy="{I[1]}" '
            f'izz="{I[2]}" ixy="0" ixz="0" iyz="0"/></inertial>')


def robot(links, joints="", extra="", version=None):
    v = "" if version is None else f' version="{version}"'
    body = "".join(f'<link name="{n}">{x}</link>' for n, x in links.items())
    return f'<robot name="r"{v}>{body}{joints}{extra}</robot>'


def joint(name, parent, child, xyz="0 0 0", axis="0 0 1", kind="revolute", extra=""):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{xyz}"/><axis xyz="{axis}"/><limit effort="1" velocity="1" lower="-3" upper="3"/>'
            f'{extra}</joint>')


CHAIN = lambda m2="0", I2=(0.1, 0.2, 0.25): robot(  # noqa: E731
    {"base": "", "a": inertial(1.0), "b": inertial(m2, I2, xyz="0.1 0.2 0")},
    joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0", axis="0 1 0"))


def kinds(model):
    return {(q.kind, q.name) for q in model.quirks}


def load_quiet(text, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_urdf_string(text, **kw)


# ---- zero_mass_inertia: keep (Pinocchio) and drop ----------------------------------------------------------

def test_zero_mass_inertia_keep_is_pinocchios_model_and_drop_is_the_massless_link():
    text = CHAIN()
    with pytest.warns(InertiaWarning, match=r"zero_mass_inertia \(1\): link 'b': mass 0.*kept"):
        keep = load_urdf_string(text)
    assert ("zero_mass_inertia", "b") in kinds(keep)
    drop = load_quiet(text, zero_mass_inertia="drop")
    pm = P.buildModelFromXML(text)
    assert pm.inertias[2].mass == 0.0 and np.allclose(pm.inertias[2].inertia, np.diag([0.1, 0.2, 0.25]))  # kept
    pm_drop = P.buildModelFromXML(CHAIN(I2=(0, 0, 0)))          # the same file with the inertia zeroed
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = rng.uniform(-np.pi, np.pi, 2)
        for model, ref in ((keep, pm), (drop, pm_drop)):
            M = P.crba(ref, ref.createData(), q)
            M = np.triu(M) + np.triu(M, 1).T
            assert error(mass_matrix(model, q), M) < 1e-13     # round-off level (2 joints)
    assert not np.allclose(mass_matrix(keep, [0.3, 0.2]), mass_matrix(drop, [0.3, 0.2]))   # the policy matters
    with pytest.raises(Exception, match="zero_mass_inertia='lose'"):
        load_urdf_string(text, zero_mass_inertia="lose")


def test_no_inertial_and_rotated_root_inertial_are_reported():
    text = robot({"base": inertial(2.0, rpy="0 0 0.3"), "a": "", "b": inertial(1.0)},
                 joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0"))
    with pytest.warns(QuirkWarning) as rec:
        model = load_urdf_string(text)
    assert {("no_inertial", "a"), ("rotated_root_inertial", "base")} <= kinds(model)
    msgs = [str(w.message) for w in rec]
    assert sum("no_inertial" in m for m in msgs) == 1 and sum("rotated_root_inertial" in m for m in msgs) == 1


def test_triangle_names_every_link_and_non_psd_lists_all():
    bad = (1.0, 1.0, 3.0)
    text = robot({"base": "", "a": inertial(1.0, bad), "b": inertial(1.0, bad)},
                 joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0"))
    with pytest.warns(InertiaWarning) as rec:
        model = load_urdf_string(text)
    tri = [str(w.message) for w in rec if "triangle" in str(w.message)]
    assert len(tri) == 1 and "link 'a'" in tri[0] and "link 'b'" in tri[0]          # one warning, both links
    assert {("triangle", "a"), ("triangle", "b")} <= kinds(model)
    with pytest.raises(ModelError, match=r"2 link\(s\).*link 'a'.*link 'b'"):
        load_urdf_string(text, strict=True)
    neg = (1.0, 1.0, -3.0)
    text = robot({"base": "", "a": inertial(1.0, neg), "b": inertial(1.0, neg)},
                 joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0"))
    with pytest.raises(ModelError, match=r"2 inertia\(s\) not positive semi-definite.*'a'.*'b'"):
        load_quiet(text)


def against_pinocchio(model, text, seed, n=10):
    """The worst §3 errors (M, τ) of manipdyn's model against Pinocchio's model of the same URDF text, at n random
    states (q uniform in [−π, π], q̇ ~ N(0, 2²), q̈ ~ N(0, 5²)); serial revolute chains: the same q order."""
    pm = P.buildModelFromXML(text)
    pd = pm.createData()
    assert model.joint_names == tuple(pm.names[1:])
    rng = np.random.default_rng(seed)
    worst = [0.0, 0.0]
    for _ in range(n):
        q, v, a = rng.uniform(-np.pi, np.pi, model.nq), rng.normal(0, 2, model.nv), rng.normal(0, 5, model.nv)
        M = P.crba(pm, pd, q)
        M = np.triu(M) + np.triu(M, 1).T
        worst[0] = max(worst[0], error(mass_matrix(model, q), M))
        worst[1] = max(worst[1], error(manipdyn.rnea(model, q, v, a), P.rnea(pm, pd, q, v, a)))
    return worst


# ---- non_psd_inertia: refuse (the default) and keep (Pinocchio) -----------------------------------------------

NON_PSD = robot({"base": inertial(1.0, (0.1, 0.1, 0.1)).replace('ixy="0"', 'ixy="0.5"'),
                 "a": inertial(1.0, (0.1, 0.2, 0.25)).replace('ixz="0"', 'ixz="0.3"'),
                 "b": inertial(2.0, (0.05, 0.2, 0.3), xyz="0.1 0.2 0").replace('ixy="0"', 'ixy="0.4"'),
                 "c": inertial(0.5, (0.01, 0.02, 0.03), xyz="0 0 0.1")},
                joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0", axis="0 1 0")
                + joint("j3", "b", "c", xyz="0 0.2 0.1", axis="1 0 0"))


def test_non_psd_inertia_is_refused_by_default_naming_the_policy_and_kept_on_request():
    with pytest.raises(ModelError, match=r"3 inertia\(s\) not positive semi-definite: fixed base 'base'.*"
                                         r"body 'a'.*body 'b'.*pass non_psd_inertia='keep' to load them"):
        load_quiet(NON_PSD)
    with pytest.warns(InertiaWarning, match=r"non_psd_inertia \(3\): link 'base'.*link 'a'.*link 'b'") as rec:
        model = load_urdf_string(NON_PSD, non_psd_inertia="keep")
    assert sum("non_psd_inertia" in str(w.message) for w in rec) == 1               # one warning names all three
    found = {q.name: q.detail for q in model.quirks if q.kind == "non_psd_inertia"}
    assert set(found) == {"base", "a", "b"}                                        # every one, not the first
    written = {"base": ((0.1, 0.5, 0), (0.5, 0.1, 0), (0, 0, 0.1)), "a": ((0.1, 0, 0.3), (0, 0.2, 0), (0.3, 0, 0.25)),
           "b": ((0.05, 0.4, 0), (0.4, 0.2, 0), (0, 0, 0.3))}
    for name, I in written.items():                               # the smallest eigenvalue of the file's inertia
        assert f"smallest eigenvalue {np.linalg.eigvalsh(np.array(I))[0]:.6g} kg m²" in found[name]
    assert np.linalg.eigvalsh(model.inertia[1])[0] < -0.1       # loaded as written, not repaired
    worst = against_pinocchio(model, NON_PSD, seed=12)
    assert max(worst) < 1e-14, worst                            # measured M 4.4e-16, τ 6.2e-16


def test_non_psd_inertia_keep_loads_a_real_file_as_pinocchio_does():
    """romeo_laas_small (example-robot-data): three bodies with eigenvalues down to −0.021 kg m², refused by default;
    kept, with a free-flyer root (so the base's inertia counts), against Pinocchio's model of the same file."""
    from manipdyn.validation.reference import Reference
    path = robots_dir() / "romeo_description/urdf/romeo_laas_small.urdf"
    if not path.is_file():
        pytest.skip("example-robot-data's romeo_laas_small.urdf is not installed")
    with pytest.raises(ModelError, match=r"3 inertia\(s\) not positive semi-definite.*non_psd_inertia='keep'"):
        load_quiet(path.read_text(), root_joint="free_flyer")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = load_urdf(path, root_joint="free_flyer", non_psd_inertia="keep")
    assert [q.name for q in model.quirks if q.kind == "non_psd_inertia"] == ["base_link", "LHipPitch_link",
                                                                             "RHipPitch_link"]
    ref = Reference(model, path)
    rng = np.random.default_rng(15)
    worst = [0.0, 0.0]
    for _ in range(5):
        q, v, a = manipdyn.random_configuration(model, rng=rng), rng.normal(0, 2, model.nv), rng.normal(0, 5, model.nv)
        pq = ref.to_pin_q(q)
        M = P.crba(ref.pm, ref.pd, pq)
        M = np.triu(M) + np.triu(M, 1).T
        worst[0] = max(worst[0], error(mass_matrix(model, q), M))
        worst[1] = max(worst[1], error(manipdyn.rnea(model, q, v, a), P.rnea(ref.pm, ref.pd, pq, v, a)))
    assert max(worst) < 1e-14, worst                            # measured M 8.7e-17, τ 3.5e-16


@pytest.mark.parametrize("value", ["yes", "Keep", "", None, True])
def test_bad_non_psd_inertia_policy_is_an_input_error_naming_the_accepted_values(value, tmp_path):
    path = tmp_path / "r.urdf"
    path.write_text(CHAIN("1.0"))
    for load in (lambda **kw: load_urdf_string(CHAIN("1.0"), **kw), lambda **kw: load_urdf(path, **kw)):
        with pytest.raises(InputError, match=re.escape(f"non_psd_inertia={value!r}; accepted values: 'refuse'")
                           + ".*'keep'"):
            load(non_psd_inertia=value)


# ---- <inertial> with <mass> but no <inertia>: a point mass (Pinocchio 4.1, Drake) ------------------------------

POINT = robot({"base": "", "a": inertial(1.0),
               "b": '<inertial><origin xyz="0.1 0.2 0.05" rpy="0.3 -0.2 0.1"/><mass value="1.5"/></inertial>',
               "c": '<inertial><origin xyz="0 0.05 0.2"/><mass value="0.7"/></inertial>',
               "d": '<inertial><mass value="0"/></inertial>'},
              joint("j1", "base", "a") + joint("j2", "a", "b", xyz="0.3 0 0", axis="0 1 0")
              + joint("j3", "b", "c", xyz="0 0.2 0.1", axis="1 0 0") + joint("j4", "c", "d", xyz="0 0 0.3"))


def test_mass_without_inertia_is_a_point_mass_as_in_pinocchio():
    with pytest.warns(InertiaWarning, match=r"point_mass \(3\): link 'b': <mass value=1.5> without <inertia>"):
        model = load_urdf_string(POINT)
    assert {q.name for q in model.quirks if q.kind == "point_mass"} == {"b", "c", "d"}
    assert not any(q.kind == "zero_mass_inertia" for q in model.quirks)     # mass 0, no inertia: nothing kept
    assert model.mass.tolist() == [1.0, 1.5, 0.7, 0.0]
    assert np.max(np.abs(model.inertia[1:])) < 1e-31            # no rotational inertia: measured 1.4e-33 (round-off)
    assert error(model.com[1], [0.1, 0.2, 0.05]) < 1e-15       # at <origin xyz> (rpy turns nothing): measured 2.8e-17
    worst = against_pinocchio(model, POINT, seed=13)
    assert max(worst) < 1e-14, worst                            # measured M 1.1e-16, τ 5.1e-16
    with pytest.raises(URDFError, match=r"link 'b': <inertia> needs all of"):      # a partial <inertia>: refused
        load_quiet(POINT.replace('<mass value="1.5"/>', '<mass value="1.5"/><inertia ixx="1" iyy="1" izz="1"/>'))
    with pytest.raises(URDFError, match=r"link 'c': <inertial> without <mass"):     # as before: no <mass>
        load_quiet(POINT.replace('<mass value="0.7"/>', '<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" '
                                                        'iyz="0"/>'))


# ---- the XML declaration's version ---------------------------------------------------------------------------

@pytest.mark.parametrize("declaration, quirk", [
    ('<?xml version="0.0"?>', True), ("<?xml version='2.5' encoding='UTF-8'?>", True),
    ('\ufeff<?xml version = "0.0" standalone="yes"?>', True), ('<?xml version="abc"?>', True),
    ('<?xml version="1.0"?>', False), ('<?xml version="1.1"?>', False)])
def test_xml_declaration_version_is_ignored_as_pinocchio_does(declaration, quirk):
    text = declaration + CHAIN("1.0", (0.1, 0.2, 0.25))
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        model = load_urdf_string(text)
    assert (("xml_version", "<?xml?>") in kinds(model)) == quirk
    assert sum("xml_version" in str(w.message) for w in rec) == quirk
    worst = against_pinocchio(model, text.encode("utf-8").decode("utf-8-sig"), seed=14)
    assert max(worst) < 1e-14, worst                            # measured M 1.1e-16, τ 2.9e-16 (all six)


@pytest.mark.parametrize("declaration, words", [
    ('<?xml version=?>', "malformed XML"), ('<?xml version=""?>', "malformed XML"),
    ('<?xml encoding="UTF-8"?>', "malformed XML"), ('<?xml version="0.0" standalone="maybe"?>', "malformed XML"),
    ('<?xml version="0.0" encoding="bogus"?>', "malformed XML"), ('x <?xml version="0.0"?>', "malformed XML"),
    ('<?xml version="0.0"?><!DOCTYPE robot>', "DOCTYPE/ENTITY declarations are refused"),
    ('<?xml version="0.0"?><!DOCTYPE r [<!ENTITY a "aaaa">]>', "DOCTYPE/ENTITY declarations are refused")])
def test_other_malformed_declarations_stay_refused(declaration, words):
    with pytest.raises(URDFError, match=f"bad.urdf: {words}"):
        load_quiet(declaration + CHAIN("1.0"), source="bad.urdf")


# ---- <robot version> and unknown elements ----------------------------------------------------------------

@pytest.mark.parametrize("version, pin_loads", [("1.0", True), ("1.2", True), (" 1.0", True), ("0.0", False),
                                                ("2.0", False), ("1", False), ("foo", False)])
def test_version_is_tolerated_and_reported_where_urdfdom_refuses_it(version, pin_loads):
    text = robot({"base": "", "a": inertial(1.0)}, joint("j1", "base", "a"), version=version)
    try:                                  # urdfdom 6.0's rule, observed through pin 4.1
        P.buildModelFromXML(text)
        loads = True
    except (RuntimeError, ValueError):
        loads = False
    assert loads == pin_loads
    model = load_quiet(text)
    assert model.nv == 1 and (("version", "robot") in kinds(model)) == (not pin_loads)
    if not pin_loads:
        with pytest.raises(URDFError, match="version"):
            load_urdf_string(text, strict=True)


def test_unknown_elements_are_reported_by_name_never_dropped():
    text = robot({"base": "", "a": inertial(1.0) + "<contact/>"}, joint("j1", "base", "a", extra="<wobble/>"),
                 extra='<sensor name="imu"/>')
    with pytest.warns(QuirkWarning, match="unknown_element") as rec:
        model = load_urdf_string(text)
    names = {q.name for q in model.quirks if q.kind == "unknown_element"}
    assert names == {"<sensor>", "link 'a'/<contact>", "joint 'j1'/<wobble>"}, names
    assert sum("unknown_element" in str(w.message) for w in rec) == 1
    with pytest.raises(URDFError, match="strict=True.*<sensor"):
        load_urdf_string(text, strict=True)
    with pytest.raises(URDFError, match="quat_xyzw"):
        load_quiet(text.replace('<origin xyz="0 0 0"/>', '<origin xyz="0 0 0" quat_xyzw="0 0 0 1"/>'))


# ---- free_root: the rule on the zoo ----------------------------------------------------------------------

def test_free_root_flags_the_legged_robots_and_drones_not_the_arms():
    root = robots_dir()
    flagged = {}
    for rel in list(ARMS) + list(FLOATING):
        if (root / rel).is_file():
            with warnings.catch_warnings(record=True) as rec:
                warnings.simplefilter("always")
                model = load_urdf(root / rel)
            fr = [q for q in model.quirks if q.kind == "free_root"]
            assert len(fr) == (sum(issubclass(w.category, FloatingBaseWarning) for w in rec))
            flagged[rel] = bool(fr)
    assert not any(flagged[r] for r in ARMS if r in flagged)
    missed = sorted(r for r in FLOATING if r in flagged and not flagged[r])
    assert missed == ["pr2_description/urdf/pr2.urdf"], missed    # a wheeled base: nothing in its shape says so


# ---- URDF+ ---------------------------------------------------------------------------------------------------

FOURBAR = (ROOT / "urdf" / "fourbar.urdf").read_text()
LOOP = '''<loop name="loop" type="revolute">
    <predecessor link="coupler"><origin xyz="0.35 0 0" rpy="0 0 0"/></predecessor>
    <successor link="rocker"><origin xyz="0.3 0 0" rpy="0 0 0"/></successor>
    <axis xyz="0 1 0"/>
  </loop>'''


def urdfplus_fourbar():
    text = re.sub(r"<constraint name=.*?</constraint>", LOOP, FOURBAR, flags=re.S)
    text = re.sub(r"<transmission name=.*?</transmission>", "", text, flags=re.S)
    return (text.replace('name="j1_crank" type="revolute"', 'name="j1_crank" type="revolute" independent="true"')
            .replace('name="j2_coupler" type="revolute"', 'name="j2_coupler" type="revolute" independent="false"')
            .replace('name="j3_rocker" type="revolute"', 'name="j3_rocker" type="revolute" independent="false"'))


def test_urdfplus_loop_is_the_same_closure_as_the_constraint_form():
    a, b = load_urdf_string(FOURBAR), load_urdf_string(urdfplus_fourbar())
    assert b.constraints[0].source == "loop" and b.actuated == a.actuated == ("j1_crank",)
    rng = np.random.default_rng(5)
    Q, V = rng.uniform(-np.pi, np.pi, (20, 3)), rng.normal(0, 2, (20, 3))
    for x, y in zip(closure_terms(a, Q, V), closure_terms(b, Q, V)):
        assert np.max(np.abs(x - y)) == 0.0                          # the same rows, bit for bit


def test_loop_constraint_older_form_is_a_point_closure():
    text = re.sub(r"<constraint name=.*?</constraint>", '''<loop_constraint name="c1"><parent link="coupler"/>
        <parent_origin xyz="0.35 0 0"/><child link="rocker"/><child_origin xyz="0.3 0 0"/></loop_constraint>''',
                  FOURBAR, flags=re.S)
    c = load_urdf_string(text).constraints[0]
    assert c.type == "spherical" and c.source == "loop_constraint" and np.allclose(c.pp, [0.35, 0, 0])


def test_unread_loop_types_are_refused_by_name():
    with pytest.raises(URDFError, match="loop 'loop': type 'prismatic'"):
        load_urdf_string(urdfplus_fourbar().replace('type="revolute">\n    <predecessor', 'type="prismatic">\n    <predecessor'))
    with pytest.raises(URDFError, match="independent='maybe'"):
        load_urdf_string(urdfplus_fourbar().replace('independent="false"', 'independent="maybe"', 1))


ROTOR = robot({"base": "", "link": inertial(1.0, (0.01, 0.02, 0.03)), "rotor": inertial(0.2, (1e-3, 1e-3, 2e-3), xyz="0 0 0"),
               "tip": inertial(0.5, (0.01, 0.01, 0.01))},
              joint("j1", "base", "link", axis="0 1 0") + joint("j1r", "base", "rotor", axis="0 1 0")
              + joint("j2", "link", "tip", xyz="0.4 0 0", axis="0 1 0"))
COUPLING = '<coupling name="gear" type="rolling"><predecessor link="link"/><successor link="rotor"/><ratio value="6.0"/></coupling>'
MIMIC = '<mimic joint="j1" multiplier="6.0" offset="0"/>'


def test_coupling_rows_are_the_gear_equation():
    """Φ = ratio · Σ q (common ancestor -> predecessor) − Σ q (-> successor), Φ_q its coefficients, Φ̇_q q̇ = 0:
    checked against the equation written out, for a one-joint and a two-joint predecessor path."""
    two = COUPLING.replace('name="gear"', 'name="gear2"').replace('link="link"', 'link="tip"').replace("6.0", "-2.5")
    model = load_urdf_string(ROTOR.replace("</robot>", COUPLING + two + "</robot>"))
    assert model.joint_names == ("j1", "j2", "j1r") and [c.ratio for c in model.constraints] == [6.0, -2.5]
    rng = np.random.default_rng(4)
    Q, V = rng.uniform(-3, 3, (5, 3)), rng.normal(0, 2, (5, 3))
    Phi, Jc, bias = closure_terms(model, Q, V)
    want = np.stack([6.0 * Q[:, 0] - Q[:, 2], -2.5 * (Q[:, 0] + Q[:, 1]) - Q[:, 2]], axis=1)
    assert error(Phi, want) < 1e-15                                  # exact up to one rounding
    assert np.array_equal(Jc[0], [[6.0, 0.0, -1.0], [-2.5, -2.5, -1.0]]) and not np.any(bias)


def test_coupling_rows_against_pinocchios_tree():
    """The same rows written from Pinocchio's tree (tests/pin_closures.py walks pm.parents), mixed with a
    revolute closure in one model so that the row offsets are exercised too."""
    from pin_closures import PinClosures
    loop = ('<constraint name="pin" type="spherical"><parent link="tip"/><parent_origin xyz="0.2 0 0"/>'
            '<child link="rotor"/><child_origin xyz="0.3 0.1 0"/></constraint>')
    two = COUPLING.replace('name="gear"', 'name="gear2"').replace('link="link"', 'link="tip"').replace("6.0", "-2.5")
    text = ROTOR.replace("</robot>", COUPLING + loop + two + "</robot>")
    model = load_urdf_string(text)
    ref = PinClosures(model, P.buildModelFromXML(text))
    rng = np.random.default_rng(6)
    worst = [0.0, 0.0, 0.0]
    for _ in range(10):
        q, v = rng.uniform(-3, 3, 3), rng.normal(0, 2, 3)
        for k, (x, y) in enumerate(zip(closure_terms(model, q, v), ref.rows(q, v))):
            worst[k] = max(worst[k], error(x, y))
    assert max(worst) < 1e-14, worst          # measured Φ 2.1e-16, Φ_q 9.3e-18, Φ̇_q q̇ 5.6e-16 (the spherical rows)


def test_coupling_dynamics_equal_pinocchios_mimic_model():
    """A gear (URDF+ <coupling>, ratio 6: q̇_rotor = 6 q̇_link) as a closure row, against Pinocchio's mimic joint
    (the same gear as rotor = 6 · link): q̈ of the independent joints."""
    ours = load_urdf_string(ROTOR.replace("</robot>", COUPLING + "</robot>"))
    c = ours.constraints[0]
    assert c.type == "coupling" and c.ratio == 6.0 and c.n_rows == 1
    pin_text = ROTOR.replace('<child link="rotor"/>', '<child link="rotor"/>').replace(
        '<limit effort="1" velocity="1" lower="-3" upper="3"/></joint><joint name="j2"',
        '<limit effort="1" velocity="1" lower="-3" upper="3"/>' + MIMIC + '</joint><joint name="j2"')
    pm = P.buildModelFromXML(pin_text, mimic=True)
    pd = pm.createData()
    names = [pm.names[i] for i in range(1, pm.njoints) if pm.joints[i].nv]
    assert names == ["j1", "j2"] and ours.joint_names == ("j1", "j2", "j1r")   # depth-first
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(20):
        qi, vi, ti = rng.uniform(-3, 3, 2), rng.normal(0, 2, 2), rng.normal(0, 5, 2)
        q, v = np.array([qi[0], qi[1], 6 * qi[0]]), np.array([vi[0], vi[1], 6 * vi[0]])
        qdd, _ = constrained_forward_dynamics(ours, q, v, np.array([ti[0], ti[1], 0.0]))
        M = P.crba(pm, pd, qi, P.Convention.WORLD)
        M = np.triu(M) + np.triu(M, 1).T
        ref = np.linalg.solve(M, ti - P.rnea(pm, pd, qi, vi, np.zeros(2)))
        assert abs(qdd[2] - 6 * qdd[0]) < 1e-12 * max(1, abs(qdd[2]))
        worst = max(worst, error(qdd[:2], ref) / np.linalg.cond(M))
    assert worst < 1e-14, worst                     # measured 6.2e-17 (cond(M)-scaled)


# ---- mimic=True against Pinocchio 4.1's mimic model --------------------------------------------------------

@pytest.mark.parametrize("rel", ["panda_description/urdf/panda.urdf", "baxter_description/urdf/baxter.urdf"])
def test_mimic_model_matches_pinocchio(rel):
    path = robots_dir() / rel
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mm = load_urdf(path, mimic=True)
    pm = P.buildModelFromUrdf(str(path), mimic=True)
    pd = pm.createData()
    assert mm.nq == pm.nq and mm.nv == pm.nv
    assert mm.joint_names == tuple(pm.names[i] for i in range(1, pm.njoints) if pm.joints[i].nv)
    rng = np.random.default_rng(11)
    worst = [0.0, 0.0, 0.0]
    for _ in range(20):
        q, v, a = rng.uniform(-1, 1, mm.nq), rng.normal(0, 2, mm.nv), rng.normal(0, 5, mm.nv)
        tau = P.rnea(pm, pd, q, v, a)
        M = P.crba(pm, pd, q, P.Convention.WORLD)         # pin 4.1's aba refuses mimic joints; crba WORLD takes them
        M = np.triu(M) + np.triu(M, 1).T
        worst[0] = max(worst[0], error(manipdyn.rnea(mm, q, v, a), tau))
        worst[1] = max(worst[1], error(manipdyn.mass_matrix(mm, q), M))
        worst[2] = max(worst[2], error(manipdyn.aba(mm, q, v, tau), a) / np.linalg.cond(M))
    assert max(worst) < 1e-13, worst     # measured rnea 1.7e-15, crba 1.5e-15, aba 4.6e-17 (cond-scaled)
    Qf, _, _ = mim.full_state(mm, q)
    for j, t, mult, off in mm.mimic:                  # the mimicking joint follows its target
        i, k = mm.full.joint_index(j), mm.full.joint_index(t)
        assert Qf[i] == mult * Qf[k] + off
