"""q order on a tree whose joint-name order, child-link-name order and file order all differ (docs/design.md §3).

Pinocchio numbers joints depth-first from the root, the children of a link in the order of their joint
names, fixed joints skipped (their child's joints visited in the fixed joint's place).
"""
import numpy as np
import pinocchio as pin
from conftest import assert_close, inertial_xml, urdf

import manipdyn as md

# (joint, type, parent, child, xyz, rpy, axis), in file order
JOINTS = [("d_last", "revolute", "base", "c_link", (0, 0.2, 0), (0, 0, 0), (1, 0, 0)),
          ("y_deep", "revolute", "z_link", "e_link", (0.1, 0, 0.1), (0.3, 0, 0), (0, 1, 0)),
          ("c_mid", "prismatic", "base", "a_link", (0, -0.2, 0), (0, 0, 0), (0, 0, 1)),
          ("k_sub", "revolute", "m_link", "b_link", (0, 0, 0.3), (0, 0.2, 0), (1, 0, 0)),
          ("a_first", "revolute", "base", "z_link", (0.2, 0, 0), (0, 0, 0.4), (0, 0, 1)),
          ("x_deep", "revolute", "z_link", "f_link", (0, 0.1, 0.2), (0, 0, 0), (1, 0, 0)),
          ("b_fix", "fixed", "base", "m_link", (-0.2, 0, 0.1), (0.1, 0, 0), None)]
LINKS = {"base": ""} | {name: inertial_xml(0.5 + 0.1 * k, (0.05, 0.02 * k, -0.1), (0.01, 0.02, 0.015, 0, 0, 0))
                        for k, name in enumerate(["a_link", "b_link", "c_link", "e_link", "f_link", "m_link",
                                                  "z_link"])}
TEXT = urdf(LINKS, JOINTS)
RULE = ("a_first", "x_deep", "y_deep", "k_sub", "c_mid", "d_last")      # the rule applied by hand


def _order(key):
    """Depth-first moving joints with children visited in the order given by key(joint row)."""
    out = []

    def visit(link):
        for j in sorted((j for j in JOINTS if j[2] == link), key=key):
            if j[1] != "fixed":
                out.append(j[0])
            visit(j[3])
    visit("base")
    return tuple(out)


def test_the_three_orders_differ():
    file_order = tuple(j[0] for j in JOINTS if j[1] != "fixed")
    by_link = _order(lambda j: j[3])
    assert _order(lambda j: j[0]) == RULE
    assert len({RULE, by_link, file_order}) == 3, (RULE, by_link, file_order)


def test_joint_names_follow_pinocchio():
    model = md.load_urdf_string(TEXT)
    pm = pin.buildModelFromXML(TEXT)
    assert tuple(pm.names[1:]) == RULE
    assert model.joint_names == tuple(pm.names[1:])
    assert [model.joint_names[p] if p >= 0 else None for p in model.parent] == \
        [pm.names[pm.parents[i]] if pm.parents[i] > 0 else None for i in range(1, pm.njoints)]


def test_torques_agree_with_pinocchio_in_that_order():
    model, pm = md.load_urdf_string(TEXT), pin.buildModelFromXML(TEXT)
    pd, rng = pm.createData(), np.random.default_rng(5)
    for _ in range(5):
        q, v, a = rng.uniform(-np.pi, np.pi, 6), rng.normal(0, 2, 6), rng.normal(0, 5, 6)
        q[RULE.index("c_mid")] = rng.uniform(-0.5, 0.5)
        assert_close(md.rnea(model, q, v, a), pin.rnea(pm, pd, q, v, a), 5e-15, "τ")      # measured 6.2e-17
