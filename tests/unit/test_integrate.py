"""Integrators and energies: physical laws and measured convergence orders, against independent references."""
import numpy as np
import pytest
from conftest import AAU, assert_close, inertial_xml, urdf, zoo_paths

import manipdyn as md
from manipdyn.dynamics.energy import kinetic_energy, potential_energy
from manipdyn.simulation import simulate
from manipdyn.validation import random_states

MODEL = md.load_urdf(AAU)
Q0, V0 = np.array([0.3, -0.5, 0.8, 0.2, -0.4]), np.array([0.5, -0.3, 0.2, 1.0, -0.5])


@pytest.mark.parametrize("path", [AAU] + [p for p in zoo_paths() if p.name == "baxter.urdf"], ids=lambda p: p.stem)
def test_kinetic_energy_over_links_equals_half_vMv(path):
    model = md.load_urdf(path)
    Q, V, _ = random_states(model, 50, np.random.default_rng(1))
    half_vMv = 0.5 * np.einsum("ni,nij,nj->n", V, md.mass_matrix(model, Q), V)
    assert_close(kinetic_energy(model, Q, V), half_vMv, 2e-14, "T")  # measured 8.1e-16


def test_gravity_torques_are_the_gradient_of_the_potential():
    Q, _, _ = random_states(MODEL, 10, np.random.default_rng(2))
    h = 1e-6
    for q in Q:
        grad = np.array([(potential_energy(MODEL, q + h * e) - potential_energy(MODEL, q - h * e)) / (2 * h)
                         for e in np.eye(MODEL.nv)])
        assert_close(md.gravity_torques(MODEL, q), grad, 1e-8, "∂V/∂q")  # measured 4.2e-10 (central difference, h = 1e-6)


def _final_error(integrator, h, ref):
    r = simulate(MODEL, Q0, V0, (0.0, 1.0), dt=h, integrator=integrator)
    return np.abs(np.r_[r.q[-1], r.v[-1]] - ref).max()


def test_measured_convergence_orders():
    # AAU arm under gravity, 1 s; the adaptive reference at rtol 1e-12. Steps in the asymptotic regime:
    # RK4 5, 2.5, 1.25 ms; semi-implicit Euler 0.5, 0.25, 0.125 ms.
    r = simulate(MODEL, Q0, V0, (0.0, 1.0), integrator="adaptive", rtol=1e-12, atol=1e-13)
    ref = np.r_[r.q[-1], r.v[-1]]
    for integrator, hs, order in (("rk4", (5e-3, 2.5e-3, 1.25e-3), 4.0), ("euler", (5e-4, 2.5e-4, 1.25e-4), 1.0)):
        e = [_final_error(integrator, h, ref) for h in hs]
        slope = np.polyfit(np.log(hs), np.log(e), 1)[0]
        print(f"\n{integrator}: errors {['%.2e' % x for x in e]}, measured order {slope:.2f}")
        assert abs(slope - order) <= 0.3


def test_energy_drift_torque_free():
    # drift = max_t |E(t) − E(0)| / max_t T(t): independent of the potential's datum
    def drift(r):
        E = kinetic_energy(MODEL, r.q, r.v) + potential_energy(MODEL, r.q)
        return np.abs(E - E[0]).max() / kinetic_energy(MODEL, r.q, r.v).max()

    rows = [("adaptive rtol 1e-12", drift(simulate(MODEL, Q0, V0, (0, 10), integrator="adaptive", rtol=1e-12,
                                                   atol=1e-13)))]
    for integrator, h in (("rk4", 4e-3), ("rk4", 2e-3), ("euler", 1e-3), ("euler", 5e-4)):
        rows.append((f"{integrator} dt {h:g}", drift(simulate(MODEL, Q0, V0, (0, 10), dt=h, integrator=integrator))))
    print("\nenergy drift over 10 s, torque-free AAU arm under gravity")
    for name, d in rows:
        print(f"  {name:<22} {d:.2e}")
    assert rows[0][1] < 2e-11                     # measured 3.9e-13
    assert rows[2][1] < 0.2 * rows[1][1]          # RK4: halving the step cuts the drift (~2⁴)
    # semi-implicit Euler is symplectic: its energy error stays bounded (no secular growth) on this
    # chaotic swing, but is not monotone in the step over 10 s
    assert max(rows[3][1], rows[4][1]) < 0.1      # measured 3.9e-2 (O(h) oscillation)


def test_batch_equals_single_runs():
    Q, V, _ = random_states(MODEL, 4, np.random.default_rng(3))
    batch = simulate(MODEL, Q, V, (0, 0.2), dt=1e-3, integrator="rk4")
    assert batch.q.shape == (4, 201, MODEL.nv) and batch.t.shape == (201,)
    for k in range(4):
        one = simulate(MODEL, Q[k], V[k], (0, 0.2), dt=1e-3, integrator="rk4")
        assert_close(batch.q[k], one.q, 1e-15, "q rows")  # measured 0 (bit-identical)
        assert_close(batch.v[k], one.v, 1e-15, "v rows")  # measured 0 (bit-identical)
    with pytest.raises(md.InputError, match="one initial state at a time"):
        simulate(MODEL, Q, V, (0, 0.1), integrator="adaptive")


@pytest.mark.parametrize("integrator", ["euler", "rk4"])
def test_dynamics_routes_give_the_same_trajectory(integrator):
    # method= is the forward-dynamics route, as in forward_dynamics: ABA and the Cholesky route (CRBA, RNEA
    # bias) are independent algorithms for the same q̈, so their trajectories agree to round-off
    Q, V, _ = random_states(MODEL, 3, np.random.default_rng(4))
    default = simulate(MODEL, Q, V, (0, 0.2), dt=1e-3, integrator=integrator)
    runs = {m: simulate(MODEL, Q, V, (0, 0.2), dt=1e-3, integrator=integrator, method=m) for m in ("aba", "cholesky")}
    assert default.integrator == runs["cholesky"].integrator == integrator
    assert np.array_equal(runs["aba"].q, default.q)             # "aba" is the default route
    assert not np.array_equal(runs["cholesky"].q, default.q)   # the other route was taken
    assert_close(runs["cholesky"].q, default.q, 1e-13, "q")     # measured 8.0e-16 (euler), 3.7e-16 (rk4)
    assert_close(runs["cholesky"].v, default.v, 1e-13, "v")     # measured 4.1e-15 (euler), 1.6e-15 (rk4)


def test_torque_forms_and_gravity_compensation():
    hold = simulate(MODEL, Q0, np.zeros(5), (0, 1), dt=2e-3, integrator="rk4",
                    tau=lambda t, q, v: md.rnea(MODEL, q, v, np.zeros_like(q)))
    assert_close(hold.q[-1], Q0, 5e-13, "gravity-compensated arm stays put")  # measured 9.9e-15
    const = simulate(MODEL, Q0, V0, (0, 0.1), dt=1e-3, tau=np.ones(5))
    assert const.q.shape == (101, 5) and const.t[-1] == 0.1
    odd = simulate(MODEL, Q0, V0, (0, 0.1005), dt=1e-3)          # last step shortened to land on t1
    assert odd.t[-1] == 0.1005 and odd.n_steps == 101


def test_divergence_names_the_time():
    with pytest.raises(md.DivergenceError, match=r"diverged at t = "):
        simulate(MODEL, Q0, V0, (0, 1), dt=1e-2, tau=lambda t, q, v: np.full_like(q, np.nan if t > 0.05 else 0.0))


def test_singular_mass_matrix_raises_naming_the_joint():
    model = md.load_urdf_string(urdf({"base": "", "a": inertial_xml(1.0, (0, 0, 0.1), (0.1, 0.1, 0.1, 0, 0, 0)),
                                      "tip": ""},
                                     [("ja", "revolute", "base", "a", (0, 0, 0), (0, 0, 0), (0, 0, 1)),
                                      ("jtip", "revolute", "a", "tip", (0, 0, 0.2), (0, 0, 0), (0, 1, 0))]))
    with pytest.raises(md.SingularError, match="jtip"):
        simulate(model, np.zeros(2), np.zeros(2), (0, 0.1))
