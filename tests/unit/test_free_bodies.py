"""Several free bodies: an arm with a free object beside it (an MJCF file's second free joint, pybullet_data's thrower
and striker) moves by the laws of free flight — the object's centre of mass on the parabola p0 + ṗ0 t + ½ g t²,
its angular momentum about the centre of mass constant in the world — while the arm, with no torque, stays at rest.

Measured (1 s of flight): RK4 (dt = 1e-3) parabola ≤ 4.3e-11 m, world angular momentum ≤ 6.7e-13 (relative);
adaptive (rtol = atol = 1e-12) ≤ 6.4e-13 m, 7.2e-15.
"""
from __future__ import annotations

import numpy as np
import pytest

import manipdyn as md

XML = """<mujoco><option gravity="0.3 -0.2 -9.81"/><compiler angle="radian"/><worldbody>
<body name="link" pos="0 0 0.5"><joint name="hinge" axis="0 1 0"/>
  <inertial pos="0.2 0 0" mass="2" diaginertia="0.01 0.05 0.05"/></body>
<body name="ball" pos="1 0.5 2" quat="0.9 0.1 0.3 0.2"><freejoint name="object"/>
  <inertial pos="0 0 0" mass="0.7" fullinertia="0.03 0.035 0.05 0.001 -0.002 0.003"/></body>
</worldbody></mujoco>"""

TOL = {"rk4": (4e-9, 6e-11), "adaptive": (6e-11, 7e-13)}    # 100× the measured (parabola m, momentum)


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
def test_a_free_object_beside_an_arm_flies_freely(integrator):
    model = md.load_mjcf_string(XML)
    assert model.joint_names == ("hinge", "object") and not model.floating     # joint 0 is the arm's
    j = model.joint_index("object")
    iq, iv = model.idx_q[j], model.idx_v[j]
    q0, v0 = md.neutral(model), np.zeros(model.nv)
    q0[iq:iq + 7] = [1.0, 0.5, 2.0, 0.1, 0.3, 0.2, 0.9]
    q0 = md.normalize(model, q0)
    v0[iv:iv + 6] = [0.4, -1.0, 3.0, 2.0, -1.0, 4.0]                # body-frame linear and angular velocity
    kw = dict(dt=1e-3) if integrator == "rk4" else dict(rtol=1e-12, atol=1e-12)
    res = md.simulate(model, q0, v0, (0.0, 1.0), tau=lambda t, q, v: np.zeros(model.nv), integrator=integrator, **kw)

    def rotation(q):
        x, y, z, w = q[iq + 3:iq + 7]
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                         [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                         [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    R0, J = rotation(q0), model.inertia[j]
    p_dot0, L0 = R0 @ v0[iv:iv + 3], R0 @ J @ v0[iv + 3:iv + 6]
    g = model.gravity
    worst_p = worst_L = 0.0
    for t, q, v in zip(res.t, res.q, res.v):
        p = q0[iq:iq + 3] + p_dot0 * t + 0.5 * g * t * t
        worst_p = max(worst_p, float(np.max(np.abs(q[iq:iq + 3] - p))))
        L = rotation(q) @ J @ v[iv + 3:iv + 6]
        worst_L = max(worst_L, float(np.max(np.abs(L - L0)) / np.max(np.abs(L0))))
    print(f"\n{integrator}: parabola {worst_p:.1e} m, angular momentum {worst_L:.1e}")
    assert worst_p <= TOL[integrator][0] and worst_L <= TOL[integrator][1]
    hinge = model.idx_v[model.joint_index("hinge")]
    assert np.all(np.isfinite(res.v[:, hinge]))


def test_a_free_joint_below_a_body_is_refused():
    with pytest.raises(md.MJCFError, match="not alone in a child of <worldbody>"):
        md.load_mjcf_string(XML.replace('<joint name="hinge" axis="0 1 0"/>',
                                        '<joint name="hinge" axis="0 1 0"/><body name="c"><freejoint name="f"/>'
                                        '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>'))


def test_playback_plots_the_arms_joints_not_the_free_body():
    """The page's plots hold joint positions, rates and torques: a free body beside the arm (its pose, its zero
    torque) is left out, as a floating root is; the torque plotted is the hinge's: at constant rate about its fixed
    axis y, τ = −(m c × g)_y with c the centre of mass turned by θ."""
    from manipdyn.viz.plots import signals
    model = md.load_mjcf_string(XML)
    t = np.linspace(0.0, 1.0, 11)
    Q = np.tile(md.neutral(model), (len(t), 1))
    Q[:, model.idx_q[model.joint_index("hinge")]] = 0.5 * t
    groups = {g["key"]: g for g in signals(model, t, Q)["groups"]}
    assert [g["names"] for g in groups.values()] == [["hinge"]] * 3
    assert "ball joints" not in groups["q"]["title"]
    th, g = 0.5 * t[5], model.gravity
    c = np.array([0.2 * np.cos(th), 0.0, -0.2 * np.sin(th)])          # R_y(θ) (0.2, 0, 0)
    want = -2.0 * np.cross(c, g)[1]
    assert abs(groups["tau"]["series"][0][5] - want) <= 1e-4 * abs(want)        # the page keeps 5 digits
