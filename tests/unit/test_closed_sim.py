"""Closed chains in time: constraint drift |Φ| over 10 s with and without stabilization, energy kept."""
import numpy as np
import pytest
from conftest import ROOT

import manipdyn as md
from manipdyn.constraints import closure_terms, complete_state
from manipdyn.examples import spm_params as P
from manipdyn.examples.spm_urdf import tree_guess

FOURBAR = md.load_urdf(ROOT / "urdf" / "fourbar.urdf")
SPM = md.load_urdf(ROOT / "urdf" / "spm.urdf")


def _phi(model, r):
    return np.abs(closure_terms(model, r.q)[0]).max(axis=1)


def test_fourbar_torque_free_10s():
    q, v, _, _ = complete_state(FOURBAR, [0.3, -1.3, -2.0], [3.0], [0.0])
    out = {}
    for stab, kw in (("none", {}), ("baumgarte", dict(baumgarte=(20.0, 20.0))), ("projection", {})):
        r = md.simulate(FOURBAR, q, v, (0, 10), dt=5e-4, integrator="rk4", stabilization=stab, **kw)
        E = md.kinetic_energy(FOURBAR, r.q, r.v) + md.potential_energy(FOURBAR, r.q)
        out[stab] = (_phi(FOURBAR, r).max(), np.abs(E - E[0]).max() / md.kinetic_energy(FOURBAR, r.q, r.v).max())
    print("\nfour-bar, 10 s torque-free, RK4 dt 0.5 ms: max |Φ| and energy drift")
    for k, (phi, drift) in out.items():
        print(f"  {k:<11} |Φ| {phi:.1e}   drift {drift:.1e}")
    assert out["baumgarte"][0] <= 5e-10 and out["projection"][0] <= 5e-11   # measured 1.5e-11, 1.0e-12
    assert out["none"][0] > out["baumgarte"][0]                 # the drift stabilization removes
    assert max(d for _, d in out.values()) < 1e-6               # measured 3.3e-8; torque-free: energy is kept


def _spm_start():
    Q0 = np.array([[np.cos(np.pi / 6), 0, np.sin(np.pi / 6)], [0, 1, 0], [-np.sin(np.pi / 6), 0, np.cos(np.pi / 6)]])
    q, v, _, _ = complete_state(SPM, tree_guess(SPM, Q0, np.radians(P.THETA0_FIRST_BRANCH_DEG)),
                                np.array([2.0, -1.5, 1.0]), np.zeros(3))
    return q, v


@pytest.mark.parametrize("stab", ["baumgarte", "projection"])
def test_spm_held_by_pd_10s(stab):
    q0, v0 = _spm_start()
    act = [SPM.joint_index(j) for j in SPM.actuated]

    def pd_law(t, q, v):                      # actuators held around the start by a PD law
        tau = np.zeros_like(q)
        tau[..., act] = 2.0 * (q0[act] - q[..., act]) - 0.05 * v[..., act]
        return tau

    r = md.simulate(SPM, q0, v0, (0, 10), dt=5e-4, integrator="rk4", tau=pd_law, stabilization=stab,
                    baumgarte=(20.0, 20.0))
    phi = _phi(SPM, r)
    print(f"\nSPM, PD-held actuators, 10 s, {stab}: max |Φ| {phi.max():.1e}")
    assert phi.max() <= 1e-10                                   # measured 5.5e-12
    assert np.abs(r.q[:, act] - q0[act]).max() < 1.0            # the motion stays bounded
