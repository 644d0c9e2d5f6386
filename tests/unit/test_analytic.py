"""Newton–Euler against closed-form equations of motion of textbook mechanisms."""
import numpy as np
import pytest
from conftest import assert_close, inertial_xml, urdf

from manipdyn import load_urdf_string, rnea

g = 9.81
rng = np.random.default_rng(7)
STATES = rng.normal(0, 2, (50, 3, 2))   # 50 × (q, q̇, q̈) for up to 2 joints


def test_single_pendulum():
    # joint about y, CoM at distance c below: τ = (I_yy + m c²) θ̈ + m g c sin θ
    m, c, Iyy = 1.7, 0.4, 0.03
    model = load_urdf_string(urdf({"base": "", "l1": inertial_xml(m, (0, 0, -c), (0.02, Iyy, 0.01, 0, 0, 0))},
                                  [("j1", "revolute", "base", "l1", (0, 0, 0), (0, 0, 0), (0, 1, 0))]))
    for q, v, a in STATES[:, :, :1]:
        tau = (Iyy + m * c**2) * a + m * g * c * np.sin(q)
        assert_close(rnea(model, q, v, a), tau, 1e-14, "pendulum")  # measured 3.3e-16


def test_double_pendulum():
    m1, m2, c1, c2, l1, I1, I2 = 1.0, 0.8, 0.3, 0.25, 0.5, 0.02, 0.015
    model = load_urdf_string(urdf(
        {"base": "", "l1": inertial_xml(m1, (0, 0, -c1), (0.01, I1, 0.01, 0, 0, 0)),
         "l2": inertial_xml(m2, (0, 0, -c2), (0.01, I2, 0.01, 0, 0, 0))},
        [("j1", "revolute", "base", "l1", (0, 0, 0), (0, 0, 0), (0, 1, 0)),
         ("j2", "revolute", "l1", "l2", (0, 0, -l1), (0, 0, 0), (0, 1, 0))]))
    for q, v, a in STATES:
        c2q, h = np.cos(q[1]), m2 * l1 * c2 * np.sin(q[1])
        M = np.array([[I1 + I2 + m1 * c1**2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * c2q),
                       I2 + m2 * (c2**2 + l1 * c2 * c2q)],
                      [I2 + m2 * (c2**2 + l1 * c2 * c2q), I2 + m2 * c2**2]])
        Cv = np.array([-h * (2 * v[0] * v[1] + v[1]**2), h * v[0]**2])
        G = np.array([(m1 * c1 + m2 * l1) * g * np.sin(q[0]) + m2 * c2 * g * np.sin(q[0] + q[1]),
                      m2 * c2 * g * np.sin(q[0] + q[1])])
        assert_close(rnea(model, q, v, a), M @ a + Cv + G, 2e-14, "double pendulum")  # measured 7.3e-16


def test_polar_arm_revolute_prismatic():
    # turntable about z carrying a slider along x (Eq. 12's Coriolis term 2 ω × ḋ z):
    # τ = (I_zz + m r²) θ̈ + 2 m r ṙ θ̇,  F = m (r̈ − r θ̇²); gravity along the table's axis does no work
    m, Izz, I0 = 2.0, 0.05, 0.3
    model = load_urdf_string(urdf(
        {"base": "", "table": inertial_xml(1.0, (0, 0, 0), (0.2, 0.2, I0, 0, 0, 0)),
         "slider": inertial_xml(m, (0, 0, 0), (0.03, 0.03, Izz, 0, 0, 0))},
        [("turn", "revolute", "base", "table", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
         ("slide", "prismatic", "table", "slider", (0, 0, 0), (0, 0, 0), (1, 0, 0))]))
    for q, v, a in STATES:
        r, rd = q[1], v[1]
        tau = [(I0 + Izz + m * r**2) * a[0] + 2 * m * r * rd * v[0], m * (a[1] - r * v[0]**2)]
        assert_close(rnea(model, q, v, a), np.array(tau), 2e-14, "polar arm")  # measured 5.0e-16


def test_vertical_slider_carries_its_weight():
    m = 3.0
    model = load_urdf_string(urdf({"base": "", "s": inertial_xml(m)},
                                  [("lift", "prismatic", "base", "s", (0, 0, 0), (0, 0, 0), (0, 0, 1))]))
    assert_close(rnea(model, [0.2], [0.5], [1.5]), np.array([m * (1.5 + g)]), 1e-15, "slider")  # measured 0


@pytest.mark.parametrize("frame", ["local", "world"])
def test_static_payload_equals_added_mass(frame):
    # a weight m_p g hanging at a frame equals the same point mass merged into the link (physical law)
    mp, c = 5.0, 0.4
    base = {"base": "", "l1": inertial_xml(1.0, (0, 0, -0.2), (0.01, 0.01, 0.01, 0, 0, 0))}
    joints = [("j1", "revolute", "base", "l1", (0, 0, 0), (0, 0, 0), (0, 1, 0)),
              ("tj", "fixed", "l1", "tool", (0, 0, -c), (0.3, 0.2, 0.1), None)]
    bare = load_urdf_string(urdf({**base, "tool": ""}, joints))
    loaded = load_urdf_string(urdf({**base, "tool": inertial_xml(mp)}, joints))
    for q in rng.uniform(-3, 3, 10):
        weight_world = np.array([0, 0, -mp * g])
        f = weight_world if frame == "world" else bare.frame("tool").R.T @ _Ry(q).T @ weight_world
        tau = rnea(bare, [q], [0.0], [0.0], f_ext={"tool": (f, np.zeros(3))}, f_ext_frame=frame)
        assert_close(tau, rnea(loaded, [q], [0.0], [0.0]), 1e-14, "payload")  # measured 2.9e-16


def _Ry(t):
    return np.array([[np.cos(t), 0, np.sin(t)], [0, 1, 0], [-np.sin(t), 0, np.cos(t)]])
