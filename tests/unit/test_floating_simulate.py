"""simulate on a free-flyer root: configurations move by integrate (q ⊕ ξ), RK4 as Runge–Kutta–Munthe-Kaas.

References are physical laws and closed forms, not our own output: a free rigid body's centre of mass
follows p0 + ṗ0 t + ½ g t² and its world angular momentum R I ω is constant (Euler's equations, no
torque); on a legged robot without gravity the kinetic energy is constant; RK4's error falls as dt⁴
against the adaptive reference on the same equations.
"""
import numpy as np
import pytest

import manipdyn as md
from manipdyn.validation.zoo import floating_paths

BODY = """<robot name="brick"><link name="brick"><inertial><origin xyz="0 0 0"/><mass value="2.0"/>
<inertia ixx="0.05" iyy="0.11" izz="0.13" ixy="0.0" ixz="0.0" iyz="0.0"/></inertial></link></robot>"""


@pytest.fixture(scope="module")
def brick():
    return md.load_urdf_string(BODY, root_joint="free_flyer")


def _rot(q):
    x, y, z, w = q[3:7]
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


@pytest.mark.parametrize("integrator, dt, tol_p, tol_L", [("rk4", 1e-3, 1e-10, 1e-11), ("euler", 1e-3, 2e-2, 5e-3)])
def test_free_brick_falls_and_tumbles(brick, integrator, dt, tol_p, tol_L):
    """A tumbling brick (distinct principal moments, ω off every axis) under gravity over 1 s."""
    q0 = md.normalize(brick, np.array([0.1, -0.2, 0.3, 0.2, -0.1, 0.3, 0.9]))
    v0 = np.array([0.5, -0.3, 0.8, 2.0, -1.5, 3.0])
    sim = md.simulate(brick, q0, v0, (0.0, 1.0), dt=dt, integrator=integrator)
    g = brick.gravity
    p_ref = q0[:3] + _rot(q0) @ v0[:3] + 0.5 * g             # CoM at the origin: p(1) exactly
    assert np.abs(sim.q[-1, :3] - p_ref).max() < tol_p        # rk4 measured 1.6e-11; euler 8.2e-3
    I = np.diag([0.05, 0.11, 0.13])
    L0 = _rot(q0) @ I @ v0[3:]
    L1 = _rot(sim.q[-1]) @ I @ sim.v[-1, 3:]
    assert np.abs(L1 - L0).max() / np.abs(L0).max() < tol_L   # rk4 measured 6.5e-13; euler 1.1e-3
    assert np.abs(np.linalg.norm(sim.q[:, 3:7], axis=1) - 1).max() < 1e-15   # unit quaternions: measured 2.2e-16


def test_rk4_is_fourth_order_on_a_legged_robot():
    """solo12 with a free flyer, no gravity, no torque: RK4's final error against the adaptive reference
    (DOP853, rtol 1e-12) falls by ≥ 2^3.5 per halving of dt, and the kinetic energy stays constant."""
    path = next(p for p in floating_paths() if "solo12" in str(p))
    m = md.load_urdf(path, root_joint="free_flyer", gravity=[0.0, 0.0, 0.0])
    rng = np.random.default_rng(1)
    q0, v0 = md.random_configuration(m, rng), rng.normal(0.0, 1.0, m.nv)
    ref = md.simulate(m, q0, v0, (0.0, 0.4), integrator="adaptive", rtol=1e-12, atol=1e-13)
    errs = []
    for dt in (8e-3, 4e-3, 2e-3):
        s = md.simulate(m, q0, v0, (0.0, 0.4), dt=dt, integrator="rk4")
        errs.append(np.abs(md.difference(m, ref.q[-1], s.q[-1])).max())
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 3.5), (errs, orders)               # measured 4.07, 4.00
    T0, T1 = md.kinetic_energy(m, q0, v0), md.kinetic_energy(m, s.q[-1], s.v[-1])
    assert abs(T1 - T0) / T0 < 1e-9                           # measured 9.0e-11 at dt = 2e-3

