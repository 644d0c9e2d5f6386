"""integrator="euler" is symplectic (semi-implicit) Euler, told apart from explicit Euler by what only it does.

A pendulum of length L (point mass, ω₀² = g/L, M constant) has q̈ = f(q) = −ω₀² sin q. One step of
symplectic Euler, v₁ = v + h f(q), q₁ = q + h v₁, has Jacobian [[1 + h² f′, h], [h f′, 1]] with determinant
exactly 1 (it preserves phase-space area); explicit Euler (q₁ = q + h v, v₁ = v + h f(q)) has
det = 1 − h² f′(q) = 1 + h² ω₀² cos q ≠ 1, and multiplies the energy of the oscillation by ≈ 1 + h² ω₀² per step.
"""
import numpy as np
import pytest
from conftest import inertial_xml, urdf

import manipdyn as md

G, L, MASS = 9.81, 1.0, 0.5
PENDULUM = md.load_urdf_string(urdf(
    {"base": "", "rod": "", "bob": inertial_xml(MASS)},
    [("swing", "revolute", "base", "rod", (0, 0, 0), (0, 0, 0), (0, 1, 0)),
     ("tip", "fixed", "rod", "bob", (0, 0, -L), (0, 0, 0), None)]))
W0 = np.sqrt(G / L)
PERIOD = 2 * np.pi / W0


def _step(x, h):
    r = md.simulate(PENDULUM, x[:1], x[1:], (0.0, h), dt=h, integrator="euler")
    return np.r_[r.q[-1], r.v[-1]]


@pytest.mark.parametrize("q0", [-2.0, -0.3, 0.4, 1.5, 2.8])
def test_one_step_map_preserves_area(q0):
    h, d = 0.05, 1e-5
    x = np.array([q0, 0.7])
    Jac = np.column_stack([(_step(x + d * e, h) - _step(x - d * e, h)) / (2 * d) for e in np.eye(2)])
    det = np.linalg.det(Jac)
    # explicit Euler would give 1 + h² ω₀² cos q0: |det − 1| between 2.4e-3 and 2.4e-2 at these q0
    assert abs(det - 1.0) <= 1e-9                          # measured 1.7e-11 (central differences)
    assert abs(Jac[0, 1] - h) <= 1e-10                     # ∂q₁/∂v = h; measured 7.0e-12


def test_energy_error_stays_bounded_over_fifty_periods():
    h = 0.01
    r = md.simulate(PENDULUM, np.array([0.3]), np.array([0.0]), (0.0, 50 * PERIOD), dt=h, integrator="euler")
    E = md.kinetic_energy(PENDULUM, r.q, r.v) + md.potential_energy(PENDULUM, r.q)
    dE = np.abs(E - E[0]) / (MASS * G * L * (1 - np.cos(0.3)))            # relative to the swing's energy
    five = int(round(5 * PERIOD / h))
    first, last = dE[:five].max(), dE[-five:].max()
    print(f"\nsymplectic Euler, h = {h}: energy error first 5 periods {first:.2e}, last 5 {last:.2e}")
    # O(h) oscillation (h ω₀ / 2 ≈ 1.6e-2), no secular growth; explicit Euler grows by e^{h ω₀² t} ≈ 2e4 here
    assert first <= 0.03                                   # measured 1.6e-2
    assert last <= 1.01 * first                            # measured ratio 0.99999
